//! Mutation fuzzing of every file loader, on the stable toolchain (no coverage guidance): valid
//! seed files per format are mutated (bit flips, boundary bytes and integers, truncation, splices,
//! deleted and duplicated chunks, number tokens replaced by extreme values) and each case is loaded
//! in-process on a worker thread under `catch_unwind` and a time limit. A case fails when the loader
//! panics, runs past the limit, or allocates more than [`alloc_limit`] of its input size; an error
//! return is the expected outcome. `fuzz_loaders` runs it as a command, `tests/fuzz_loaders.rs` runs
//! a few hundred fixed-seed cases per format.
//!
//! The allocation check needs [`CountingAlloc`] installed as the binary's global allocator; without
//! it only panics and hangs are caught ([`counting_active`] tells).

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, Mutex};
use std::time::Duration;

// ---------------------------------------------------------------------------------------------
// Allocation accounting

static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static LARGEST: AtomicUsize = AtomicUsize::new(0);
static ACTIVE: AtomicBool = AtomicBool::new(false);

/// A single request above this is refused (null / `try_reserve` error) rather than risk the
/// machine's memory on a header's word; it is still counted as the case's largest request.
pub const REFUSE_ABOVE: usize = 2 << 30;

/// The system allocator, counting live bytes, their peak and the largest single request.
pub struct CountingAlloc;

impl CountingAlloc {
    fn grew(size: usize) {
        let now = CURRENT.fetch_add(size, Ordering::Relaxed) + size;
        PEAK.fetch_max(now, Ordering::Relaxed);
    }

    /// Records a request of `size` bytes as the largest so far if it is; false: refuse it.
    fn admit(size: usize) -> bool {
        LARGEST.fetch_max(size, Ordering::Relaxed);
        size <= REFUSE_ABOVE
    }

    /// A fresh allocation of `size` bytes from `System` (null or not), counted if it succeeded.
    fn counted(p: *mut u8, size: usize) -> *mut u8 {
        if !p.is_null() {
            Self::grew(size);
        }
        p
    }
}

// SAFETY: every method forwards to `System` with the caller's layout unchanged (or returns null,
// which GlobalAlloc permits for any request); the counters are plain atomics and never allocate.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ACTIVE.store(true, Ordering::Relaxed);
        if !Self::admit(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded with the caller's valid, non-zero-size layout.
        Self::counted(unsafe { System.alloc(layout) }, layout.size())
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        ACTIVE.store(true, Ordering::Relaxed);
        if !Self::admit(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: as in alloc.
        Self::counted(unsafe { System.alloc_zeroed(layout) }, layout.size())
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        CURRENT.fetch_sub(layout.size(), Ordering::Relaxed);
        // SAFETY: ptr came from this allocator (so from System) with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if !Self::admit(new_size) {
            return std::ptr::null_mut();
        }
        // SAFETY: ptr came from System with `layout`; new_size is the caller's valid request.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            CURRENT.fetch_sub(layout.size(), Ordering::Relaxed);
            Self::grew(new_size);
        }
        p
    }
}

/// Whether [`CountingAlloc`] is this process's global allocator (it has seen an allocation).
pub fn counting_active() -> bool {
    // Make sure at least one allocation has happened before asking.
    drop(std::hint::black_box(vec![0u8; 1]));
    ACTIVE.load(Ordering::Relaxed)
}

/// Most a case may allocate beyond what was live when it started: 64 × its input bytes, at
/// least 32 MiB (room for decompressing the small seeds; far below what a header claiming
/// billions of voxels would take).
pub fn alloc_limit(input_bytes: usize) -> usize {
    (input_bytes.saturating_mul(64)).max(32 << 20)
}

// ---------------------------------------------------------------------------------------------
// Randomness and mutation

/// splitmix64: small, seedable, the same sequence on every platform.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator starting from `seed`.
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next_u64() % n as u64) as usize
        }
    }
}

/// Integers at the edges of the ranges headers store (sizes, offsets, counts, type codes).
const INT_EDGES: [u64; 14] = [
    0,
    1,
    2,
    0x7F,
    0x80,
    0xFF,
    0x7FFF,
    0xFFFF,
    0x1_0000,
    0x7FFF_FFFF,
    0x8000_0000,
    0xFFFF_FFFF,
    0x7FFF_FFFF_FFFF_FFFF,
    u64::MAX,
];

/// Number tokens for text headers: zero, negatives, overflow of every integer width, float
/// extremes and non-numbers.
const TEXT_EDGES: [&str; 18] = [
    "0",
    "-1",
    "-0",
    "65536",
    "2147483648",
    "4294967295",
    "4294967296",
    "18446744073709551616",
    "99999999999999999999999999",
    "1e39",
    "-1e39",
    "1e308",
    "1e-45",
    "nan",
    "inf",
    "-inf",
    "0.0000001",
    "",
];

