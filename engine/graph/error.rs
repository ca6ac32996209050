//! Misuse of the graph API, reported instead of panicking.

use ash::vk;

use super::access::Access;

/// A graph declaration or compilation error.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum GraphError {
    /// A shader pass's declared bindings disagree with the shader's reflected ones.
    #[error("pass `{pass}`: binding {binding} of {shader}: {problem}")]
    ShaderBinding {
        /// Pass name.
        pass: String,
        /// Shader path (and variant).
        shader: String,
        /// Binding index (or "push constants").
        binding: String,
        /// What disagrees.
        problem: String,
    },
    /// A handle that this builder did not create (or of the wrong kind).
    #[error("unknown {kind} handle #{index}")]
    UnknownHandle {
        /// "image" or "buffer".
        kind: &'static str,
        /// Raw index of the handle.
        index: u32,
    },
    /// A pass reads a transient that no earlier pass wrote.
    #[error("pass `{pass}` reads `{resource}` but no earlier pass writes it")]
    ReadBeforeWrite {
        /// Pass name.
        pass: String,
        /// Resource name.
        resource: String,
    },
    /// `read_*` with a writing access or `write_*` with a read-only access.
    #[error("pass `{pass}` uses `{resource}` with {access:?} through the {method} method")]
    AccessDirection {
        /// Pass name.
        pass: String,
        /// Resource name.
        resource: String,
        /// Offending access.
        access: Access,
        /// "read" or "write".
        method: &'static str,
    },
    /// The access cannot apply to this kind of resource (e.g. `IndexBuffer` on an image).
    #[error("{access:?} is not a valid access for `{resource}`")]
    AccessKind {
        /// Resource name.
        resource: String,
        /// Offending access.
        access: Access,
    },
    /// An attachment access in a pass that is not a raster pass.
    #[error("pass `{pass}` is not a raster pass but uses `{resource}` as an attachment")]
    AttachmentOutsideRaster {
        /// Pass name.
        pass: String,
        /// Resource name.
        resource: String,
    },
    /// A write to a resource imported read-only.
    #[error("pass `{pass}` writes `{resource}`, which was imported read-only")]
    WriteToReadOnly {
        /// Pass name.
        pass: String,
        /// Resource name.
        resource: String,
    },
    /// One pass uses one image in two layouts.
    #[error("pass `{pass}` uses `{resource}` in both {first:?} and {second:?}")]
    LayoutConflict {
        /// Pass name.
        pass: String,
        /// Resource name.
        resource: String,
        /// Layout of the earlier declared use.
        first: vk::ImageLayout,
        /// Layout of the conflicting use.
        second: vk::ImageLayout,
    },
    /// A read-only depth attachment with a load op other than Load.
    #[error("pass `{pass}`: read-only depth attachment `{resource}` must use LoadOp::Load")]
    ReadOnlyDepthNeedsLoad {
        /// Pass name.
        pass: String,
        /// Resource name.
        resource: String,
    },
    /// A second depth attachment in one pass.
    #[error("pass `{pass}` declares more than one depth attachment")]
    MultipleDepthAttachments {
        /// Pass name.
        pass: String,
    },
    /// Export of a transient that no pass writes.
    #[error("`{resource}` is exported but no pass writes it")]
    ExportUnwritten {
        /// Resource name.
        resource: String,
    },
    /// Export with a writing access or one invalid for the resource kind.
    #[error("`{resource}` cannot be exported as {access:?}")]
    InvalidExportAccess {
        /// Resource name.
        resource: String,
        /// Offending access.
        access: Access,
    },
    /// The same resource exported twice with different final accesses.
    #[error("`{resource}` is exported twice with different final accesses")]
    ConflictingExport {
        /// Resource name.
        resource: String,
    },
    /// An alias plan that does not match this graph's transients.
    #[error("alias plan has {got} entries but the graph has {expected} transients")]
    AliasPlanMismatch {
        /// Number of allocated transients.
        expected: usize,
        /// Entries in the plan / request list.
        got: usize,
    },
    /// `apply_aliasing` called twice on the same compiled graph.
    #[error("aliasing was already applied to this compiled graph")]
    AlreadyAliased,
}

impl From<GraphError> for crate::Error {
    fn from(e: GraphError) -> Self {
        crate::Error::Graph(e.to_string())
    }
}
