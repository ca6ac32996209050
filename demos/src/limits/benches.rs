//! The suite's benchmarks: buffer copy, storage-buffer and storage-image bandwidth, trilinear
//! fetch rate, atomics, dispatch and draw overhead, and the LPV SH layout comparison. Each
//! implements [`Bench`]; the readbacks and `expected` values are what the tests check.

use super::cpu::*;
use super::{Bench, BenchGraph, Case, Rate, Tracked};
use vkengine::graph::{Access, LoadOp, ResourceState, ShaderStage};
use vkengine::shaders;
use vkengine::vk::pipeline::push_words;
use vkengine::vk::pipeline_cache::Sampling;
use vkengine::vk::{vk, Buffer, Context, GraphicsDesc, Image, ImageInfo, MemoryLocation, Pipeline};
use vkengine::{Error, Result};

const MIB: f64 = 1024.0 * 1024.0;

fn mib(bytes: u64) -> f64 {
    bytes as f64 / MIB
}

/// A case measured in GB/s of `bytes` per pass.
fn bandwidth(name: &str, detail: String, bytes: u64) -> Case {
    Case {
        name: name.into(),
        detail,
        unit: "GB/s",
        work: bytes as f64,
        work_unit: "bytes",
        rate: Rate::PerSecond(1e9),
        skipped: None,
    }
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

fn storage_buffer(ctx: &Context, name: &str, bytes: u64) -> Result<Tracked<Buffer>> {
    let usage =
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC;
    Ok(Tracked::fresh(Buffer::new(ctx, name, bytes, usage, MemoryLocation::GpuOnly)?))
}

fn uploaded(ctx: &Context, name: &str, data: &[u8], usage: vk::BufferUsageFlags) -> Result<Tracked<Buffer>> {
    Ok(Tracked::new(ctx.upload_buffer(name, data, usage)?, after_buffer_upload()))
}

fn rgba32f_3d(ctx: &Context, name: &str, n: u32, usage: vk::ImageUsageFlags) -> Result<Image> {
    Image::new(ctx, name, ImageInfo::d3(vk::Format::R32G32B32A32_SFLOAT, [n, n, n], usage))
}

/// Buffer → buffer copy bandwidth: `vkCmdCopyBuffer` in a transfer pass.
pub struct CopyBench {
    ctx: Context,
    src: Tracked<Buffer>,
    dst: Tracked<Buffer>,
    bytes: u64,
}

impl CopyBench {
    /// Source filled with [`copy_word`]s, destination undefined.
    pub fn new(ctx: &Context, bytes: u64) -> Result<Self> {
        let bytes = bytes.max(4) / 4 * 4;
        let data: Vec<u8> = (0..(bytes / 4) as u32).flat_map(|i| copy_word(i).to_le_bytes()).collect();
        let src = uploaded(ctx, "copy src", &data, vk::BufferUsageFlags::TRANSFER_SRC)?;
        Ok(Self { ctx: ctx.clone(), src, dst: storage_buffer(ctx, "copy dst", bytes)?, bytes })
    }

    /// Bytes copied per pass.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// The destination's bytes (after a run).
    pub fn read_dst(&self) -> Result<Vec<u8>> {
        self.dst.read(&self.ctx)
    }
}

impl Bench for CopyBench {
    fn cases(&self) -> Vec<Case> {
        let detail = format!("vkCmdCopyBuffer {:.0} MiB; bytes = read + written", mib(self.bytes));
        vec![bandwidth("buffer copy", detail, 2 * self.bytes)]
    }

    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, _case: usize, reps: u32) -> Result<()> {
        let src = g.input_buffer("copy src", &self.src);
        let dst = g.output_buffer("copy dst", &self.dst);
        let size = self.bytes;
        for i in 0..reps {
            let name = g.timed(i);
            let mut p = g.g.add_transfer_pass(name);
            p.side_effect();
            p.read_buffer(src, Access::TransferSrc)?;
            p.write_buffer(dst, Access::TransferDst)?;
            p.record(move |pc| {
                let region = [vk::BufferCopy { src_offset: 0, dst_offset: 0, size }];
                // SAFETY: transfer pass; both buffers hold at least `size` bytes.
                unsafe { pc.device().cmd_copy_buffer(pc.cmd, pc.buffer(src).raw, pc.buffer(dst).raw, &region) };
                Ok(())
            });
        }
        Ok(())
    }
}

