//! Per-view triangle culling before a raster pass (mesh/cull.comp): a compute pass keeps the
//! triangles that can cover a sample of the view, compacted in their order chunk by chunk, and
//! the pass draws each chunk's survivors with one indirect draw. The image is the same bit for
//! bit (only triangles that produce no fragment are dropped); llvmpipe's geometry front end,
//! which costs per triangle on one thread, then sees a fraction of the scene.

use super::frame::{VIEW_CAMERA, VIEW_RSM, VIEW_SKY};
use super::gpu_scene::{GpuScene, CULL_CHUNK, POSITION_BYTES};
use crate::graph::execute::Imports;
use crate::graph::{Access, BufferDesc, BufferId, GraphBuilder, PassBuilder, Work};
use crate::shaders;
use crate::vk::{vk, Buffer, Context, DeviceInfo, MemoryLocation};
use crate::Result;

/// Bytes of one `VkDrawIndexedIndirectCommand`: a chunk's draw in [`CulledDraws::draws`].
pub const DRAW_STRIDE: u32 = std::mem::size_of::<vk::DrawIndexedIndirectCommand>() as u32;

/// Draw views the statistics count (mesh/frame.glsl: camera, 8 shadow tiles, RSM, sky).
pub const STAT_VIEWS: usize = 11;

/// A draw view's name in reports.
pub fn view_name(view: u32) -> String {
    match view {
        VIEW_CAMERA => "camera".into(),
        VIEW_RSM => "rsm".into(),
        VIEW_SKY => "lpv sky height".into(),
        v => format!("shadow tile {}", v - 1),
    }
}

/// Host-visible counts of the triangles each view's culling kept in the last frame.
pub struct CullStats {
    buffer: Buffer,
}

impl CullStats {
    /// Allocates the counters, zeroed: a scene under the culling threshold never clears them,
    /// and its report read fresh memory as counts ("camera 3280994306%" of 32 triangles).
    pub fn new(ctx: &Context) -> Result<Self> {
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
        let mut buffer = Buffer::new(ctx, "cull stats", 4 * STAT_VIEWS as u64, usage, MemoryLocation::GpuToCpu)?;
        buffer.write_bytes(&[0; 4 * STAT_VIEWS])?;
        Ok(Self { buffer })
    }

    /// Triangles draw view `view` kept in the last frame that culled it (0 if none did).
    pub fn kept(&self, view: u32) -> u32 {
        self.buffer.mapped_u32(view as usize)
    }

    /// The views that kept triangles in the last frame that culled, named, with their counts.
    pub fn kept_per_view(&self) -> Vec<(String, u32)> {
        (0..STAT_VIEWS as u32).map(|v| (view_name(v), self.kept(v))).filter(|(_, k)| *k > 0).collect()
    }

    /// Declares the counters in `g`, cleared by a transfer pass, and exports them for the host.
    pub fn import(&self, g: &mut GraphBuilder<'_>, imports: &mut Imports) -> Result<BufferId> {
        let id = imports.buffer(g, "cull stats", &self.buffer, crate::graph::ResourceState::UNDEFINED);
        g.export_buffer(id, Some(Access::HostRead))?;
        let mut p = g.add_transfer_pass("cull stats clear");
        p.write_buffer(id, Access::TransferDst)?;
        p.record(move |pc| {
            // SAFETY: transfer pass; the counters are declared TransferDst.
            unsafe { pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(id).raw, 0, vk::WHOLE_SIZE, 0) };
            Ok(())
        });
        Ok(id)
    }
}

/// A view's surviving triangles: an index buffer laid out as the scene's, each chunk's survivors
/// at the front of its range, and a `VkDrawIndexedIndirectCommand` per chunk.
#[derive(Clone, Copy, Debug)]
pub struct CulledDraws {
    /// The view's index buffer.
    pub indices: BufferId,
    /// One indirect draw per chunk, in [`GpuScene::chunks`] order.
    pub draws: BufferId,
}

