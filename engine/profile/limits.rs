//! Measured device limits: micro-benchmarks that each run as one or a few frame-graph passes and
//! are timed by the graph's GPU timestamps (one sample per timed pass), repeated until stable
//! ([`super::measure`]).
//!
//! Every benchmark keeps its inputs and outputs in persistent buffers/images that each graph
//! run imports (carrying their state from run to run), so tests can run a benchmark once at a
//! tiny size and check the work itself: copies equal their source, kernels wrote exactly the
//! expected values, atomic counters hold exact totals, and the three LPV grid layouts agree.
//! The CPU mirrors of the kernels (`pattern`, `read_input`, `trilinear`, `lpv_reference`, …)
//! follow `shaders_glsl/profile/`.

use super::{measure, LimitRow};
use crate::graph::execute::{run_graph, ExecuteOptions, Imports, PassContext};
use crate::graph::{Access, GraphBuilder, LoadOp, ResourceId, ResourceState, ShaderStage};
use crate::shaders;
use crate::vk::pipeline::push_words;
use crate::vk::{
    vk, Binding, Buffer, Context, Descriptor, GraphicsDesc, Image, ImageInfo, MemoryLocation, Pipeline, Sampler,
};
use crate::{Error, Result};

/// Invocations per workgroup of the buffer kernels (`WG` in `profile/common.glsl`).
pub const WG: u32 = 64;
/// vec4s each buffer-kernel invocation reads or writes (`ITEMS`).
pub const ITEMS: u32 = 32;
/// Texels along z each storage-image invocation covers (`ZITEMS`).
pub const ZITEMS: u32 = 16;
/// Trilinear fetches per texture-kernel invocation (`TEXTURE_FETCHES`).
pub const TEXTURE_FETCHES: u32 = 8;
/// What each tiny dispatch stores (`profile/tiny.comp`).
pub const TINY_MARKER: u32 = 0xD15A;
/// Addresses the contended atomics share.
pub const CONTENDED_ADDRESSES: u32 = 64;

const MIB: f64 = 1024.0 * 1024.0;
const CS: ShaderStage = ShaderStage::Compute;

/// Sizes, repetitions and the stop rule of a suite run.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LimitsConfig {
    /// Bytes the copy benchmark copies.
    pub copy_bytes: u64,
    /// Bytes the storage-buffer kernels read or write (rounded up to whole workgroup blocks).
    pub buffer_bytes: u64,
    /// Edge of the RGBA32F 3D storage image (rounded up to a multiple of 16).
    pub image_edge: u32,
    /// Edge of the sampled RGBA32F 3D texture.
    pub texture_edge: u32,
    /// Edge of the fetch kernel's invocation lattice (edge³ invocations, multiple of 4).
    pub fetch_grid: u32,
    /// Invocations of the atomic kernels (multiple of 64).
    pub atomic_invocations: u32,
    /// atomicAdds per invocation.
    pub atomics_per_invocation: u32,
    /// Dispatches in the dispatch-overhead pass.
    pub dispatches: u32,
    /// Draws in the draw-overhead pass.
    pub draws: u32,
    /// Grid edges of the LPV layout comparison.
    pub lpv_sizes: Vec<u32>,
    /// Timed passes per graph run.
    pub reps: u32,
    /// When to stop repeating.
    pub rule: super::StopRule,
}

impl LimitsConfig {
    /// Default sizes: buffers and images larger than a 32 MiB last-level cache; under a minute
    /// on lavapipe with 2 cores (noisy benchmarks run to the 5 s limit).
    pub fn full() -> Self {
        Self {
            copy_bytes: 64 << 20,
            buffer_bytes: 64 << 20,
            image_edge: 160,
            texture_edge: 128,
            fetch_grid: 64,
            atomic_invocations: 1 << 18,
            atomics_per_invocation: 16,
            dispatches: 1000,
            draws: 4096,
            lpv_sizes: vec![32, 64],
            reps: 4,
            rule: super::StopRule { window: 8, tolerance: 0.05, max_samples: 200, max_seconds: 5.0 },
        }
    }

    /// Smaller sizes and a shorter time limit (cache effects show at these sizes).
    pub fn quick() -> Self {
        Self {
            copy_bytes: 16 << 20,
            buffer_bytes: 16 << 20,
            image_edge: 96,
            texture_edge: 64,
            fetch_grid: 32,
            atomic_invocations: 1 << 16,
            atomics_per_invocation: 16,
            dispatches: 256,
            draws: 1024,
            lpv_sizes: vec![32, 64],
            reps: 3,
            rule: super::StopRule { window: 6, tolerance: 0.05, max_samples: 24, max_seconds: 1.0 },
        }
    }

    /// Tiny sizes, one sample each: for tests under validation.
    pub fn tiny() -> Self {
        Self {
            copy_bytes: 256 << 10,
            buffer_bytes: 64 << 10,
            image_edge: 16,
            texture_edge: 16,
            fetch_grid: 8,
            atomic_invocations: 4096,
            atomics_per_invocation: 4,
            dispatches: 16,
            draws: 64,
            lpv_sizes: vec![6, 8],
            reps: 1,
            rule: super::StopRule { window: 1, tolerance: f64::INFINITY, max_samples: 1, max_seconds: 0.0 },
        }
    }
}

/// `pattern(i)` of `profile/common.glsl`: what the write kernels store at element i.
pub fn pattern(i: u32) -> [f32; 4] {
    [(i & 0xFFF) as f32, ((i >> 12) & 0xFFF) as f32, (i >> 24) as f32, 1.0]
}

/// The read kernels' input at element j: small integers, so every sum is exact in f32.
pub fn read_input(j: u32) -> [f32; 4] {
    [(j % 7) as f32, (j % 5) as f32, (j % 3) as f32, 1.0]
}

/// `pcg_hash` of `common/hash.glsl`.
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277803737);
    (word >> 22) ^ word
}

/// Little-endian bytes of vec4s.
fn vec4_bytes(v: impl Iterator<Item = [f32; 4]>) -> Vec<u8> {
    v.flat_map(|t| t.into_iter().flat_map(f32::to_le_bytes)).collect()
}

/// Decodes little-endian u32 words.
pub fn u32s(bytes: &[u8]) -> Vec<u32> {
    bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

/// Decodes little-endian f32 vec4s.
pub fn vec4s(bytes: &[u8]) -> Vec<[f32; 4]> {
    u32s(bytes).chunks_exact(4).map(|c| [0, 1, 2, 3].map(|i| f32::from_bits(c[i]))).collect()
}

fn add4(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]]
}

/// A persistent resource and the state the last graph run left it in.
struct Tracked<T> {
    res: T,
    state: ResourceState,
}

impl<T> Tracked<T> {
    fn fresh(res: T) -> Self {
        Self { res, state: ResourceState::UNDEFINED }
    }
}

/// Reads a tracked buffer back; the next graph's first use then also waits for that copy.
fn read_buffer(ctx: &Context, t: &mut Tracked<Buffer>) -> Result<Vec<u8>> {
    let bytes = ctx.read_buffer(&t.res)?;
    t.state.stage |= vk::PipelineStageFlags2::TRANSFER;
    Ok(bytes)
}