/// Applies 1–4 random mutations to `data`; `donor` supplies bytes for splices.
pub fn mutate(rng: &mut Rng, data: &mut Vec<u8>, donor: &[u8]) {
    for _ in 0..1 + rng.below(4) {
        let len = data.len();
        match rng.below(8) {
            0 => {
                for _ in 0..1 + rng.below(8) {
                    if len > 0 {
                        let i = rng.below(len);
                        data[i] ^= 1 << rng.below(8);
                    }
                }
            }
            1 if len > 0 => {
                let i = rng.below(len);
                data[i] = [0, 1, 0x7F, 0x80, 0xFF, rng.next_u64() as u8][rng.below(6)];
            }
            2 if len > 0 => {
                let width = [1usize, 2, 4, 8][rng.below(4)];
                let v = INT_EDGES[rng.below(INT_EDGES.len())];
                let v = if rng.below(4) == 0 { v.wrapping_sub(1) } else { v };
                let bytes = if rng.below(2) == 0 { v.to_le_bytes() } else { v.to_be_bytes() };
                let bytes = if rng.below(2) == 0 { &bytes[..width] } else { &bytes[8 - width..] };
                // Aligned offsets hit header fields more often than random ones.
                let at = rng.below(len) & !(width - 1);
                for (k, b) in bytes.iter().enumerate() {
                    if let Some(d) = data.get_mut(at + k) {
                        *d = *b;
                    }
                }
            }
            3 => data.truncate(rng.below(len + 1)),
            4 if !donor.is_empty() => {
                let a = rng.below(donor.len());
                let n = 1 + rng.below((donor.len() - a).min(256));
                let chunk = &donor[a..a + n];
                let at = rng.below(len + 1);
                if rng.below(2) == 0 {
                    data.splice(at..at, chunk.iter().copied());
                } else {
                    let end = (at + n).min(len);
                    data.splice(at..end, chunk.iter().copied());
                }
            }
            5 if len > 0 => {
                let a = rng.below(len);
                let n = 1 + rng.below((len - a).min(64));
                data.drain(a..a + n);
            }
            6 if len > 0 => {
                let a = rng.below(len);
                let n = 1 + rng.below((len - a).min(64));
                let chunk = data[a..a + n].to_vec();
                let at = rng.below(len + 1);
                data.splice(at..at, chunk);
            }
            _ => replace_number(rng, data),
        }
    }
}

/// Replaces one run of ASCII digits (with sign, point and exponent) by an extreme token.
fn replace_number(rng: &mut Rng, data: &mut Vec<u8>) {
    let is_num = |b: u8| b.is_ascii_digit() || matches!(b, b'.' | b'-' | b'+' | b'e' | b'E');
    let starts: Vec<usize> =
        (0..data.len()).filter(|&i| data[i].is_ascii_digit() && (i == 0 || !is_num(data[i - 1]))).collect();
    if starts.is_empty() {
        return;
    }
    let a = starts[rng.below(starts.len())];
    let mut b = a;
    while b < data.len() && is_num(data[b]) {
        b += 1;
    }
    let token = TEXT_EDGES[rng.below(TEXT_EDGES.len())];
    data.splice(a..b, token.bytes());
}

// ---------------------------------------------------------------------------------------------
// Formats

/// One file of a seed: its name in the case folder and its bytes.
pub type SeedFile = (String, Vec<u8>);

/// A loader under test: the files of one valid input, which of them to load, and the call.
pub struct Format {
    /// Short name (`nrrd`, `gltf`, …).
    pub name: &'static str,
    /// Builds the valid seed files.
    pub seed: fn() -> Vec<SeedFile>,
    /// The file (or `.` for the folder) the loader is given.
    pub entry: &'static str,
    /// Loads it; the error text is the loader's message.
    pub load: fn(&Path) -> Result<(), String>,
    /// Allocation allowed beyond [`alloc_limit`]'s: compressed images decode to far more than
    /// their size by design, so their loader bounds what a header may claim instead (0: none).
    pub claim_cap: usize,
}

fn load_volume(p: &Path) -> Result<(), String> {
    // Negative voxels are accepted, so benign mutations of values reach the later stages.
    let opts = vkengine::volume::data::LoadOptions { allow_negative: true, ..Default::default() };
    vkengine::volume::data::load(p, &opts).map(|_| ()).map_err(|e| e.to_string())
}

/// The streamed path (normalized u16 in slabs) with a small device, so a header's claim is
/// refused before anything is allocated.
fn load_volume_streamed(p: &Path) -> Result<(), String> {
    let budget = vkengine::volume::data::DeviceBudget { heap_bytes: 64 << 20, max_allocation: 16 << 20 };
    let opts = vkengine::volume::data::LoadOptions {
        allow_negative: true,
        stream_above: 0,
        device: Some(budget),
        ..Default::default()
    };
    vkengine::volume::data::load(p, &opts).map(|_| ()).map_err(|e| e.to_string())
}

/// The loader straight into the sparse layout's bricks (`volume::data::bricked`), then their own
/// check (`volume::bricks`) and the bricks of the same voxels built from the dense volume: the
/// odd dims and values of mutated files must brick without a panic, alike both ways.
fn load_volume_bricked(p: &Path) -> Result<(), String> {
    let bricks = Some(vkengine::volume::data::IntoBricks { always: true, max_image_3d: 2048 });
    load_bricked_with(p, &vkengine::volume::data::LoadOptions { allow_negative: true, bricks, ..Default::default() })
}

/// [`load_volume_bricked`] on a device and a host with room for a few slots, so most mutated
/// sizes load at a coarser pyramid level or are refused after the first pass, before any brick
/// is built (`volume::data::bricked`).
fn load_volume_bricked_small(p: &Path) -> Result<(), String> {
    let bricks = Some(vkengine::volume::data::IntoBricks { always: true, max_image_3d: 2048 });
    let device = Some(vkengine::volume::data::DeviceBudget { heap_bytes: 16 << 10, max_allocation: 8 << 10 });
    let small =
        vkengine::volume::data::LoadOptions { host_memory: Some(32 << 10), device, bricks, ..Default::default() };
    load_bricked_with(p, &vkengine::volume::data::LoadOptions { allow_negative: true, ..small })
}

/// [`load_volume_bricked`] with no per-axis limit but `u32` and a host with room for 16 MiB:
/// mutated dims reach the 64-bit voxel counts (past `u32`, past `u64` as a product) that loads
/// into bricks accept, and must be refused as truncated or by their dims, allocating nothing big.
fn load_volume_bricked_wide(p: &Path) -> Result<(), String> {
    let bricks = Some(vkengine::volume::data::IntoBricks { always: true, max_image_3d: 2048 });
    let wide = vkengine::volume::data::LoadOptions {
        allow_negative: true,
        max_dimension: u32::MAX,
        host_memory: Some(16 << 20),
        bricks,
        ..Default::default()
    };
    load_bricked_with(p, &wide)
}

