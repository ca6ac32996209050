//! OpenVDB float grids (`.vdb`, file format 222–224: OpenVDB 3 and later), read by hand: `vdb-rs`
//! ignores background values and root tiles, panics on unexpected input and sizes buffers from the
//! file before checking them.
//!
//! The grid's active voxels and active tiles are written into a dense box spanning their bounds; every
//! other voxel takes the grid's background value. The voxel size of the transform becomes the spacing.

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;
use std::sync::Arc;

use super::sparse::RawSparse;
use super::{
    blosc, check_dims, check_fits, finish_values, value_buffer, LoadOptions, Progress, Quantity, ValueUnit, Volume,
    VolumeError,
};

const MAGIC: [u8; 8] = [0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0];
/// First format with per-grid compression and node-mask compression (OpenVDB 3).
const MIN_VERSION: u32 = 222;
const MAX_VERSION: u32 = 224;
const COMPRESS_ZIP: u32 = 0x1;
const COMPRESS_ACTIVE_MASK: u32 = 0x2;
const COMPRESS_BLOSC: u32 = 0x4;
/// Most bricks a sparse grid's bounding box may span: bricking visits each (2²⁸ take about 20 s).
const MAX_BRICKS: u64 = 1 << 28;
/// Longest name or metadata value read into memory; longer ones are skipped or refused.
const MAX_STRING: u64 = 1 << 20;

fn invalid(file: &str, message: impl Into<String>) -> VolumeError {
    VolumeError::Invalid { file: file.to_owned(), message: message.into() }
}

/// A file read front to back with its position tracked, so that every length can be checked
/// against what is left before anything is allocated.
struct Src {
    r: BufReader<File>,
    pos: u64,
    len: u64,
    file: String,
}

impl Src {
    fn err(&self, message: impl Into<String>) -> VolumeError {
        invalid(&self.file, message)
    }

    fn truncated(&self, want: u64) -> VolumeError {
        self.err(format!(
            "file is truncated: {want} more bytes needed at offset {}, {} left",
            self.pos,
            self.len - self.pos
        ))
    }

    fn fill(&mut self, buf: &mut [u8]) -> Result<(), VolumeError> {
        if buf.len() as u64 > self.len - self.pos {
            return Err(self.truncated(buf.len() as u64));
        }
        self.r.read_exact(buf).map_err(|source| VolumeError::Io { file: self.file.clone(), source })?;
        self.pos += buf.len() as u64;
        Ok(())
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], VolumeError> {
        let mut a = [0u8; N];
        self.fill(&mut a)?;
        Ok(a)
    }

    fn u8(&mut self) -> Result<u8, VolumeError> {
        Ok(self.array::<1>()?[0])
    }
    fn u32(&mut self) -> Result<u32, VolumeError> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    fn i32(&mut self) -> Result<i32, VolumeError> {
        Ok(i32::from_le_bytes(self.array()?))
    }
    fn i64(&mut self) -> Result<i64, VolumeError> {
        Ok(i64::from_le_bytes(self.array()?))
    }
    fn f32(&mut self) -> Result<f32, VolumeError> {
        Ok(f32::from_le_bytes(self.array()?))
    }
    fn f64(&mut self) -> Result<f64, VolumeError> {
        Ok(f64::from_le_bytes(self.array()?))
    }
    fn vec3d(&mut self) -> Result<[f64; 3], VolumeError> {
        Ok([self.f64()?, self.f64()?, self.f64()?])
    }
    fn coord(&mut self) -> Result<[i32; 3], VolumeError> {
        Ok([self.i32()?, self.i32()?, self.i32()?])
    }

    /// `n` bytes, after checking that the file holds them.
    fn bytes(&mut self, n: u64) -> Result<Vec<u8>, VolumeError> {
        if n > self.len - self.pos {
            return Err(self.truncated(n));
        }
        let mut v = vec![0u8; n as usize];
        self.fill(&mut v)?;
        Ok(v)
    }