/// Reads a tracked RGBA32F image back (it returns to its layout); the next graph's first use
/// then also waits for that copy.
fn read_image(ctx: &Context, t: &mut Tracked<Image>) -> Result<Vec<[f32; 4]>> {
    let s = t.state;
    let texels = ctx.read_image_rgba32f(&t.res, s.layout, s.stage, s.access)?;
    t.state.stage |= vk::PipelineStageFlags2::TRANSFER;
    Ok(texels)
}

/// The state `Context::upload_buffer` leaves a buffer in (its copy still to be made visible).
fn after_buffer_upload() -> ResourceState {
    ResourceState::from_access(Access::TransferDst)
}

/// Uploads texels into `image`, leaving it in `layout` visible to compute `access`, and returns
/// that state (the upload's barrier already made the copy visible, so no write is pending).
fn upload_image(
    ctx: &Context,
    image: &Image,
    bytes: &[u8],
    layout: vk::ImageLayout,
    access: vk::AccessFlags2,
) -> Result<ResourceState> {
    let stage = vk::PipelineStageFlags2::COMPUTE_SHADER;
    ctx.upload_image(image, bytes, layout, stage, access)?;
    Ok(ResourceState { layout, stage, access: vk::AccessFlags2::NONE })
}

fn storage_buffer(ctx: &Context, name: &str, bytes: u64) -> Result<Buffer> {
    let usage =
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC;
    Buffer::new(ctx, name, bytes, usage, MemoryLocation::GpuOnly)
}

fn rgba32f_3d(ctx: &Context, name: &str, n: u32, usage: vk::ImageUsageFlags) -> Result<Image> {
    Image::new(ctx, name, ImageInfo::d3(vk::Format::R32G32B32A32_SFLOAT, [n, n, n], usage))
}

fn dispatch(pc: &PassContext<'_>, x: u32, y: u32, z: u32) {
    // SAFETY: called right after a successful pipeline bind inside a compute pass.
    unsafe { pc.device().cmd_dispatch(pc.cmd, x, y, z) };
}

/// Compiles and runs `g`, carries the final states of imported resources into `tracked`, and
/// returns the GPU ms of the passes named in `timed`, in that order.
fn execute(
    ctx: &Context,
    g: GraphBuilder<'_>,
    imports: &Imports,
    tracked: &mut [(ResourceId, &mut ResourceState)],
    timed: &[String],
) -> Result<Vec<f64>> {
    let compiled = g.compile()?;
    for (id, state) in tracked.iter_mut() {
        if let Some(s) = compiled.final_state(*id) {
            **state = s;
        }
    }
    let run = run_graph(ctx, compiled, imports, ExecuteOptions::default())?;
    let ms: Vec<f64> = timed
        .iter()
        .filter_map(|name| run.timings.iter().find(|t| &t.name == name))
        .map(|t| t.gpu_end_ns.saturating_sub(t.gpu_begin_ns) as f64 * 1e-6)
        .collect();
    if ms.len() != timed.len() {
        return Err(Error::Input(format!("profile: a timed pass did not run (culled: {:?})", run.culled)));
    }
    Ok(ms)
}

/// Name of timed pass i. Timed passes are marked `side_effect`: a benchmark's later pass may
/// overwrite (discard) what an earlier one wrote, which would otherwise let the graph cull it.
fn timed_name(label: &str, i: u32) -> String {
    format!("{label} #{i}")
}

/// Buffer → buffer copy bandwidth: `vkCmdCopyBuffer` in a transfer pass.
pub struct CopyBench {
    ctx: Context,
    src: Tracked<Buffer>,
    dst: Tracked<Buffer>,
    bytes: u64,
}

/// The copy source's word i.
pub fn copy_word(i: u32) -> u32 {
    i.wrapping_mul(2654435761) ^ 0xA5A5_A5A5
}

impl CopyBench {
    /// Source filled with [`copy_word`]s, destination undefined.
    pub fn new(ctx: &Context, bytes: u64) -> Result<Self> {
        let bytes = bytes.max(4) / 4 * 4;
        let data: Vec<u8> = (0..(bytes / 4) as u32).flat_map(|i| copy_word(i).to_le_bytes()).collect();
        let src = ctx.upload_buffer("copy src", &data, vk::BufferUsageFlags::TRANSFER_SRC)?;
        let dst = storage_buffer(ctx, "copy dst", bytes)?;
        Ok(Self {
            ctx: ctx.clone(),
            src: Tracked { res: src, state: after_buffer_upload() },
            dst: Tracked::fresh(dst),
            bytes,
        })
    }

    /// Bytes copied per pass.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// One graph with `reps` copy passes; GPU ms of each.
    pub fn run(&mut self, reps: u32) -> Result<Vec<f64>> {
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let src = imports.buffer(&mut g, "copy src", &self.src.res, self.src.state);
        let dst = imports.buffer(&mut g, "copy dst", &self.dst.res, self.dst.state);
        let size = self.bytes;
        let mut timed = Vec::new();
        for i in 0..reps {
            let name = timed_name("buffer copy", i);
            let mut p = g.add_transfer_pass(name.clone());
            p.side_effect();
            p.read_buffer(src, Access::TransferSrc)?;
            p.write_buffer(dst, Access::TransferDst)?;
            p.record(move |pc| {
                let region = [vk::BufferCopy { src_offset: 0, dst_offset: 0, size }];
                // SAFETY: transfer pass; both buffers hold at least `size` bytes.
                unsafe { pc.device().cmd_copy_buffer(pc.cmd, pc.buffer(src).raw, pc.buffer(dst).raw, &region) };
                Ok(())
            });
            timed.push(name);
        }
        g.export_buffer(dst, None)?;
        let tracked = &mut [(src.into(), &mut self.src.state), (dst.into(), &mut self.dst.state)];
        execute(&self.ctx, g, &imports, tracked, &timed)
    }

    /// The destination's bytes (after a run).
    pub fn read_dst(&mut self) -> Result<Vec<u8>> {
        read_buffer(&self.ctx, &mut self.dst)
    }
}

/// Storage-buffer read bandwidth: vec4 loads, one vec4 sum stored per ITEMS loads.
pub struct BufferReadBench {
    ctx: Context,
    pipe: Pipeline,
    src: Tracked<Buffer>,
    sums: Tracked<Buffer>,
    vec4s: u32,
}

/// vec4s of `bytes` rounded up to whole workgroup blocks (WG·ITEMS vec4s).
fn buffer_vec4s(bytes: u64) -> u32 {
    let block = (WG * ITEMS) as u64;
    ((bytes / 16).div_ceil(block).max(1) * block) as u32
}

fn buffer_bindings(count: u32) -> Vec<Binding> {
    (0..count).map(|i| Binding::new(i, vk::DescriptorType::STORAGE_BUFFER, vk::ShaderStageFlags::COMPUTE)).collect()
}

impl BufferReadBench {
    /// Input of `bytes` (rounded up to whole blocks) filled with [`read_input`].
    pub fn new(ctx: &Context, bytes: u64) -> Result<Self> {
        let vec4s = buffer_vec4s(bytes);
        let pipe = Pipeline::compute(ctx, &shaders::PROFILE_BUFFER_READ_COMP, &buffer_bindings(2), 0)?;
        let data = vec4_bytes((0..vec4s).map(read_input));
        let src = ctx.upload_buffer("read src", &data, vk::BufferUsageFlags::STORAGE_BUFFER)?;
        let sums = storage_buffer(ctx, "read sums", (vec4s / ITEMS) as u64 * 16)?;
        Ok(Self {
            ctx: ctx.clone(),
            pipe,
            src: Tracked { res: src, state: after_buffer_upload() },
            sums: Tracked::fresh(sums),
            vec4s,
        })
    }

