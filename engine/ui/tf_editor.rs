//! Transfer-function editor: a 1D curve with colour stops, or 2D value × gradient-magnitude
//! boxes, drawn over the loaded volume's histogram; saves and loads the JSON the CLI reads.

use crate::volume::optics::tf::{TfBox, TfPoint, TransferFunction, TF_GRADIENTS, TF_VALUES};
use egui::{Color32, Pos2, Rect, Sense, Stroke, Ui, Vec2};
use std::path::Path;

/// What the user did in the editor this frame.
#[derive(Clone, Debug, PartialEq)]
pub enum TfEvent {
    /// Nothing.
    None,
    /// The function changed (upload it).
    Changed,
}

/// Editor state around the function being edited.
pub struct TfEditor {
    /// The function as edited.
    pub tf: TransferFunction,
    /// Voxel counts per (value, gradient) table cell, row-major with value along x.
    histogram: Vec<u32>,
    /// Log counts per value (summed over gradients), normalized to 1: the 1D plot's backdrop.
    histogram_1d: Vec<f32>,
    texture: Option<egui::TextureHandle>,
    selected: usize,
    /// Extinction shown at the top of the 1D plot.
    scale: f32,
    /// File the Save/Load buttons use.
    pub path: String,
    /// Result of the last save/load.
    pub message: String,
}