impl CulledDraws {
    /// Declares the raster pass's reads of both buffers.
    pub fn declare_reads(&self, p: &mut PassBuilder<'_, '_>) -> Result<()> {
        p.read_buffer(self.indices, Access::IndexBuffer)?;
        p.read_buffer(self.draws, Access::IndirectArgs)?;
        Ok(())
    }
}

/// Where a view rasterizes and which faces its pipelines cull.
#[derive(Clone, Copy, Debug)]
pub struct CullView {
    /// Draw view index (mesh/frame.glsl `view_matrix`).
    pub view: u32,
    /// Viewport corner and size in framebuffer pixels.
    pub viewport: [u32; 4],
    /// +1: the pipelines cull clockwise (back) faces, −1: counter-clockwise ones, 0: none.
    pub facing: f32,
}

/// Push constants of mesh/cull.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct CullPush {
    view: u32,
    facing: f32,
    origin: [f32; 2],
    size: [f32; 2],
}

/// Scenes with fewer triangles draw them all: a culling pass costs a dispatch per view (~0.1 ms
/// on llvmpipe), more than the geometry front end spends on a few thousand triangles.
pub const MIN_TRIANGLES: usize = 4096;

/// Whether `scene`'s views are worth culling ([`MIN_TRIANGLES`]) and this device can: subgroup
/// ballots (the compaction), a workgroup per chunk within one dispatch row, and vertices and
/// indices within a texel buffer's reach.
pub fn supported(info: &DeviceInfo, scene: &GpuScene) -> bool {
    let texels = u64::from(info.limits.max_texel_buffer_elements);
    scene.triangles >= MIN_TRIANGLES
        && info.subgroup_ballot
        && scene.chunk_count > 0
        && scene.chunk_count <= info.limits.max_compute_work_group_count[0]
        && scene.positions.size / u64::from(POSITION_BYTES) <= texels
        && scene.indices.size / 4 <= texels
}

/// Adds the culling pass of one view; `positions`, `ib`, `chunks` are the scene's buffers in `g`,
/// `stats` the imported [`CullStats`], and `subgroup` the device's least subgroup size (the
/// pass's workgroup size).
pub fn add_cull_pass(
    g: &mut GraphBuilder<'_>,
    name: String,
    subgroup: u32,
    scene: &GpuScene,
    ubo: BufferId,
    [positions, ib, chunks, stats]: [BufferId; 4],
    v: CullView,
) -> Result<CulledDraws> {
    let indices = g.create_buffer(format!("{name} indices"), BufferDesc::new(scene.indices.size));
    let draws = g
        .create_buffer(format!("{name} draws"), BufferDesc::new(u64::from(DRAW_STRIDE) * u64::from(scene.chunk_count)));
    let [x, y, w, h] = v.viewport.map(|c| c as f32);
    let push = CullPush { view: v.view, facing: v.facing, origin: [x, y], size: [w, h] };
    let triangles = scene.indices.size / 12;
    g.compute(name, &shaders::MESH_CULL_COMP)
        // Per triangle: 3 indices and 3 positions read, up to 3 indices written.
        .work(Work::bytes(triangles * (12 + 48 + 12)))
        .uniform(ubo)
        .read_texels(positions, vk::Format::R32G32B32A32_SFLOAT)
        .read_texels(ib, vk::Format::R32_UINT)
        .read(chunks)
        .write(indices)
        .write(draws)
        .atomic(stats)
        .constants(&push)
        .specialize(&[subgroup])
        // The box's 8 corners, then one loop over the chunk, a block of `subgroup` triangles per
        // iteration; each with its exit.
        .loop_bound(8 + 1 + u64::from(CULL_CHUNK.div_ceil(subgroup)) + 1)
        .dispatch([scene.chunk_count, 1, 1])?;
    Ok(CulledDraws { indices, draws })
}
