//! The LPV SH grid layout comparison: one propagation-like gather step in three layouts.

use super::{rgba32f_3d, storage_buffer, upload_image, uploaded};
use crate::limits::cpu::*;
use crate::limits::{Bench, BenchGraph, Case, Rate};
use vkengine::graph::{PersistentBuffer, PersistentImage};
use vkengine::shaders;
use vkengine::vk::{vk, Context};
use vkengine::{Error, Result};

/// How an LPV grid of 12 floats per cell (3 channels × 4 SH coefficients) is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShLayout {
    /// Coefficient-major floats `[channel·4 + k][cell]` (the engine's LPV buffers).
    CoefficientMajor,
    /// Cell-major vec4s `[cell][channel]`.
    CellMajor,
    /// One RGBA32F 3D storage image per channel.
    Images,
}

impl ShLayout {
    /// Every layout, in report order (the [`LpvLayoutBench`] case order).
    pub const ALL: [ShLayout; 3] = [ShLayout::CoefficientMajor, ShLayout::CellMajor, ShLayout::Images];

    /// Short key for names.
    pub fn key(self) -> &'static str {
        match self {
            ShLayout::CoefficientMajor => "soa",
            ShLayout::CellMajor => "aos",
            ShLayout::Images => "images",
        }
    }

    /// Human-readable description.
    pub fn describe(self) -> &'static str {
        match self {
            ShLayout::CoefficientMajor => "SoA floats [channel*4+k][cell] (current)",
            ShLayout::CellMajor => "AoS vec4 [cell][channel]",
            ShLayout::Images => "three RGBA32F 3D storage images",
        }
    }

    /// Its case index in [`LpvLayoutBench`].
    pub fn case(self) -> usize {
        self as usize
    }
}

/// The LPV SH layout comparison: one propagation-like gather step in each [`ShLayout`].
pub struct LpvLayoutBench {
    ctx: Context,
    n: u32,
    soa: [PersistentBuffer; 2],
    aos: [PersistentBuffer; 2],
    src_images: Vec<PersistentImage>,
    dst_images: Vec<PersistentImage>,
}

impl LpvLayoutBench {
    /// An n³ grid of [`lpv_input`] in every layout.
    pub fn new(ctx: &Context, n: u32) -> Result<Self> {
        let n = n.max(1);
        let cells = n * n * n;
        let floats =
            |f: &dyn Fn(u32) -> f32, len: u32| -> Vec<u8> { (0..len).flat_map(|i| f(i).to_le_bytes()).collect() };
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let bytes = cells as u64 * 48;
        let soa_data = floats(&|i| lpv_input(i % cells, i / cells), cells * 12);
        let aos_data = floats(&|i| lpv_input(i / 12, i % 12), cells * 12);
        let soa = [uploaded(ctx, "lpv soa src", &soa_data, usage)?, storage_buffer(ctx, "lpv soa dst", bytes)?];
        let aos = [uploaded(ctx, "lpv aos src", &aos_data, usage)?, storage_buffer(ctx, "lpv aos dst", bytes)?];
        let src_usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST;
        let dst_usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        let (mut src_images, mut dst_images) = (Vec::new(), Vec::new());
        for ch in 0..3u32 {
            let img = rgba32f_3d(ctx, "lpv image src", n, src_usage)?;
            let texels = (0..cells).map(|c| [0, 1, 2, 3].map(|k| lpv_input(c, ch * 4 + k)));
            let layout = vk::ImageLayout::GENERAL;
            let state = upload_image(ctx, &img, &vec4_bytes(texels), layout, vk::AccessFlags2::SHADER_STORAGE_READ)?;
            src_images.push(PersistentImage::with_state(img, state));
            dst_images.push(PersistentImage::new(rgba32f_3d(ctx, "lpv image dst", n, dst_usage)?));
        }
        Ok(Self { ctx: ctx.clone(), n, soa, aos, src_images, dst_images })
    }

