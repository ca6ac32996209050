//! NIfTI-1 and NIfTI-2 single files (`.nii`, gzipped `.nii.gz`), parsed by hand: the `nifti` crate reads
//! NIfTI-1 only and sizes its buffers from the header before checking it.
//!
//! Values are scaled by `scl_slope`/`scl_inter`, spacing comes from `pixdim` (in mm), the sform (else the
//! qform) reorders voxels into patient axes, and a 4D file yields one volume (`LoadOptions::frame`).

use std::fs::File;
use std::io::{self, BufReader, Read};
use std::path::Path;

use flate2::read::MultiGzDecoder;

use super::orient::{plan, to_lps, Grid};
use super::read::{fill, SLAB};
use super::stream::{normalize, Decode};
use super::{
    check_fits, check_load_dims, check_spacing, finish_values, streamed, voxel, Endian, LoadOptions, Progress,
    Quantity, Volume, VolumeError, VoxelType,
};

fn invalid(file: &str, message: impl Into<String>) -> VolumeError {
    VolumeError::Invalid { file: file.to_owned(), message: message.into() }
}

/// Header fields the loader uses, from either version.
struct Header {
    endian: Endian,
    dims: Vec<u64>,
    datatype: i16,
    pixdim: [f64; 8],
    vox_offset: u64,
    slope: f64,
    inter: f64,
    xyzt_units: u32,
    qform_code: i32,
    sform_code: i32,
    quatern: [f64; 3],
    srow: [[f64; 4]; 3],
}

/// Little/big-endian field reads from the header bytes.
struct Fields<'a> {
    b: &'a [u8],
    endian: Endian,
}

impl Fields<'_> {
    fn bytes<const N: usize>(&self, at: usize) -> [u8; N] {
        let mut a = [0u8; N];
        a.copy_from_slice(&self.b[at..at + N]);
        if self.endian == Endian::Big {
            a.reverse();
        }
        a
    }
    fn i16(&self, at: usize) -> i16 {
        i16::from_le_bytes(self.bytes(at))
    }
    fn i32(&self, at: usize) -> i32 {
        i32::from_le_bytes(self.bytes(at))
    }
    fn i64(&self, at: usize) -> i64 {
        i64::from_le_bytes(self.bytes(at))
    }
    fn f32(&self, at: usize) -> f64 {
        f64::from(f32::from_le_bytes(self.bytes(at)))
    }
    fn f64(&self, at: usize) -> f64 {
        f64::from_le_bytes(self.bytes(at))
    }
}

fn parse_header(file: &str, head: &[u8]) -> Result<Header, VolumeError> {
    let too_short = || invalid(file, format!("file is truncated: {} bytes, shorter than a NIfTI header", head.len()));
    if head.len() < 348 {
        return Err(too_short());
    }
    let size_le = i32::from_le_bytes([head[0], head[1], head[2], head[3]]);
    let size_be = i32::from_be_bytes([head[0], head[1], head[2], head[3]]);
    let (endian, size) = match (size_le, size_be) {
        (348 | 540, _) => (Endian::Little, size_le),
        (_, 348 | 540) => (Endian::Big, size_be),
        _ => return Err(invalid(file, format!("not a NIfTI file: header size {size_le} is neither 348 nor 540"))),
    };
    let f = Fields { b: head, endian };
    if size == 348 {
        let magic = &head[344..348];
        if magic == b"ni1\0" {
            return Err(invalid(
                file,
                "NIfTI header/image pairs (.hdr + .img) are not supported; convert to a single .nii",
            ));
        }
        if magic != b"n+1\0" {
            return Err(invalid(file, format!("bad NIfTI-1 magic {magic:?} (expected \"n+1\")")));
        }
        let n = f.i16(40);
        let dims = (1..=7).map(|i| f.i16(40 + 2 * i) as i64).collect::<Vec<_>>();
        return Ok(Header {
            endian,
            dims: ndims(file, i64::from(n), &dims)?,
            datatype: f.i16(70),
            pixdim: std::array::from_fn(|i| f.f32(76 + 4 * i)),
            vox_offset: offset(file, f.f32(108))?,
            slope: f.f32(112),
            inter: f.f32(116),
            xyzt_units: u32::from(head[123]),
            qform_code: i32::from(f.i16(252)),
            sform_code: i32::from(f.i16(254)),
            quatern: std::array::from_fn(|i| f.f32(256 + 4 * i)),
            srow: std::array::from_fn(|r| std::array::from_fn(|c| f.f32(280 + 16 * r + 4 * c))),
        });
    }
    if head.len() < 540 {
        return Err(too_short());
    }
    if &head[4..8] != b"n+2\0" {
        return Err(invalid(file, format!("bad NIfTI-2 magic {:?} (expected \"n+2\")", &head[4..8])));
    }
    let dims = (1..=7).map(|i| f.i64(16 + 8 * i)).collect::<Vec<_>>();
    Ok(Header {
        endian,
        dims: ndims(file, f.i64(16), &dims)?,
        datatype: f.i16(12),
        pixdim: std::array::from_fn(|i| f.f64(104 + 8 * i)),
        vox_offset: offset(file, f.i64(168) as f64)?,
        slope: f.f64(176),
        inter: f.f64(184),
        xyzt_units: f.i32(500) as u32,
        qform_code: f.i32(344),
        sform_code: f.i32(348),
        quatern: std::array::from_fn(|i| f.f64(352 + 8 * i)),
        srow: std::array::from_fn(|r| std::array::from_fn(|c| f.f64(400 + 32 * r + 8 * c))),
    })
}

