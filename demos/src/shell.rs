//! What every windowed demo's UI shares: the overlay (created with the window), the replay
//! script, the profiler, screenshots and the status line.

use crate::cli::DemoArgs;
use crate::output;
use std::path::PathBuf;
use vkengine::error::{Error, Result};
use vkengine::ui::profiler::Profiler;
use vkengine::ui::script::{Action, Script};
use vkengine::ui::Overlay;
use vkengine::vk::Context;
use winit::event::WindowEvent;
use winit::window::Window;

/// A screenshot in progress.
#[derive(Clone, Debug, PartialEq)]
pub enum Shot {
    /// The scene without the UI: PNG (tone-mapped) and EXR (linear HDR).
    Scene,
    /// The window as shown, UI included, to this PNG.
    Window(PathBuf),
}

/// UI state shared by the volume and mesh windows.
pub struct Shell {
    /// Created on the first frame (it needs the window).
    pub overlay: Option<Overlay>,
    script: Script,
    /// The live profiler.
    pub profiler: Profiler,
    /// Last action's outcome, shown in the settings panel.
    pub status: String,
    exit: bool,
    requested: Option<Shot>,
    rendering: Option<Shot>,
    /// F1 hides the panels.
    user_hidden: bool,
    dragging: bool,
    last_cursor: Option<(f64, f64)>,
    shots: u32,
    /// Stem of screenshot files (`--out` without extension, or `screenshots/DEMO`).
    stem: PathBuf,
    /// `--reference` and its pixels once loaded at the window's size.
    reference: Option<(PathBuf, Option<Vec<[f32; 4]>>)>,
    measured_at: Option<u64>,
}

impl Shell {
    /// Reads `--ui-script` and `--out` for `demo`.
    pub fn new(demo: &str, args: &DemoArgs) -> Result<Self> {
        let script = match &args.ui_script {
            Some(s) => Script::parse(s).map_err(Error::Input)?,
            None => Script::default(),
        };
        let stem = match &args.out {
            Some(p) => p.with_extension(""),
            None => PathBuf::from("screenshots").join(demo),
        };
        Ok(Self {
            overlay: None,
            script,
            profiler: Profiler::default(),
            status: String::new(),
            exit: false,
            requested: None,
            rendering: None,
            user_hidden: false,
            dragging: false,
            last_cursor: None,
            shots: 0,
            stem,
            reference: args.reference.clone().map(|p| (p, None)),
            measured_at: None,
        })
    }

    /// Whether a script asked to close the window.
    pub fn wants_exit(&self) -> bool {
        self.exit
    }

    /// Passes a window event to the UI; true when the UI used it. F1 shows/hides the panels.
    pub fn input(&mut self, window: &Window, event: &WindowEvent) -> bool {
        if let WindowEvent::KeyboardInput { event: k, .. } = event {
            if k.state == winit::event::ElementState::Pressed
                && k.logical_key == winit::keyboard::Key::Named(winit::keyboard::NamedKey::F1)
            {
                self.user_hidden = !self.user_hidden;
                return true;
            }
        }
        if self.user_hidden {
            return false;
        }
        let used = match &mut self.overlay {
            Some(o) => o.on_event(window, event) || o.wants_pointer(),
            None => false,
        };
        if used {
            self.dragging = false;
        }
        used
    }

    /// Tracks left-button drags outside the panels (call after [`Shell::input`] said the UI did
    /// not use the event); returns the cursor movement in pixels while dragging.
    pub fn drag(&mut self, event: &WindowEvent) -> Option<(f32, f32)> {
        match event {
            WindowEvent::MouseInput { state, button: winit::event::MouseButton::Left, .. } => {
                self.dragging = *state == winit::event::ElementState::Pressed;
                None
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = (position.x, position.y);
                let moved =
                    self.last_cursor.filter(|_| self.dragging).map(|l| ((p.0 - l.0) as f32, (p.1 - l.1) as f32));
                self.last_cursor = Some(p);
                moved
            }
            _ => None,
        }
    }

    /// Takes the previous frame's timings (the runner waited for it, so they are ready).
    pub fn frame_done(&mut self, previous: Option<vkengine::graph::execute::RecordedGraph>) {
        if let Some(t) = previous.and_then(|p| p.timings().ok()) {
            self.profiler.record(&t);
        }
    }

    /// The UI as the passes a frame draws over its output (none when the UI is off).
    pub fn frame_overlay(&self) -> Option<&dyn vkengine::graph::FrameOverlay> {
        self.overlay.as_ref().map(|o| o as &dyn vkengine::graph::FrameOverlay)
    }

    /// After a frame was recorded: its UI uploads are in the command buffer, drop the staging.
    pub fn frame_recorded(&mut self) {
        if let Some(o) = &mut self.overlay {
            o.finish_frame();
        }
    }

    /// Asks for a screenshot of the next frame.
    pub fn request(&mut self, shot: Shot) {
        self.requested = Some(shot);
    }

