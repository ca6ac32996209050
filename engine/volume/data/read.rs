//! Reading exactly the voxel bytes a header describes from a (possibly compressed) file region.

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use flate2::read::{MultiGzDecoder, ZlibDecoder};

use super::VolumeError;

/// Where the voxel data sits in its file.
pub(crate) enum Start {
    /// This many bytes after the region start (after any line skip).
    Skip(u64),
    /// The data is the last `expected` bytes of the file (MetaImage `HeaderSize = -1`, NRRD `byte skip: -1`).
    FromEnd,
}

/// A region of a file holding voxel data.
pub(crate) struct DataRegion<'a> {
    /// File holding the data.
    pub path: &'a Path,
    /// Byte offset where the data region begins (e.g. right after an attached header).
    pub offset: u64,
    /// Text lines to skip at `offset` before anything else (NRRD `line skip`).
    pub line_skip: u64,
    /// Bytes to skip: in the file for raw data, in the decompressed stream for compressed data.
    pub start: Start,
    /// Whether the data is a zlib or gzip stream.
    pub compressed: bool,
    /// Compressed stream length, if the header says (MetaImage `CompressedDataSize`).
    pub compressed_size: Option<u64>,
    /// Exact number of voxel bytes required.
    pub expected: u64,
}

fn io_err(path: &Path) -> impl Fn(io::Error) -> VolumeError + '_ {
    move |source| VolumeError::Io { file: path.display().to_string(), source }
}

/// Allocates a buffer for `len` bytes without aborting if memory is short.
fn buffer(path: &Path, len: u64) -> Result<Vec<u8>, VolumeError> {
    let mut v = Vec::new();
    let n = usize::try_from(len).map_err(|_| io::Error::new(io::ErrorKind::OutOfMemory, "volume too large"));
    n.and_then(|n| {
        v.try_reserve_exact(n).map_err(|_| {
            io::Error::new(io::ErrorKind::OutOfMemory, format!("cannot allocate {len} bytes for voxel data"))
        })
    })
    .map_err(io_err(path))?;
    Ok(v)
}

/// Skips `lines` newline-terminated lines without buffering whole lines (binary data may have none).
fn skip_lines<R: BufRead>(r: &mut R, lines: u64) -> io::Result<u64> {
    let mut consumed = 0u64;
    let mut remaining = lines;
    while remaining > 0 {
        let buf = r.fill_buf()?;
        if buf.is_empty() {
            break;
        }
        let (used, hit) = match buf.iter().position(|&b| b == b'\n') {
            Some(p) => (p + 1, true),
            None => (buf.len(), false),
        };
        r.consume(used);
        consumed += used as u64;
        if hit {
            remaining -= 1;
        }
    }
    Ok(consumed)
}

/// Bytes read (or decompressed) at a time when streaming: small next to any volume worth streaming,
/// large enough that a read costs more than its call.
pub(crate) const SLAB: usize = 4 << 20;

/// Reads exactly `region.expected` voxel bytes, failing with `Truncated` / `SizeMismatch` otherwise.
pub(crate) fn read_region(region: &DataRegion<'_>, hint: impl Fn(u64) -> String) -> Result<Vec<u8>, VolumeError> {
    let mut buf = buffer(region.path, region.expected)?;
    stream_region(region, hint, &mut |slab| {
        buf.extend_from_slice(slab);
        Ok(())
    })?;
    Ok(buf)
}

