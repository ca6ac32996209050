//! The live profiler panel: per-pass GPU time of the last frame (from the frame graph's
//! timestamp queries), frame-time history, samples per pixel and error against a reference.

use crate::graph::trace::PassTiming;
use crate::metrics::ImageError;
use egui::{Color32, Rect, Sense, Stroke, Ui, Vec2};
use std::collections::VecDeque;

const HISTORY: usize = 240;

/// What the panel shows, fed once per completed frame.
#[derive(Default)]
pub struct Profiler {
    passes: Vec<(String, f64)>,
    frame_ms: VecDeque<f64>,
    /// Progressive samples per pixel (0 for renderers that do not accumulate).
    pub samples: u32,
    /// Latest error against the reference, with the samples it was measured at.
    pub error: Option<(ImageError, u32)>,
    /// Reference image name, when one is loaded.
    pub reference: Option<String>,
}

impl Profiler {
    /// Takes a completed frame's pass timings.
    pub fn record(&mut self, timings: &[PassTiming]) {
        self.passes = timings
            .iter()
            .map(|t| (t.name.clone(), t.gpu_end_ns.saturating_sub(t.gpu_begin_ns) as f64 * 1e-6))
            .collect();
        let begin = timings.iter().map(|t| t.gpu_begin_ns).min().unwrap_or(0);
        let end = timings.iter().map(|t| t.gpu_end_ns).max().unwrap_or(0);
        if self.frame_ms.len() == HISTORY {
            self.frame_ms.pop_front();
        }
        self.frame_ms.push_back(end.saturating_sub(begin) as f64 * 1e-6);
    }

    /// GPU ms of the last completed frame.
    pub fn last_frame_ms(&self) -> f64 {
        self.frame_ms.back().copied().unwrap_or(0.0)
    }

    /// Draws the panel.
    pub fn show(&self, ui: &mut Ui) {
        ui.label(format!("GPU frame {:.2} ms · {} spp", self.last_frame_ms(), self.samples));
        match (&self.reference, &self.error) {
            (Some(r), Some((e, at))) => {
                ui.label(format!(
                    "vs {r} at {at} spp: RMSE {:.4}, relMSE {:.4}, PSNR {:.1} dB",
                    e.rmse, e.rel_mse, e.psnr_db
                ));
            }
            (Some(r), None) => {
                ui.label(format!("vs {r}: measuring…"));
            }
            _ => {}
        }
        let max = self.passes.iter().map(|p| p.1).fold(1e-3, f64::max);
        let width = ui.available_width().max(120.0);
        for (name, ms) in &self.passes {
            let (rect, _) = ui.allocate_exact_size(Vec2::new(width, 14.0), Sense::hover());
            let bar = Rect::from_min_size(rect.min, Vec2::new(rect.width() * (*ms / max) as f32, rect.height()));
            let p = ui.painter();
            p.rect_filled(bar, 2.0, Color32::from_rgb(70, 120, 190));
            p.text(
                rect.left_center() + Vec2::new(4.0, 0.0),
                egui::Align2::LEFT_CENTER,
                format!("{name} {ms:.2} ms"),
                egui::FontId::monospace(10.0),
                Color32::WHITE,
            );
        }
        ui.label("frame time (ms), last 240 frames");
        let (rect, _) = ui.allocate_exact_size(Vec2::new(width, 60.0), Sense::hover());
        let p = ui.painter();
        p.rect_stroke(rect, 0.0, Stroke::new(1.0, Color32::GRAY), egui::StrokeKind::Inside);
        let top = self.frame_ms.iter().copied().fold(1e-3, f64::max);
        let pts: Vec<egui::Pos2> = self
            .frame_ms
            .iter()
            .enumerate()
            .map(|(i, ms)| {
                egui::pos2(
                    rect.left() + rect.width() * i as f32 / (HISTORY - 1) as f32,
                    rect.bottom() - rect.height() * (*ms / top) as f32,
                )
            })
            .collect();
        p.add(egui::Shape::line(pts, Stroke::new(1.5, Color32::from_rgb(240, 180, 60))));
        p.text(
            rect.left_top(),
            egui::Align2::LEFT_TOP,
            format!("{top:.1}"),
            egui::FontId::monospace(10.0),
            Color32::GRAY,
        );
    }
}
