//! GPU images (2D, 3D, 2D arrays) with a default view, and deferred destruction.

use super::context::{Context, Garbage};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

/// Image dimensionality.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ImageKind {
    /// 2D image.
    D2,
    /// 3D (volume) image.
    D3,
    /// 2D array with this many layers.
    D2Array(u32),
}

/// Everything needed to create an image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ImageInfo {
    /// Texel format.
    pub format: vk::Format,
    /// Width, height, depth (depth 1 for 2D).
    pub extent: [u32; 3],
    /// Dimensionality.
    pub kind: ImageKind,
    /// Mip levels (≥ 1).
    pub mip_levels: u32,
    /// Usage flags.
    pub usage: vk::ImageUsageFlags,
}

impl ImageInfo {
    /// A single-mip 2D image.
    pub fn d2(format: vk::Format, width: u32, height: u32, usage: vk::ImageUsageFlags) -> Self {
        Self { format, extent: [width, height, 1], kind: ImageKind::D2, mip_levels: 1, usage }
    }

    /// A single-mip 3D image.
    pub fn d3(format: vk::Format, extent: [u32; 3], usage: vk::ImageUsageFlags) -> Self {
        Self { format, extent, kind: ImageKind::D3, mip_levels: 1, usage }
    }

    /// Layer count (1 unless an array).
    pub fn layers(&self) -> u32 {
        match self.kind {
            ImageKind::D2Array(n) => n,
            _ => 1,
        }
    }

    /// Vulkan create info for this description.
    pub fn create_info(&self) -> vk::ImageCreateInfo<'static> {
        let (ty, extent) = match self.kind {
            ImageKind::D3 => (vk::ImageType::TYPE_3D, self.extent),
            _ => (vk::ImageType::TYPE_2D, [self.extent[0], self.extent[1], 1]),
        };
        vk::ImageCreateInfo::default()
            .image_type(ty)
            .format(self.format)
            .extent(vk::Extent3D { width: extent[0], height: extent[1], depth: extent[2] })
            .mip_levels(self.mip_levels)
            .array_layers(self.layers())
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(self.usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED)
    }

    /// Aspect implied by the format.
    pub fn aspect(&self) -> vk::ImageAspectFlags {
        aspect_of(self.format)
    }

    /// Subresource range covering every mip and layer.
    pub fn full_range(&self) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange {
            aspect_mask: self.aspect(),
            base_mip_level: 0,
            level_count: self.mip_levels,
            base_array_layer: 0,
            layer_count: self.layers(),
        }
    }

    fn validate(&self, name: &str, limits: &vk::PhysicalDeviceLimits) -> Result<()> {
        let [w, h, d] = self.extent;
        if w == 0 || h == 0 || d == 0 || self.mip_levels == 0 {
            return Err(Error::Input(format!("image `{name}`: zero-sized extent {w}x{h}x{d} or no mips")));
        }
        let max = match self.kind {
            ImageKind::D3 => limits.max_image_dimension3_d,
            _ => limits.max_image_dimension2_d,
        };
        if w > max || h > max || d > max {
            return Err(Error::Input(format!("image `{name}`: extent {w}x{h}x{d} exceeds the device limit {max}")));
        }
        Ok(())
    }
}

/// Aspect flags for a format (depth, stencil or color).
pub fn aspect_of(format: vk::Format) -> vk::ImageAspectFlags {
    match format {
        vk::Format::D16_UNORM | vk::Format::D32_SFLOAT | vk::Format::X8_D24_UNORM_PACK32 => vk::ImageAspectFlags::DEPTH,
        vk::Format::D24_UNORM_S8_UINT | vk::Format::D32_SFLOAT_S8_UINT | vk::Format::D16_UNORM_S8_UINT => {
            vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL
        }
        _ => vk::ImageAspectFlags::COLOR,
    }
}

/// Bytes per texel for the uncompressed formats the engine uploads/reads back.
pub fn texel_size(format: vk::Format) -> Option<u64> {
    Some(match format {
        vk::Format::R8_UNORM | vk::Format::R8_UINT => 1,
        vk::Format::R16_UNORM | vk::Format::R16_SFLOAT | vk::Format::R16_UINT | vk::Format::R8G8_UNORM => 2,
        vk::Format::R8G8B8A8_UNORM
        | vk::Format::R8G8B8A8_SRGB
        | vk::Format::B8G8R8A8_UNORM
        | vk::Format::B8G8R8A8_SRGB
        | vk::Format::R32_SFLOAT
        | vk::Format::R32_UINT
        | vk::Format::R32_SINT
        | vk::Format::D32_SFLOAT
        | vk::Format::R16G16_SFLOAT => 4,
        vk::Format::R16G16B16A16_SFLOAT | vk::Format::R32G32_SFLOAT | vk::Format::R32G32_UINT => 8,
        vk::Format::R32G32B32A32_SFLOAT | vk::Format::R32G32B32A32_UINT => 16,
        _ => return None,
    })
}