    /// Writes the screenshot rendered last frame, if one is due, reading the display image
    /// (and for scene shots the linear HDR image) through the closures.
    pub fn write_due_shot(
        &mut self,
        size: [u32; 2],
        read_ldr: impl FnOnce() -> Result<Vec<u8>>,
        read_hdr: impl FnOnce() -> Result<Vec<[f32; 4]>>,
    ) -> Result<()> {
        let Some(shot) = self.due_shot() else { return Ok(()) };
        let ldr = read_ldr()?;
        let hdr = if shot == Shot::Scene { Some(read_hdr()?) } else { None };
        self.write_shot(&shot, size, &ldr, hdr.as_deref())
    }

    /// The screenshot rendered last frame, now ready to be read back.
    fn due_shot(&mut self) -> Option<Shot> {
        let due = self.rendering.take();
        if let Some(o) = &mut self.overlay {
            o.hidden = self.user_hidden;
        }
        due
    }

    /// Writes a read-back screenshot: PNG always, EXR of the HDR image for scene shots.
    fn write_shot(&mut self, shot: &Shot, size: [u32; 2], ldr: &[u8], hdr: Option<&[[f32; 4]]>) -> Result<()> {
        let [w, h] = size;
        match shot {
            Shot::Window(path) => {
                output::write_png(path, w, h, ldr)?;
                self.status = format!("captured {}", path.display());
            }
            Shot::Scene => {
                self.shots += 1;
                let base = format!("{}-{:03}", self.stem.display(), self.shots);
                let png = PathBuf::from(format!("{base}.png"));
                output::write_png(&png, w, h, ldr)?;
                if let Some(hdr) = hdr {
                    output::write_exr(&PathBuf::from(format!("{base}.exr")), w, h, hdr)?;
                }
                self.status = format!("saved {base}.png/.exr");
            }
        }
        eprintln!("{}", self.status);
        Ok(())
    }

    /// Measures the error against `--reference` when `progress` (samples per pixel, or frames)
    /// reaches a power of two or a multiple of 16; `read_hdr` reads the current linear image.
    pub fn measure(
        &mut self,
        size: [u32; 2],
        progress: u64,
        read_hdr: impl FnOnce() -> Result<Vec<[f32; 4]>>,
    ) -> Result<()> {
        let Some((path, pixels)) = &mut self.reference else { return Ok(()) };
        if self.measured_at == Some(progress) || !(progress.is_power_of_two() || progress.is_multiple_of(16)) {
            return Ok(());
        }
        self.measured_at = Some(progress);
        self.profiler.reference = Some(path.display().to_string());
        if pixels.as_ref().is_none_or(|p| p.len() != (size[0] * size[1]) as usize) {
            match vkengine::metrics::load_reference(path, size) {
                Ok(p) => *pixels = Some(p),
                Err(e) => {
                    self.status = format!("reference: {e}");
                    *pixels = None;
                }
            }
        }
        if let Some(r) = pixels {
            let e = vkengine::metrics::compare(&read_hdr()?, r)?;
            self.profiler.error = Some((e, progress as u32));
        }
        Ok(())
    }

    /// Queues a scripted click (or, with `press`, a press held over a frame) on a widget.
    fn pointer(&mut self, frame: u64, name: &str, press: bool) -> Result<()> {
        if let Some(o) = &mut self.overlay {
            let queued = if press { o.press(name) } else { o.click(name) };
            queued.map_err(|e| Error::Input(format!("--ui-script at frame {frame}: {e}")))?;
        }
        Ok(())
    }

    /// Starts a frame: creates the overlay, runs the script's actions for `frame` (clicks and
    /// screenshots here; the rest returned for the demo), and hides the overlay for a scene shot.
    pub fn begin_frame(&mut self, ctx: &Context, window: &Window, frame: u64) -> Result<Vec<Action>> {
        if self.overlay.is_none() {
            self.overlay = Some(Overlay::new(ctx, window)?);
        }
        let mut rest = Vec::new();
        let actions: Vec<Action> = self.script.at(frame).cloned().collect();
        for a in actions {
            match a {
                Action::Click(name) => self.pointer(frame, &name, false)?,
                Action::Press(name) => self.pointer(frame, &name, true)?,
                Action::Screenshot => self.request(Shot::Scene),
                Action::Capture(p) => self.request(Shot::Window(p)),
                Action::Quit => self.exit = true,
                Action::Resize(w, h) => {
                    // The new extent arrives as a resize event; the swapchain follows it.
                    let _ = window.request_inner_size(winit::dpi::PhysicalSize::new(w, h));
                }
                Action::Minimize(m) => window.set_minimized(m),
                other => rest.push(other),
            }
        }
        if let Some(shot) = self.requested.take() {
            if let Some(o) = &mut self.overlay {
                o.hidden = self.user_hidden || shot == Shot::Scene;
            }
            self.rendering = Some(shot);
        }
        Ok(rest)
    }

    /// The buttons every demo has: screenshot, save scene; true when Save scene was clicked.
    pub fn actions(&mut self, ui: &mut egui::Ui) -> bool {
        let mut save = false;
        ui.horizontal(|ui| {
            let shot = ui.button("Screenshot");
            vkengine::ui::track(&shot, "screenshot");
            if shot.clicked() {
                self.request(Shot::Scene);
            }
            let s = ui.button("Save scene");
            vkengine::ui::track(&s, "save-scene");
            save = s.clicked();
        });
        if !self.status.is_empty() {
            ui.label(&self.status);
        }
        save
    }
}
