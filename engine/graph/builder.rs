//! Declaration API: resources and passes, validated as they are declared.

use ash::vk;

use super::access::Access;
use super::error::GraphError;
use super::pass_context::PassContext;
use super::resource::{BufferDesc, BufferId, ImageDesc, ImageId, ResourceDesc, ResourceId, ResourceState};
use super::work::Work;

/// A pass's recording closure.
pub type RecordFn<'a> = Box<dyn FnOnce(&mut PassContext<'_>) -> crate::Result<()> + 'a>;

/// Queue-capability class of a pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PassKind {
    /// Dispatches.
    Compute,
    /// Draws inside a dynamic rendering scope.
    Raster,
    /// Copies, fills, clears.
    Transfer,
}

/// What happens to an attachment's previous contents when rendering begins.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LoadOp {
    /// Keep them (a read of the previous version).
    Load,
    /// Clear to the given value (a pure write).
    Clear,
    /// Discard them (a pure write).
    DontCare,
}

/// A color attachment of a raster pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColorAttachment {
    /// Target image.
    pub image: ImageId,
    /// Load op.
    pub load_op: LoadOp,
    /// Clear color, used with `LoadOp::Clear`.
    pub clear: [f32; 4],
}

/// The depth attachment of a raster pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthAttachment {
    /// Target image.
    pub image: ImageId,
    /// Load op.
    pub load_op: LoadOp,
    /// Clear depth, used with `LoadOp::Clear`.
    pub clear_depth: f32,
    /// Whether depth writes are enabled.
    pub write: bool,
}

/// Where a resource comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Origin {
    Transient,
    Imported { state: ResourceState, read_only: bool },
}

pub(crate) struct ResourceDecl {
    pub(crate) name: String,
    pub(crate) desc: ResourceDesc,
    pub(crate) origin: Origin,
    /// `Some(None)`: must survive; `Some(Some(a))`: must also end in access `a`.
    pub(crate) export: Option<Option<Access>>,
    /// Declaration indices of writing passes, ascending.
    pub(crate) writers: Vec<usize>,
}

/// All accesses of one pass to one resource, merged (a pass's uses are simultaneous).
#[derive(Clone, Debug)]
pub(crate) struct Use {
    pub(crate) res: usize,
    pub(crate) stage: vk::PipelineStageFlags2,
    pub(crate) access: vk::AccessFlags2,
    /// `None` for buffers.
    pub(crate) layout: Option<vk::ImageLayout>,
    /// Observes the version written by an earlier pass.
    pub(crate) reads_prev: bool,
    pub(crate) writes: bool,
    /// Overwrites everything (attachment Clear/DontCare): old contents need not survive.
    pub(crate) discards: bool,
    pub(crate) image_usage: vk::ImageUsageFlags,
    pub(crate) buffer_usage: vk::BufferUsageFlags,
}

pub(crate) struct PassDecl<'a> {
    pub(crate) name: String,
    pub(crate) kind: PassKind,
    pub(crate) uses: Vec<Use>,
    pub(crate) colors: Vec<ColorAttachment>,
    pub(crate) depth: Option<DepthAttachment>,
    pub(crate) side_effect: bool,
    pub(crate) work: Option<Work>,
    /// Worst-case loop iterations per SIMD row and dispatch ([`PassBuilder::loop_bound`]).
    pub(crate) loop_iterations: u64,
    pub(crate) record: Option<RecordFn<'a>>,
}

/// Collects resource and pass declarations; declaration order defines which version a read sees.
#[derive(Default)]
pub struct GraphBuilder<'a> {
    pub(crate) resources: Vec<ResourceDecl>,
    pub(crate) passes: Vec<PassDecl<'a>>,
}

impl<'a> GraphBuilder<'a> {
    /// An empty graph.
    pub fn new() -> Self {
        Self { resources: Vec::new(), passes: Vec::new() }
    }

    fn add_resource(&mut self, name: String, desc: ResourceDesc, origin: Origin) -> u32 {
        self.resources.push(ResourceDecl { name, desc, origin, export: None, writers: Vec::new() });
        (self.resources.len() - 1) as u32
    }

    /// Declares a graph-owned image whose contents start undefined.
    pub fn create_image(&mut self, name: impl Into<String>, desc: ImageDesc) -> ImageId {
        ImageId(self.add_resource(name.into(), ResourceDesc::Image(desc), Origin::Transient))
    }