fn ndims(file: &str, n: i64, dims: &[i64]) -> Result<Vec<u64>, VolumeError> {
    if !(1..=7).contains(&n) {
        return Err(invalid(file, format!("dim[0] = {n}: the number of dimensions must be 1 to 7")));
    }
    dims[..n as usize]
        .iter()
        .map(|&d| u64::try_from(d).ok().filter(|&d| d > 0))
        .collect::<Option<Vec<u64>>>()
        .ok_or_else(|| invalid(file, format!("dim = {:?}: every dimension must be > 0", &dims[..n as usize])))
}

fn offset(file: &str, v: f64) -> Result<u64, VolumeError> {
    if !(v.is_finite() && (0.0..=1e12).contains(&v)) {
        return Err(invalid(file, format!("vox_offset {v} is not a byte offset")));
    }
    Ok(v as u64)
}

fn voxel_type(file: &str, code: i16) -> Result<VoxelType, VolumeError> {
    Ok(match code {
        2 => VoxelType::U8,
        4 => VoxelType::I16,
        8 => VoxelType::I32,
        16 => VoxelType::F32,
        64 => VoxelType::F64,
        256 => VoxelType::I8,
        512 => VoxelType::U16,
        768 => VoxelType::U32,
        other => {
            let name = match other {
                32 => "complex64",
                128 => "RGB24",
                1024 => "int64",
                1280 => "uint64",
                1536 => "float128",
                1792 => "complex128",
                2048 => "complex256",
                2304 => "RGBA32",
                _ => "unknown",
            };
            return Err(VolumeError::UnsupportedType {
                file: file.to_owned(),
                type_name: format!("NIfTI datatype {other} ({name})"),
                location: "header field datatype".into(),
            });
        }
    })
}

/// LPS direction of each voxel axis from the sform, else the qform; `None` when neither is set.
fn axes(h: &Header) -> Option<[[f64; 3]; 3]> {
    let ras: [[f64; 3]; 3] = if h.sform_code > 0 {
        std::array::from_fn(|c| std::array::from_fn(|r| h.srow[r][c]))
    } else if h.qform_code > 0 {
        let [b, c, d] = h.quatern;
        let a = (1.0 - (b * b + c * c + d * d)).max(0.0).sqrt();
        let m = [
            [a * a + b * b - c * c - d * d, 2.0 * (b * c - a * d), 2.0 * (b * d + a * c)],
            [2.0 * (b * c + a * d), a * a + c * c - b * b - d * d, 2.0 * (c * d - a * b)],
            [2.0 * (b * d - a * c), 2.0 * (c * d + a * b), a * a + d * d - c * c - b * b],
        ];
        let qfac = if h.pixdim[0] < 0.0 { -1.0 } else { 1.0 };
        std::array::from_fn(|col| {
            let s = if col == 2 { qfac } else { 1.0 };
            std::array::from_fn(|r| m[r][col] * s)
        })
    } else {
        return None;
    };
    // NIfTI world space is RAS; patient LPS negates the first two axes.
    Some(ras.map(|v| [-v[0], -v[1], v[2]]))
}

