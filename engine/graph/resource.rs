//! Resource descriptors, typed handles and the cross-frame resource state.

use crate::vk::ImageInfo;
use ash::vk;

/// Dimensionality of an image (shared with the resource layer).
pub use crate::vk::ImageKind;

/// Creation parameters of an image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ImageDesc {
    /// Texel format.
    pub format: vk::Format,
    /// Width, height, depth.
    pub extent: [u32; 3],
    /// Dimensionality.
    pub kind: ImageKind,
    /// Number of mip levels.
    pub mip_levels: u32,
    /// Usage beyond what the graph derives from declared accesses (e.g. for the executor's own use).
    pub extra_usage: vk::ImageUsageFlags,
}

impl ImageDesc {
    /// A single-mip 2D image with no extra usage.
    pub fn d2(format: vk::Format, width: u32, height: u32) -> Self {
        Self {
            format,
            extent: [width, height, 1],
            kind: ImageKind::D2,
            mip_levels: 1,
            extra_usage: vk::ImageUsageFlags::empty(),
        }
    }
}

/// Creation parameters of a buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BufferDesc {
    /// Size in bytes.
    pub size: u64,
    /// Usage beyond what the graph derives from declared accesses.
    pub extra_usage: vk::BufferUsageFlags,
}

impl BufferDesc {
    /// A buffer of `size` bytes with no extra usage.
    pub fn new(size: u64) -> Self {
        Self { size, extra_usage: vk::BufferUsageFlags::empty() }
    }
}

/// Handle of an image declared in one graph builder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ImageId(pub(crate) u32);

/// Handle of a buffer declared in one graph builder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BufferId(pub(crate) u32);

impl ImageId {
    /// Index of the resource in the graph's resource table.
    pub fn index(self) -> u32 {
        self.0
    }
}

impl BufferId {
    /// Index of the resource in the graph's resource table.
    pub fn index(self) -> u32 {
        self.0
    }
}

/// Either kind of resource handle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ResourceId {
    /// An image.
    Image(ImageId),
    /// A buffer.
    Buffer(BufferId),
}

impl ResourceId {
    /// Index of the resource in the graph's resource table.
    pub fn index(self) -> usize {
        match self {
            ResourceId::Image(i) => i.0 as usize,
            ResourceId::Buffer(b) => b.0 as usize,
        }
    }
}

/// How a persistent resource was last used: what a later use must wait for and transition from.
///
/// `stage` is every stage that may still touch the resource, `access` the writes among them
/// that still need to be made available (read bits are ignored), `layout` the current layout
/// (`UNDEFINED` for buffers or discardable contents).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ResourceState {
    /// Image layout (ignored for buffers).
    pub layout: vk::ImageLayout,
    /// Stages of the last use(s).
    pub stage: vk::PipelineStageFlags2,
    /// Access mask of the last use(s).
    pub access: vk::AccessFlags2,
}

impl ResourceState {
    /// Never used / contents undefined.
    pub const UNDEFINED: Self = Self {
        layout: vk::ImageLayout::UNDEFINED,
        stage: vk::PipelineStageFlags2::NONE,
        access: vk::AccessFlags2::NONE,
    };

    /// The state a resource is in right after being used as `access` (image layout included).
    pub fn from_access(access: crate::graph::Access) -> Self {
        Self { layout: access.image_layout(), stage: access.stage(), access: access.access() }
    }
}

/// Descriptor of either resource kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResourceDesc {
    /// An image.
    Image(ImageDesc),
    /// A buffer.
    Buffer(BufferDesc),
}

impl From<ImageId> for ResourceId {
    fn from(id: ImageId) -> Self {
        ResourceId::Image(id)
    }
}

impl From<BufferId> for ResourceId {
    fn from(id: BufferId) -> Self {
        ResourceId::Buffer(id)
    }
}

/// The image a transient descriptor creates, with the usage the graph derived.
pub(crate) fn info_of(desc: &ImageDesc, usage: vk::ImageUsageFlags) -> ImageInfo {
    ImageInfo { format: desc.format, extent: desc.extent, kind: desc.kind, mip_levels: desc.mip_levels, usage }
}