/// vec4s of `bytes` rounded up to whole workgroup blocks (WG·ITEMS vec4s).
fn buffer_vec4s(bytes: u64) -> u32 {
    let block = (WG * ITEMS) as u64;
    ((bytes / 16).div_ceil(block).max(1) * block) as u32
}

/// Storage-buffer read bandwidth: vec4 loads, one vec4 sum stored per ITEMS loads.
pub struct BufferReadBench {
    ctx: Context,
    src: Tracked<Buffer>,
    sums: Tracked<Buffer>,
    vec4s: u32,
}

impl BufferReadBench {
    /// Input of `bytes` (rounded up to whole blocks) filled with [`read_input`].
    pub fn new(ctx: &Context, bytes: u64) -> Result<Self> {
        let vec4s = buffer_vec4s(bytes);
        let data = vec4_bytes((0..vec4s).map(read_input));
        let src = uploaded(ctx, "read src", &data, vk::BufferUsageFlags::STORAGE_BUFFER)?;
        let sums = storage_buffer(ctx, "read sums", (vec4s / ITEMS) as u64 * 16)?;
        Ok(Self { ctx: ctx.clone(), src, sums, vec4s })
    }

    /// Bytes read plus bytes of sums written per pass.
    pub fn bytes(&self) -> u64 {
        self.input_bytes() + (self.vec4s / ITEMS) as u64 * 16
    }

    /// Bytes read per pass.
    pub fn input_bytes(&self) -> u64 {
        self.vec4s as u64 * 16
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
    pub fn read_sums(&self) -> Result<Vec<[f32; 4]>> {
        Ok(vec4s(&self.sums.read(&self.ctx)?))
    }
}

impl Bench for BufferReadBench {
    fn cases(&self) -> Vec<Case> {
        let detail = format!("vec4 loads of {:.0} MiB (+1/{ITEMS} sums written)", mib(self.input_bytes()));
        vec![bandwidth("ssbo read", detail, self.bytes())]
    }

    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, _case: usize, reps: u32) -> Result<()> {
        let src = g.input_buffer("read src", &self.src);
        let sums = g.output_buffer("read sums", &self.sums);
        let groups = self.vec4s / (WG * ITEMS);
        for i in 0..reps {
            let name = g.timed(i);
            g.g.compute(name, &shaders::PROFILE_BUFFER_READ_COMP)
                .read(src)
                .write(sums)
                .side_effect()
                .dispatch([groups, 1, 1])?;
        }
        Ok(())
    }
}

/// Storage-buffer write bandwidth: vec4 stores of [`pattern`].
pub struct BufferWriteBench {
    ctx: Context,
    dst: Tracked<Buffer>,
    vec4s: u32,
}

impl BufferWriteBench {
    /// Destination of `bytes` (rounded up to whole blocks).
    pub fn new(ctx: &Context, bytes: u64) -> Result<Self> {
        let vec4s = buffer_vec4s(bytes);
        Ok(Self { ctx: ctx.clone(), dst: storage_buffer(ctx, "write dst", vec4s as u64 * 16)?, vec4s })
    }