fn load_bricked_with(p: &Path, opts: &vkengine::volume::data::LoadOptions) -> Result<(), String> {
    let v = vkengine::volume::data::load(p, opts).map_err(|e| e.to_string())?;
    let built = v.bricks_only().ok_or_else(|| format!("{}: not loaded into bricks", p.display()))?;
    built.bricks.validate().map_err(|e| format!("{}: bricks of a loaded volume fail their check: {e}", p.display()))?;
    let values = v.normalized_u16();
    let gradients = vkengine::volume::data::stats::gradient_magnitudes(&values, v.dims);
    let b = vkengine::volume::data::bricks::Bricks::build(&values, &gradients, v.dims)?;
    if b != built.bricks {
        return Err(format!("{}: bricks built while reading differ from the dense volume's", p.display()));
    }
    Ok(())
}

/// Bricks corrupted by the file's bytes (`volume::data::bricks`): its first three bytes give
/// the dims (1 to 40 per axis), each following pair of little-endian words sets a page-table
/// entry (brick index, slot), a trailing partial pair truncates the slot data. Their check must
/// refuse them, or every entry must read inside the slots (indexing panics where the check let
/// a bad entry through). The residency chooser and streamer then take ranges made of the same
/// bytes, in whatever order, with budgets from them.
fn load_corrupt_bricks(p: &Path) -> Result<(), String> {
    use vkengine::volume::data::bricks::residency::{choose, Pyramid, Streamer, View};
    use vkengine::volume::data::bricks::{Bricks, SLOT_TEXELS};
    let bytes = std::fs::read(p).map_err(|e| format!("{}: {e}", p.display()))?;
    let (head, rest) = bytes.split_at(bytes.len().min(3));
    let dims: [u32; 3] = std::array::from_fn(|a| u32::from(head.get(a).copied().unwrap_or(0)) % 40 + 1);
    let n = dims.iter().product::<u32>() as usize;
    let nx = dims[0] as usize;
    let values: Vec<u16> = (0..n).map(|i| if i % nx * 2 < nx { (i * 40503 % 65536) as u16 } else { 0 }).collect();
    let gradients = vkengine::volume::data::stats::gradient_magnitudes(&values, dims);
    let mut b = Bricks::build(&values, &gradients, dims)?;
    let count = b.brick_count();
    let mut words = rest.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]));
    while let (Some(i), Some(s)) = (words.next(), words.next()) {
        b.slot_of.set(b.slot_of.brick(u64::from(i) % count), s)?;
    }
    if let Some(&cut) = rest.last().filter(|_| rest.len() % 8 != 0) {
        b.values.truncate(b.values.len().saturating_sub(usize::from(cut)));
    }
    let checked = b.validate();
    if checked.is_ok() {
        let mut sum = 0u64;
        b.slot_of.for_each_brick(|_, s| {
            let last = s as usize * SLOT_TEXELS + SLOT_TEXELS - 1;
            sum += u64::from(b.values[last]) + u64::from(b.gradients[last]);
        });
        std::hint::black_box(sum);
    }
    let byte = |i: usize| bytes.get(i % bytes.len().max(1)).copied().map_or(0, u16::from) * 257;
    let ranges: Vec<[u16; 2]> = (0..count as usize).map(|i| [byte(2 * i), byte(2 * i + 1)]).collect();
    let pyramid = Pyramid::from_ranges(&ranges, dims)?;
    let eye = glam::Vec3::new(-30.0, 20.0, f32::from(byte(3)) / 600.0 - 50.0);
    let vp = glam::Mat4::perspective_rh(1.0, 1.0, 0.5, 500.0)
        * glam::Mat4::look_at_rh(eye, glam::Vec3::splat(10.0), glam::Vec3::Y);
    let view = View::from_view_projection(vp.to_cols_array_2d(), eye.to_array());
    // At least a few bricks, so the seed loads; the rest of the range mutations reach.
    let budget = (u64::from(byte(5)) + 257) * 64;
    let cut = choose(&pyramid, &view, budget);
    let mut streamer = Streamer::new(&pyramid, budget, (u64::from(byte(6)) + 257) * 4)?;
    for _ in 0..4 {
        streamer.frame(&pyramid, &view, &cut);
    }
    checked.map_err(|e| format!("{}: {e}", p.display()))
}

/// Seeds for [`load_corrupt_bricks`]: a 20 × 9 × 17 volume with two page-table entries set to
/// slots that exist.
fn seed_bricks() -> Vec<SeedFile> {
    let mut bytes = vec![19u8, 8, 16];
    for w in [0u32, 0, 5, 1] {
        bytes.extend_from_slice(&w.to_le_bytes());
    }
    vec![file("b.bin", bytes)]
}

/// OpenVDB's two grids of a fire by name, `density` and `temperature`, and the temperature grid
/// checked as the renderer would take it (same box, finite values).
fn load_vdb_two_grids(p: &Path) -> Result<(), String> {
    use vkengine::volume::render::temperature;
    let opts = |grid: &str| vkengine::volume::data::LoadOptions {
        allow_negative: true,
        grid: Some(grid.into()),
        ..Default::default()
    };
    let d = vkengine::volume::data::load(p, &opts("density")).map_err(|e| e.to_string())?;
    let t = vkengine::volume::data::load(p, &opts("temperature")).map_err(|e| e.to_string())?;
    let what = p.display().to_string();
    temperature::check_same_box(&what, &d, &t).map_err(|e| e.to_string())?;
    temperature::check(&what, d.dims, &t, [1000.0, 3000.0]).map_err(|e| e.to_string())
}