    fn string(&mut self) -> Result<String, VolumeError> {
        let n = u64::from(self.u32()?);
        if n > MAX_STRING {
            return Err(
                self.err(format!("a name of {n} bytes at offset {}: not an OpenVDB file, or corrupt", self.pos))
            );
        }
        Ok(String::from_utf8_lossy(&self.bytes(n)?).into_owned())
    }

    fn seek(&mut self, to: u64) -> Result<(), VolumeError> {
        if to > self.len {
            return Err(self.err(format!("offset {to} lies past the end of the {}-byte file", self.len)));
        }
        self.r.seek(SeekFrom::Start(to)).map_err(|source| VolumeError::Io { file: self.file.clone(), source })?;
        self.pos = to;
        Ok(())
    }

    fn skip(&mut self, n: u64) -> Result<(), VolumeError> {
        if n > self.len - self.pos {
            return Err(self.truncated(n));
        }
        self.seek(self.pos + n)
    }

    fn mask(&mut self, bits: usize) -> Result<Vec<u64>, VolumeError> {
        (0..bits / 64).map(|_| Ok(u64::from_le_bytes(self.array()?))).collect()
    }
}

fn bit(mask: &[u64], i: usize) -> bool {
    mask[i / 64] >> (i % 64) & 1 == 1
}

/// Reads a metadata block; returns the value of the boolean `is_saved_as_half_float` if present.
fn metadata(s: &mut Src) -> Result<Option<bool>, VolumeError> {
    let count = s.u32()?;
    let mut half = None;
    for _ in 0..count {
        let name = s.string()?;
        let ty = s.string()?;
        let len = u64::from(s.u32()?);
        if name == "is_saved_as_half_float" && ty == "bool" && len == 1 {
            half = Some(s.u8()? != 0);
        } else {
            s.skip(len)?;
        }
    }
    Ok(half)
}

struct Descriptor {
    name: String,
    grid_type: String,
    instance_parent: String,
    grid_pos: u64,
    block_pos: u64,
    /// Where the grid's data ends (as the file says: checked against the file's length only).
    end_pos: u64,
}

/// Per-grid settings the node readers need.
struct Codec {
    compression: u32,
    half: bool,
    background: f32,
}

/// An IEEE half float's value (exact: every half is an f32).
pub(crate) fn half_to_f32(h: u16) -> f32 {
    let sign = u32::from(h >> 15) << 31;
    let exp = u32::from((h >> 10) & 0x1f);
    let man = u32::from(h & 0x3ff);
    let bits = match (exp, man) {
        (0, 0) => sign,
        (0, m) => {
            // Subnormal: value m × 2^-24.
            return if sign != 0 { -(m as f32) } else { m as f32 } * (2.0f32).powi(-24);
        }
        (31, 0) => sign | 0x7f80_0000,
        (31, m) => sign | 0x7f80_0000 | (m << 13),
        (e, m) => sign | ((e + 112) << 23) | (m << 13),
    };
    f32::from_bits(bits)
}

/// Reads `count` element values as stored (BLOSC, ZIP or raw; 16- or 32-bit floats).
fn read_data(s: &mut Src, c: &Codec, count: usize) -> Result<Vec<f32>, VolumeError> {
    let elem = if c.half { 2 } else { 4 };
    let nbytes = count * elem;
    let raw = if c.compression & (COMPRESS_BLOSC | COMPRESS_ZIP) != 0 {
        let n = s.i64()?;
        if n <= 0 {
            // A non-positive size marks data stored uncompressed, |n| bytes long.
            if n.unsigned_abs() != nbytes as u64 {
                return Err(s.err(format!("node data of {} bytes where {nbytes} were expected", n.unsigned_abs())));
            }
            s.bytes(nbytes as u64)?
        } else {
            let at = s.pos;
            let packed = s.bytes(n as u64)?;
            let out = if c.compression & COMPRESS_BLOSC != 0 {
                blosc::decompress(&packed, nbytes)
            } else {
                let mut out = Vec::with_capacity(nbytes);
                flate2::read::ZlibDecoder::new(packed.as_slice())
                    .take(nbytes as u64)
                    .read_to_end(&mut out)
                    .map_err(|e| format!("zlib: {e}"))
                    .and_then(|_| {
                        if out.len() == nbytes {
                            Ok(out)
                        } else {
                            Err(format!("zlib data gave {} bytes, expected {nbytes}", out.len()))
                        }
                    })
            };
            out.map_err(|e| s.err(format!("cannot decompress node data at offset {at}: {e}")))?
        }
    } else {
        s.bytes(nbytes as u64)?
    };
    Ok(if c.half {
        raw.chunks_exact(2).map(|b| half_to_f32(u16::from_le_bytes([b[0], b[1]]))).collect()
    } else {
        raw.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect()
    })
}