    /// Bytes written per pass.
    pub fn bytes(&self) -> u64 {
        self.vec4s as u64 * 16
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
    pub fn read_dst(&self) -> Result<Vec<[f32; 4]>> {
        Ok(vec4s(&self.dst.read(&self.ctx)?))
    }
}

impl Bench for BufferWriteBench {
    fn cases(&self) -> Vec<Case> {
        vec![bandwidth("ssbo write", format!("vec4 stores of {:.0} MiB", mib(self.bytes())), self.bytes())]
    }

    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, _case: usize, reps: u32) -> Result<()> {
        let dst = g.output_buffer("write dst", &self.dst);
        let groups = self.vec4s / (WG * ITEMS);
        for i in 0..reps {
            let name = g.timed(i);
            g.g.compute(name, &shaders::PROFILE_BUFFER_WRITE_COMP).write(dst).side_effect().dispatch([groups, 1, 1])?;
        }
        Ok(())
    }
}

/// Edge rounded up to whole ZITEMS columns.
fn image_edge(n: u32) -> u32 {
    n.max(1).div_ceil(ZITEMS) * ZITEMS
}

/// Storage-image read bandwidth: imageLoad of an RGBA32F 3D image, one sum stored per column.
pub struct ImageReadBench {
    ctx: Context,
    image: Tracked<Image>,
    sums: Tracked<Buffer>,
    n: u32,
}

impl ImageReadBench {
    /// An n³ image (n rounded up to a multiple of 16) holding [`read_input`] of each linear index.
    pub fn new(ctx: &Context, n: u32) -> Result<Self> {
        let n = image_edge(n);
        let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST;
        let image = rgba32f_3d(ctx, "image read src", n, usage)?;
        let data = vec4_bytes((0..n * n * n).map(read_input));
        let state = upload_image(ctx, &image, &data, vk::ImageLayout::GENERAL, vk::AccessFlags2::SHADER_STORAGE_READ)?;
        let sums = storage_buffer(ctx, "image read sums", (n * n * n / ZITEMS) as u64 * 16)?;
        Ok(Self { ctx: ctx.clone(), image: Tracked::new(image, state), sums, n })
    }

    /// Edge of the image.
    pub fn edge(&self) -> u32 {
        self.n
    }

    /// Bytes read plus bytes of sums written per pass.
    pub fn bytes(&self) -> u64 {
        (self.n as u64).pow(3) * 16 * (ZITEMS as u64 + 1) / ZITEMS as u64
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
    pub fn read_sums(&self) -> Result<Vec<[f32; 4]>> {
        Ok(vec4s(&self.sums.read(&self.ctx)?))
    }
}

impl Bench for ImageReadBench {
    fn cases(&self) -> Vec<Case> {
        let n = self.n;
        let detail =
            format!("imageLoad RGBA32F 3D {n}^3 ({:.1} MiB; +1/{ZITEMS} sums written)", mib(16 * (n as u64).pow(3)));
        vec![bandwidth("image read", detail, self.bytes())]
    }

    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, _case: usize, reps: u32) -> Result<()> {
        let img = g.input_image("image read src", &self.image);
        let sums = g.output_buffer("image read sums", &self.sums);
        let n = self.n;
        for i in 0..reps {
            let name = g.timed(i);
            g.g.compute(name, &shaders::PROFILE_IMAGE_READ_COMP).read(img).write(sums).side_effect().dispatch([
                n / 8,
                n / 8,
                n / ZITEMS,
            ])?;
        }
        Ok(())
    }
}

/// Storage-image write bandwidth: imageStore of [`pattern`] into an RGBA32F 3D image.
pub struct ImageWriteBench {
    ctx: Context,
    image: Tracked<Image>,
    n: u32,
}

impl ImageWriteBench {
    /// An n³ image, n rounded up to a multiple of 16.
    pub fn new(ctx: &Context, n: u32) -> Result<Self> {
        let n = image_edge(n);
        let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        Ok(Self { ctx: ctx.clone(), image: Tracked::fresh(rgba32f_3d(ctx, "image write dst", n, usage)?), n })
    }