    /// Bytes read plus bytes of sums written per pass.
    pub fn bytes(&self) -> u64 {
        self.input_bytes() + (self.vec4s / ITEMS) as u64 * 16
    }

    /// Bytes read per pass.
    pub fn input_bytes(&self) -> u64 {
        self.vec4s as u64 * 16
    }

    /// One graph with `reps` read passes; GPU ms of each.
    pub fn run(&mut self, reps: u32) -> Result<Vec<f64>> {
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let src = imports.buffer(&mut g, "read src", &self.src.res, self.src.state);
        let sums = imports.buffer(&mut g, "read sums", &self.sums.res, self.sums.state);
        let (pipe, groups) = (&self.pipe, self.vec4s / (WG * ITEMS));
        let mut timed = Vec::new();
        for i in 0..reps {
            let name = timed_name("ssbo read", i);
            let mut p = g.add_compute_pass(name.clone());
            p.side_effect();
            p.read_buffer(src, Access::StorageRead(CS))?;
            p.write_buffer(sums, Access::StorageWrite(CS))?;
            p.record(move |pc| {
                let ds =
                    [Descriptor::StorageBuffer(pc.buffer(src).raw), Descriptor::StorageBuffer(pc.buffer(sums).raw)];
                pipe.bind(pc.cmd, &ds, &[])?;
                dispatch(pc, groups, 1, 1);
                Ok(())
            });
            timed.push(name);
        }
        g.export_buffer(sums, None)?;
        let tracked = &mut [(src.into(), &mut self.src.state), (sums.into(), &mut self.sums.state)];
        execute(&self.ctx, g, &imports, tracked, &timed)
    }

    /// What the kernel must store: per invocation, the sum of its ITEMS inputs.
    pub fn expected(&self) -> Vec<[f32; 4]> {
        (0..self.vec4s / ITEMS)
            .map(|t| {
                let (group, lane) = (t / WG, t % WG);
                let at = |k: u32| read_input(group * WG * ITEMS + k * WG + lane);
                let (mut a, mut b) = ([0.0; 4], [0.0; 4]);
                for k in (0..ITEMS).step_by(2) {
                    a = add4(a, at(k));
                    b = add4(b, at(k + 1));
                }
                add4(a, b)
            })
            .collect()
    }

    /// The stored sums (after a run).
    pub fn read_sums(&mut self) -> Result<Vec<[f32; 4]>> {
        Ok(vec4s(&read_buffer(&self.ctx, &mut self.sums)?))
    }
}

/// Storage-buffer write bandwidth: vec4 stores of [`pattern`].
pub struct BufferWriteBench {
    ctx: Context,
    pipe: Pipeline,
    dst: Tracked<Buffer>,
    vec4s: u32,
}

impl BufferWriteBench {
    /// Destination of `bytes` (rounded up to whole blocks).
    pub fn new(ctx: &Context, bytes: u64) -> Result<Self> {
        let vec4s = buffer_vec4s(bytes);
        let pipe = Pipeline::compute(ctx, &shaders::PROFILE_BUFFER_WRITE_COMP, &buffer_bindings(1), 0)?;
        let dst = storage_buffer(ctx, "write dst", vec4s as u64 * 16)?;
        Ok(Self { ctx: ctx.clone(), pipe, dst: Tracked::fresh(dst), vec4s })
    }

    /// Bytes written per pass.
    pub fn bytes(&self) -> u64 {
        self.vec4s as u64 * 16
    }

    /// One graph with `reps` write passes; GPU ms of each.
    pub fn run(&mut self, reps: u32) -> Result<Vec<f64>> {
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let dst = imports.buffer(&mut g, "write dst", &self.dst.res, self.dst.state);
        let (pipe, groups) = (&self.pipe, self.vec4s / (WG * ITEMS));
        let mut timed = Vec::new();
        for i in 0..reps {
            let name = timed_name("ssbo write", i);
            g.add_compute_pass(name.clone()).side_effect().write_buffer(dst, Access::StorageWrite(CS))?.record(
                move |pc| {
                    pipe.bind(pc.cmd, &[Descriptor::StorageBuffer(pc.buffer(dst).raw)], &[])?;
                    dispatch(pc, groups, 1, 1);
                    Ok(())
                },
            );
            timed.push(name);
        }
        g.export_buffer(dst, None)?;
        execute(&self.ctx, g, &imports, &mut [(dst.into(), &mut self.dst.state)], &timed)
    }

    /// Elements written per pass.
    pub fn len(&self) -> u32 {
        self.vec4s
    }

    /// Always false: a benchmark writes at least one block.
    pub fn is_empty(&self) -> bool {
        self.vec4s == 0
    }

    /// The destination's vec4s (after a run).
    pub fn read_dst(&mut self) -> Result<Vec<[f32; 4]>> {
        Ok(vec4s(&read_buffer(&self.ctx, &mut self.dst)?))
    }
}

/// Edge rounded up to whole ZITEMS columns.
fn image_edge(n: u32) -> u32 {
    n.max(1).div_ceil(ZITEMS) * ZITEMS
}

fn image_bindings(kinds: &[vk::DescriptorType]) -> Vec<Binding> {
    kinds.iter().enumerate().map(|(i, &t)| Binding::new(i as u32, t, vk::ShaderStageFlags::COMPUTE)).collect()
}

/// Storage-image read bandwidth: imageLoad of an RGBA32F 3D image, one sum stored per column.
pub struct ImageReadBench {
    ctx: Context,
    pipe: Pipeline,
    image: Tracked<Image>,
    sums: Tracked<Buffer>,
    n: u32,
}

impl ImageReadBench {
    /// An n³ image (n rounded up to a multiple of 16) holding [`read_input`] of each linear index.
    pub fn new(ctx: &Context, n: u32) -> Result<Self> {
        let n = image_edge(n);
        let kinds = [vk::DescriptorType::STORAGE_IMAGE, vk::DescriptorType::STORAGE_BUFFER];
        let pipe = Pipeline::compute(ctx, &shaders::PROFILE_IMAGE_READ_COMP, &image_bindings(&kinds), 0)?;
        let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST;
        let image = rgba32f_3d(ctx, "image read src", n, usage)?;
        let data = vec4_bytes((0..n * n * n).map(read_input));
        let state = upload_image(ctx, &image, &data, vk::ImageLayout::GENERAL, vk::AccessFlags2::SHADER_STORAGE_READ)?;
        let sums = storage_buffer(ctx, "image read sums", (n * n * n / ZITEMS) as u64 * 16)?;
        Ok(Self { ctx: ctx.clone(), pipe, image: Tracked { res: image, state }, sums: Tracked::fresh(sums), n })
    }

    /// Edge of the image.
    pub fn edge(&self) -> u32 {
        self.n
    }

    /// Bytes read plus bytes of sums written per pass.
    pub fn bytes(&self) -> u64 {
        (self.n as u64).pow(3) * 16 * (ZITEMS as u64 + 1) / ZITEMS as u64
    }