/// OpenVDB's `readCompressedValues`: the node's `count` values, with the inactive ones restored from
/// the per-node metadata (only active values are stored when the active-mask compression is on).
fn read_values(s: &mut Src, c: &Codec, count: usize, value_mask: &[u64]) -> Result<Vec<f32>, VolumeError> {
    let meta = s.u8()?;
    if meta > 6 {
        return Err(s.err(format!("node metadata {meta} at offset {} is not 0 to 6: corrupt file", s.pos - 1)));
    }
    let bg = c.background;
    let mut inactive0 = if meta == 0 { bg } else { -bg };
    let mut inactive1 = bg;
    if matches!(meta, 2 | 4 | 5) {
        inactive0 = s.f32()?;
        if meta == 5 {
            inactive1 = s.f32()?;
        }
    }
    let selection = if matches!(meta, 3..=5) { s.mask(count)? } else { vec![0; count / 64] };
    let active_only = c.compression & COMPRESS_ACTIVE_MASK != 0 && meta != 6;
    let stored = if active_only { value_mask.iter().map(|w| w.count_ones() as usize).sum() } else { count };
    let data = read_data(s, c, stored)?;
    if stored == count {
        return Ok(data);
    }
    let mut it = data.into_iter();
    Ok((0..count)
        .map(|i| {
            if bit(value_mask, i) {
                it.next().unwrap_or(bg)
            } else if bit(&selection, i) {
                inactive1
            } else {
                inactive0
            }
        })
        .collect())
}

/// Active regions found while reading the topology.
#[derive(Default)]
struct Topology {
    /// Active tiles: origin, edge length in voxels, value.
    tiles: Vec<([i64; 3], i64, f32)>,
    /// Leaf origins and their active-voxel masks, in file order (the order of the leaf buffers).
    leaves: Vec<([i64; 3], Vec<u64>)>,
}

/// Reads an internal node (log2 dim 5 or 4) and its children's topology.
fn internal(s: &mut Src, c: &Codec, origin: [i64; 3], log2: u32, topo: &mut Topology) -> Result<(), VolumeError> {
    let count = 1usize << (3 * log2);
    let child_mask = s.mask(count)?;
    let value_mask = s.mask(count)?;
    let values = read_values(s, c, count, &value_mask)?;
    // Edge of a child (or tile) in voxels: 16 × 8 below a 32³ node, 8 below a 16³ node.
    let child_edge = if log2 == 5 { 128 } else { 8 };
    let dim = 1usize << log2;
    let at = |i: usize| {
        let (x, y, z) = (i >> (2 * log2), (i >> log2) & (dim - 1), i & (dim - 1));
        // i64: origins come from the file and must not overflow.
        [origin[0] + x as i64 * child_edge, origin[1] + y as i64 * child_edge, origin[2] + z as i64 * child_edge]
    };
    for (i, &v) in values.iter().enumerate().take(count) {
        if bit(&value_mask, i) && !bit(&child_mask, i) {
            topo.tiles.push((at(i), child_edge, v));
        }
    }
    for i in (0..count).filter(|&i| bit(&child_mask, i)) {
        if log2 == 5 {
            internal(s, c, at(i), 4, topo)?;
        } else {
            topo.leaves.push((at(i), s.mask(512)?));
        }
    }
    Ok(())
}

/// Coordinate of voxel `i` (z fastest, as OpenVDB numbers them) of the leaf at `origin`.
fn leaf_voxel(origin: &[i64; 3], i: usize) -> [i64; 3] {
    [origin[0] + (i >> 6) as i64, origin[1] + ((i >> 3) & 7) as i64, origin[2] + (i & 7) as i64]
}