    /// Edge of the image.
    pub fn edge(&self) -> u32 {
        self.n
    }

    /// Bytes written per pass.
    pub fn bytes(&self) -> u64 {
        (self.n as u64).pow(3) * 16
    }

    /// The image's texels, x fastest (after a run).
    pub fn read_image(&self) -> Result<Vec<[f32; 4]>> {
        self.image.read_rgba32f(&self.ctx)
    }
}

impl Bench for ImageWriteBench {
    fn cases(&self) -> Vec<Case> {
        let n = self.n;
        let detail = format!("imageStore RGBA32F 3D {n}^3 ({:.1} MiB)", mib(self.bytes()));
        vec![bandwidth("image write", detail, self.bytes())]
    }

    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, _case: usize, reps: u32) -> Result<()> {
        let img = g.output_image("image write dst", &self.image);
        let n = self.n;
        for i in 0..reps {
            let name = g.timed(i);
            g.g.compute(name, &shaders::PROFILE_IMAGE_WRITE_COMP).write(img).side_effect().dispatch([
                n / 8,
                n / 8,
                n / ZITEMS,
            ])?;
        }
        Ok(())
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
    tex: Tracked<Image>,
    out: Tracked<Buffer>,
    n: u32,
    grid: u32,
}

const TEXTURE_CASES: [(&str, &str); 2] = [
    ("texture coherent", "neighbouring invocations at neighbouring texels"),
    ("texture scattered", "hashed coordinates"),
];

impl TextureBench {
    /// An n³ texture of [`texture_texel`]s read by grid³ invocations (grid rounded up to a multiple of 4).
    pub fn new(ctx: &Context, n: u32, grid: u32) -> Result<Self> {
        if let Some(reason) = linear_rgba32f_unsupported(ctx) {
            return Err(Error::Input(reason));
        }
        let (n, grid) = (n.max(2), grid.max(1).div_ceil(4) * 4);
        let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        let tex = rgba32f_3d(ctx, "fetch texture", n, usage)?;
        let texels = (0..n).flat_map(|z| (0..n).flat_map(move |y| (0..n).map(move |x| texture_texel(x, y, z))));
        let layout = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let state = upload_image(ctx, &tex, &vec4_bytes(texels), layout, vk::AccessFlags2::SHADER_SAMPLED_READ)?;
        let out = storage_buffer(ctx, "fetch sums", (grid as u64).pow(3) * 16)?;
        Ok(Self { ctx: ctx.clone(), tex: Tracked::new(tex, state), out, n, grid })
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
        let groups = self.grid / 4;
        for i in 0..reps {
            let name = g.timed(i);
            g.g.compute(name, shader)
                .sampled(tex, Sampling::Linear)
                .write(out)
                .side_effect()
                .dispatch([groups, groups, groups])?;
        }
        Ok(())
    }
}

/// 32-bit atomicAdd throughput: cases uint/float × uncontended/contended ([`AtomicBench::case`]).
pub struct AtomicBench {
    ctx: Context,
    counters: Tracked<Buffer>,
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

/// Dispatch overhead: N one-invocation dispatches in one compute pass, each with its own
/// push-descriptor range (so no two dispatches touch the same bytes).
pub struct DispatchBench {
    ctx: Context,
    slots: Tracked<Buffer>,
    count: u32,
    stride: u64,
}

impl DispatchBench {
    /// `count` dispatches into `count` slots.
    pub fn new(ctx: &Context, count: u32) -> Result<Self> {
        let count = count.max(1);
        let stride = ctx.info.limits.min_storage_buffer_offset_alignment.max(4);
        let slots = storage_buffer(ctx, "dispatch slots", count as u64 * stride)?;
        Ok(Self { ctx: ctx.clone(), slots, count, stride })
    }

