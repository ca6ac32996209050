//! Memory bandwidth: buffer copy, storage-buffer and storage-image reads and writes.

use super::{bandwidth, mib, rgba32f_3d, storage_buffer, upload_image, uploaded};
use crate::limits::cpu::*;
use crate::limits::{Bench, BenchGraph, Case};
use vkengine::graph::Access;
use vkengine::graph::{PersistentBuffer, PersistentImage};
use vkengine::shaders;
use vkengine::vk::{vk, Context};
use vkengine::Result;

/// Buffer → buffer copy bandwidth: `vkCmdCopyBuffer` in a transfer pass.
pub struct CopyBench {
    ctx: Context,
    src: PersistentBuffer,
    dst: PersistentBuffer,
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
    src: PersistentBuffer,
    sums: PersistentBuffer,
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
    dst: PersistentBuffer,
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
    image: PersistentImage,
    sums: PersistentBuffer,
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
        Ok(Self { ctx: ctx.clone(), image: PersistentImage::with_state(image, state), sums, n })
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
    image: PersistentImage,
    n: u32,
}

impl ImageWriteBench {
    /// An n³ image, n rounded up to a multiple of 16.
    pub fn new(ctx: &Context, n: u32) -> Result<Self> {
        let n = image_edge(n);
        let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        Ok(Self { ctx: ctx.clone(), image: PersistentImage::new(rgba32f_3d(ctx, "image write dst", n, usage)?), n })
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