/// Voxel size from the grid transform; warns about what a dense box cannot show.
fn transform(s: &mut Src, warnings: &mut Vec<String>) -> Result<[f64; 3], VolumeError> {
    let map = s.string()?;
    let voxel = match map.as_str() {
        "UniformScaleMap" | "ScaleMap" => {
            let _scale = s.vec3d()?;
            let voxel = s.vec3d()?;
            for _ in 0..3 {
                s.vec3d()?;
            }
            voxel
        }
        "UniformScaleTranslateMap" | "ScaleTranslateMap" => {
            let _translation = s.vec3d()?;
            let _scale = s.vec3d()?;
            let voxel = s.vec3d()?;
            for _ in 0..3 {
                s.vec3d()?;
            }
            voxel
        }
        "TranslationMap" => {
            s.vec3d()?;
            [1.0; 3]
        }
        "AffineMap" => {
            let m: Vec<f64> = (0..16).map(|_| s.f64()).collect::<Result<_, _>>()?;
            // Row-vector convention: row i of the upper 3×3 is the world image of index axis i.
            let rows: [[f64; 3]; 3] = std::array::from_fn(|r| [m[4 * r], m[4 * r + 1], m[4 * r + 2]]);
            let voxel = rows.map(|r| r.iter().map(|v| v * v).sum::<f64>().sqrt());
            let rotated = (0..3).any(|r| (0..3).any(|k| k != r && (rows[r][k] / voxel[r]).abs() > 1e-6));
            if rotated {
                warnings.push(format!("{}: the grid transform rotates or shears the grid; shown axis-aligned", s.file));
            }
            voxel
        }
        other => {
            return Err(s.err(format!("grid transform {other} is not supported (scale, translate and affine maps are)")))
        }
    };
    Ok(voxel.map(f64::abs))
}