/// OpenVDB kept sparse (every box above `stream_above`), bricked leaf by leaf
/// (`volume::sparse_bricks`) into bricks that pass their own check, with one normalized range
/// per occupancy/majorant cell (`volume::cells`; an unfilled cell would index the transfer
/// function's table out of bounds).
fn load_vdb_sparse_bricked(p: &Path) -> Result<(), String> {
    let opts = vkengine::volume::data::LoadOptions { allow_negative: true, stream_above: 0, ..Default::default() };
    let v = vkengine::volume::data::load(p, &opts).map_err(|e| e.to_string())?;
    let g = v.sparse_only().ok_or_else(|| format!("{}: a VDB above stream_above was densified", p.display()))?;
    let b = vkengine::volume::data::bricks::builder::build(g)?;
    let cells = vkengine::volume::data::bricks::cells::cell_grid(v.dims, b.cell_bricks)
        .iter()
        .map(|&c| c as usize)
        .product::<usize>();
    let bad = b.block_ranges.iter().find(|[lo, hi]| !(0.0 <= *lo && lo <= hi && *hi <= 1.0));
    if b.block_ranges.len() != cells || bad.is_some() {
        return Err(format!("{}: {} cell ranges for {cells} cells, {bad:?}", p.display(), b.block_ranges.len()));
    }
    b.bricks.validate().map_err(|e| format!("{}: bricks of a sparse grid fail their check: {e}", p.display()))
}

fn load_scene(p: &Path) -> Result<(), String> {
    vkengine::scene::load_scene(p).map(|_| ()).map_err(|e| e.to_string())
}

fn load_tf(p: &Path) -> Result<(), String> {
    vkengine::volume::optics::tf::TransferFunction::load(p).map(|_| ()).map_err(|e| e.to_string())
}

fn load_env(p: &Path) -> Result<(), String> {
    vkengine::volume::optics::envmap::EnvMap::load(p).map(|_| ()).map_err(|e| e.to_string())
}

fn load_session(p: &Path) -> Result<(), String> {
    // Load and apply: applying checks every setting against the schema and resolves paths.
    let args = crate::cli::DemoArgs {
        scene: Some(p.to_path_buf()),
        ..<crate::cli::DemoArgs as clap::Parser>::parse_from(["volume"])
    };
    crate::volume_session::VolumeSession::apply(&args).map(|_| ()).map_err(|e| e.to_string())
}

/// A label map, then its segments' table (Slicer's colours where the file gives them).
fn load_labels(p: &Path) -> Result<(), String> {
    let l = vkengine::volume::data::labels::load_labels(p, &vkengine::volume::data::LoadOptions::default())
        .map_err(|e| e.to_string())?;
    let _ = vkengine::volume::optics::label_table::LabelTable::for_volume(&l);
    Ok(())
}

/// A label colour table (JSON) checked against the label map beside it (`l.nrrd`), as
/// `--labels` with `label_colors=` does.
fn load_label_colors(p: &Path) -> Result<(), String> {
    use vkengine::volume::optics::label_table::LabelTable;
    let map = p.with_file_name("l.nrrd");
    let l = vkengine::volume::data::labels::load_labels(&map, &vkengine::volume::data::LoadOptions::default())
        .map_err(|e| e.to_string())?;
    LabelTable::with_colors(&l, Some(p)).map(|_| ()).map_err(|e| e.to_string())
}

/// 6×5×4 labels 0..=3 as bytes.
fn label_bytes() -> Vec<u8> {
    (0..6 * 5 * 4u32).map(|i| (i % 6 / 2 + i / 30 % 2) as u8).collect()
}

fn label_nrrd(extra: &str) -> Vec<u8> {
    let mut bytes = format!(
        "NRRD0004\ntype: unsigned char\ndimension: 3\nsizes: 6 5 4\nencoding: raw\n\
         space: left-posterior-superior\nspace directions: (1,0,0) (0,1,0) (0,0,1.5)\nspace origin: (0,0,0)\n{extra}\n"
    )
    .into_bytes();
    bytes.extend(label_bytes());
    bytes
}

fn seed_labels_nrrd() -> Vec<SeedFile> {
    vec![file("l.nrrd", label_nrrd(""))]
}

/// As Slicer writes a single-layer segmentation (`SegmentN_*` keys).
fn seed_labels_seg() -> Vec<SeedFile> {
    let keys = "Segment0_Color:=0.5 0.25 1\nSegment0_ID:=Segment_1\nSegment0_LabelValue:=1\nSegment0_Layer:=0\n\
                Segment0_Name:=liver\nSegment1_Color:=1 0 0\nSegment1_ID:=Segment_2\nSegment1_LabelValue:=3\n\
                Segment1_Layer:=0\nSegment1_Name:=tumour\nSegmentation_MasterRepresentation:=Binary labelmap\n";
    vec![file("l.seg.nrrd", label_nrrd(keys))]
}

/// A NIfTI-1 label map (uint8, no orientation): the 348-byte header, 4 extension bytes, voxels.
fn seed_labels_nifti() -> Vec<SeedFile> {
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    for (i, d) in [3i16, 6, 5, 4, 1, 1, 1, 1].iter().enumerate() {
        h[40 + 2 * i..42 + 2 * i].copy_from_slice(&d.to_le_bytes());
    }
    h[70..72].copy_from_slice(&2i16.to_le_bytes()); // datatype: unsigned char
    h[72..74].copy_from_slice(&8i16.to_le_bytes()); // bitpix
    for (i, p) in [1f32, 1.0, 1.0, 1.5].iter().enumerate() {
        h[76 + 4 * i..80 + 4 * i].copy_from_slice(&p.to_le_bytes());
    }
    h[108..112].copy_from_slice(&352f32.to_le_bytes()); // vox_offset
    h[112..116].copy_from_slice(&1f32.to_le_bytes()); // scl_slope
    h[344..348].copy_from_slice(b"n+1\0");
    h.extend(label_bytes());
    vec![file("l.nii", h)]
}

