//! Surface and swapchain: creation, recreation on resize/out-of-date, acquire and present.

use crate::error::{Error, Result, VkContext};
use crate::vk::Context;
use ash::vk;

/// A window surface with its swapchain and per-image present semaphores.
pub struct Swapchain {
    ctx: Context,
    surface_loader: ash::khr::surface::Instance,
    loader: ash::khr::swapchain::Device,
    surface: vk::SurfaceKHR,
    /// Raw swapchain (null until the first successful `recreate`).
    pub raw: vk::SwapchainKHR,
    /// Swapchain images.
    pub images: Vec<vk::Image>,
    /// Surface format in use.
    pub format: vk::Format,
    /// Current extent.
    pub extent: vk::Extent2D,
    /// Signalled by the submission that renders into image i, waited on by its present.
    render_done: Vec<vk::Semaphore>,
    /// How many times the swapchain was (re)created.
    pub generation: u32,
}

/// Result of trying to acquire an image.
pub enum Acquired {
    /// Image index to render into.
    Image(u32),
    /// The swapchain must be recreated first (resized or out of date).
    Stale,
}

impl Swapchain {
    /// Creates the surface for a window; the swapchain itself is made by `recreate`.
    pub fn new(
        ctx: &Context,
        display: raw_window_handle::RawDisplayHandle,
        window: raw_window_handle::RawWindowHandle,
    ) -> Result<Self> {
        // SAFETY: handles come from a live winit window that outlives this swapchain.
        let surface = unsafe { ash_window::create_surface(&ctx.entry, &ctx.instance, display, window, None) }
            .vk("vkCreateSurfaceKHR")?;
        let surface_loader = ash::khr::surface::Instance::new(&ctx.entry, &ctx.instance);
        // SAFETY: valid physical device, family and surface.
        let supported = unsafe {
            surface_loader.get_physical_device_surface_support(ctx.physical_device, ctx.queue_family, surface)
        }
        .vk("vkGetPhysicalDeviceSurfaceSupportKHR")?;
        if !supported {
            // SAFETY: surface unused.
            unsafe { surface_loader.destroy_surface(surface, None) };
            return Err(Error::Window(format!("device {} cannot present to this window", ctx.info.name)));
        }
        Ok(Self {
            ctx: ctx.clone(),
            loader: ash::khr::swapchain::Device::new(&ctx.instance, &ctx.device),
            surface_loader,
            surface,
            raw: vk::SwapchainKHR::null(),
            images: vec![],
            format: vk::Format::UNDEFINED,
            extent: vk::Extent2D::default(),
            render_done: vec![],
            generation: 0,
        })
    }

