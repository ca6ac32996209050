//! The LPV's first passes: the clear (parameters, counters, atomic targets), VPL injection in
//! its four variants (integer and float atomics, gather, raster), and the injected light as the
//! flat buffer propagation reads.

use super::copies::{copy_channels, copy_flat, flat_bytes, Flat};
use super::{Frame, LpvPipelines, GRID_FORMAT};
use crate::graph::{Access, BufferDesc, BufferId, GraphBuilder, ImageDesc, ImageId, ImageKind, ShaderStage, Work};
use crate::lpv::settings::{Injection, LpvSettings};
use crate::shaders;
use crate::vk::{vk, Descriptor, Sampling};
use crate::{Error, Result};

/// Edge of the RSM tile one gather-injection dispatch reads: 128² texels, 16,650 loop iterations
/// per SIMD row at worst ([`gather_loop_iterations`]), a quarter of llvmpipe's limit; a 256² RSM
/// takes 4 dispatches, 512² 16.
pub const GATHER_TILE: u32 = 128;

/// Worst-case loop iterations of one SIMD row in one gather-injection dispatch over a `tile`²
/// tile: the projected box's 8 corners (+1 exit test), then at most `tile` rows (+1) of at most
/// `tile` texels (+1) each. Every lane's texel rectangle lies inside the tile, so the row's
/// loops, which run while any lane still loops, never run longer than one lane reading all of it.
pub fn gather_loop_iterations(tile: u32) -> u64 {
    let t = u64::from(tile);
    9 + (t + 1) + t * (t + 1)
}

/// Push constants of `inject_gather.comp`: the tile this dispatch reads.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GatherTile {
    origin: [i32; 2],
    size: i32,
    accumulate: u32,
}

/// The buffers passes add into with atomics, each present only where its variant runs.
#[derive(Clone, Copy)]
pub(super) struct AtomicTargets {
    /// Integer injection's fixed-point light, 12 values per cell (lpv/common.glsl).
    pub int: Option<BufferId>,
    /// Float-atomic injection's light.
    pub float: Option<BufferId>,
    /// The geometry volume: 4 integers per lattice point and source.
    pub gv: Option<BufferId>,
    /// Directional propagation's summed VPL normals, 4 integers per cell.
    pub normals: Option<BufferId>,
}

impl AtomicTargets {
    /// Declares the targets `s` needs for `gv_sources` geometry-volume sources.
    pub fn new(g: &mut GraphBuilder<'_>, f: &Frame, s: &LpvSettings, gv_sources: u32) -> Self {
        let flat = BufferDesc::new(12 * f.cells * 4);
        let tag = f.tag;
        let mut buf = |on: bool, name: &str, desc| on.then(|| g.create_buffer(format!("{tag} {name}"), desc));
        Self {
            int: buf(s.injection == Injection::AtomicInt, "fixed point", flat),
            float: buf(s.injection == Injection::AtomicFloat, "float atomics", flat),
            gv: buf(gv_sources > 0, "geometry volume", BufferDesc::new(2 * 4 * f.cells * 4)),
            normals: buf(s.directional && s.steps > 0, "normal sums", BufferDesc::new(4 * f.cells * 4)),
        }
    }

    fn all(&self) -> Vec<BufferId> {
        [self.int, self.float, self.gv, self.normals].into_iter().flatten().collect()
    }
}

/// The frame's first pass: uploads the parameters and zeroes the counters and atomic targets.
pub(super) fn clear(g: &mut GraphBuilder<'_>, f: &Frame, ubo_bytes: Vec<u8>, targets: &AtomicTargets) -> Result<()> {
    let (ubo, stats) = (f.ubo, f.stats);
    let mut p = g.add_transfer_pass(format!("{} clear", f.tag));
    p.write_buffer(ubo, Access::TransferDst)?;
    p.write_buffer(stats, Access::TransferDst)?;
    let cleared = targets.all();
    for &b in &cleared {
        p.write_buffer(b, Access::TransferDst)?;
    }
    p.record(move |pc| {
        // SAFETY: transfer pass; every buffer was declared as written here.
        unsafe {
            pc.device().cmd_update_buffer(pc.cmd, pc.buffer(ubo).raw, 0, &ubo_bytes);
            pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(stats).raw, 0, vk::WHOLE_SIZE, 0);
            for &b in &cleared {
                pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(b).raw, 0, vk::WHOLE_SIZE, 0);
            }
        }
        Ok(())
    });
    Ok(())
}