/// The file's bytes, decompressed when it is gzipped (the magic says, not the name).
fn open(path: &Path, file: &str) -> Result<(Box<dyn Read>, bool), VolumeError> {
    let f = File::open(path).map_err(|source| VolumeError::Io { file: file.to_owned(), source })?;
    let mut reader = BufReader::new(f);
    let mut magic = [0u8; 2];
    let n = reader.read(&mut magic).map_err(|source| VolumeError::Io { file: file.to_owned(), source })?;
    let raw = std::io::Cursor::new(magic[..n].to_vec()).chain(reader);
    let gz = n == 2 && magic == [0x1f, 0x8b];
    Ok((if gz { Box::new(MultiGzDecoder::new(raw)) } else { Box::new(raw) }, gz))
}

/// Where one volume's bytes lie in the (decompressed) file.
struct Span {
    /// Offset of the volume's first byte.
    start: u64,
    /// Its length.
    len: u64,
    /// The whole file's length as the header implies, for messages.
    total: u64,
}

/// A read failure of `file`: a decompression error when it is gzipped, else an I/O error.
fn read_error(file: &str, gz: bool, e: io::Error) -> VolumeError {
    if gz {
        VolumeError::Decompress { file: file.to_owned(), message: e.to_string() }
    } else {
        VolumeError::Io { file: file.to_owned(), source: e }
    }
}

/// Hands the span's bytes to `each` in slabs, reading the file from its start (a gzipped file
/// cannot seek), failing with `Truncated` when the file ends early.
fn read_span(
    path: &Path,
    file: &str,
    span: &Span,
    each: &mut dyn FnMut(&[u8]) -> Result<(), VolumeError>,
) -> Result<(), VolumeError> {
    let (mut stream, gz) = open(path, file)?;
    let rd_err = |e: io::Error| read_error(file, gz, e);
    let skipped = io::copy(&mut (&mut stream).take(span.start), &mut io::sink()).map_err(rd_err)?;
    if skipped < span.start {
        return Err(VolumeError::Truncated { file: file.to_owned(), expected: span.total, got: skipped });
    }
    let mut slab = vec![0u8; span.len.min(SLAB as u64) as usize];
    let mut data = stream.take(span.len);
    let mut got = 0u64;
    while got < span.len {
        let n = fill(&mut data, &mut slab).map_err(&rd_err)?;
        if n == 0 {
            return Err(VolumeError::Truncated { file: file.to_owned(), expected: span.total, got: span.start + got });
        }
        got += n as u64;
        each(&slab[..n])?;
    }
    Ok(())
}