fn seed_label_colors() -> Vec<SeedFile> {
    let json = r#"{"labels": {"1": {"color": [0.9, 0.3, 0.2], "name": "liver"}, "2": {"opacity": 0.3}, "3": {"visible": false}}}"#;
    vec![file("c.json", json), file("l.nrrd", label_nrrd(""))]
}

fn file(name: &str, bytes: impl Into<Vec<u8>>) -> SeedFile {
    (name.to_string(), bytes.into())
}

/// A 6×5×4 ramp as little-endian u16.
fn ramp_u16() -> Vec<u8> {
    (0..6 * 5 * 4u16).flat_map(|i| (i * 500).to_le_bytes()).collect()
}

fn deflate(bytes: &[u8], gzip: bool) -> Vec<u8> {
    use std::io::Write;
    let mut out = Vec::new();
    if gzip {
        let mut e = flate2::write::GzEncoder::new(&mut out, flate2::Compression::default());
        // Writing into a Vec cannot fail.
        let _ = e.write_all(bytes);
        let _ = e.finish();
    } else {
        let mut e = flate2::write::ZlibEncoder::new(&mut out, flate2::Compression::default());
        let _ = e.write_all(bytes);
        let _ = e.finish();
    }
    out
}

fn seed_raw() -> Vec<SeedFile> {
    vec![
        file("v.raw", ramp_u16()),
        file("v.raw.json", r#"{"dims":[6,5,4],"type":"u16","endian":"little","spacing":[1,1,1.5]}"#),
    ]
}

fn mhd_header(extra: &str, data: &str) -> String {
    format!(
        "ObjectType = Image\nNDims = 3\nDimSize = 6 5 4\nElementType = MET_USHORT\nElementSpacing = 0.5 0.5 2\n\
         Offset = 0 0 0\nTransformMatrix = 1 0 0 0 1 0 0 0 1\nBinaryDataByteOrderMSB = False\n{extra}ElementDataFile = {data}\n"
    )
}

fn seed_mha() -> Vec<SeedFile> {
    let mut bytes = mhd_header("", "LOCAL").into_bytes();
    bytes.extend(ramp_u16());
    vec![file("v.mha", bytes)]
}

fn seed_mhd_zlib() -> Vec<SeedFile> {
    let z = deflate(&ramp_u16(), false);
    let header = mhd_header(&format!("CompressedData = True\nCompressedDataSize = {}\n", z.len()), "v.zraw");
    vec![file("v.mhd", header), file("v.zraw", z)]
}

fn nrrd_header(encoding: &str) -> String {
    format!(
        "NRRD0004\n# Complete NRRD file format specification at:\n# http://teem.sourceforge.net/nrrd/format.html\n\
         type: unsigned short\ndimension: 3\nsizes: 6 5 4\nendian: little\nencoding: {encoding}\n\
         space directions: (1,0,0) (0,1,0) (0,0,1.5)\n\n"
    )
}

fn seed_nrrd() -> Vec<SeedFile> {
    let mut bytes = nrrd_header("raw").into_bytes();
    bytes.extend(ramp_u16());
    vec![file("v.nrrd", bytes)]
}

fn seed_nrrd_gzip() -> Vec<SeedFile> {
    let mut bytes = nrrd_header("gzip").into_bytes();
    bytes.extend(deflate(&ramp_u16(), true));
    vec![file("v.nrrd", bytes)]
}

macro_rules! fixture {
    ($name:literal) => {
        include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/formats/", $name)).as_slice()
    };
}

fn seed_nifti() -> Vec<SeedFile> {
    vec![file("v.nii", fixture!("ramp_ras_qform.nii"))]
}

fn seed_nifti_gz() -> Vec<SeedFile> {
    vec![file("v.nii.gz", fixture!("ramp_4d.nii.gz"))]
}

fn seed_dicom() -> Vec<SeedFile> {
    vec![file("v.dcm", fixture!("ct_multiframe.dcm"))]
}

fn seed_rtdose() -> Vec<SeedFile> {
    vec![file("v.dcm", fixture!("rtdose.dcm"))]
}

fn seed_nifti_ras() -> Vec<SeedFile> {
    vec![file("v.nii.gz", fixture!("ramp_ras.nii.gz"))]
}

fn seed_dicom_series() -> Vec<SeedFile> {
    vec![
        file("a.dcm", fixture!("ct_rle/a.dcm")),
        file("b.dcm", fixture!("ct_rle/b.dcm")),
        file("c.dcm", fixture!("ct_rle/c.dcm")),
        file("d.dcm", fixture!("ct_rle/d.dcm")),
    ]
}

fn seed_vdb() -> Vec<SeedFile> {
    vec![file("v.vdb", fixture!("smoke.vdb"))]
}

fn seed_vdb_fire() -> Vec<SeedFile> {
    vec![file("v.vdb", fixture!("fireball.vdb"))]
}

fn seed_vdb_sparse() -> Vec<SeedFile> {
    vec![file("v.vdb", fixture!("sparse.vdb"))]
}

/// A 2×2 RGBA PNG texture.
fn png() -> Vec<u8> {
    let img = image::RgbaImage::from_fn(2, 2, |x, y| image::Rgba([x as u8 * 255, y as u8 * 255, 128, 255]));
    let mut out = std::io::Cursor::new(Vec::new());
    // Encoding a 2×2 image into memory cannot fail.
    let _ = image::DynamicImage::ImageRgba8(img).write_to(&mut out, image::ImageFormat::Png);
    out.into_inner()
}

/// A textured quad's vertex buffer (positions, normals, uvs) and u16 indices.
fn quad_buffer() -> (Vec<u8>, [usize; 4]) {
    let mut b = Vec::new();
    let pos = [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]];
    pos.iter().flatten().for_each(|v| b.extend(v.to_le_bytes()));
    (0..4).for_each(|_| [0f32, 0., 1.].iter().for_each(|v| b.extend(v.to_le_bytes())));
    [[0f32, 0.], [1., 0.], [1., 1.], [0., 1.]].iter().flatten().for_each(|v| b.extend(v.to_le_bytes()));
    [0u16, 1, 2, 0, 2, 3].iter().for_each(|v| b.extend(v.to_le_bytes()));
    (b, [0, 48, 96, 128])
}

