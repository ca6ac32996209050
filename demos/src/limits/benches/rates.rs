//! Rates: trilinear 3D-texture fetches and 32-bit atomic adds.

use super::{bandwidth, rgba32f_3d, storage_buffer, upload_image};
use crate::limits::cpu::*;
use crate::limits::{Bench, BenchGraph, Case, Rate};
use vkengine::graph::Access;
use vkengine::graph::{PersistentBuffer, PersistentImage};
use vkengine::shaders;
use vkengine::vk::pipeline::cache::Sampling;
use vkengine::vk::{vk, Context};
use vkengine::{Error, Result};

/// Why the device cannot sample RGBA32F 3D images with a linear filter, if it cannot.
pub fn linear_rgba32f_unsupported(ctx: &Context) -> Option<String> {
    // SAFETY: a pure query on the context's own physical device.
    let props = unsafe {
        ctx.instance.get_physical_device_format_properties(ctx.physical_device, vk::Format::R32G32B32A32_SFLOAT)
    };
    let need = vk::FormatFeatureFlags::SAMPLED_IMAGE | vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR;
    (!props.optimal_tiling_features.contains(need))
        .then(|| "the device cannot filter R32G32B32A32_SFLOAT images linearly".to_string())
}

/// A benchmark the device cannot run: its cases, each skipped with the reason.
pub struct Unsupported {
    cases: Vec<Case>,
}

impl Bench for Unsupported {
    fn cases(&self) -> Vec<Case> {
        self.cases.clone()
    }

    fn declare<'a>(&'a self, _g: &mut BenchGraph<'a>, case: usize, _reps: u32) -> Result<()> {
        let c = self.cases.get(case);
        Err(Error::Input(c.and_then(|c| c.skipped.clone()).unwrap_or_else(|| "unsupported benchmark".into())))
    }
}

/// Trilinear fetch rate of a sampled RGBA32F 3D texture, at coherent (case 0) and scattered
/// (case 1) coordinates.
pub struct TextureBench {
    ctx: Context,
    tex: PersistentImage,
    out: PersistentBuffer,
    n: u32,
    grid: u32,
}

const TEXTURE_CASES: [(&str, &str); 2] = [
    ("texture coherent", "neighbouring invocations at neighbouring texels"),
    ("texture scattered", "hashed coordinates"),
];

impl TextureBench {
    /// An n³ texture of [`texture_texel`]s read by grid³ invocations (grid rounded up to a multiple
    /// of 8: the shader runs 8×4×2 workgroups, full 8-lane rows on llvmpipe).
    pub fn new(ctx: &Context, n: u32, grid: u32) -> Result<Self> {
        if let Some(reason) = linear_rgba32f_unsupported(ctx) {
            return Err(Error::Input(reason));
        }
        let (n, grid) = (n.max(2), grid.max(1).div_ceil(8) * 8);
        let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        let tex = rgba32f_3d(ctx, "fetch texture", n, usage)?;
        let texels = (0..n).flat_map(|z| (0..n).flat_map(move |y| (0..n).map(move |x| texture_texel(x, y, z))));
        let layout = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let state = upload_image(ctx, &tex, &vec4_bytes(texels), layout, vk::AccessFlags2::SHADER_SAMPLED_READ)?;
        let out = storage_buffer(ctx, "fetch sums", (grid as u64).pow(3) * 16)?;
        Ok(Self { ctx: ctx.clone(), tex: PersistentImage::with_state(tex, state), out, n, grid })
    }

    /// Both cases skipped with `reason`.
    pub fn unsupported(reason: String) -> Unsupported {
        let cases = TEXTURE_CASES
            .iter()
            .map(|(name, _)| Case {
                skipped: Some(reason.clone()),
                unit: "Gfetch/s",
                ..bandwidth(name, "trilinear RGBA32F 3D".into(), 0)
            })
            .collect();
        Unsupported { cases }
    }

    /// Fetches per pass.
    pub fn fetches(&self) -> u64 {
        (self.grid as u64).pow(3) * TEXTURE_FETCHES as u64
    }

    /// Texture edge and invocation lattice edge.
    pub fn sizes(&self) -> (u32, u32) {
        (self.n, self.grid)
    }

    /// What the kernel must store (up to filtering precision): per invocation, the sum of its fetches.
    pub fn expected(&self, scattered: bool) -> Vec<[f32; 4]> {
        let n = self.n;
        let tex: Vec<[f32; 4]> =
            (0..n).flat_map(|z| (0..n).flat_map(move |y| (0..n).map(move |x| texture_texel(x, y, z)))).collect();
        let g = self.grid;
        let mut out = Vec::with_capacity((g * g * g) as usize);
        for z in 0..g {
            for y in 0..g {
                for x in 0..g {
                    let linear = x + g * (y + g * z);
                    let (mut a, mut b) = ([0.0; 4], [0.0; 4]);
                    for k in (0..TEXTURE_FETCHES).step_by(2) {
                        let fetch = |k| trilinear(&tex, n, fetch_coord([x, y, z], linear, k, g, scattered));
                        a = add4(a, fetch(k));
                        b = add4(b, fetch(k + 1));
                    }
                    out.push(add4(a, b));
                }
            }
        }
        out
    }

    /// The stored sums (after a run).
    pub fn read_sums(&self) -> Result<Vec<[f32; 4]>> {
        Ok(vec4s(&self.out.read(&self.ctx)?))
    }
}

