//! winit 0.30 event loop driving an app whose frame graph ends in a present pass onto the
//! acquired swapchain image ([`crate::graph::add_present_pass`]). The same app code runs
//! headless (read back to PNG) or windowed.

use super::swapchain::{Acquired, Swapchain};
use crate::error::{Error, Result, VkContext};
use crate::graph::PresentTarget;
use crate::vk::{commands, CommandPool, Context, ContextOptions, ValidationMessage};
use ash::vk;
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::window::{Window, WindowId};

const FRAMES_IN_FLIGHT: usize = 2;

/// An app shown in a window.
pub trait WindowApp {
    /// Records one frame into `cmd`; its graph must end with [`crate::graph::add_present_pass`]
    /// onto `target` (the acquired swapchain image, whose size is the window's).
    fn render(
        &mut self,
        ctx: &Context,
        window: &Window,
        cmd: vk::CommandBuffer,
        frame: u64,
        target: PresentTarget,
    ) -> Result<()>;

    /// Sees every window event (mouse, keys) before the runner handles it.
    fn input(&mut self, _window: &Window, _event: &WindowEvent) {}

    /// Asked after every presented frame: true closes the window (e.g. a script's `quit`).
    fn wants_exit(&self) -> bool {
        false
    }

    /// Window title to show, polled after every frame (`None` keeps the current one).
    fn title(&self) -> Option<String> {
        None
    }
}

/// Window behaviour, including a script for automated tests.
#[derive(Clone, Debug)]
pub struct WindowConfig {
    /// Title bar text.
    pub title: String,
    /// Initial inner size.
    pub size: [u32; 2],
    /// Close after this many presented frames (`None`: run until closed).
    pub max_frames: Option<u64>,
    /// Request these inner sizes after the given number of presented frames.
    pub resize_script: Vec<(u64, [u32; 2])>,
    /// Allow the event loop off the main thread (tests run on worker threads).
    pub any_thread: bool,
}

/// What happened during a windowed run.
#[derive(Debug, Default)]
pub struct WindowStats {
    /// Frames presented.
    pub frames_presented: u64,
    /// Swapchain creations (1 + recreations).
    pub swapchain_generations: u32,
    /// Swapchain extents seen, in order.
    pub extents: Vec<[u32; 2]>,
    /// Validation messages recorded during the run (empty without validation).
    pub validation_messages: Vec<ValidationMessage>,
}

struct Slot {
    pool: CommandPool,
    cmd: vk::CommandBuffer,
    acquired: vk::Semaphore,
    done_value: u64,
}

struct Runner<A: WindowApp> {
    config: WindowConfig,
    ctx: Context,
    app: A,
    window: Option<Window>,
    swapchain: Option<Swapchain>,
    slots: Vec<Slot>,
    frame: u64,
    dirty: bool,
    stats: WindowStats,
    error: Option<Error>,
}

