//! How a pass touches a resource, and the Vulkan synchronization2 facts that follow from it.

use ash::vk;

/// Shader stage(s) a shader-side access happens in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShaderStage {
    /// Compute shader.
    Compute,
    /// Vertex shader.
    Vertex,
    /// Fragment shader.
    Fragment,
    /// Geometry shader.
    Geometry,
    /// Every graphics shader stage (pre-rasterization and fragment).
    AllGraphics,
}

impl ShaderStage {
    /// Pipeline stages this shader stage executes in.
    pub fn stage_flags(self) -> vk::PipelineStageFlags2 {
        match self {
            ShaderStage::Compute => vk::PipelineStageFlags2::COMPUTE_SHADER,
            ShaderStage::Vertex => vk::PipelineStageFlags2::VERTEX_SHADER,
            ShaderStage::Fragment => vk::PipelineStageFlags2::FRAGMENT_SHADER,
            ShaderStage::Geometry => vk::PipelineStageFlags2::GEOMETRY_SHADER,
            // PRE_RASTERIZATION_SHADERS rather than naming GEOMETRY/TESSELLATION bits, which
            // are invalid in barriers when those device features are disabled.
            ShaderStage::AllGraphics => {
                vk::PipelineStageFlags2::PRE_RASTERIZATION_SHADERS | vk::PipelineStageFlags2::FRAGMENT_SHADER
            }
        }
    }
}

/// One kind of use of an image or buffer by a pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Access {
    /// Sampled image / texel fetch through a sampler.
    Sampled(ShaderStage),
    /// Storage image or storage buffer read.
    StorageRead(ShaderStage),
    /// Uniform buffer read.
    UniformRead(ShaderStage),
    /// Storage image or storage buffer write (may be partial).
    StorageWrite(ShaderStage),
    /// Storage read and write in the same pass (read-modify-write).
    StorageReadWrite(ShaderStage),
    /// Storage atomics (read-modify-write).
    StorageAtomic(ShaderStage),
    /// Color attachment output without reading previous contents.
    ColorAttachmentWrite,
    /// Color attachment with load op Load or blending (reads previous contents).
    ColorAttachmentReadWrite,
    /// Read-only depth attachment (depth test without writes).
    DepthRead,
    /// Depth test and depth write.
    DepthWrite,
    /// Source of a copy/blit.
    TransferSrc,
    /// Destination of a copy, blit, fill, update or clear.
    TransferDst,
    /// Indirect draw/dispatch arguments.
    IndirectArgs,
    /// Vertex buffer binding.
    VertexBuffer,
    /// Index buffer binding.
    IndexBuffer,
    /// Host readback after submission completes.
    HostRead,
    /// Presentation to a swapchain.
    Present,
}

const WRITE_ACCESS_BITS: vk::AccessFlags2 = vk::AccessFlags2::from_raw(
    vk::AccessFlags2::SHADER_STORAGE_WRITE.as_raw()
        | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw()
        | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw()
        | vk::AccessFlags2::TRANSFER_WRITE.as_raw()
        | vk::AccessFlags2::HOST_WRITE.as_raw()
        | vk::AccessFlags2::SHADER_WRITE.as_raw()
        | vk::AccessFlags2::MEMORY_WRITE.as_raw(),
);

/// The write bits of an access mask (what must be made available to later accesses).
pub fn write_bits(access: vk::AccessFlags2) -> vk::AccessFlags2 {
    access & WRITE_ACCESS_BITS
}

impl Access {
    /// Pipeline stages the access happens in.
    pub fn stage(self) -> vk::PipelineStageFlags2 {
        use vk::PipelineStageFlags2 as S;
        match self {
            Access::Sampled(s)
            | Access::StorageRead(s)
            | Access::UniformRead(s)
            | Access::StorageWrite(s)
            | Access::StorageReadWrite(s)
            | Access::StorageAtomic(s) => s.stage_flags(),
            Access::ColorAttachmentWrite | Access::ColorAttachmentReadWrite => S::COLOR_ATTACHMENT_OUTPUT,
            Access::DepthRead | Access::DepthWrite => S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
            // Never COPY/CLEAR: validation counts vkCmdFillBuffer/vkCmdUpdateBuffer as
            // all-transfer writes, so only TRANSFER is guaranteed to cover every transfer op.
            Access::TransferSrc | Access::TransferDst => S::TRANSFER,
            Access::IndirectArgs => S::DRAW_INDIRECT,
            Access::VertexBuffer => S::VERTEX_ATTRIBUTE_INPUT,
            Access::IndexBuffer => S::INDEX_INPUT,
            Access::HostRead => S::HOST,
            // Presentation is ordered by the present semaphore, not by a pipeline stage.
            Access::Present => S::NONE,
        }
    }