    /// Declares a graph-owned buffer whose contents start undefined.
    pub fn create_buffer(&mut self, name: impl Into<String>, desc: BufferDesc) -> BufferId {
        BufferId(self.add_resource(name.into(), ResourceDesc::Buffer(desc), Origin::Transient))
    }

    /// Declares a persistent image last used as `state`.
    pub fn import_image(&mut self, name: impl Into<String>, desc: ImageDesc, state: ResourceState) -> ImageId {
        let origin = Origin::Imported { state, read_only: false };
        ImageId(self.add_resource(name.into(), ResourceDesc::Image(desc), origin))
    }

    /// Declares a persistent image that passes may only read.
    pub fn import_image_readonly(&mut self, name: impl Into<String>, desc: ImageDesc, state: ResourceState) -> ImageId {
        let origin = Origin::Imported { state, read_only: true };
        ImageId(self.add_resource(name.into(), ResourceDesc::Image(desc), origin))
    }

    /// Declares a persistent buffer last used as `state`.
    pub fn import_buffer(&mut self, name: impl Into<String>, desc: BufferDesc, state: ResourceState) -> BufferId {
        let origin = Origin::Imported { state, read_only: false };
        BufferId(self.add_resource(name.into(), ResourceDesc::Buffer(desc), origin))
    }

    /// Declares a persistent buffer that passes may only read.
    pub fn import_buffer_readonly(
        &mut self,
        name: impl Into<String>,
        desc: BufferDesc,
        state: ResourceState,
    ) -> BufferId {
        let origin = Origin::Imported { state, read_only: true };
        BufferId(self.add_resource(name.into(), ResourceDesc::Buffer(desc), origin))
    }

    /// Marks an image as needed after the graph, optionally transitioned to `access` at the end.
    pub fn export_image(&mut self, id: ImageId, access: Option<Access>) -> Result<(), GraphError> {
        let res = self.check_image(id)?;
        self.export(res, access, Access::valid_for_image)
    }

    /// Marks a buffer as needed after the graph, optionally made visible to `access` at the end.
    pub fn export_buffer(&mut self, id: BufferId, access: Option<Access>) -> Result<(), GraphError> {
        let res = self.check_buffer(id)?;
        self.export(res, access, Access::valid_for_buffer)
    }

    fn export(&mut self, res: usize, access: Option<Access>, valid: fn(Access) -> bool) -> Result<(), GraphError> {
        let decl = &mut self.resources[res];
        if let Some(a) = access {
            if a.is_write() || !valid(a) {
                return Err(GraphError::InvalidExportAccess { resource: decl.name.clone(), access: a });
            }
        }
        if decl.origin == Origin::Transient && decl.writers.is_empty() {
            return Err(GraphError::ExportUnwritten { resource: decl.name.clone() });
        }
        match decl.export {
            Some(prev) if prev != access && prev.is_some() && access.is_some() => {
                Err(GraphError::ConflictingExport { resource: decl.name.clone() })
            }
            _ => {
                decl.export = Some(decl.export.flatten().or(access));
                Ok(())
            }
        }
    }

    pub(crate) fn check_image(&self, id: ImageId) -> Result<usize, GraphError> {
        match self.resources.get(id.0 as usize) {
            Some(ResourceDecl { desc: ResourceDesc::Image(_), .. }) => Ok(id.0 as usize),
            _ => Err(GraphError::UnknownHandle { kind: "image", index: id.0 }),
        }
    }

    pub(crate) fn check_buffer(&self, id: BufferId) -> Result<usize, GraphError> {
        match self.resources.get(id.0 as usize) {
            Some(ResourceDecl { desc: ResourceDesc::Buffer(_), .. }) => Ok(id.0 as usize),
            _ => Err(GraphError::UnknownHandle { kind: "buffer", index: id.0 }),
        }
    }

    /// Declares a compute pass.
    pub fn add_compute_pass(&mut self, name: impl Into<String>) -> PassBuilder<'_, 'a> {
        self.add_pass(name.into(), PassKind::Compute)
    }

    /// Declares a raster pass.
    pub fn add_raster_pass(&mut self, name: impl Into<String>) -> PassBuilder<'_, 'a> {
        self.add_pass(name.into(), PassKind::Raster)
    }