/// Opens a window, creates the device for it, and runs `make_app`'s app until closed (or the
/// config's frame budget is spent).
pub fn run_windowed<A: WindowApp>(
    config: WindowConfig,
    opts: &ContextOptions,
    make_app: impl FnOnce(&Context) -> Result<A>,
) -> Result<WindowStats> {
    let mut builder = EventLoop::builder();
    if config.any_thread {
        #[cfg(all(unix, not(target_os = "macos")))]
        winit::platform::x11::EventLoopBuilderExtX11::with_any_thread(&mut builder, true);
    }
    let event_loop = builder.build().map_err(|e| Error::Window(format!("no display: {e}")))?;
    let display = event_loop.display_handle().map_err(|e| Error::Window(e.to_string()))?.as_raw();
    let ctx = Context::new(&ContextOptions { display: Some(display), ..opts.clone() })?;
    let sink = ctx.message_sink();
    let app = make_app(&ctx)?;
    let mut slots = Vec::new();
    for _ in 0..FRAMES_IN_FLIGHT {
        let pool = CommandPool::new(&ctx)?;
        let cmd = pool.allocate()?;
        // SAFETY: valid device.
        let acquired = unsafe { ctx.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
            .vk("vkCreateSemaphore")?;
        slots.push(Slot { pool, cmd, acquired, done_value: 0 });
    }
    let mut runner = Runner {
        config,
        ctx,
        app,
        window: None,
        swapchain: None,
        slots,
        frame: 0,
        dirty: true,
        stats: WindowStats::default(),
        error: None,
    };
    event_loop.run_app(&mut runner).map_err(|e| Error::Window(e.to_string()))?;
    let Runner { ctx, app, swapchain, slots, window, mut stats, error, .. } = runner;
    ctx.wait_idle()?;
    for s in &slots {
        // SAFETY: device idle; semaphores no longer in use.
        unsafe { ctx.device.destroy_semaphore(s.acquired, None) };
    }
    drop((slots, swapchain, app, window));
    drop(ctx);
    stats.validation_messages = sink.map(|s| s.lock().map(|v| v.clone()).unwrap_or_default()).unwrap_or_default();
    match error {
        Some(e) => Err(e),
        None => Ok(stats),
    }
}

impl<A: WindowApp> Runner<A> {
    fn fail(&mut self, el: &ActiveEventLoop, e: Error) {
        self.error.get_or_insert(e);
        el.exit();
    }

    fn draw(&mut self) -> Result<()> {
        let (Some(window), Some(sc)) = (self.window.as_ref(), self.swapchain.as_mut()) else { return Ok(()) };
        if self.dirty {
            let size = window.inner_size();
            if !sc.recreate([size.width, size.height])? {
                return Ok(()); // minimized: nothing to draw until it has area again
            }
            self.dirty = false;
            self.stats.swapchain_generations = sc.generation;
            self.stats.extents.push([sc.extent.width, sc.extent.height]);
        }
        let slot = &mut self.slots[(self.frame % FRAMES_IN_FLIGHT as u64) as usize];
        self.ctx.wait_for(slot.done_value)?;
        self.ctx.collect_garbage()?;
        let index = match sc.acquire(slot.acquired)? {
            Acquired::Image(i) => i,
            Acquired::Stale => {
                self.dirty = true;
                return Ok(());
            }
        };
        // SAFETY: the slot's previous submission completed (waited above).
        unsafe { self.ctx.device.reset_command_pool(slot.pool.raw, vk::CommandPoolResetFlags::empty()) }
            .vk("vkResetCommandPool")?;
        let cmd = slot.cmd;
        commands::begin(&self.ctx, cmd)?;
        let target = PresentTarget {
            image: sc.images[index as usize],
            format: sc.format,
            extent: [sc.extent.width, sc.extent.height],
        };
        self.ctx.set_frame(self.frame);
        self.app.render(&self.ctx, window, cmd, self.frame, target)?;
        // SAFETY: cmd is recording.
        unsafe { self.ctx.device.end_command_buffer(cmd) }.vk("vkEndCommandBuffer")?;
        slot.done_value =
            self.ctx.submit(&[cmd], &[(slot.acquired, vk::PipelineStageFlags2::TRANSFER)], &[sc.render_done(index)])?;
        if !sc.present(index)? {
            self.dirty = true;
        }
        self.frame += 1;
        self.stats.frames_presented += 1;
        Ok(())
    }
}

impl<A: WindowApp> ApplicationHandler for Runner<A> {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let attrs = Window::default_attributes()
            .with_title(self.config.title.clone())
            .with_inner_size(PhysicalSize::new(self.config.size[0], self.config.size[1]));
        let made = el.create_window(attrs).map_err(|e| Error::Window(e.to_string())).and_then(|w| {
            let d = w.display_handle().map_err(|e| Error::Window(e.to_string()))?.as_raw();
            let h = w.window_handle().map_err(|e| Error::Window(e.to_string()))?.as_raw();
            let sc = Swapchain::new(&self.ctx, d, h)?;
            Ok((w, sc))
        });
        match made {
            Ok((w, sc)) => {
                self.swapchain = Some(sc);
                w.request_redraw();
                self.window = Some(w);
            }
            Err(e) => self.fail(el, e),
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        if let Some(w) = &self.window {
            self.app.input(w, &event);
        }
        match event {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::Resized(_) => self.dirty = true,
            WindowEvent::RedrawRequested => {
                let before = self.stats.frames_presented;
                if let Err(e) = self.draw() {
                    return self.fail(el, e);
                }
                if self.stats.frames_presented != before {
                    let n = self.stats.frames_presented;
                    if let (Some(w), Some(title)) = (self.window.as_ref(), self.app.title()) {
                        w.set_title(&title);
                    }
                    if let (Some(w), Some(&(_, size))) =
                        (self.window.as_ref(), self.config.resize_script.iter().find(|(f, _)| *f == n))
                    {
                        let _ = w.request_inner_size(PhysicalSize::new(size[0], size[1]));
                    }
                    if self.config.max_frames.is_some_and(|m| n >= m) || self.app.wants_exit() {
                        el.exit();
                    }
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _el: &ActiveEventLoop) {
        if let Some(w) = &self.window {
            w.request_redraw();
        }
    }
}