    /// Dispatches per pass.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The first word of every slot (after a run): [`TINY_MARKER`] where a dispatch ran.
    pub fn read_slots(&self) -> Result<Vec<u32>> {
        let words = u32s(&self.slots.read(&self.ctx)?);
        Ok(words.iter().step_by((self.stride / 4) as usize).copied().collect())
    }
}

impl Bench for DispatchBench {
    fn cases(&self) -> Vec<Case> {
        vec![Case {
            name: "dispatch".into(),
            detail: format!("{} x (push descriptor + vkCmdDispatch(1,1,1)) in one pass", self.count),
            unit: "us/dispatch",
            work: self.count as f64,
            work_unit: "dispatches",
            rate: Rate::MicrosEach,
            skipped: None,
        }]
    }

    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, _case: usize, reps: u32) -> Result<()> {
        let slots = g.output_buffer("dispatch slots", &self.slots);
        let (count, stride) = (self.count, self.stride);
        for i in 0..reps {
            g.g.add_transfer_pass(format!("clear slots #{i}")).write_buffer(slots, Access::TransferDst)?.record(
                move |pc| {
                    // SAFETY: transfer pass writing the declared buffer.
                    unsafe { pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(slots).raw, 0, vk::WHOLE_SIZE, 0) };
                    Ok(())
                },
            );
            // A hand-recorded pass: the point is one push-descriptor range per dispatch, which the
            // shader-pass builder (one descriptor per binding per pass) does not express.
            let name = g.timed(i);
            g.g.add_compute_pass(name)
                .side_effect()
                .write_buffer(slots, Access::StorageWrite(ShaderStage::Compute))?
                .record(move |pc| {
                    let pipe = pc.ctx.pipelines().compute(pc.ctx, &shaders::PROFILE_TINY_COMP)?;
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
                });
        }
        Ok(())
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

    /// The target's pixels, row-major (after a run): i + 1 at pixel i < N, 0 elsewhere.
    pub fn read_target(&self) -> Result<Vec<u32>> {
        Ok(u32s(&self.target.read_bytes(&self.ctx)?))
    }
}

impl Bench for DrawBench {
    fn cases(&self) -> Vec<Case> {
        vec![Case {
            name: "draw".into(),
            detail: format!("{} x vkCmdDraw(1 point) in one dynamic-rendering pass", self.count),
            unit: "us/draw",
            work: self.count as f64,
            work_unit: "draws",
            rate: Rate::MicrosEach,
            skipped: None,
        }]
    }

    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, _case: usize, reps: u32) -> Result<()> {
        let target = g.output_image("draw target", &self.target);
        let (pipe, count, push) = (&self.pipe, self.count, push_words(&self.size));
        for i in 0..reps {
            let name = g.timed(i);
            let push = push.clone();
            g.g.add_raster_pass(name).side_effect().color_attachment(target, LoadOp::Clear, [0.0; 4])?.record(
                move |pc| {
                    pipe.bind(pc.cmd, &[], &push)?;
                    for d in 0..count {
                        // SAFETY: inside the pass's rendering scope with the pipeline bound; no vertex buffers.
                        unsafe { pc.device().cmd_draw(pc.cmd, 1, 1, 0, d) };
                    }
                    Ok(())
                },
            );
        }
        Ok(())
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
    soa: [Tracked<Buffer>; 2],
    aos: [Tracked<Buffer>; 2],
    src_images: Vec<Tracked<Image>>,
    dst_images: Vec<Tracked<Image>>,
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
            src_images.push(Tracked::new(img, state));
            dst_images.push(Tracked::fresh(rgba32f_3d(ctx, "lpv image dst", n, dst_usage)?));
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
        let (n, groups) = (self.n, self.n.div_ceil(4));
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
                    g.g.compute(name, shader)
                        .read(src)
                        .write(dst)
                        .constants(&n)
                        .side_effect()
                        .dispatch([groups, groups, groups])?;
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
                        .dispatch([groups, groups, groups])?;
                }
            }
        }
        Ok(())
    }
}