fn color32(c: [f32; 3], alpha: u8) -> Color32 {
    let b = |v: f32| (v.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8;
    Color32::from_rgba_unmultiplied(b(c[0]), b(c[1]), b(c[2]), alpha)
}

fn max_extinction(tf: &TransferFunction) -> f32 {
    match tf {
        TransferFunction::OneD { points } => points.iter().map(|p| p.extinction).fold(0.0, f32::max),
        TransferFunction::TwoD { boxes } => boxes.iter().map(|b| b.extinction).fold(0.0, f32::max),
    }
}

fn histogram_1d(histogram: &[u32]) -> Vec<f32> {
    let mut h = vec![0u64; TF_VALUES];
    for row in histogram.chunks(TF_VALUES) {
        for (a, &c) in h.iter_mut().zip(row) {
            *a += u64::from(c);
        }
    }
    let top = h.iter().map(|&c| (c as f32).ln_1p()).fold(1e-6, f32::max);
    h.iter().map(|&c| (c as f32).ln_1p() / top).collect()
}

impl TfEditor {
    /// Edits `tf` over `histogram` (`TF_VALUES × TF_GRADIENTS` counts), saving to `path`.
    pub fn new(tf: TransferFunction, histogram: Vec<u32>, path: String) -> Self {
        let scale = (max_extinction(&tf) * 1.25).max(1.0);
        let histogram_1d = histogram_1d(&histogram);
        Self { tf, histogram, histogram_1d, texture: None, selected: 0, scale, path, message: String::new() }
    }

    /// Replaces the function (a preset or a loaded file).
    pub fn set(&mut self, tf: TransferFunction) {
        self.scale = (max_extinction(&tf) * 1.25).max(1.0);
        self.tf = tf;
        self.selected = 0;
    }

    /// Writes the function as JSON (the format `--set tf=FILE.json` reads).
    pub fn save(&self, path: &Path) -> crate::Result<()> {
        let text = serde_json::to_string_pretty(&self.tf).map_err(|e| crate::Error::Input(e.to_string()))?;
        std::fs::write(path, text).map_err(|source| crate::Error::Io { path: path.display().to_string(), source })
    }

    fn texture(&mut self, ctx: &egui::Context) -> egui::TextureId {
        if let Some(t) = &self.texture {
            return t.id();
        }
        // Log counts, gradient magnitude growing upwards as in the plot.
        let top = self.histogram.iter().map(|&c| (c as f32).ln_1p()).fold(1e-6, f32::max);
        let mut pixels = Vec::with_capacity(self.histogram.len());
        for y in (0..TF_GRADIENTS).rev() {
            for x in 0..TF_VALUES {
                let v = ((self.histogram[y * TF_VALUES + x] as f32).ln_1p() / top * 200.0) as u8;
                pixels.push(Color32::from_gray(v));
            }
        }
        let img = egui::ColorImage {
            size: [TF_VALUES, TF_GRADIENTS],
            source_size: Vec2::new(TF_VALUES as f32, TF_GRADIENTS as f32),
            pixels,
        };
        let t = ctx.load_texture("tf histogram", img, egui::TextureOptions::NEAREST);
        let id = t.id();
        self.texture = Some(t);
        id
    }

    /// Draws the editor; reports whether the function changed.
    pub fn show(&mut self, ui: &mut Ui) -> TfEvent {
        let before = self.tf.clone();
        ui.horizontal(|ui| {
            for name in ["default", "cloud", "bone", "edges"] {
                let r = ui.button(name);
                super::track(&r, &format!("tf:preset:{name}"));
                if r.clicked() {
                    if let Ok(tf) = TransferFunction::preset(name) {
                        self.set(tf);
                    }
                }
            }
        });
        match &self.tf {
            TransferFunction::OneD { .. } => self.curve(ui),
            TransferFunction::TwoD { .. } => self.boxes(ui),
        }
        ui.horizontal(|ui| {
            ui.text_edit_singleline(&mut self.path);
            let save = ui.button("Save TF");
            super::track(&save, "tf:save");
            if save.clicked() {
                self.message = match self.save(Path::new(&self.path)) {
                    Ok(()) => format!("saved {}", self.path),
                    Err(e) => e.to_string(),
                };
            }
            let load = ui.button("Load TF");
            super::track(&load, "tf:load");
            if load.clicked() {
                match TransferFunction::load(Path::new(&self.path)) {
                    Ok(tf) => {
                        self.set(tf);
                        self.message = format!("loaded {}", self.path);
                    }
                    Err(e) => self.message = e.to_string(),
                }
            }
        });
        if !self.message.is_empty() {
            ui.label(&self.message);
        }
        if self.tf != before && self.tf.validate().is_ok() {
            TfEvent::Changed
        } else {
            if self.tf.validate().is_err() {
                self.tf = before;
            }
            TfEvent::None
        }
    }

    fn curve(&mut self, ui: &mut Ui) {
        let TransferFunction::OneD { points } = &mut self.tf else { return };
        let width = ui.available_width().max(200.0);
        let (rect, _) = ui.allocate_exact_size(Vec2::new(width, 120.0), Sense::hover());
        let scale = self.scale;
        let to_screen = |v: f32, e: f32| {
            Pos2::new(rect.left() + v * rect.width(), rect.bottom() - (e / scale).min(1.0) * rect.height())
        };
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 0.0, Color32::from_gray(20));
        let bw = rect.width() / TF_VALUES as f32;
        for (i, h) in self.histogram_1d.iter().enumerate() {
            let x = rect.left() + i as f32 * bw;
            let r =
                Rect::from_min_max(Pos2::new(x, rect.bottom() - h * rect.height()), Pos2::new(x + bw, rect.bottom()));
            painter.rect_filled(r, 0.0, Color32::from_gray(60));
        }
        let line: Vec<Pos2> = points.iter().map(|p| to_screen(p.value, p.extinction)).collect();
        painter.add(egui::Shape::line(line, Stroke::new(2.0, Color32::WHITE)));
        let n = points.len();
        for i in 0..n {
            let p = points[i];
            let at = to_screen(p.value, p.extinction);
            let handle = Rect::from_center_size(at, Vec2::splat(10.0));
            let r = ui.interact(handle, ui.id().with(("tf point", i)), Sense::click_and_drag());
            super::track(&r, &format!("tf:point:{i}"));
            if r.clicked() || r.drag_started() {
                self.selected = i;
            }
            if r.dragged() {
                let d = r.drag_delta();
                let lo = if i == 0 { 0.0 } else { points[i - 1].value };
                let hi = if i + 1 == n { 1.0 } else { points[i + 1].value };
                let q = &mut points[i];
                q.value = (q.value + d.x / rect.width()).clamp(lo, hi);
                q.extinction = (q.extinction - d.y / rect.height() * scale).max(0.0);
            }
            let sel = i == self.selected;
            painter.circle(at, if sel { 6.0 } else { 4.5 }, color32(p.color, 255), Stroke::new(1.5, Color32::WHITE));
        }
        // Colour strip: the emission colour each value maps to.
        let (strip, _) = ui.allocate_exact_size(Vec2::new(width, 10.0), Sense::hover());
        let tf = TransferFunction::OneD { points: points.clone() };
        for i in 0..64 {
            let v = (i as f32 + 0.5) / 64.0;
            let c = tf.eval(v, 0.0);
            let x0 = strip.left() + strip.width() * i as f32 / 64.0;
            let r = Rect::from_min_max(
                Pos2::new(x0, strip.top()),
                Pos2::new(x0 + strip.width() / 64.0 + 1.0, strip.bottom()),
            );
            ui.painter().rect_filled(r, 0.0, color32([c[0], c[1], c[2]], 255));
        }
        let sel = self.selected.min(n.saturating_sub(1));
        let mut switch = None;
        ui.horizontal(|ui| {
            if let Some(p) = points.get_mut(sel) {
                ui.label(format!("point {sel}"));
                ui.color_edit_button_rgb(&mut p.color);
                ui.add(egui::DragValue::new(&mut p.extinction).speed(0.1).range(0.0..=1e5).prefix("σt "));
            }
            let add = ui.button("+");
            super::track(&add, "tf:add");
            if add.clicked() {
                let next = points.get(sel + 1).map_or(1.0, |p| p.value);
                let p = points[sel];
                let value = 0.5 * (p.value + next);
                let mid = TfPoint { value, ..p };
                points.insert(sel + 1, mid);
                self.selected = sel + 1;
            }
            if ui.button("−").clicked() && points.len() > 2 {
                points.remove(sel);
                self.selected = sel.saturating_sub(1);
            }
            ui.add(egui::DragValue::new(&mut self.scale).speed(0.5).range(0.1..=1e5).prefix("plot top σt "));
            if ui.button("2D").on_hover_text("switch to value × gradient boxes").clicked() {
                switch = Some(TransferFunction::TwoD {
                    boxes: vec![TfBox {
                        value: [0.2, 1.0],
                        gradient: [0.2, 1.0],
                        color: [0.9, 0.7, 0.5],
                        extinction: scale * 0.5,
                    }],
                });
            }
        });
        if let Some(tf) = switch {
            self.set(tf);
        }
    }

    fn boxes(&mut self, ui: &mut Ui) {
        let tex = self.texture(ui.ctx());
        let TransferFunction::TwoD { boxes } = &mut self.tf else { return };
        let width = ui.available_width().max(200.0);
        let (rect, _) = ui.allocate_exact_size(Vec2::new(width, 140.0), Sense::hover());
        let painter = ui.painter_at(rect);
        painter.image(tex, rect, Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)), Color32::WHITE);
        let to_screen = |v: f32, g: f32| Pos2::new(rect.left() + v * rect.width(), rect.bottom() - g * rect.height());
        let n = boxes.len();
        for (i, b) in boxes.iter_mut().enumerate() {
            let r = Rect::from_two_pos(to_screen(b.value[0], b.gradient[0]), to_screen(b.value[1], b.gradient[1]));
            let body = ui.interact(r, ui.id().with(("tf box", i)), Sense::click_and_drag());
            super::track(&body, &format!("tf:box:{i}"));
            let corner = ui.interact(
                Rect::from_center_size(r.right_top(), Vec2::splat(10.0)),
                ui.id().with(("tf box corner", i)),
                Sense::drag(),
            );
            if body.clicked() || body.drag_started() || corner.drag_started() {
                self.selected = i;
            }
            let dv = |d: Vec2| (d.x / rect.width(), -d.y / rect.height());
            if corner.dragged() {
                let (x, y) = dv(corner.drag_delta());
                b.value[1] = (b.value[1] + x).clamp(b.value[0], 1.0);
                b.gradient[1] = (b.gradient[1] + y).clamp(b.gradient[0], 1.0);
            } else if body.dragged() {
                let (x, y) = dv(body.drag_delta());
                let x = x.clamp(-b.value[0], 1.0 - b.value[1]);
                let y = y.clamp(-b.gradient[0], 1.0 - b.gradient[1]);
                b.value = b.value.map(|v| v + x);
                b.gradient = b.gradient.map(|g| g + y);
            }
            let sel = i == self.selected;
            painter.rect_filled(r, 0.0, color32(b.color, 70));
            let stroke = Stroke::new(if sel { 2.5 } else { 1.5 }, color32(b.color, 255));
            painter.rect_stroke(r, 0.0, stroke, egui::StrokeKind::Inside);
            painter.circle_filled(r.right_top(), 4.0, Color32::WHITE);
        }
        ui.label("x: value · y: gradient magnitude · drag a box to move it, its corner to resize");
        let sel = self.selected.min(n.saturating_sub(1));
        let mut switch = None;
        ui.horizontal(|ui| {
            if let Some(b) = boxes.get_mut(sel) {
                ui.label(format!("box {sel}"));
                ui.color_edit_button_rgb(&mut b.color);
                ui.add(egui::DragValue::new(&mut b.extinction).speed(0.1).range(0.0..=1e5).prefix("σt "));
            }
            if ui.button("+").clicked() {
                boxes.push(TfBox { value: [0.4, 0.6], gradient: [0.0, 0.5], color: [0.8, 0.8, 0.8], extinction: 10.0 });
                self.selected = boxes.len() - 1;
            }
            if ui.button("−").clicked() && boxes.len() > 1 {
                boxes.remove(sel);
                self.selected = 0;
            }
            if ui.button("1D").on_hover_text("switch to a value curve").clicked() {
                switch = Some(TransferFunction::ramp(0.1, 0.6, [0.9, 0.7, 0.5], 20.0));
            }
        });
        if let Some(tf) = switch {
            self.set(tf);
        }
    }
}