    /// One graph with `reps` read passes; GPU ms of each.
    pub fn run(&mut self, reps: u32) -> Result<Vec<f64>> {
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let img = imports.image(&mut g, "image read src", &self.image.res, self.image.state);
        let sums = imports.buffer(&mut g, "image read sums", &self.sums.res, self.sums.state);
        let (pipe, n) = (&self.pipe, self.n);
        let mut timed = Vec::new();
        for i in 0..reps {
            let name = timed_name("image read", i);
            let mut p = g.add_compute_pass(name.clone());
            p.side_effect();
            p.read_image(img, Access::StorageRead(CS))?;
            p.write_buffer(sums, Access::StorageWrite(CS))?;
            p.record(move |pc| {
                let ds = [Descriptor::StorageImage(pc.image(img).view), Descriptor::StorageBuffer(pc.buffer(sums).raw)];
                pipe.bind(pc.cmd, &ds, &[])?;
                dispatch(pc, n / 8, n / 8, n / ZITEMS);
                Ok(())
            });
            timed.push(name);
        }
        g.export_buffer(sums, None)?;
        let tracked = &mut [(img.into(), &mut self.image.state), (sums.into(), &mut self.sums.state)];
        execute(&self.ctx, g, &imports, tracked, &timed)
    }

    /// What the kernel must store: per (x, y, z-column), the sum of the column's texels.
    pub fn expected(&self) -> Vec<[f32; 4]> {
        let n = self.n;
        let mut out = Vec::with_capacity((n * n * n / ZITEMS) as usize);
        for zb in 0..n / ZITEMS {
            for y in 0..n {
                for x in 0..n {
                    let at = |k: u32| read_input(x + n * (y + n * (zb * ZITEMS + k)));
                    let (mut a, mut b) = ([0.0; 4], [0.0; 4]);
                    for k in (0..ZITEMS).step_by(2) {
                        a = add4(a, at(k));
                        b = add4(b, at(k + 1));
                    }
                    out.push(add4(a, b));
                }
            }
        }
        out
    }

    /// The stored sums (after a run).
    pub fn read_sums(&mut self) -> Result<Vec<[f32; 4]>> {
        Ok(vec4s(&read_buffer(&self.ctx, &mut self.sums)?))
    }
}

/// Storage-image write bandwidth: imageStore of [`pattern`] into an RGBA32F 3D image.
pub struct ImageWriteBench {
    ctx: Context,
    pipe: Pipeline,
    image: Tracked<Image>,
    n: u32,
}

impl ImageWriteBench {
    /// An n³ image, n rounded up to a multiple of 16.
    pub fn new(ctx: &Context, n: u32) -> Result<Self> {
        let n = image_edge(n);
        let kinds = [vk::DescriptorType::STORAGE_IMAGE];
        let pipe = Pipeline::compute(ctx, &shaders::PROFILE_IMAGE_WRITE_COMP, &image_bindings(&kinds), 0)?;
        let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        let image = rgba32f_3d(ctx, "image write dst", n, usage)?;
        Ok(Self { ctx: ctx.clone(), pipe, image: Tracked::fresh(image), n })
    }

    /// Edge of the image.
    pub fn edge(&self) -> u32 {
        self.n
    }

    /// Bytes written per pass.
    pub fn bytes(&self) -> u64 {
        (self.n as u64).pow(3) * 16
    }

    /// One graph with `reps` write passes; GPU ms of each.
    pub fn run(&mut self, reps: u32) -> Result<Vec<f64>> {
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let img = imports.image(&mut g, "image write dst", &self.image.res, self.image.state);
        let (pipe, n) = (&self.pipe, self.n);
        let mut timed = Vec::new();
        for i in 0..reps {
            let name = timed_name("image write", i);
            g.add_compute_pass(name.clone()).side_effect().write_image(img, Access::StorageWrite(CS))?.record(
                move |pc| {
                    pipe.bind(pc.cmd, &[Descriptor::StorageImage(pc.image(img).view)], &[])?;
                    dispatch(pc, n / 8, n / 8, n / ZITEMS);
                    Ok(())
                },
            );
            timed.push(name);
        }
        g.export_image(img, None)?;
        execute(&self.ctx, g, &imports, &mut [(img.into(), &mut self.image.state)], &timed)
    }

    /// The image's texels, x fastest (after a run).
    pub fn read_image(&mut self) -> Result<Vec<[f32; 4]>> {
        read_image(&self.ctx, &mut self.image)
    }
}

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

/// Texel (x, y, z) of the fetch benchmark's texture: linear in every channel.
pub fn texture_texel(x: u32, y: u32, z: u32) -> [f32; 4] {
    [x as f32, 2.0 * y as f32, 3.0 * z as f32, (x + y + z) as f32]
}

/// Coordinate of fetch k of invocation `id` (linear index `linear`) on a grid³ lattice, as
/// `profile/texture_fetch.comp` computes it.
pub fn fetch_coord(id: [u32; 3], linear: u32, k: u32, grid: u32, scattered: bool) -> [f32; 3] {
    if scattered {
        let h = pcg_hash(linear.wrapping_mul(TEXTURE_FETCHES).wrapping_add(k));
        [h & 1023, (h >> 10) & 1023, (h >> 20) & 1023].map(|v| (v as f32 + 0.5) * (1.0 / 1024.0))
    } else {
        let step = [0.25f32, 0.125, 0.0625];
        let inv = 1.0 / grid as f32;
        [0, 1, 2].map(|a| (id[a] as f32 + 0.5 + k as f32 * step[a]) * inv)
    }
}

/// Trilinear sample with clamp-to-edge of an n³ texture (x fastest) at normalised `uvw`.
pub fn trilinear(tex: &[[f32; 4]], n: u32, uvw: [f32; 3]) -> [f32; 4] {
    let mut i0 = [0u32; 3];
    let mut i1 = [0u32; 3];
    let mut f = [0f32; 3];
    for a in 0..3 {
        let t = uvw[a] * n as f32 - 0.5;
        let fl = t.floor();
        f[a] = t - fl;
        let clamp = |v: f32| v.clamp(0.0, (n - 1) as f32) as u32;
        i0[a] = clamp(fl);
        i1[a] = clamp(fl + 1.0);
    }
    let mut out = [0f32; 4];
    for corner in 0..8u32 {
        let pick = |a: usize| corner >> a & 1 == 1;
        let w: f32 = (0..3).map(|a| if pick(a) { f[a] } else { 1.0 - f[a] }).product();
        let [x, y, z] = [0, 1, 2].map(|a| if pick(a) { i1[a] } else { i0[a] });
        let t = tex[(x + n * (y + n * z)) as usize];
        for c in 0..4 {
            out[c] += w * t[c];
        }
    }
    out
}

/// Trilinear fetch rate of a sampled RGBA32F 3D texture, at coherent and scattered coordinates.
pub struct TextureBench {
    ctx: Context,
    coherent: Pipeline,
    scattered: Pipeline,
    sampler: Sampler,
    tex: Tracked<Image>,
    out: Tracked<Buffer>,
    n: u32,
    grid: u32,
}