    /// Grid edge.
    pub fn edge(&self) -> u32 {
        self.n
    }

    /// The input per cell `[channel·4 + k]`.
    pub fn input(&self) -> Vec<[f32; 12]> {
        (0..self.n.pow(3)).map(|c| std::array::from_fn(|j| lpv_input(c, j as u32))).collect()
    }

    /// The step's output in `layout`, per cell `[channel·4 + k]` (after a run in that layout).
    pub fn output(&self, layout: ShLayout) -> Result<Vec<[f32; 12]>> {
        let cells = self.n.pow(3) as usize;
        let mut out = vec![[0f32; 12]; cells];
        match layout {
            ShLayout::CoefficientMajor | ShLayout::CellMajor => {
                let soa = layout == ShLayout::CoefficientMajor;
                let t = if soa { &self.soa[1] } else { &self.aos[1] };
                let f: Vec<f32> = u32s(&t.read(&self.ctx)?).into_iter().map(f32::from_bits).collect();
                for (c, o) in out.iter_mut().enumerate() {
                    for (j, v) in o.iter_mut().enumerate() {
                        *v = if soa { f[j * cells + c] } else { f[c * 12 + j] };
                    }
                }
            }
            ShLayout::Images => {
                for (ch, t) in self.dst_images.iter().enumerate() {
                    for (o, tx) in out.iter_mut().zip(t.read_rgba32f(&self.ctx)?) {
                        o[ch * 4..ch * 4 + 4].copy_from_slice(&tx);
                    }
                }
            }
        }
        Ok(out)
    }
}

impl Bench for LpvLayoutBench {
    fn cases(&self) -> Vec<Case> {
        let n = self.n;
        ShLayout::ALL
            .iter()
            .map(|layout| Case {
                name: format!("lpv {} {n}", layout.key()),
                detail: format!("LPV gather step {n}^3 x 12 floats; {}", layout.describe()),
                unit: "ms/step",
                work: (n as f64).powi(3),
                work_unit: "cells",
                rate: Rate::Millis,
                skipped: None,
            })
            .collect()
    }

    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, case: usize, reps: u32) -> Result<()> {
        let layout = ShLayout::ALL.get(case).copied().ok_or_else(|| Error::Graph(format!("lpv layout {case}")))?;
        // 8×4×2 workgroups, as the LPV's own cell passes.
        let (n, groups) = (self.n, [self.n.div_ceil(8), self.n.div_ceil(4), self.n.div_ceil(2)]);
        match layout {
            ShLayout::CoefficientMajor | ShLayout::CellMajor => {
                let (shader, [src_t, dst_t]) = match layout {
                    ShLayout::CoefficientMajor => (&shaders::PROFILE_LPV_LAYOUT_COMP, &self.soa),
                    _ => (&shaders::PROFILE_LPV_LAYOUT_COMP__AOS, &self.aos),
                };
                let src = g.input_buffer("lpv src", src_t);
                let dst = g.output_buffer("lpv dst", dst_t);
                for i in 0..reps {
                    let name = g.timed(i);
                    g.g.compute(name, shader).read(src).write(dst).constants(&n).side_effect().dispatch(groups)?;
                }
            }
            ShLayout::Images => {
                let src: Vec<_> = self.src_images.iter().map(|t| g.input_image("lpv image src", t)).collect();
                let dst: Vec<_> = self.dst_images.iter().map(|t| g.output_image("lpv image dst", t)).collect();
                for i in 0..reps {
                    let name = g.timed(i);
                    g.g.compute(name, &shaders::PROFILE_LPV_LAYOUT_COMP__IMAGE)
                        .each(src.iter().copied(), |p, s| p.read(s))
                        .each(dst.iter().copied(), |p, d| p.write(d))
                        .constants(&n)
                        .side_effect()
                        .dispatch(groups)?;
                }
            }
        }
        Ok(())
    }
}