pub(crate) fn load(path: &Path, opts: &LoadOptions, progress: Progress<'_>) -> Result<Volume, VolumeError> {
    let file = path.display().to_string();
    let (mut stream, gz) = open(path, &file)?;
    let rd_err = |e: io::Error| read_error(&file, gz, e);

    let mut head = Vec::with_capacity(540);
    (&mut stream).take(348).read_to_end(&mut head).map_err(rd_err)?;
    if head.len() == 348 {
        let size = [
            i32::from_le_bytes([head[0], head[1], head[2], head[3]]),
            i32::from_be_bytes([head[0], head[1], head[2], head[3]]),
        ];
        if size.contains(&540) {
            (&mut stream).take(540 - 348).read_to_end(&mut head).map_err(rd_err)?;
        }
    }
    drop(stream);
    let h = parse_header(&file, &head)?;
    let voxel = voxel_type(&file, h.datatype)?;

    let mut warnings = Vec::new();
    let d = |i: usize| h.dims.get(i).copied().unwrap_or(1);
    if (4..h.dims.len()).any(|i| d(i) > 1) {
        return Err(invalid(
            &file,
            format!("dims {:?}: 5D and higher (vector or multi-component) data is not supported", h.dims),
        ));
    }
    let volumes = d(3);
    let frame = match opts.frame {
        Some(t) if u64::from(t) >= volumes => {
            return Err(invalid(
                &file,
                format!("frame {t} requested but the file holds {volumes} volume(s) (0 to {})", volumes - 1),
            ))
        }
        Some(t) => u64::from(t),
        None => {
            if volumes > 1 {
                warnings
                    .push(format!("{file}: 4D file with {volumes} volumes; loading volume 0 (choose with --frame N)"));
            }
            0
        }
    };
    let dims3 = [d(0), d(1), d(2)];
    let count = check_load_dims(&file, dims3, opts)?;
    check_fits(&file, dims3, opts)?;
    let vol_bytes = count * voxel.bytes() as u64;
    let header_len = head.len() as u64;
    if h.vox_offset != 0 && h.vox_offset < header_len {
        return Err(invalid(&file, format!("vox_offset {} lies inside the {header_len}-byte header", h.vox_offset)));
    }
    let start = frame
        .checked_mul(vol_bytes)
        .and_then(|b| b.checked_add(h.vox_offset.max(header_len)))
        .ok_or_else(|| invalid(&file, format!("volume {frame} lies beyond any file size")))?;
    let total = volumes.saturating_mul(vol_bytes).saturating_add(h.vox_offset.max(header_len));
    let span = Span { start, len: vol_bytes, total };
    // scl_slope 0 (or non-finite) means "no scaling" in the standard.
    let rescale = (h.slope.is_finite() && h.slope != 0.0 && (h.slope != 1.0 || h.inter != 0.0))
        .then(|| (h.slope, if h.inter.is_finite() { h.inter } else { 0.0 }));
    let to_mm = match h.xyzt_units & 7 {
        1 => 1000.0,
        3 => 0.001,
        _ => 1.0,
    };
    let spacing = [1, 2, 3].map(|i| {
        let s = h.pixdim[i].abs() * to_mm;
        if i <= h.dims.len() && s.is_finite() && s > 0.0 {
            s
        } else {
            1.0
        }
    });
    if let Some(bad) = (1..=h.dims.len().min(3)).find(|&i| !(h.pixdim[i].is_finite() && h.pixdim[i] != 0.0)) {
        warnings.push(format!("{file}: pixdim[{bad}] = {} is not a voxel size; using 1", h.pixdim[bad]));
    }
    let dims = dims3.map(|v| v as u32);
    let spacing = spacing.map(|s| s as f32);

    let bricks = super::bricked::wanted(dims, opts);
    if count > opts.stream_above || bricks != super::bricked::Want::No {
        let reorder = axes(&h).and_then(|a| plan(&file, dims, spacing, a, &mut warnings));
        let decode = Decode { voxel, endian: h.endian, rescale };
        let mut s = normalize(
            &file,
            dims,
            spacing,
            &decode,
            reorder.as_ref(),
            opts.allow_negative,
            (bricks, &super::bricked::Room::of(opts)),
            progress,
            &mut |each| read_span(path, &file, &span, each),
        )?;
        warnings.append(&mut s.warnings);
        s.spacing = check_spacing(&file, opts.spacing.unwrap_or(s.spacing).map(f64::from))?;
        let mut vol = streamed(&file, s, warnings);
        vol.patient_axes = true;
        return Ok(vol);
    }

    let mut bytes = Vec::new();
    let len = usize::try_from(vol_bytes).map_err(|_| invalid(&file, "volume too large"))?;
    bytes.try_reserve_exact(len).map_err(|_| invalid(&file, format!("cannot allocate {vol_bytes} bytes")))?;
    read_span(path, &file, &span, &mut |slab| {
        bytes.extend_from_slice(slab);
        Ok(())
    })?;
    let mut data = voxel::decode(&bytes, voxel, h.endian);
    drop(bytes);
    if let Some((slope, inter)) = rescale {
        for v in &mut data {
            *v = (f64::from(*v) * slope + inter) as f32;
        }
    }
    let mut grid = Grid { dims, spacing, data };
    if let Some(axes) = axes(&h) {
        grid = to_lps(&file, grid, axes, &mut warnings)?;
    }
    let mut vol = finish_values(&file, grid.dims, grid.spacing, grid.data, opts, Quantity::default(), warnings)?;
    vol.patient_axes = true;
    Ok(vol)
}