impl TextureBench {
    /// An n³ texture of [`texture_texel`]s read by grid³ invocations (grid rounded up to a multiple of 4).
    pub fn new(ctx: &Context, n: u32, grid: u32) -> Result<Self> {
        if let Some(reason) = linear_rgba32f_unsupported(ctx) {
            return Err(Error::Input(reason));
        }
        let (n, grid) = (n.max(2), grid.max(1).div_ceil(4) * 4);
        let kinds = [vk::DescriptorType::COMBINED_IMAGE_SAMPLER, vk::DescriptorType::STORAGE_BUFFER];
        let bindings = image_bindings(&kinds);
        let coherent = Pipeline::compute(ctx, &shaders::PROFILE_TEXTURE_FETCH_COMP, &bindings, 0)?;
        let scattered = Pipeline::compute(ctx, &shaders::PROFILE_TEXTURE_FETCH_COMP__SCATTERED, &bindings, 0)?;
        let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        let tex = rgba32f_3d(ctx, "fetch texture", n, usage)?;
        let texels = (0..n).flat_map(|z| (0..n).flat_map(move |y| (0..n).map(move |x| texture_texel(x, y, z))));
        let layout = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let state = upload_image(ctx, &tex, &vec4_bytes(texels), layout, vk::AccessFlags2::SHADER_SAMPLED_READ)?;
        let out = storage_buffer(ctx, "fetch sums", (grid as u64).pow(3) * 16)?;
        Ok(Self {
            ctx: ctx.clone(),
            coherent,
            scattered,
            sampler: Sampler::clamped(ctx, true)?,
            tex: Tracked { res: tex, state },
            out: Tracked::fresh(out),
            n,
            grid,
        })
    }

    /// Fetches per pass.
    pub fn fetches(&self) -> u64 {
        (self.grid as u64).pow(3) * TEXTURE_FETCHES as u64
    }

    /// Texture edge and invocation lattice edge.
    pub fn sizes(&self) -> (u32, u32) {
        (self.n, self.grid)
    }

    /// One graph with `reps` fetch passes; GPU ms of each.
    pub fn run(&mut self, scattered: bool, reps: u32) -> Result<Vec<f64>> {
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let tex = imports.image_readonly(&mut g, "fetch texture", &self.tex.res, self.tex.state);
        let out = imports.buffer(&mut g, "fetch sums", &self.out.res, self.out.state);
        let pipe = if scattered { &self.scattered } else { &self.coherent };
        let (sampler, groups) = (self.sampler.raw, self.grid / 4);
        let label = if scattered { "texture scattered" } else { "texture coherent" };
        let mut timed = Vec::new();
        for i in 0..reps {
            let name = timed_name(label, i);
            let mut p = g.add_compute_pass(name.clone());
            p.side_effect();
            p.read_image(tex, Access::Sampled(CS))?;
            p.write_buffer(out, Access::StorageWrite(CS))?;
            p.record(move |pc| {
                let ds = [
                    Descriptor::CombinedImageSampler(pc.image(tex).view, sampler),
                    Descriptor::StorageBuffer(pc.buffer(out).raw),
                ];
                pipe.bind(pc.cmd, &ds, &[])?;
                dispatch(pc, groups, groups, groups);
                Ok(())
            });
            timed.push(name);
        }
        g.export_buffer(out, None)?;
        execute(&self.ctx, g, &imports, &mut [(out.into(), &mut self.out.state)], &timed)
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
    pub fn read_sums(&mut self) -> Result<Vec<[f32; 4]>> {
        Ok(vec4s(&read_buffer(&self.ctx, &mut self.out)?))
    }
}

/// 32-bit atomicAdd throughput, uint and float, uncontended and contended.
pub struct AtomicBench {
    ctx: Context,
    int: Pipeline,
    float: Option<Pipeline>,
    counters: Tracked<Buffer>,
    invocations: u32,
    per_invocation: u32,
}

impl AtomicBench {
    /// `invocations` (rounded up to a multiple of 64) adding `per_invocation` times each.
    pub fn new(ctx: &Context, invocations: u32, per_invocation: u32) -> Result<Self> {
        let invocations = invocations.max(1).div_ceil(64) * 64;
        let b = buffer_bindings(1);
        let int = Pipeline::compute(ctx, &shaders::PROFILE_ATOMICS_COMP, &b, 8)?;
        let float = match ctx.info.float_atomics {
            true => Some(Pipeline::compute(ctx, &shaders::PROFILE_ATOMICS_COMP__FLOAT, &b, 8)?),
            false => None,
        };
        let counters = storage_buffer(ctx, "atomic counters", invocations.max(CONTENDED_ADDRESSES) as u64 * 4)?;
        Ok(Self {
            ctx: ctx.clone(),
            int,
            float,
            counters: Tracked::fresh(counters),
            invocations,
            per_invocation: per_invocation.max(1),
        })
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

    /// One graph with `reps` × (clear counters, atomics); GPU ms of each atomics pass.
    pub fn run(&mut self, float: bool, contended: bool, reps: u32) -> Result<Vec<f64>> {
        let pipe = match (float, &self.float) {
            (false, _) => &self.int,
            (true, Some(p)) => p,
            (true, None) => return Err(Error::Input(Self::float_unsupported(&self.ctx).unwrap_or_default())),
        };
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let c = imports.buffer(&mut g, "atomic counters", &self.counters.res, self.counters.state);
        let push = push_words(&[self.addresses(contended), self.per_invocation]);
        let groups = self.invocations / 64;
        let label = format!(
            "atomic {} {}",
            if float { "float" } else { "uint" },
            if contended { "contended" } else { "uncontended" }
        );
        let mut timed = Vec::new();
        for i in 0..reps {
            g.add_transfer_pass(format!("clear counters #{i}")).write_buffer(c, Access::TransferDst)?.record(
                move |pc| {
                    // SAFETY: transfer pass writing the declared buffer.
                    unsafe { pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(c).raw, 0, vk::WHOLE_SIZE, 0) };
                    Ok(())
                },
            );
            let name = timed_name(&label, i);
            let push = push.clone();
            g.add_compute_pass(name.clone()).side_effect().write_buffer(c, Access::StorageAtomic(CS))?.record(
                move |pc| {
                    pipe.bind(pc.cmd, &[Descriptor::StorageBuffer(pc.buffer(c).raw)], &push)?;
                    dispatch(pc, groups, 1, 1);
                    Ok(())
                },
            );
            timed.push(name);
        }
        g.export_buffer(c, None)?;
        execute(&self.ctx, g, &imports, &mut [(c.into(), &mut self.counters.state)], &timed)
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
    pub fn read_counters(&mut self) -> Result<Vec<u32>> {
        Ok(u32s(&read_buffer(&self.ctx, &mut self.counters)?))
    }
}

/// Dispatch overhead: N one-invocation dispatches in one compute pass, each with its own
/// push-descriptor range (so no two dispatches touch the same bytes).
pub struct DispatchBench {
    ctx: Context,
    pipe: Pipeline,
    slots: Tracked<Buffer>,
    count: u32,
    stride: u64,
}

impl DispatchBench {
    /// `count` dispatches into `count` slots.
    pub fn new(ctx: &Context, count: u32) -> Result<Self> {
        let count = count.max(1);
        let pipe = Pipeline::compute(ctx, &shaders::PROFILE_TINY_COMP, &buffer_bindings(1), 0)?;
        let stride = ctx.info.limits.min_storage_buffer_offset_alignment.max(4);
        let slots = storage_buffer(ctx, "dispatch slots", count as u64 * stride)?;
        Ok(Self { ctx: ctx.clone(), pipe, slots: Tracked::fresh(slots), count, stride })
    }