fn gltf_json(buffer_uri: Option<&str>, len: usize) -> String {
    let [_, n, uv, idx] = quad_buffer().1;
    let uri = buffer_uri.map(|u| format!(r#", "uri": "{u}""#)).unwrap_or_default();
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"name": "root", "translation": [1, 0, 0], "rotation": [0, 0, 0, 1], "scale": [2, 2, 2], "children": [1]}}, {{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 3, "mode": 4, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.5, 0.2, 1], "baseColorTexture": {{"index": 0}}, "metallicFactor": 0.1, "roughnessFactor": 0.6}}}}],
  "textures": [{{"source": 0}}], "images": [{{"uri": "tex.png"}}],
  "buffers": [{{"byteLength": {len}{uri}}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": {n}}}, {{"buffer": 0, "byteOffset": {n}, "byteLength": {nl}}},
                  {{"buffer": 0, "byteOffset": {uv}, "byteLength": {uvl}}}, {{"buffer": 0, "byteOffset": {idx}, "byteLength": 12}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
                {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}},
                {{"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"}},
                {{"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}}]}}"#,
        nl = uv - n,
        uvl = idx - uv,
    )
}

fn seed_gltf() -> Vec<SeedFile> {
    let (buf, _) = quad_buffer();
    vec![file("m.gltf", gltf_json(Some("m.bin"), buf.len())), file("m.bin", buf), file("tex.png", png())]
}

fn seed_glb() -> Vec<SeedFile> {
    let (mut bin, _) = quad_buffer();
    let mut json = gltf_json(None, bin.len()).into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    vec![file("m.glb", out), file("tex.png", png())]
}

fn seed_obj() -> Vec<SeedFile> {
    let obj = "# quad\nmtllib m.mtl\no quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
               vn 0 0 1\nusemtl red\nf 1/1/1 2/2/1 3/3/1 4/4/1\ng second\nf -4 -3 -2\n";
    let mtl = "newmtl red\nKd 0.8 0.1 0.05\nKs 0.2 0.2 0.2\nNs 32\nd 1\nmap_Kd -bm 1.0 tex.png\n";
    vec![file("m.obj", obj), file("m.mtl", mtl), file("tex.png", png())]
}

fn seed_scene_toml() -> Vec<SeedFile> {
    let toml = r#"model = "m.obj"
[camera]
position = [0.0, 1.5, 4.0]
target = [0.0, 1.0, 0.0]
fov = 45.0
[[camera_path]]
time = 0.0
position = [0.0, 1.5, 4.0]
target = [0.0, 1.0, 0.0]
[[camera_path]]
time = 2.0
position = [1.0, 1.5, 4.0]
target = [0.0, 1.0, 0.0]
[[lights]]
type = "directional"
direction = [-0.3, -1.0, -0.2]
intensity = 3.0
[[lights]]
type = "spot"
position = [0.0, 3.0, 0.0]
direction = [0.0, -1.0, 0.0]
intensity = 10.0
inner_angle_deg = 30.0
outer_angle_deg = 45.0
[settings]
cascades = 3
lpv = true
"#;
    let mut files = seed_obj();
    files.insert(0, file("s.toml", toml));
    files
}

fn seed_session() -> Vec<SeedFile> {
    let text = r#"# vkengine volume session
renderer = "mcs"
volume = "v.raw"
dims = [6, 5, 4]
type = "u16"
spacing = [1.0, 1.0, 1.5]
[settings]
density = 2.5
g = 0.3
exposure = 1
"#;
    vec![file("s.toml", text), file("v.raw", ramp_u16())]
}

fn seed_tf() -> Vec<SeedFile> {
    let tf = vkengine::volume::optics::tf::TransferFunction::ramp(0.1, 0.7, [0.9, 0.6, 0.3], 5.0);
    let mut text = serde_json::to_string_pretty(&tf).unwrap_or_default();
    if text.is_empty() {
        text = "{}".into();
    }
    vec![file("tf.json", text)]
}

fn seed_hdr() -> Vec<SeedFile> {
    let img = image::Rgb32FImage::from_fn(8, 4, |x, y| image::Rgb([x as f32 * 0.5, y as f32, 2.0]));
    let mut out = std::io::Cursor::new(Vec::new());
    // Encoding into memory cannot fail.
    let _ = image::DynamicImage::ImageRgb32F(img).write_to(&mut out, image::ImageFormat::Hdr);
    vec![file("env.hdr", out.into_inner())]
}

fn seed_exr() -> Vec<SeedFile> {
    let img = image::Rgb32FImage::from_fn(8, 4, |x, y| image::Rgb([x as f32 * 0.5, y as f32, 2.0]));
    let mut out = std::io::Cursor::new(Vec::new());
    let _ = image::DynamicImage::ImageRgb32F(img).write_to(&mut out, image::ImageFormat::OpenExr);
    vec![file("env.exr", out.into_inner())]
}

/// What an environment map's header may make the loader allocate: the decoded size the loader
/// accepts, plus the decoder's scratch.
const ENV_CAP: usize = vkengine::volume::optics::envmap::MAX_ALLOC as usize + (64 << 20);

/// Every loader the engine and demos read user files with.
pub const FORMATS: &[Format] = &[
    Format { name: "raw+json", seed: seed_raw, entry: "v.raw", load: load_volume, claim_cap: 0 },
    Format { name: "metaimage", seed: seed_mha, entry: "v.mha", load: load_volume, claim_cap: 0 },
    Format { name: "metaimage-zlib", seed: seed_mhd_zlib, entry: "v.mhd", load: load_volume, claim_cap: 0 },
    Format { name: "nrrd", seed: seed_nrrd, entry: "v.nrrd", load: load_volume, claim_cap: 0 },
    Format { name: "nrrd-gzip", seed: seed_nrrd_gzip, entry: "v.nrrd", load: load_volume, claim_cap: 0 },
    Format { name: "nifti", seed: seed_nifti, entry: "v.nii", load: load_volume, claim_cap: 0 },
    Format { name: "nifti-gz", seed: seed_nifti_gz, entry: "v.nii.gz", load: load_volume, claim_cap: 0 },
    Format { name: "dicom", seed: seed_dicom, entry: "v.dcm", load: load_volume, claim_cap: 0 },
    Format { name: "dicom-series", seed: seed_dicom_series, entry: ".", load: load_volume, claim_cap: 0 },
    Format { name: "dicom-rtdose", seed: seed_rtdose, entry: "v.dcm", load: load_volume, claim_cap: 0 },
    Format { name: "raw-streamed", seed: seed_raw, entry: "v.raw", load: load_volume_streamed, claim_cap: 0 },
    Format { name: "raw-bricked", seed: seed_raw, entry: "v.raw", load: load_volume_bricked, claim_cap: 0 },
    Format { name: "nrrd-bricked", seed: seed_nrrd, entry: "v.nrrd", load: load_volume_bricked, claim_cap: 0 },
    Format { name: "mhd-zlib-bricked", seed: seed_mhd_zlib, entry: "v.mhd", load: load_volume_bricked, claim_cap: 0 },
    Format { name: "nifti-bricked", seed: seed_nifti_ras, entry: "v.nii.gz", load: load_volume_bricked, claim_cap: 0 },
    Format {
        name: "dicom-series-bricked",
        seed: seed_dicom_series,
        entry: ".",
        load: load_volume_bricked,
        claim_cap: 0,
    },
    Format { name: "dicom-rtdose-bricked", seed: seed_rtdose, entry: "v.dcm", load: load_volume_bricked, claim_cap: 0 },
    Format { name: "raw-bricked-small", seed: seed_raw, entry: "v.raw", load: load_volume_bricked_small, claim_cap: 0 },
    Format { name: "bricks-corrupt", seed: seed_bricks, entry: "b.bin", load: load_corrupt_bricks, claim_cap: 0 },
    Format {
        name: "nifti-bricked-small",
        seed: seed_nifti_ras,
        entry: "v.nii.gz",
        load: load_volume_bricked_small,
        claim_cap: 0,
    },
    Format { name: "raw-bricked-wide", seed: seed_raw, entry: "v.raw", load: load_volume_bricked_wide, claim_cap: 0 },
    Format {
        name: "nrrd-bricked-wide",
        seed: seed_nrrd,
        entry: "v.nrrd",
        load: load_volume_bricked_wide,
        claim_cap: 0,
    },
    Format {
        name: "mhd-zlib-bricked-wide",
        seed: seed_mhd_zlib,
        entry: "v.mhd",
        load: load_volume_bricked_wide,
        claim_cap: 0,
    },
    Format { name: "mhd-zlib-streamed", seed: seed_mhd_zlib, entry: "v.mhd", load: load_volume_streamed, claim_cap: 0 },
    Format {
        name: "nrrd-gz-streamed",
        seed: seed_nrrd_gzip,
        entry: "v.nrrd",
        load: load_volume_streamed,
        claim_cap: 0,
    },
    Format {
        name: "nifti-streamed",
        seed: seed_nifti_ras,
        entry: "v.nii.gz",
        load: load_volume_streamed,
        claim_cap: 0,
    },
    Format { name: "vdb", seed: seed_vdb, entry: "v.vdb", load: load_volume, claim_cap: 0 },
    Format { name: "vdb-sparse", seed: seed_vdb_sparse, entry: "v.vdb", load: load_volume, claim_cap: 0 },
    Format { name: "vdb-two-grids", seed: seed_vdb_fire, entry: "v.vdb", load: load_vdb_two_grids, claim_cap: 0 },
    Format { name: "vdb-bricked", seed: seed_vdb, entry: "v.vdb", load: load_vdb_sparse_bricked, claim_cap: 0 },
    Format {
        name: "vdb-sparse-bricked",
        seed: seed_vdb_sparse,
        entry: "v.vdb",
        load: load_vdb_sparse_bricked,
        claim_cap: 0,
    },
    Format { name: "labels-nrrd", seed: seed_labels_nrrd, entry: "l.nrrd", load: load_labels, claim_cap: 0 },
    Format { name: "labels-seg-nrrd", seed: seed_labels_seg, entry: "l.seg.nrrd", load: load_labels, claim_cap: 0 },
    Format { name: "labels-nifti", seed: seed_labels_nifti, entry: "l.nii", load: load_labels, claim_cap: 0 },
    Format {
        name: "label-colors-json",
        seed: seed_label_colors,
        entry: "c.json",
        load: load_label_colors,
        claim_cap: 0,
    },
    Format { name: "gltf", seed: seed_gltf, entry: "m.gltf", load: load_scene, claim_cap: 0 },
    Format { name: "glb", seed: seed_glb, entry: "m.glb", load: load_scene, claim_cap: 0 },
    Format { name: "obj+mtl", seed: seed_obj, entry: "m.obj", load: load_scene, claim_cap: 0 },
    Format { name: "scene-toml", seed: seed_scene_toml, entry: "s.toml", load: load_scene, claim_cap: 0 },
    Format { name: "session", seed: seed_session, entry: "s.toml", load: load_session, claim_cap: 0 },
    Format { name: "tf-json", seed: seed_tf, entry: "tf.json", load: load_tf, claim_cap: 0 },
    Format { name: "envmap-hdr", seed: seed_hdr, entry: "env.hdr", load: load_env, claim_cap: ENV_CAP },
    Format { name: "envmap-exr", seed: seed_exr, entry: "env.exr", load: load_env, claim_cap: ENV_CAP },
];

// ---------------------------------------------------------------------------------------------
// Running

/// What went wrong in one case.
#[derive(Clone, Debug)]
pub enum Problem {
    /// The loader panicked (message).
    Panic(String),
    /// It ran past the time limit (the case's files are left in its folder).
    Hang,
    /// It allocated `bytes` (peak beyond the start, or one request) over `limit`.
    Alloc {
        /// Bytes allocated or requested.
        bytes: usize,
        /// The case's limit.
        limit: usize,
    },
}

/// One failing case, reproducible from its folder.
#[derive(Clone, Debug)]
pub struct Finding {
    /// Case index (0 is the unmutated seed).
    pub case: u64,
    /// What happened.
    pub problem: Problem,
    /// Where the case's files were saved.
    pub saved: PathBuf,
}

/// The outcome of fuzzing one format.
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// Cases run (the unmutated seed included).
    pub cases: u64,
    /// Cases the loader accepted.
    pub accepted: u64,
    /// Cases the loader rejected with an error.
    pub rejected: u64,
    /// Failing cases.
    pub findings: Vec<Finding>,
    /// The seed itself failed to load (the message): the harness, not the loader, is wrong.
    pub seed_error: Option<String>,
    /// Largest allocation peak of any case, bytes.
    pub max_peak: usize,
}

fn write_case(dir: &Path, files: &[SeedFile]) -> std::io::Result<usize> {
    if dir.exists() {
        std::fs::remove_dir_all(dir)?;
    }
    std::fs::create_dir_all(dir)?;
    let mut total = 0;
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes)?;
        total += bytes.len();
    }
    Ok(total)
}