/// An image, its default view and memory; destroyed once the GPU is done after the last drop.
pub struct Image {
    ctx: Context,
    /// Raw handle.
    pub raw: vk::Image,
    /// View over all mips and layers (null for transfer-only images).
    pub view: vk::ImageView,
    /// Creation parameters.
    pub info: ImageInfo,
    allocation: Option<Allocation>,
    owned: bool,
}

impl Image {
    /// The context the image belongs to (to create siblings where no context is at hand).
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// Bytes of device memory this image was given (0 when its memory is owned elsewhere).
    pub fn memory_bytes(&self) -> u64 {
        self.allocation.as_ref().map_or(0, |a| a.size())
    }

    /// Creates an image with dedicated GPU memory and a full view.
    pub fn new(ctx: &Context, name: &str, info: ImageInfo) -> Result<Self> {
        info.validate(name, &ctx.info.limits)?;
        // SAFETY: valid device and create info.
        let raw = unsafe { ctx.device.create_image(&info.create_info(), None) }.vk("vkCreateImage")?;
        // SAFETY: raw just created from this device.
        let requirements = unsafe { ctx.device.get_image_memory_requirements(raw) };
        let allocation = match ctx.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location: MemoryLocation::GpuOnly,
            linear: false,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        }) {
            Ok(a) => a,
            Err(source) => {
                // SAFETY: image unused so far.
                unsafe { ctx.device.destroy_image(raw, None) };
                return Err(Error::Allocation { name: name.into(), source });
            }
        };
        // SAFETY: allocation satisfies the image's requirements.
        if let Err(e) = unsafe { ctx.device.bind_image_memory(raw, allocation.memory(), allocation.offset()) } {
            ctx.defer_destroy(Garbage::Image(raw, vec![], Some(allocation)));
            return Err(Error::Vulkan { call: "vkBindImageMemory", result: e });
        }
        let view = match create_view(ctx, raw, &info) {
            Ok(v) => v,
            Err(e) => {
                ctx.defer_destroy(Garbage::Image(raw, vec![], Some(allocation)));
                return Err(e);
            }
        };
        ctx.set_name(raw, name);
        ctx.set_name(view, name);
        Ok(Self { ctx: ctx.clone(), raw, view, info, allocation: Some(allocation), owned: true })
    }

    /// Wraps an image whose memory is owned elsewhere (a swapchain image, or aliased graph
    /// memory); creates and owns only the view.
    pub fn wrap(ctx: &Context, name: &str, raw: vk::Image, info: ImageInfo, owns_image: bool) -> Result<Self> {
        let view = create_view(ctx, raw, &info)?;
        ctx.set_name(view, name);
        Ok(Self { ctx: ctx.clone(), raw, view, info, allocation: None, owned: owns_image })
    }
}

/// Creates a view over every mip and layer with the image's natural view type; a null view for
/// images whose usage allows no view (transfer-only).
pub fn create_view(ctx: &Context, raw: vk::Image, info: &ImageInfo) -> Result<vk::ImageView> {
    let viewable = vk::ImageUsageFlags::SAMPLED
        | vk::ImageUsageFlags::STORAGE
        | vk::ImageUsageFlags::COLOR_ATTACHMENT
        | vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
        | vk::ImageUsageFlags::INPUT_ATTACHMENT;
    if !info.usage.intersects(viewable) {
        return Ok(vk::ImageView::null());
    }
    let view_type = match info.kind {
        ImageKind::D2 => vk::ImageViewType::TYPE_2D,
        ImageKind::D3 => vk::ImageViewType::TYPE_3D,
        ImageKind::D2Array(_) => vk::ImageViewType::TYPE_2D_ARRAY,
    };
    let vinfo = vk::ImageViewCreateInfo::default()
        .image(raw)
        .view_type(view_type)
        .format(info.format)
        .subresource_range(info.full_range());
    // SAFETY: raw is a live image of this device with a compatible format.
    unsafe { ctx.device.create_image_view(&vinfo, None) }.vk("vkCreateImageView")
}

impl Drop for Image {
    fn drop(&mut self) {
        if self.owned {
            self.ctx.defer_destroy(Garbage::Image(self.raw, vec![self.view], self.allocation.take()));
        } else {
            self.ctx.defer_destroy(Garbage::Image(vk::Image::null(), vec![self.view], None));
        }
    }
}