    /// Dispatches per pass.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// One graph with `reps` × (clear slots, N dispatches); GPU ms of each dispatch pass.
    pub fn run(&mut self, reps: u32) -> Result<Vec<f64>> {
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let slots = imports.buffer(&mut g, "dispatch slots", &self.slots.res, self.slots.state);
        let (pipe, count, stride) = (&self.pipe, self.count, self.stride);
        let mut timed = Vec::new();
        for i in 0..reps {
            g.add_transfer_pass(format!("clear slots #{i}")).write_buffer(slots, Access::TransferDst)?.record(
                move |pc| {
                    // SAFETY: transfer pass writing the declared buffer.
                    unsafe { pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(slots).raw, 0, vk::WHOLE_SIZE, 0) };
                    Ok(())
                },
            );
            let name = timed_name("dispatch", i);
            g.add_compute_pass(name.clone()).side_effect().write_buffer(slots, Access::StorageWrite(CS))?.record(
                move |pc| {
                    let buf = pc.buffer(slots).raw;
                    // SAFETY: compute pass; the pipeline's only binding is pushed before each dispatch.
                    unsafe { pc.device().cmd_bind_pipeline(pc.cmd, vk::PipelineBindPoint::COMPUTE, pipe.raw) };
                    for d in 0..count {
                        let info = [vk::DescriptorBufferInfo { buffer: buf, offset: d as u64 * stride, range: 4 }];
                        let write = [vk::WriteDescriptorSet::default()
                            .dst_binding(0)
                            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                            .buffer_info(&info)];
                        // SAFETY: aligned in-bounds range; set 0 is this pipeline's one-binding push set.
                        unsafe {
                            pc.ctx.push_descriptor.cmd_push_descriptor_set(
                                pc.cmd,
                                vk::PipelineBindPoint::COMPUTE,
                                pipe.layout,
                                0,
                                &write,
                            );
                            pc.device().cmd_dispatch(pc.cmd, 1, 1, 1);
                        }
                    }
                    Ok(())
                },
            );
            timed.push(name);
        }
        g.export_buffer(slots, None)?;
        execute(&self.ctx, g, &imports, &mut [(slots.into(), &mut self.slots.state)], &timed)
    }

    /// The first word of every slot (after a run): [`TINY_MARKER`] where a dispatch ran.
    pub fn read_slots(&mut self) -> Result<Vec<u32>> {
        let words = u32s(&read_buffer(&self.ctx, &mut self.slots)?);
        Ok(words.iter().step_by((self.stride / 4) as usize).copied().collect())
    }
}

/// Draw overhead: N one-point draws in one dynamic-rendering pass; draw i writes i + 1 into pixel i.
pub struct DrawBench {
    ctx: Context,
    pipe: Pipeline,
    target: Tracked<Image>,
    count: u32,
    size: [u32; 2],
}

impl DrawBench {
    /// `count` draws onto an R32_UINT target just large enough for one pixel each.
    pub fn new(ctx: &Context, count: u32) -> Result<Self> {
        let count = count.max(1);
        let w = (count as f64).sqrt().ceil() as u32;
        let size = [w, count.div_ceil(w)];
        let desc = GraphicsDesc {
            color_formats: vec![vk::Format::R32_UINT],
            topology: vk::PrimitiveTopology::POINT_LIST,
            ..Default::default()
        };
        let pipe = Pipeline::graphics(ctx, &[&shaders::PROFILE_TINY_VERT, &shaders::PROFILE_TINY_FRAG], &[], 8, &desc)?;
        let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let target = Image::new(ctx, "draw target", ImageInfo::d2(vk::Format::R32_UINT, size[0], size[1], usage))?;
        Ok(Self { ctx: ctx.clone(), pipe, target: Tracked::fresh(target), count, size })
    }

    /// Draws per pass.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// One graph with `reps` raster passes (clear + N draws); GPU ms of each.
    pub fn run(&mut self, reps: u32) -> Result<Vec<f64>> {
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let target = imports.image(&mut g, "draw target", &self.target.res, self.target.state);
        let (pipe, count, push) = (&self.pipe, self.count, push_words(&self.size));
        let mut timed = Vec::new();
        for i in 0..reps {
            let name = timed_name("draw", i);
            let push = push.clone();
            g.add_raster_pass(name.clone()).side_effect().color_attachment(target, LoadOp::Clear, [0.0; 4])?.record(
                move |pc| {
                    pipe.bind(pc.cmd, &[], &push)?;
                    for d in 0..count {
                        // SAFETY: inside the pass's rendering scope with the pipeline bound; no vertex buffers.
                        unsafe { pc.device().cmd_draw(pc.cmd, 1, 1, 0, d) };
                    }
                    Ok(())
                },
            );
            timed.push(name);
        }
        g.export_image(target, None)?;
        execute(&self.ctx, g, &imports, &mut [(target.into(), &mut self.target.state)], &timed)
    }

    /// The target's pixels, row-major (after a run): i + 1 at pixel i < N, 0 elsewhere.
    pub fn read_target(&mut self) -> Result<Vec<u32>> {
        let s = self.target.state;
        let bytes = self.ctx.read_image(&self.target.res, s.layout, s.stage, s.access)?;
        self.target.state.stage |= vk::PipelineStageFlags2::TRANSFER;
        Ok(u32s(&bytes))
    }
}

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
    /// Every layout, in report order.
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
}

/// The layout comparison's input: coefficient j of `cell`, an integer in 0..16.
pub fn lpv_input(cell: u32, j: u32) -> f32 {
    (pcg_hash(cell * 12 + j) & 15) as f32
}

/// CPU twin of `profile/lpv_layout.comp`: one gather step, per cell `[channel·4 + k]`.
pub fn lpv_reference(n: u32, input: &[[f32; 12]]) -> Vec<[f32; 12]> {
    const DIRS: [[i32; 3]; 6] = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]];
    let ni = n as i32;
    let mut out = vec![[0f32; 12]; input.len()];
    for z in 0..ni {
        for y in 0..ni {
            for x in 0..ni {
                let mut o = [0f32; 12];
                for d in DIRS {
                    let f = [x - d[0], y - d[1], z - d[2]];
                    if f.iter().any(|&v| v < 0 || v >= ni) {
                        continue;
                    }
                    let s = &input[(f[0] + ni * (f[1] + ni * f[2])) as usize];
                    let dv = d.map(|v| v as f32);
                    let basis = [0.5, -0.5 * dv[1], 0.5 * dv[2], -0.5 * dv[0]];
                    let lobe = [0.25, -0.5 * dv[1], 0.5 * dv[2], -0.5 * dv[0]];
                    for ch in 0..3 {
                        let c = &s[ch * 4..ch * 4 + 4];
                        let e: f32 = (0..4).map(|k| c[k] * basis[k]).sum();
                        for k in 0..4 {
                            o[ch * 4 + k] += 0.25 * c[k] + e * lobe[k];
                        }
                    }
                }
                out[(x + ni * (y + ni * z)) as usize] = o;
            }
        }
    }
    out
}

/// The LPV SH layout comparison: one propagation-like gather step in each [`ShLayout`].
pub struct LpvLayoutBench {
    ctx: Context,
    n: u32,
    pipes: [Pipeline; 3],
    soa: [Tracked<Buffer>; 2],
    aos: [Tracked<Buffer>; 2],
    src_images: [Tracked<Image>; 3],
    dst_images: [Tracked<Image>; 3],
}