/// Where the last caught panic happened (the hook sees the location, catch_unwind does not).
static PANIC_AT: Mutex<Option<String>> = Mutex::new(None);

/// Runs one load on a worker thread; `None` when it did not finish within `limit`.
fn run_one(
    load: fn(&Path) -> Result<(), String>,
    path: PathBuf,
    limit: Duration,
) -> Option<Result<Result<(), String>, String>> {
    let (tx, rx) = mpsc::channel();
    let spawned = std::thread::Builder::new().name("fuzz-case".into()).spawn(move || {
        let r = std::panic::catch_unwind(move || load(&path)).map_err(|p| {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "non-string panic".into());
            let at = PANIC_AT.lock().unwrap_or_else(|e| e.into_inner()).take().unwrap_or_default();
            format!("{msg} at {at}")
        });
        // The receiver is gone only after a hang was reported; nothing to tell then.
        let _ = tx.send(r);
    });
    if let Err(e) = spawned {
        return Some(Err(format!("could not start the case thread: {e}")));
    }
    rx.recv_timeout(limit).ok()
}

/// Fuzzes `format` with `cases` cases (case 0 is the unmutated seed) from `seed`, each under
/// `time_limit`, in `work/<format>/`. Stops at the first hang (its thread cannot be stopped).
pub fn fuzz(format: &Format, cases: u64, seed: u64, time_limit: Duration, work: &Path) -> std::io::Result<Report> {
    // One run at a time per process: the allocation counters and the panic hook are global.
    static RUN: Mutex<()> = Mutex::new(());
    let _one = RUN.lock().unwrap_or_else(|e| e.into_inner());
    let base = (format.seed)();
    let donor: Vec<u8> = base.iter().flat_map(|(_, b)| b.iter().copied()).collect();
    let dir = work.join(format.name.replace('+', "_"));
    let mut rng = Rng::new(seed ^ fnv(format.name));
    let mut report = Report::default();
    // Silence the default hook's message per caught panic; findings carry message and place.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|info| {
        let at = info.location().map(|l| format!("{}:{}", l.file(), l.line())).unwrap_or_default();
        *PANIC_AT.lock().unwrap_or_else(|e| e.into_inner()) = Some(at);
    }));
    for case in 0..cases {
        let mut files = base.clone();
        if case > 0 {
            // The entry file is mutated most, the files it refers to the rest of the time.
            let i = if files.len() == 1 || rng.below(10) < 7 { 0 } else { 1 + rng.below(files.len() - 1) };
            mutate(&mut rng, &mut files[i].1, &donor);
        }
        let bytes = write_case(&dir, &files)?;
        let limit = alloc_limit(bytes).max(format.claim_cap);
        let start = CURRENT.load(Ordering::Relaxed);
        PEAK.store(start, Ordering::Relaxed);
        LARGEST.store(0, Ordering::Relaxed);
        let outcome = run_one(format.load, dir.join(format.entry), time_limit);
        let peak = PEAK.load(Ordering::Relaxed).saturating_sub(start).max(LARGEST.load(Ordering::Relaxed));
        report.max_peak = report.max_peak.max(peak);
        report.cases += 1;
        let mut problem = None;
        match outcome {
            None => problem = Some(Problem::Hang),
            Some(Err(msg)) => problem = Some(Problem::Panic(msg)),
            Some(Ok(Ok(()))) => report.accepted += 1,
            Some(Ok(Err(msg))) => {
                report.rejected += 1;
                if case == 0 {
                    report.seed_error = Some(msg);
                }
            }
        }
        if problem.is_none() && peak > limit {
            problem = Some(Problem::Alloc { bytes: peak, limit });
        }
        if let Some(problem) = problem {
            let saved = work.join(format!("{}-case{case}", format.name.replace('+', "_")));
            write_case(&saved, &files)?;
            let hang = matches!(problem, Problem::Hang);
            report.findings.push(Finding { case, problem, saved });
            if hang {
                break;
            }
        }
    }
    std::panic::set_hook(hook);
    let _ = std::fs::remove_dir_all(&dir);
    Ok(report)
}

/// FNV-1a of a name, so each format draws its own stream from one seed.
fn fnv(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3))
}
