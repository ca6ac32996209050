//! The interactive overlay: egui driven by winit events, drawn by the engine as frame-graph
//! passes onto the display image (`painter`), plus the panels the windowed demos share
//! (`controls` from the settings schemas, `tf_editor`, `profiler`) and `--ui-script` playback
//! (`script`). Its files do not import each other. Uses `crate::graph`, `crate::settings`,
//! `crate::volume` (the transfer function it edits) and `crate::vk`; used by the demos' windows.

pub mod controls;
pub mod painter;
pub mod profiler;
pub mod script;
pub mod tf_editor;

use crate::error::Result;
use crate::graph::execute::Imports;
use crate::graph::{GraphBuilder, ImageId};
use crate::vk::Context;
use painter::Painter;
use std::collections::VecDeque;
use winit::event::WindowEvent;
use winit::window::Window;

/// egui context, its winit adapter and the painter.
pub struct Overlay {
    /// The egui context panels are built with.
    pub egui: egui::Context,
    state: egui_winit::State,
    painter: Painter,
    pixels_per_point: f32,
    /// Clicks and presses a script asked for, in order.
    scripted: VecDeque<Scripted>,
    /// Hidden for one frame to capture the scene alone.
    pub hidden: bool,
}

/// Remembers where a widget was drawn, so scripts (and tests) can click it by name.
pub fn track(response: &egui::Response, name: &str) {
    let rect = response.rect;
    response.ctx.data_mut(|d| d.insert_temp(egui::Id::new(("ui-widget", name)), rect));
}

/// A scripted pointer action: the widget, whether the button is held over a frame (a press) or
/// released at once (a click), and the frames already done (hover, press, release).
struct Scripted {
    name: String,
    hold: bool,
    step: u8,
}

impl Overlay {
    /// Creates the egui state for `window` and the pipeline that draws it.
    pub fn new(ctx: &Context, window: &Window) -> Result<Self> {
        let egui = egui::Context::default();
        let max_side = ctx.info.limits.max_image_dimension2_d as usize;
        let state = egui_winit::State::new(
            egui.clone(),
            egui::ViewportId::ROOT,
            window,
            Some(window.scale_factor() as f32),
            window.theme(),
            Some(max_side),
        );
        Ok(Self {
            egui,
            state,
            painter: Painter::new(ctx)?,
            pixels_per_point: window.scale_factor() as f32,
            scripted: VecDeque::new(),
            hidden: false,
        })
    }

    /// Feeds a window event to egui; true when the UI used it (the camera should ignore it).
    pub fn on_event(&mut self, window: &Window, event: &WindowEvent) -> bool {
        self.state.on_window_event(window, event).consumed
    }

    /// Whether the pointer is over a panel (drags there are not camera drags).
    pub fn wants_pointer(&self) -> bool {
        self.egui.wants_pointer_input() || self.egui.is_pointer_over_area()
    }

    /// Where the widget tracked as `name` was drawn last frame, in points.
    pub fn widget_rect(&self, name: &str) -> Option<egui::Rect> {
        self.egui.data(|d| d.get_temp(egui::Id::new(("ui-widget", name))))
    }

    /// Queues a left click on the widget tracked as `name`: hover in one frame, press and release
    /// in the next (so the click is never slower than egui's click-duration limit). The widget
    /// is looked up each frame, so a layout change in between cannot misdirect the click.
    pub fn click(&mut self, name: &str) -> std::result::Result<(), String> {
        self.widget_rect(name).ok_or_else(|| format!("no widget named `{name}` on screen"))?;
        self.scripted.push_back(Scripted { name: name.to_string(), hold: false, step: 0 });
        Ok(())
    }

    /// Queues a press on the middle of the widget tracked as `name` that is released one frame
    /// later: what a slider needs to take the value under the pointer (it reads the pointer while
    /// the button is down; a click within one frame leaves it unchanged).
    pub fn press(&mut self, name: &str) -> std::result::Result<(), String> {
        self.widget_rect(name).ok_or_else(|| format!("no widget named `{name}` on screen"))?;
        self.scripted.push_back(Scripted { name: name.to_string(), hold: true, step: 0 });
        Ok(())
    }

    /// This frame's scripted pointer events.
    fn scripted_events(&mut self) -> Vec<egui::Event> {
        let Some(mut s) = self.scripted.pop_front() else { return Vec::new() };
        let Some(pos) = self.widget_rect(&s.name).map(|r| r.center()) else { return Vec::new() };
        let button = |pressed| egui::Event::PointerButton {
            pos,
            button: egui::PointerButton::Primary,
            pressed,
            modifiers: egui::Modifiers::NONE,
        };
        let moved = egui::Event::PointerMoved(pos);
        s.step += 1;
        match (s.step, s.hold) {
            (1, _) => {
                self.scripted.push_front(s);
                vec![moved]
            }
            (2, false) => vec![moved, button(true), button(false)],
            (2, true) => {
                self.scripted.push_front(s);
                vec![moved, button(true)]
            }
            _ => vec![moved, button(false)],
        }
    }

    /// Runs one UI frame (`build` adds the panels), tessellates it and stages its geometry and
    /// texture changes for [`Overlay::add_passes`]. Skipped while hidden, so nothing staged is
    /// lost to a frame that draws no overlay.
    pub fn run(
        &mut self,
        ctx: &Context,
        window: &Window,
        extent: [u32; 2],
        build: impl FnMut(&egui::Context),
    ) -> Result<()> {
        if self.hidden {
            return Ok(());
        }
        let mut raw = self.state.take_egui_input(window);
        let scripted = self.scripted_events();
        raw.events.extend(scripted);
        let out = self.egui.run(raw, build);
        self.state.handle_platform_output(window, out.platform_output);
        self.pixels_per_point = out.pixels_per_point;
        self.painter.update_textures(ctx, &out.textures_delta)?;
        let prims = self.egui.tessellate(out.shapes, out.pixels_per_point);
        self.painter.set_meshes(ctx, &prims, out.pixels_per_point, extent)
    }

    /// Drops this frame's staged texture uploads; call once the frame is recorded.
    pub fn finish_frame(&mut self) {
        self.painter.finish_frame();
    }
}

impl crate::graph::FrameOverlay for Overlay {
    /// The upload and overlay passes onto `target` (nothing when hidden).
    fn add_passes<'a>(&'a self, g: &mut GraphBuilder<'a>, imports: &mut Imports, target: ImageId) -> Result<()> {
        if self.hidden {
            return Ok(());
        }
        self.painter.add_passes(g, imports, target)
    }
}