    /// Minimal access mask of the access.
    pub fn access(self) -> vk::AccessFlags2 {
        use vk::AccessFlags2 as A;
        match self {
            Access::Sampled(_) => A::SHADER_SAMPLED_READ,
            Access::StorageRead(_) => A::SHADER_STORAGE_READ,
            Access::UniformRead(_) => A::UNIFORM_READ,
            Access::StorageWrite(_) => A::SHADER_STORAGE_WRITE,
            Access::StorageReadWrite(_) | Access::StorageAtomic(_) => A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
            Access::ColorAttachmentWrite => A::COLOR_ATTACHMENT_WRITE,
            Access::ColorAttachmentReadWrite => A::COLOR_ATTACHMENT_READ | A::COLOR_ATTACHMENT_WRITE,
            Access::DepthRead => A::DEPTH_STENCIL_ATTACHMENT_READ,
            Access::DepthWrite => A::DEPTH_STENCIL_ATTACHMENT_READ | A::DEPTH_STENCIL_ATTACHMENT_WRITE,
            Access::TransferSrc => A::TRANSFER_READ,
            Access::TransferDst => A::TRANSFER_WRITE,
            Access::IndirectArgs => A::INDIRECT_COMMAND_READ,
            Access::VertexBuffer => A::VERTEX_ATTRIBUTE_READ,
            Access::IndexBuffer => A::INDEX_READ,
            Access::HostRead => A::HOST_READ,
            Access::Present => A::NONE,
        }
    }

    /// Image layout the access requires (`UNDEFINED` for buffer-only accesses).
    pub fn image_layout(self) -> vk::ImageLayout {
        use vk::ImageLayout as L;
        match self {
            Access::Sampled(_) => L::SHADER_READ_ONLY_OPTIMAL,
            Access::StorageRead(_)
            | Access::StorageWrite(_)
            | Access::StorageReadWrite(_)
            | Access::StorageAtomic(_) => L::GENERAL,
            Access::ColorAttachmentWrite | Access::ColorAttachmentReadWrite => L::COLOR_ATTACHMENT_OPTIMAL,
            Access::DepthRead => L::DEPTH_READ_ONLY_OPTIMAL,
            Access::DepthWrite => L::DEPTH_ATTACHMENT_OPTIMAL,
            Access::TransferSrc => L::TRANSFER_SRC_OPTIMAL,
            Access::TransferDst => L::TRANSFER_DST_OPTIMAL,
            // Host access to images is only possible on linear images in GENERAL.
            Access::HostRead => L::GENERAL,
            Access::Present => L::PRESENT_SRC_KHR,
            Access::UniformRead(_) | Access::IndirectArgs | Access::VertexBuffer | Access::IndexBuffer => L::UNDEFINED,
        }
    }

    /// Whether the access modifies the resource.
    pub fn is_write(self) -> bool {
        !write_bits(self.access()).is_empty()
    }

    /// Whether the access observes the previous contents (read-modify-write counts).
    pub fn is_read(self) -> bool {
        !(self.access() & !WRITE_ACCESS_BITS).is_empty() || self == Access::Present
    }

    /// Whether the access is an attachment access, only legal in raster passes.
    pub fn is_attachment(self) -> bool {
        matches!(
            self,
            Access::ColorAttachmentWrite | Access::ColorAttachmentReadWrite | Access::DepthRead | Access::DepthWrite
        )
    }

    /// Whether the access can apply to an image.
    pub fn valid_for_image(self) -> bool {
        self.image_layout() != vk::ImageLayout::UNDEFINED
    }

    /// Whether the access can apply to a buffer.
    pub fn valid_for_buffer(self) -> bool {
        !self.is_attachment() && self != Access::Present
    }

    /// Image usage flags an image needs to support this access.
    pub fn image_usage(self) -> vk::ImageUsageFlags {
        use vk::ImageUsageFlags as U;
        match self {
            Access::Sampled(_) => U::SAMPLED,
            Access::StorageRead(_)
            | Access::StorageWrite(_)
            | Access::StorageReadWrite(_)
            | Access::StorageAtomic(_) => U::STORAGE,
            Access::ColorAttachmentWrite | Access::ColorAttachmentReadWrite => U::COLOR_ATTACHMENT,
            Access::DepthRead | Access::DepthWrite => U::DEPTH_STENCIL_ATTACHMENT,
            Access::TransferSrc => U::TRANSFER_SRC,
            Access::TransferDst => U::TRANSFER_DST,
            _ => U::empty(),
        }
    }

    /// Buffer usage flags a buffer needs to support this access.
    pub fn buffer_usage(self) -> vk::BufferUsageFlags {
        use vk::BufferUsageFlags as U;
        match self {
            Access::Sampled(_) => U::UNIFORM_TEXEL_BUFFER,
            Access::UniformRead(_) => U::UNIFORM_BUFFER,
            Access::StorageRead(_)
            | Access::StorageWrite(_)
            | Access::StorageReadWrite(_)
            // Storage texel usage too: a pass may read a storage buffer as an `imageBuffer`.
            | Access::StorageAtomic(_) => U::STORAGE_BUFFER | U::STORAGE_TEXEL_BUFFER,
            Access::TransferSrc => U::TRANSFER_SRC,
            Access::TransferDst => U::TRANSFER_DST,
            Access::IndirectArgs => U::INDIRECT_BUFFER,
            Access::VertexBuffer => U::VERTEX_BUFFER,
            Access::IndexBuffer => U::INDEX_BUFFER,
            _ => U::empty(),
        }
    }
}