pub(crate) fn load(path: &Path, opts: &LoadOptions, progress: Progress<'_>) -> Result<Volume, VolumeError> {
    let file = path.display().to_string();
    let io = |source| VolumeError::Io { file: file.clone(), source };
    let f = File::open(path).map_err(io)?;
    let len = f.metadata().map_err(io)?.len();
    let mut s = Src { r: BufReader::new(f), pos: 0, len, file: file.clone() };

    if s.array::<8>().ok() != Some(MAGIC) {
        return Err(invalid(&file, "not an OpenVDB file (no VDB magic number)"));
    }
    let version = s.u32()?;
    if version < MIN_VERSION {
        return Err(invalid(
            &file,
            format!("file format {version} is older than {MIN_VERSION} (OpenVDB 3); re-save it with a current OpenVDB"),
        ));
    }
    let mut warnings = Vec::new();
    if version > MAX_VERSION {
        warnings
            .push(format!("{file}: file format {version} is newer than {MAX_VERSION}; reading it as {MAX_VERSION}"));
    }
    let _library = (s.u32()?, s.u32()?);
    if s.u8()? == 0 {
        return Err(invalid(&file, "written as a stream without grid offsets, which is not supported"));
    }
    s.skip(36)?; // UUID
    metadata(&mut s)?;
    let grid_count = s.u32()?;
    let mut grids = Vec::new();
    for _ in 0..grid_count {
        let unique = s.string()?;
        // Duplicate names are made unique with a record-separator suffix.
        let name = unique.split('\u{1e}').next().unwrap_or_default().to_owned();
        let grid_type = s.string()?;
        let instance_parent = s.string()?;
        let (grid_pos, block_pos, end_pos) = (s.i64()?, s.i64()?, s.i64()?);
        let pos = |v: i64| u64::try_from(v).ok().filter(|&p| p <= len);
        let (Some(grid_pos), Some(block_pos), Some(end_pos)) = (pos(grid_pos), pos(block_pos), pos(end_pos)) else {
            return Err(invalid(&file, format!("grid {name}: offsets lie outside the file (truncated?)")));
        };
        grids.push(Descriptor { name, grid_type, instance_parent, grid_pos, block_pos, end_pos });
        s.seek(end_pos)?;
    }
    let is_float = |d: &Descriptor| d.grid_type.starts_with("Tree_float_5_4_3");
    let list = || grids.iter().map(|d| format!("{} ({})", d.name, d.grid_type)).collect::<Vec<_>>().join(", ");
    let chosen = match &opts.grid {
        Some(name) => grids
            .iter()
            .find(|d| &d.name == name)
            .ok_or_else(|| invalid(&file, format!("no grid named {name}; the file holds: {}", list())))?,
        None => match grids.iter().find(|d| d.name == "density") {
            Some(d) => d,
            None => {
                let mut floats = grids.iter().filter(|d| is_float(d));
                match (floats.next(), floats.next()) {
                    (Some(one), None) => one,
                    _ => {
                        return Err(invalid(
                            &file,
                            format!(
                                "no grid named density; pick one with --grid NAME: {}",
                                if grids.is_empty() { "(no grids)".into() } else { list() }
                            ),
                        ))
                    }
                }
            }
        },
    };
    let name = chosen.name.clone();
    if !is_float(chosen) {
        return Err(invalid(
            &file,
            format!("grid {name} is a {} grid: only float grids (Tree_float_5_4_3) are supported", chosen.grid_type),
        ));
    }
    if !chosen.instance_parent.is_empty() {
        return Err(invalid(
            &file,
            format!("grid {name} is an instance of {}; instanced grids are not supported", chosen.instance_parent),
        ));
    }

    s.seek(chosen.grid_pos)?;
    let compression = s.u32()?;
    if compression & !(COMPRESS_ZIP | COMPRESS_ACTIVE_MASK | COMPRESS_BLOSC) != 0 {
        return Err(invalid(&file, format!("grid {name}: unknown compression flags {compression:#x}")));
    }
    let half = metadata(&mut s)?.unwrap_or(false) || chosen.grid_type.ends_with("_HalfFloat");
    let voxel = transform(&mut s, &mut warnings)?;
    let buffers = s.u32()?;
    if buffers != 1 {
        return Err(invalid(&file, format!("grid {name}: {buffers} buffers per node are not supported")));
    }
    let background = s.f32()?;
    let mut c = Codec { compression, half, background };
    let (tiles, children) = (s.u32()?, s.u32()?);
    let mut topo = Topology::default();
    for _ in 0..tiles {
        let (origin, value, active) = (s.coord()?, s.f32()?, s.u8()?);
        if active != 0 {
            topo.tiles.push((origin.map(i64::from), 4096, value));
        }
    }
    for _ in 0..children {
        let origin = s.coord()?;
        internal(&mut s, &c, origin.map(i64::from), 5, &mut topo)?;
    }

    let mut lo = [i64::MAX; 3];
    let mut hi = [i64::MIN; 3];
    let mut grow = |p: [i64; 3], q: [i64; 3]| {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(q[a]);
        }
    };
    for (o, edge, _) in &topo.tiles {
        grow(*o, o.map(|v| v + edge - 1));
    }
    for (o, mask) in &topo.leaves {
        for i in (0..512).filter(|&i| bit(mask, i)) {
            let p = leaf_voxel(o, i);
            grow(p, p);
        }
    }
    if lo[0] > hi[0] {
        return Err(invalid(&file, format!("grid {name} has no active voxels")));
    }
    let dims = [0, 1, 2].map(|a| (hi[a] - lo[a] + 1) as u64);
    let total = dims.iter().try_fold(1u64, |acc, &d| acc.checked_mul(d));
    // Boxes up to `stream_above` voxels load dense as always; larger ones stay sparse: host
    // memory then grows with the leaves, and the device's page table bounds the box.
    let dense = total.is_some_and(|n| n <= opts.stream_above.min(super::MAX_VOXELS));
    if dense {
        check_dims(&file, dims, opts.max_dimension)?;
        check_fits(&file, dims, opts)?;
    } else {
        let limit = opts.max_dimension.saturating_mul(super::sparse::LEAF as u32);
        if dims.iter().any(|&d| d > u64::from(limit)) {
            return Err(VolumeError::TooLarge { file: file.clone(), dims, limit });
        }
        // Bricking visits every brick of the box (a bit each on the host, and time: 137 M bricks
        // take about 10 s); the page table and the occupancy and majorant grids grow with the
        // pages and cells that hold data (`volume::page_images`, `volume::cells`).
        let bricks = dims.iter().map(|&d| d.div_ceil(8)).product::<u64>();
        if bricks > MAX_BRICKS {
            return Err(invalid(
                &file,
                format!(
                    "grid {name}: its {}x{}x{} box spans {bricks} bricks of 8³ voxels, past the {MAX_BRICKS} this loader bricks",
                    dims[0], dims[1], dims[2]
                ),
            ));
        }
    }

    s.seek(chosen.block_pos)?;
    c.background = background;
    let mut leaves = Vec::new();
    // Progress in bytes of the grid's leaf data, twice: read, then made into the volume (dense
    // or sparse, normalized), that half at its steps. A corrupt end offset only makes the bar
    // wrong, never the load.
    let total = chosen.end_pos.saturating_sub(chosen.block_pos);
    let both = total.saturating_mul(2);
    for (k, (o, topo_mask)) in topo.leaves.into_iter().enumerate() {
        if k % 256 == 0 {
            progress((s.pos - chosen.block_pos).min(total), both);
        }
        let mask = s.mask(512)?;
        if mask != topo_mask {
            return Err(invalid(
                &file,
                format!("grid {name}: a leaf's active mask differs between topology and data (corrupt file)"),
            ));
        }
        let values = read_values(&mut s, &c, 512, &mask)?;
        leaves.push((o, mask, values));
    }
    progress(total, both);
    let raw = RawSparse { lo, dims, background, tiles: topo.tiles, leaves };
    let spacing = voxel.map(|v| v as f32);
    // Simulation tools name the grid of a medium's density `density`; other grids (temperature,
    // SDFs) have no such meaning.
    let unit = if name == "density" { ValueUnit::Density } else { ValueUnit::Unknown };
    let quantity = Quantity { modality: None, unit };
    let source = format!("{file} (grid {name})");
    let mut vol = if dense {
        let data = densify(&file, &raw)?;
        progress(total + total / 4, both);
        finish_values(&source, dims.map(|v| v as u32), spacing, data, opts, quantity, warnings)?
    } else {
        let (range, mut w) = raw.value_range(&source, opts.allow_negative)?;
        warnings.append(&mut w);
        let mut v = Volume::new([1; 3], opts.spacing.unwrap_or(spacing), vec![range[0]], source.clone())?;
        v.dims = dims.map(|v| v as u32);
        v.data.clear();
        v.value_range = range;
        v.warnings = warnings;
        v.quantity = quantity;
        v
    };
    progress(total + total / 2, both);
    let grid = raw.normalize(vol.value_range).map_err(|e| invalid(&file, format!("grid {name}: {e}")))?;
    progress(both, both);
    vol.sparse = Some(Arc::new(grid));
    vol.index_origin = Some(lo);
    Ok(vol)
}

/// The box with every voxel: the background, then the tiles, then the leaves' active voxels.
fn densify(file: &str, raw: &RawSparse) -> Result<Vec<f32>, VolumeError> {
    let d = raw.dims.map(|v| v as usize);
    let count = raw.dims.iter().product::<u64>();
    let mut data = value_buffer(file, count)?;
    data.resize(count as usize, raw.background);
    let lo = raw.lo;
    let index = |p: [i64; 3]| {
        let r = [0, 1, 2].map(|a| (p[a] - lo[a]) as usize);
        (r[2] * d[1] + r[1]) * d[0] + r[0]
    };
    for (o, e, v) in &raw.tiles {
        let (o, e) = (*o, *e);
        for z in o[2]..o[2] + e {
            for y in o[1]..o[1] + e {
                let row = index([o[0], y, z]);
                data[row..row + e as usize].fill(*v);
            }
        }
    }
    for (o, mask, values) in &raw.leaves {
        for i in (0..512).filter(|&i| bit(mask, i)) {
            data[index(leaf_voxel(o, i))] = values[i];
        }
    }
    Ok(data)
}