    /// (Re)creates the swapchain for `want` pixels; returns false when the surface has zero
    /// area (minimized) and nothing should be rendered.
    pub fn recreate(&mut self, want: [u32; 2]) -> Result<bool> {
        let pd = self.ctx.physical_device;
        // SAFETY: valid surface and physical device.
        let caps = unsafe { self.surface_loader.get_physical_device_surface_capabilities(pd, self.surface) }
            .vk("vkGetPhysicalDeviceSurfaceCapabilitiesKHR")?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: want[0].clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: want[1].clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        if extent.width == 0 || extent.height == 0 {
            return Ok(false);
        }
        // SAFETY: valid surface.
        let formats = unsafe { self.surface_loader.get_physical_device_surface_formats(pd, self.surface) }
            .vk("vkGetPhysicalDeviceSurfaceFormatsKHR")?;
        // Tone mapping writes linear values; an sRGB swapchain does the encode on blit.
        let fmt = formats
            .iter()
            .find(|f| f.format == vk::Format::B8G8R8A8_SRGB || f.format == vk::Format::R8G8B8A8_SRGB)
            .or(formats.first())
            .copied()
            .ok_or_else(|| Error::Window("surface reports no formats".into()))?;
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        self.ctx.wait_idle()?;
        let old = self.raw;
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(count)
            .image_format(fmt.format)
            .image_color_space(fmt.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::COLOR_ATTACHMENT)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(vk::CompositeAlphaFlagsKHR::OPAQUE)
            .present_mode(vk::PresentModeKHR::FIFO)
            .clipped(true)
            .old_swapchain(old);
        // SAFETY: valid surface; old swapchain (if any) is idle.
        self.raw = unsafe { self.loader.create_swapchain(&info, None) }.vk("vkCreateSwapchainKHR")?;
        self.destroy_old(old);
        // SAFETY: swapchain just created.
        self.images = unsafe { self.loader.get_swapchain_images(self.raw) }.vk("vkGetSwapchainImagesKHR")?;
        for _ in 0..self.images.len() {
            // SAFETY: valid device.
            let s = unsafe { self.ctx.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
                .vk("vkCreateSemaphore")?;
            self.render_done.push(s);
        }
        self.format = fmt.format;
        self.extent = extent;
        self.generation += 1;
        Ok(true)
    }

    fn destroy_old(&mut self, old: vk::SwapchainKHR) {
        // SAFETY: device is idle (recreate waited); these objects are no longer used.
        unsafe {
            for s in self.render_done.drain(..) {
                self.ctx.device.destroy_semaphore(s, None);
            }
            if old != vk::SwapchainKHR::null() {
                self.loader.destroy_swapchain(old, None);
            }
        }
    }

    /// Acquires the next image, signalling `acquired` when it is ready to be written.
    pub fn acquire(&self, acquired: vk::Semaphore) -> Result<Acquired> {
        let timeout = u64::try_from(self.ctx.gpu_timeout().as_nanos()).unwrap_or(u64::MAX);
        // SAFETY: valid swapchain; semaphore unsignalled and owned by the caller's frame slot.
        match unsafe { self.loader.acquire_next_image(self.raw, timeout, acquired, vk::Fence::null()) } {
            Ok((i, false)) => Ok(Acquired::Image(i)),
            // Suboptimal still signals the semaphore; render this frame, recreate afterwards.
            Ok((i, true)) => Ok(Acquired::Image(i)),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(Acquired::Stale),
            Err(vk::Result::TIMEOUT | vk::Result::NOT_READY) => Err(Error::GpuTimeout {
                work: "acquiring a swapchain image".into(),
                timeout_s: self.ctx.gpu_timeout().as_secs_f64(),
            }),
            Err(e) => Err(Error::Vulkan { call: "vkAcquireNextImageKHR", result: e }),
        }
    }

    /// Semaphore the rendering submission for image `i` must signal.
    pub fn render_done(&self, i: u32) -> vk::Semaphore {
        self.render_done[i as usize]
    }

    /// Presents image `i`; returns false if the swapchain is stale and must be recreated.
    pub fn present(&self, i: u32) -> Result<bool> {
        let waits = [self.render_done[i as usize]];
        let chains = [self.raw];
        let idx = [i];
        let info = vk::PresentInfoKHR::default().wait_semaphores(&waits).swapchains(&chains).image_indices(&idx);
        let _q = self.ctx.lock_queue();
        // SAFETY: queue access serialized; image i was acquired and rendered.
        match unsafe { self.loader.queue_present(self.ctx.queue, &info) } {
            Ok(false) => Ok(true),
            Ok(true) | Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(false),
            Err(e) => Err(Error::Vulkan { call: "vkQueuePresentKHR", result: e }),
        }
    }
}

impl Drop for Swapchain {
    fn drop(&mut self) {
        let _ = self.ctx.wait_idle();
        let old = std::mem::replace(&mut self.raw, vk::SwapchainKHR::null());
        self.destroy_old(old);
        // SAFETY: swapchain destroyed above; the surface is unused.
        unsafe { self.surface_loader.destroy_surface(self.surface, None) };
    }
}