impl LpvLayoutBench {
    /// An n³ grid of [`lpv_input`] in every layout.
    pub fn new(ctx: &Context, n: u32) -> Result<Self> {
        let n = n.max(1);
        let cells = n * n * n;
        let b = buffer_bindings(2);
        let imgs = image_bindings(&[vk::DescriptorType::STORAGE_IMAGE; 6]);
        let pipes = [
            Pipeline::compute(ctx, &shaders::PROFILE_LPV_LAYOUT_COMP, &b, 4)?,
            Pipeline::compute(ctx, &shaders::PROFILE_LPV_LAYOUT_COMP__AOS, &b, 4)?,
            Pipeline::compute(ctx, &shaders::PROFILE_LPV_LAYOUT_COMP__IMAGE, &imgs, 4)?,
        ];
        let floats =
            |f: &dyn Fn(u32) -> f32, len: u32| -> Vec<u8> { (0..len).flat_map(|i| f(i).to_le_bytes()).collect() };
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let bytes = cells as u64 * 48;
        let soa_data = floats(&|i| lpv_input(i % cells, i / cells), cells * 12);
        let aos_data = floats(&|i| lpv_input(i / 12, i % 12), cells * 12);
        let soa = [
            Tracked { res: ctx.upload_buffer("lpv soa src", &soa_data, usage)?, state: after_buffer_upload() },
            Tracked::fresh(storage_buffer(ctx, "lpv soa dst", bytes)?),
        ];
        let aos = [
            Tracked { res: ctx.upload_buffer("lpv aos src", &aos_data, usage)?, state: after_buffer_upload() },
            Tracked::fresh(storage_buffer(ctx, "lpv aos dst", bytes)?),
        ];
        let src_usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST;
        let dst_usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        let mut src_images = Vec::new();
        let mut dst_images = Vec::new();
        for ch in 0..3u32 {
            let img = rgba32f_3d(ctx, "lpv image src", n, src_usage)?;
            let texels = (0..cells).map(|c| [0, 1, 2, 3].map(|k| lpv_input(c, ch * 4 + k)));
            let layout = vk::ImageLayout::GENERAL;
            let state = upload_image(ctx, &img, &vec4_bytes(texels), layout, vk::AccessFlags2::SHADER_STORAGE_READ)?;
            src_images.push(Tracked { res: img, state });
            dst_images.push(Tracked::fresh(rgba32f_3d(ctx, "lpv image dst", n, dst_usage)?));
        }
        let three = |v: Vec<Tracked<Image>>| -> Result<[Tracked<Image>; 3]> {
            v.try_into().map_err(|_| Error::Input("profile: expected three LPV channel images".into()))
        };
        Ok(Self {
            ctx: ctx.clone(),
            n,
            pipes,
            soa,
            aos,
            src_images: three(src_images)?,
            dst_images: three(dst_images)?,
        })
    }

    /// Grid edge.
    pub fn edge(&self) -> u32 {
        self.n
    }

    /// One graph with `reps` gather steps in `layout`; GPU ms of each.
    pub fn run(&mut self, layout: ShLayout, reps: u32) -> Result<Vec<f64>> {
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let (n, groups) = (self.n, self.n.div_ceil(4));
        let push = push_words(&[n]);
        let label = format!("lpv {} {n}", layout.key());
        let mut timed = Vec::new();
        match layout {
            ShLayout::CoefficientMajor | ShLayout::CellMajor => {
                let (pipe, [src_t, dst_t]) = match layout {
                    ShLayout::CoefficientMajor => (&self.pipes[0], &mut self.soa),
                    _ => (&self.pipes[1], &mut self.aos),
                };
                let src = imports.buffer(&mut g, "lpv src", &src_t.res, src_t.state);
                let dst = imports.buffer(&mut g, "lpv dst", &dst_t.res, dst_t.state);
                for i in 0..reps {
                    let name = timed_name(&label, i);
                    let push = push.clone();
                    let mut p = g.add_compute_pass(name.clone());
                    p.side_effect();
                    p.read_buffer(src, Access::StorageRead(CS))?;
                    p.write_buffer(dst, Access::StorageWrite(CS))?;
                    p.record(move |pc| {
                        let ds = [
                            Descriptor::StorageBuffer(pc.buffer(src).raw),
                            Descriptor::StorageBuffer(pc.buffer(dst).raw),
                        ];
                        pipe.bind(pc.cmd, &ds, &push)?;
                        dispatch(pc, groups, groups, groups);
                        Ok(())
                    });
                    timed.push(name);
                }
                g.export_buffer(dst, None)?;
                let tracked = &mut [(src.into(), &mut src_t.state), (dst.into(), &mut dst_t.state)];
                execute(&self.ctx, g, &imports, tracked, &timed)
            }
            ShLayout::Images => {
                let pipe = &self.pipes[2];
                let src: Vec<_> =
                    self.src_images.iter().map(|t| imports.image(&mut g, "lpv image src", &t.res, t.state)).collect();
                let dst: Vec<_> =
                    self.dst_images.iter().map(|t| imports.image(&mut g, "lpv image dst", &t.res, t.state)).collect();
                let ids: Vec<_> = src.iter().chain(&dst).copied().collect();
                for i in 0..reps {
                    let name = timed_name(&label, i);
                    let (push, ids) = (push.clone(), ids.clone());
                    let mut p = g.add_compute_pass(name.clone());
                    p.side_effect();
                    for &s in &src {
                        p.read_image(s, Access::StorageRead(CS))?;
                    }
                    for &d in &dst {
                        p.write_image(d, Access::StorageWrite(CS))?;
                    }
                    p.record(move |pc| {
                        let ds: Vec<_> = ids.iter().map(|&id| Descriptor::StorageImage(pc.image(id).view)).collect();
                        pipe.bind(pc.cmd, &ds, &push)?;
                        dispatch(pc, groups, groups, groups);
                        Ok(())
                    });
                    timed.push(name);
                }
                for &d in &dst {
                    g.export_image(d, None)?;
                }
                let mut tracked: Vec<(ResourceId, &mut ResourceState)> = src
                    .iter()
                    .chain(&dst)
                    .map(|&id| ResourceId::from(id))
                    .zip(self.src_images.iter_mut().chain(self.dst_images.iter_mut()).map(|t| &mut t.state))
                    .collect();
                execute(&self.ctx, g, &imports, &mut tracked, &timed)
            }
        }
    }

    /// The input per cell `[channel·4 + k]`.
    pub fn input(&self) -> Vec<[f32; 12]> {
        (0..self.n.pow(3)).map(|c| std::array::from_fn(|j| lpv_input(c, j as u32))).collect()
    }