    /// Declares a transfer pass.
    pub fn add_transfer_pass(&mut self, name: impl Into<String>) -> PassBuilder<'_, 'a> {
        self.add_pass(name.into(), PassKind::Transfer)
    }

    fn add_pass(&mut self, name: String, kind: PassKind) -> PassBuilder<'_, 'a> {
        self.passes.push(PassDecl {
            name,
            kind,
            uses: Vec::new(),
            colors: Vec::new(),
            depth: None,
            side_effect: false,
            work: None,
            loop_iterations: 0,
            record: None,
        });
        let index = self.passes.len() - 1;
        PassBuilder { graph: self, index }
    }

    /// Re-opens the declaration of pass `index` (shader passes add uses call by call).
    pub(crate) fn pass_builder(&mut self, index: usize) -> PassBuilder<'_, 'a> {
        PassBuilder { graph: self, index }
    }

    /// Handle → resource id, for diagnostics and tooling.
    pub fn resource_name(&self, id: ResourceId) -> Option<&str> {
        self.resources.get(id.index()).map(|r| r.name.as_str())
    }
}

/// Declares the uses of one pass; every method validates immediately.
pub struct PassBuilder<'g, 'a> {
    graph: &'g mut GraphBuilder<'a>,
    index: usize,
}

impl<'a> PassBuilder<'_, 'a> {
    /// Reads an image with a non-writing access.
    pub fn read_image(&mut self, id: ImageId, access: Access) -> Result<&mut Self, GraphError> {
        let res = self.graph.check_image(id)?;
        self.use_resource(res, access, false, "read")
    }

    /// Writes an image; read-modify-write accesses also read the previous version.
    pub fn write_image(&mut self, id: ImageId, access: Access) -> Result<&mut Self, GraphError> {
        let res = self.graph.check_image(id)?;
        self.use_resource(res, access, true, "write")
    }

    /// Reads a buffer with a non-writing access.
    pub fn read_buffer(&mut self, id: BufferId, access: Access) -> Result<&mut Self, GraphError> {
        let res = self.graph.check_buffer(id)?;
        self.use_resource(res, access, false, "read")
    }

    /// Writes a buffer; read-modify-write accesses also read the previous version.
    pub fn write_buffer(&mut self, id: BufferId, access: Access) -> Result<&mut Self, GraphError> {
        let res = self.graph.check_buffer(id)?;
        self.use_resource(res, access, true, "write")
    }

    /// Binds a color attachment; `LoadOp::Load` reads the previous version.
    pub fn color_attachment(&mut self, id: ImageId, load_op: LoadOp, clear: [f32; 4]) -> Result<&mut Self, GraphError> {
        let res = self.graph.check_image(id)?;
        let access =
            if load_op == LoadOp::Load { Access::ColorAttachmentReadWrite } else { Access::ColorAttachmentWrite };
        self.add_use(res, access, load_op == LoadOp::Load, load_op != LoadOp::Load)?;
        self.decl().colors.push(ColorAttachment { image: id, load_op, clear });
        Ok(self)
    }

    /// Binds the depth attachment; read-only (`write == false`) requires `LoadOp::Load`.
    pub fn depth_attachment(
        &mut self,
        id: ImageId,
        load_op: LoadOp,
        clear_depth: f32,
        write: bool,
    ) -> Result<&mut Self, GraphError> {
        let res = self.graph.check_image(id)?;
        if self.decl().depth.is_some() {
            return Err(GraphError::MultipleDepthAttachments { pass: self.decl().name.clone() });
        }
        if !write && load_op != LoadOp::Load {
            return Err(GraphError::ReadOnlyDepthNeedsLoad {
                pass: self.decl().name.clone(),
                resource: self.graph.resources[res].name.clone(),
            });
        }
        let access = if write { Access::DepthWrite } else { Access::DepthRead };
        self.add_use(res, access, load_op == LoadOp::Load, load_op != LoadOp::Load)?;
        self.decl().depth = Some(DepthAttachment { image: id, load_op, clear_depth, write });
        Ok(self)
    }

    /// Keeps the pass even if nothing exported depends on it (debug readback, timers, ...).
    pub fn side_effect(&mut self) -> &mut Self {
        self.decl().side_effect = true;
        self
    }

    /// Declares what the pass does (bytes, fetches, atomics) for profiling; without it the graph
    /// assumes each declared resource is touched once.
    pub fn work(&mut self, work: Work) -> &mut Self {
        self.decl().work = Some(Work { declared: true, ..work });
        self
    }

    /// Declares the pass's worst-case loop iterations per SIMD row and dispatch (see
    /// [`Work::loop_iterations`]); the rest of its work stays derived unless declared.
    pub fn loop_bound(&mut self, iterations: u64) -> &mut Self {
        self.decl().loop_iterations = iterations;
        self
    }

    /// Sets the closure that records the pass's commands.
    pub fn record(&mut self, f: impl FnOnce(&mut PassContext<'_>) -> crate::Result<()> + 'a) -> &mut Self {
        self.decl().record = Some(Box::new(f));
        self
    }

    /// Declaration index of the pass.
    pub(crate) fn index(&self) -> usize {
        self.index
    }

    fn decl(&mut self) -> &mut PassDecl<'a> {
        &mut self.graph.passes[self.index]
    }

    fn use_resource(
        &mut self,
        res: usize,
        access: Access,
        write: bool,
        method: &'static str,
    ) -> Result<&mut Self, GraphError> {
        if access.is_write() != write {
            return Err(GraphError::AccessDirection {
                pass: self.graph.passes[self.index].name.clone(),
                resource: self.graph.resources[res].name.clone(),
                access,
                method,
            });
        }
        self.add_use(res, access, access.is_read(), false)?;
        Ok(self)
    }

    /// Validates one access and merges it into the pass's use of `res`.
    fn add_use(&mut self, res: usize, access: Access, reads_prev: bool, discards: bool) -> Result<(), GraphError> {
        let pass = &self.graph.passes[self.index];
        let decl = &self.graph.resources[res];
        let is_image = matches!(decl.desc, ResourceDesc::Image(_));
        let err_ctx = || (pass.name.clone(), decl.name.clone());
        let valid = if is_image { access.valid_for_image() } else { access.valid_for_buffer() };
        if !valid {
            return Err(GraphError::AccessKind { resource: decl.name.clone(), access });
        }
        if access.is_attachment() && pass.kind != PassKind::Raster {
            let (pass, resource) = err_ctx();
            return Err(GraphError::AttachmentOutsideRaster { pass, resource });
        }
        let writes = access.is_write();
        if writes {
            if let Origin::Imported { read_only: true, .. } = decl.origin {
                let (pass, resource) = err_ctx();
                return Err(GraphError::WriteToReadOnly { pass, resource });
            }
        }
        if reads_prev && decl.origin == Origin::Transient && !decl.writers.iter().any(|&w| w < self.index) {
            let (pass, resource) = err_ctx();
            return Err(GraphError::ReadBeforeWrite { pass, resource });
        }
        let layout = is_image.then(|| access.image_layout());
        if let Some(existing) = pass.uses.iter().find(|u| u.res == res) {
            if existing.layout != layout {
                let (pass, resource) = err_ctx();
                return Err(GraphError::LayoutConflict {
                    pass,
                    resource,
                    first: existing.layout.unwrap_or_default(),
                    second: layout.unwrap_or_default(),
                });
            }
        }
        let new = Use {
            res,
            stage: access.stage(),
            access: access.access(),
            layout,
            reads_prev,
            writes,
            discards,
            image_usage: access.image_usage(),
            buffer_usage: access.buffer_usage(),
        };
        let pass = &mut self.graph.passes[self.index];
        match pass.uses.iter_mut().find(|u| u.res == res) {
            Some(u) => {
                // Discarding is only safe if every write discards and nothing reads the old contents.
                let ok = |x: &Use| !x.writes || x.discards;
                u.discards = ok(u) && ok(&new) && !(u.reads_prev || new.reads_prev);
                u.stage |= new.stage;
                u.access |= new.access;
                u.reads_prev |= new.reads_prev;
                u.writes |= new.writes;
                u.discards &= u.writes;
                u.image_usage |= new.image_usage;
                u.buffer_usage |= new.buffer_usage;
            }
            None => pass.uses.push(new),
        }
        if writes {
            let writers = &mut self.graph.resources[res].writers;
            if writers.last() != Some(&self.index) {
                writers.push(self.index);
            }
        }
        Ok(())
    }
}