impl Bench for TextureBench {
    fn cases(&self) -> Vec<Case> {
        let (n, grid) = (self.n, self.grid);
        TEXTURE_CASES
            .iter()
            .map(|(name, how)| Case {
                name: name.to_string(),
                detail: format!("trilinear RGBA32F 3D {n}^3; {grid}^3 invocations x {TEXTURE_FETCHES} fetches; {how}"),
                unit: "Gfetch/s",
                work: self.fetches() as f64,
                work_unit: "fetches",
                rate: Rate::PerSecond(1e9),
                skipped: None,
            })
            .collect()
    }

    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, case: usize, reps: u32) -> Result<()> {
        let tex = g.texture("fetch texture", &self.tex);
        let out = g.output_buffer("fetch sums", &self.out);
        let shader = if case == 1 {
            &shaders::PROFILE_TEXTURE_FETCH_COMP__SCATTERED
        } else {
            &shaders::PROFILE_TEXTURE_FETCH_COMP
        };
        let groups = [self.grid / 8, self.grid / 4, self.grid / 2];
        for i in 0..reps {
            let name = g.timed(i);
            g.g.compute(name, shader).sampled(tex, Sampling::Linear).write(out).side_effect().dispatch(groups)?;
        }
        Ok(())
    }
}

/// 32-bit atomicAdd throughput: cases uint/float × uncontended/contended ([`AtomicBench::case`]).
pub struct AtomicBench {
    ctx: Context,
    counters: PersistentBuffer,
    invocations: u32,
    per_invocation: u32,
}

impl AtomicBench {
    /// `invocations` (rounded up to a multiple of 64) adding `per_invocation` times each.
    pub fn new(ctx: &Context, invocations: u32, per_invocation: u32) -> Result<Self> {
        let invocations = invocations.max(1).div_ceil(64) * 64;
        let counters = storage_buffer(ctx, "atomic counters", invocations.max(CONTENDED_ADDRESSES) as u64 * 4)?;
        Ok(Self { ctx: ctx.clone(), counters, invocations, per_invocation: per_invocation.max(1) })
    }

    /// The case index of a variant.
    pub fn case(float: bool, contended: bool) -> usize {
        usize::from(float) * 2 + usize::from(contended)
    }

    /// Why float atomics cannot run here, if they cannot.
    pub fn float_unsupported(ctx: &Context) -> Option<String> {
        (!ctx.info.float_atomics).then(|| {
            "VK_EXT_shader_atomic_float with shaderBufferFloat32AtomicAdd is not available on this device".to_string()
        })
    }

    /// atomicAdds per pass.
    pub fn atomics(&self) -> u64 {
        self.invocations as u64 * self.per_invocation as u64
    }

    /// Invocations per pass.
    pub fn invocations(&self) -> u32 {
        self.invocations
    }

    fn addresses(&self, contended: bool) -> u32 {
        if contended {
            CONTENDED_ADDRESSES.min(self.invocations)
        } else {
            self.invocations
        }
    }

    /// Exact counter values after one atomics pass (every counter of the buffer, unused ones 0).
    pub fn expected(&self, contended: bool) -> Vec<u32> {
        let a = self.addresses(contended);
        let mut out = vec![0u32; self.invocations.max(CONTENDED_ADDRESSES) as usize];
        for i in 0..self.invocations {
            out[(i % a) as usize] += self.per_invocation;
        }
        out
    }

    /// The counters' raw 32-bit words (after a run); float counters are `f32::from_bits`.
    pub fn read_counters(&self) -> Result<Vec<u32>> {
        Ok(u32s(&self.counters.read(&self.ctx)?))
    }
}

impl Bench for AtomicBench {
    fn cases(&self) -> Vec<Case> {
        let mut cases = Vec::new();
        for float in [false, true] {
            for contended in [false, true] {
                let ty = if float { "float" } else { "uint" };
                let target = if contended {
                    format!("all to {CONTENDED_ADDRESSES} addresses")
                } else {
                    "each invocation its own address".into()
                };
                cases.push(Case {
                    name: format!("atomic {ty} {}", if contended { "contended" } else { "uncontended" }),
                    detail: format!(
                        "atomicAdd {ty}; {} invocations x {}; {target}",
                        self.invocations, self.per_invocation
                    ),
                    unit: "Gatomic/s",
                    work: self.atomics() as f64,
                    work_unit: "atomics",
                    rate: Rate::PerSecond(1e9),
                    skipped: if float { Self::float_unsupported(&self.ctx) } else { None },
                });
            }
        }
        cases
    }

    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, case: usize, reps: u32) -> Result<()> {
        let (float, contended) = (case >= 2, case % 2 == 1);
        if float {
            if let Some(reason) = Self::float_unsupported(&self.ctx) {
                return Err(Error::Input(reason));
            }
        }
        let shader = if float { &shaders::PROFILE_ATOMICS_COMP__FLOAT } else { &shaders::PROFILE_ATOMICS_COMP };
        let c = g.output_buffer("atomic counters", &self.counters);
        let push = [self.addresses(contended), self.per_invocation];
        let groups = self.invocations / 64;
        for i in 0..reps {
            g.g.add_transfer_pass(format!("clear counters #{i}")).write_buffer(c, Access::TransferDst)?.record(
                move |pc| {
                    // SAFETY: transfer pass writing the declared buffer.
                    unsafe { pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(c).raw, 0, vk::WHOLE_SIZE, 0) };
                    Ok(())
                },
            );
            let name = g.timed(i);
            g.g.compute(name, shader).atomic(c).constants(&push).side_effect().dispatch([groups, 1, 1])?;
        }
        Ok(())
    }
}