/// Fills `buf` from `r` as far as the stream goes; returns how many bytes it holds.
pub(crate) fn fill(r: &mut impl Read, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// Hands the region's `expected` voxel bytes to `each` in slabs of [`SLAB`] bytes (the last one shorter),
/// with the same size checks as [`read_region`]; only one slab is held at a time.
pub(crate) fn stream_region(
    region: &DataRegion<'_>,
    hint: impl Fn(u64) -> String,
    each: &mut dyn FnMut(&[u8]) -> Result<(), VolumeError>,
) -> Result<(), VolumeError> {
    let path = region.path;
    let name = path.display().to_string();
    let err = io_err(path);
    let mut file = File::open(path).map_err(&err)?;
    let len = file.metadata().map_err(&err)?.len();
    file.seek(SeekFrom::Start(region.offset.min(len))).map_err(&err)?;
    let mut reader = BufReader::new(file);
    let skipped = skip_lines(&mut reader, region.line_skip).map_err(&err)?;
    let begin = region.offset.saturating_add(skipped).min(len);
    let expected = region.expected;
    // Allocated once the size checks have passed: a header's claim alone allocates nothing.
    let slab = || vec![0u8; expected.min(SLAB as u64) as usize];

    if !region.compressed {
        let available = len - begin;
        let (data_start, got) = match region.start {
            Start::FromEnd if available < expected => {
                return Err(VolumeError::Truncated { file: name, expected, got: available })
            }
            Start::FromEnd => (len - expected, expected),
            Start::Skip(n) => (begin.saturating_add(n).min(len), available.saturating_sub(n)),
        };
        if got < expected {
            return Err(VolumeError::Truncated { file: name, expected, got });
        }
        if got > expected {
            return Err(VolumeError::SizeMismatch { file: name, expected, got, hint: hint(got) });
        }
        reader.seek(SeekFrom::Start(data_start)).map_err(&err)?;
        let mut data = reader.take(expected);
        let mut slab = slab();
        let mut done = 0u64;
        while done < expected {
            let n = fill(&mut data, &mut slab).map_err(&err)?;
            if n == 0 {
                // The file shrank between the size check and the read.
                return Err(VolumeError::Truncated { file: name, expected, got: done });
            }
            done += n as u64;
            each(&slab[..n])?;
        }
        return Ok(());
    }

    let skip = match region.start {
        Start::Skip(n) => n,
        Start::FromEnd => {
            return Err(VolumeError::Decompress {
                file: name,
                message: "compressed data cannot be located from the end of the file (skip -1)".into(),
            })
        }
    };
    let compressed: Box<dyn Read> = match region.compressed_size {
        Some(n) => Box::new(reader.take(n)),
        None => Box::new(reader),
    };
    let mut compressed = BufReader::new(compressed);
    // Auto-detect gzip vs zlib: writers disagree (ITK writes zlib, teem writes gzip) and the magic is unambiguous.
    let is_gzip = compressed.fill_buf().map_err(&err)?.starts_with(&[0x1f, 0x8b]);
    let mut decoder: Box<dyn Read> =
        if is_gzip { Box::new(MultiGzDecoder::new(compressed)) } else { Box::new(ZlibDecoder::new(compressed)) };
    let dec_err = |e: io::Error| VolumeError::Decompress { file: name.clone(), message: e.to_string() };
    let skipped = io::copy(&mut (&mut decoder).take(skip), &mut io::sink()).map_err(dec_err)?;
    if skipped < skip {
        return Err(VolumeError::Truncated { file: name.clone(), expected: expected + skip, got: skipped });
    }
    let mut got = 0u64;
    {
        let mut slab = slab();
        let mut data = (&mut decoder).take(expected);
        while got < expected {
            let n = fill(&mut data, &mut slab).map_err(dec_err)?;
            if n == 0 {
                return Err(VolumeError::Truncated { file: format!("{name} (decompressed)"), expected, got });
            }
            got += n as u64;
            each(&slab[..n])?;
        }
    }
    // Count (without storing) any surplus so the message can say how big the data really is.
    let extra = io::copy(&mut decoder, &mut io::sink()).map_err(dec_err)?;
    if extra > 0 {
        let got = expected + extra;
        return Err(VolumeError::SizeMismatch {
            file: format!("{name} (decompressed)"),
            expected,
            got,
            hint: hint(got),
        });
    }
    Ok(())
}

/// Suggests dims (or a type) that would explain `got` bytes, given the declared dims and voxel size.
pub(crate) fn size_hint(dims: [u32; 3], voxel_bytes: usize, got: u64) -> String {
    let vb = voxel_bytes as u64;
    let mut hints = Vec::new();
    if got.is_multiple_of(vb) {
        let n = got / vb;
        let c = (n as f64).cbrt().round() as u64;
        if c > 0 && c.checked_pow(3) == Some(n) {
            hints.push(format!("dims {c}x{c}x{c}"));
        }
        let plane = u64::from(dims[0]) * u64::from(dims[1]);
        if plane > 0 && n.is_multiple_of(plane) && n / plane != u64::from(dims[2]) {
            hints.push(format!("dims {}x{}x{}", dims[0], dims[1], n / plane));
        }
    }
    let expected = dims.iter().map(|&d| u64::from(d)).product::<u64>() * vb;
    if expected > 0 && got.is_multiple_of(expected) && vb * (got / expected) <= 8 {
        hints.push(format!("a {}-byte voxel type with the same dims", vb * (got / expected)));
    }
    if hints.is_empty() {
        String::new()
    } else {
        format!("; {} would fit", hints.join(" or "))
    }
}