/// A pass over the RSM's texels: the parameters, the RSM images (nearest), then the buffers it
/// adds into with atomics.
pub(super) fn rsm_pass<'g, 'a>(
    g: &'g mut GraphBuilder<'a>,
    f: &Frame,
    name: String,
    shader: &'static crate::shaders::Shader,
    rsm: &[ImageId],
    targets: &[BufferId],
) -> crate::graph::ComputePass<'g, 'a> {
    g.compute(name, shader)
        .uniform(f.ubo)
        .each(rsm.iter().copied(), |p, id| p.sampled(id, Sampling::Nearest))
        .each(targets.iter().copied(), |p, b| p.atomic(b))
}

/// Injects the RSM's VPLs; returns the injected light as a flat buffer (lpv/images.glsl) that
/// gather propagation reads. Raster and gather injection write images and copy them there.
pub(super) fn inject<'a>(
    g: &mut GraphBuilder<'a>,
    f: &Frame,
    pipes: &'a LpvPipelines,
    s: &LpvSettings,
    targets: &AtomicTargets,
) -> Result<BufferId> {
    let inj_flat = g.create_buffer(format!("{} injected (flat)", f.tag), BufferDesc::new(flat_bytes(f.cells)));
    let raw = match s.injection {
        Injection::Raster => Some(raster(g, f, pipes)?),
        Injection::Gather => Some(gather(g, f)?),
        Injection::AtomicInt | Injection::AtomicFloat => {
            atomic(g, f, s, targets, inj_flat)?;
            None
        }
    };
    if let Some(images) = raw {
        let mut p = g.add_transfer_pass(format!("{} injection flat copy", f.tag));
        for img in images {
            p.read_image(img, Access::TransferSrc)?;
        }
        p.write_buffer(inj_flat, Access::TransferDst)?;
        let (stacked, slots) = (f.grid_desc.extent, f.identity());
        p.record(move |pc| copy_flat(pc, Flat::FromImages, inj_flat, images, stacked, &slots));
    }
    Ok(inj_flat)
}

/// Raster injection: VPLs as points blended into 2D-array slices, copied onto the 3D grid.
fn raster<'a>(g: &mut GraphBuilder<'a>, f: &Frame, pipes: &'a LpvPipelines) -> Result<[ImageId; 3]> {
    let (n, count, tag) = (f.n, f.count, f.tag);
    let desc = ImageDesc { extent: [n, n, 1], kind: ImageKind::D2Array(n * count), ..f.grid_desc };
    let slices = ["red", "green", "blue"].map(|ch| g.create_image(format!("{tag} slices {ch}"), desc));
    let injected = f.grid(g, &format!("{tag} injection"));
    if let Some(pipe) = &pipes.inject_raster {
        let mut p = g.add_raster_pass(format!("{tag} inject (raster)"));
        for id in slices {
            p.color_attachment(id, crate::graph::LoadOp::Clear, [0.0; 4])?;
        }
        let ubo = f.ubo;
        p.read_buffer(ubo, Access::UniformRead(ShaderStage::AllGraphics))?;
        let [pos, nrm, flux] = f.rsm;
        for id in f.rsm {
            p.read_image(id, Access::Sampled(ShaderStage::Vertex))?;
        }
        let (points, instances) = (f.rsm_size * f.rsm_size, count);
        p.record(move |pc| {
            let nearest = pc.ctx.pipelines().sampler(pc.ctx, Sampling::Nearest)?;
            let t = |id| Descriptor::CombinedImageSampler(pc.image(id).view, nearest);
            let ds = [Descriptor::UniformBuffer(pc.buffer(ubo).raw), t(pos), t(nrm), t(flux)];
            pipe.bind(pc.cmd, &ds, &[])?;
            // SAFETY: inside the pass's rendering scope; the pipeline takes no vertex buffers.
            unsafe { pc.device().cmd_draw(pc.cmd, points, instances, 0, 0) };
            Ok(())
        });
    }
    // Layers of a 2D array copy straight onto the slices of a 3D image (Vulkan 1.1).
    let mut p = g.add_transfer_pass(format!("{tag} resolve (raster)"));
    for i in 0..3 {
        p.read_image(slices[i], Access::TransferSrc)?;
        p.write_image(injected[i], Access::TransferDst)?;
    }
    let layers = n * count;
    p.record(move |pc| copy_channels(pc, slices, injected, layers, [n, n, layers]));
    Ok(injected)
}