    /// The step's output in `layout`, per cell `[channel·4 + k]` (after a run in that layout).
    pub fn output(&mut self, layout: ShLayout) -> Result<Vec<[f32; 12]>> {
        let cells = self.n.pow(3) as usize;
        let mut out = vec![[0f32; 12]; cells];
        match layout {
            ShLayout::CoefficientMajor | ShLayout::CellMajor => {
                let t = if layout == ShLayout::CoefficientMajor { &mut self.soa[1] } else { &mut self.aos[1] };
                let f: Vec<f32> = u32s(&read_buffer(&self.ctx, t)?).into_iter().map(f32::from_bits).collect();
                for (c, o) in out.iter_mut().enumerate() {
                    for (j, v) in o.iter_mut().enumerate() {
                        *v = if layout == ShLayout::CoefficientMajor { f[j * cells + c] } else { f[c * 12 + j] };
                    }
                }
            }
            ShLayout::Images => {
                for (ch, t) in self.dst_images.iter_mut().enumerate() {
                    let texels = read_image(&self.ctx, t)?;
                    for (o, tx) in out.iter_mut().zip(texels) {
                        o[ch * 4..ch * 4 + 4].copy_from_slice(&tx);
                    }
                }
            }
        }
        Ok(out)
    }
}

/// Rate conversion: `work` per pass, reported in units of `scale` per second.
fn per_second(work: f64, scale: f64) -> impl Fn(f64) -> f64 {
    move |ms| work / (ms * 1e-3) / scale
}

/// Runs every benchmark of the suite at `cfg`'s sizes, calling `progress` after each row.
pub fn run_all(ctx: &Context, cfg: &LimitsConfig, mut progress: impl FnMut(&LimitRow)) -> Result<Vec<LimitRow>> {
    let mut rows = Vec::new();
    let mut emit = |row: LimitRow| {
        progress(&row);
        rows.push(row);
    };
    let (rule, reps) = (&cfg.rule, cfg.reps.max(1));
    let gbs = |bytes: u64| per_second(bytes as f64, 1e9);
    let mib = |bytes: u64| bytes as f64 / MIB;

    {
        let mut b = CopyBench::new(ctx, cfg.copy_bytes)?;
        let m = measure(rule, || b.run(reps))?;
        let detail = format!("vkCmdCopyBuffer {:.0} MiB; bytes = read + written", mib(b.bytes()));
        emit(LimitRow::from_ms(
            "buffer copy",
            detail,
            "GB/s",
            (2.0 * b.bytes() as f64, "bytes"),
            &m,
            gbs(2 * b.bytes()),
        ));
    }
    {
        let mut b = BufferReadBench::new(ctx, cfg.buffer_bytes)?;
        let m = measure(rule, || b.run(reps))?;
        let detail = format!("vec4 loads of {:.0} MiB (+1/{ITEMS} sums written)", mib(b.input_bytes()));
        emit(LimitRow::from_ms("ssbo read", detail, "GB/s", (b.bytes() as f64, "bytes"), &m, gbs(b.bytes())));
    }
    {
        let mut b = BufferWriteBench::new(ctx, cfg.buffer_bytes)?;
        let m = measure(rule, || b.run(reps))?;
        let detail = format!("vec4 stores of {:.0} MiB", mib(b.bytes()));
        emit(LimitRow::from_ms("ssbo write", detail, "GB/s", (b.bytes() as f64, "bytes"), &m, gbs(b.bytes())));
    }
    {
        let mut b = ImageReadBench::new(ctx, cfg.image_edge)?;
        let m = measure(rule, || b.run(reps))?;
        let n = b.edge();
        let detail = format!(
            "imageLoad RGBA32F 3D {n}^3 ({:.1} MiB; +1/{ZITEMS} sums written)",
            mib(16 * n as u64 * n as u64 * n as u64)
        );
        emit(LimitRow::from_ms("image read", detail, "GB/s", (b.bytes() as f64, "bytes"), &m, gbs(b.bytes())));
    }
    {
        let mut b = ImageWriteBench::new(ctx, cfg.image_edge)?;
        let m = measure(rule, || b.run(reps))?;
        let n = b.edge();
        let detail = format!("imageStore RGBA32F 3D {n}^3 ({:.1} MiB)", mib(b.bytes()));
        emit(LimitRow::from_ms("image write", detail, "GB/s", (b.bytes() as f64, "bytes"), &m, gbs(b.bytes())));
    }
    match linear_rgba32f_unsupported(ctx) {
        Some(reason) => {
            for name in ["texture coherent", "texture scattered"] {
                emit(LimitRow::skipped(name, "trilinear RGBA32F 3D".into(), "Gfetch/s", reason.clone()));
            }
        }
        None => {
            let mut b = TextureBench::new(ctx, cfg.texture_edge, cfg.fetch_grid)?;
            let (n, grid) = b.sizes();
            for scattered in [false, true] {
                let m = measure(rule, || b.run(scattered, reps))?;
                let (name, how) = if scattered {
                    ("texture scattered", "hashed coordinates")
                } else {
                    ("texture coherent", "neighbouring invocations at neighbouring texels")
                };
                let detail =
                    format!("trilinear RGBA32F 3D {n}^3; {grid}^3 invocations x {TEXTURE_FETCHES} fetches; {how}");
                let work = b.fetches() as f64;
                emit(LimitRow::from_ms(name, detail, "Gfetch/s", (work, "fetches"), &m, per_second(work, 1e9)));
            }
        }
    }
    {
        let mut b = AtomicBench::new(ctx, cfg.atomic_invocations, cfg.atomics_per_invocation)?;
        let work = b.atomics() as f64;
        for float in [false, true] {
            for contended in [false, true] {
                let ty = if float { "float" } else { "uint" };
                let name = format!("atomic {ty} {}", if contended { "contended" } else { "uncontended" });
                let target = if contended {
                    format!("all to {CONTENDED_ADDRESSES} addresses")
                } else {
                    "each invocation its own address".into()
                };
                let detail = format!(
                    "atomicAdd {ty}; {} invocations x {}; {target}",
                    b.invocations(),
                    cfg.atomics_per_invocation
                );
                if float {
                    if let Some(reason) = AtomicBench::float_unsupported(ctx) {
                        emit(LimitRow::skipped(&name, detail, "Gatomic/s", reason));
                        continue;
                    }
                }
                let m = measure(rule, || b.run(float, contended, reps))?;
                emit(LimitRow::from_ms(&name, detail, "Gatomic/s", (work, "atomics"), &m, per_second(work, 1e9)));
            }
        }
    }
    {
        let mut b = DispatchBench::new(ctx, cfg.dispatches)?;
        let m = measure(rule, || b.run(reps))?;
        let count = b.count() as f64;
        let detail = format!("{} x (push descriptor + vkCmdDispatch(1,1,1)) in one pass", b.count());
        emit(LimitRow::from_ms("dispatch", detail, "us/dispatch", (count, "dispatches"), &m, |ms| ms * 1e3 / count));
    }
    {
        let mut b = DrawBench::new(ctx, cfg.draws)?;
        let m = measure(rule, || b.run(reps))?;
        let count = b.count() as f64;
        let detail = format!("{} x vkCmdDraw(1 point) in one dynamic-rendering pass", b.count());
        emit(LimitRow::from_ms("draw", detail, "us/draw", (count, "draws"), &m, |ms| ms * 1e3 / count));
    }
    for &n in &cfg.lpv_sizes {
        let mut b = LpvLayoutBench::new(ctx, n)?;
        for layout in ShLayout::ALL {
            let m = measure(rule, || b.run(layout, reps))?;
            let detail = format!("LPV gather step {n}^3 x 12 floats; {}", layout.describe());
            let cells = (n as f64).powi(3);
            let name = format!("lpv {} {n}", layout.key());
            emit(LimitRow::from_ms(&name, detail, "ms/step", (cells, "cells"), &m, |ms| ms));
        }
    }
    Ok(rows)
}