/// Gather injection: each cell reads the RSM texels that land in it, one dispatch per RSM tile
/// (bounded loops, see [`gather_loop_iterations`]); the first writes the grid, the others add.
fn gather(g: &mut GraphBuilder<'_>, f: &Frame) -> Result<[ImageId; 3]> {
    let injected = f.grid(g, &format!("{} injection", f.tag));
    let tiles = f.rsm_size.div_ceil(GATHER_TILE).max(1);
    for ty in 0..tiles {
        for tx in 0..tiles {
            let first = tx == 0 && ty == 0;
            let push = GatherTile {
                origin: [(tx * GATHER_TILE) as i32, (ty * GATHER_TILE) as i32],
                size: GATHER_TILE as i32,
                accumulate: u32::from(!first),
            };
            let name = match tiles {
                1 => format!("{} inject (gather)", f.tag),
                _ => format!("{} inject (gather) tile {tx},{ty}", f.tag),
            };
            g.compute(name, &shaders::LPV_INJECT_GATHER_COMP)
                .uniform(f.ubo)
                .each(f.rsm, |p, id| p.sampled(id, Sampling::Nearest))
                .each(injected, |p, id| if first { p.write(id) } else { p.read_write(id) })
                .constants(&push)
                .loop_bound(gather_loop_iterations(GATHER_TILE))
                .dispatch(f.cell_groups)?;
        }
    }
    Ok(injected)
}

/// Atomic injection (integer fixed point or float) into a flat buffer, resolved into `inj_flat`.
fn atomic(g: &mut GraphBuilder<'_>, f: &Frame, s: &LpvSettings, t: &AtomicTargets, inj_flat: BufferId) -> Result<()> {
    let int = s.injection == Injection::AtomicInt;
    let (shader, resolve, kind) = if int {
        (&shaders::LPV_INJECT_COMP__INT, &shaders::LPV_RESOLVE_COMP__INT, "int")
    } else {
        (&shaders::LPV_INJECT_COMP, &shaders::LPV_RESOLVE_COMP, "float")
    };
    let Some(target) = t.int.or(t.float) else {
        return Err(Error::Graph("LPV: scatter injection without its buffer".into()));
    };
    let texels = u64::from(f.rsm_size).pow(2);
    let work = Work { bytes: texels * 3 * 16, atomics: texels * u64::from(f.count) * 12, ..Default::default() };
    rsm_pass(g, f, format!("{} inject (atomic {kind})", f.tag), shader, &f.rsm, &[target, f.stats])
        .work(work)
        .dispatch(f.rsm_groups)?;
    let texel = if int { vk::Format::R32G32B32A32_SINT } else { GRID_FORMAT };
    g.compute(format!("{} resolve", f.tag), resolve)
        .uniform(f.ubo)
        .read_texels(target, texel)
        .write(inj_flat)
        .dispatch(f.cell_groups)?;
    Ok(())
}
