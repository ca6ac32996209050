//! DICOM: a folder holding one series of single-frame files, or one (multi-frame) file.
//!
//! Slices are ordered by `ImagePositionPatient` projected on the slice normal (row × column direction of
//! `ImageOrientationPatient`): file names and `InstanceNumber` say nothing reliable about geometry. The
//! slice spacing comes from those positions, the in-plane spacing from `PixelSpacing`, and
//! `RescaleSlope`/`RescaleIntercept` are applied per slice (CT → Hounsfield units).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

use dicom_dictionary_std::tags;
use dicom_object::{DefaultDicomObject, InMemDicomObject, OpenFileOptions, Tag};
use dicom_pixeldata::{PixelDecoder, PixelRepresentation};
use dicom_transfer_syntax_registry::{TransferSyntaxIndex, TransferSyntaxRegistry};

use super::orient::{to_lps, Grid};
use super::{
    check_fits, check_load_dims, finish_values, value_buffer, LoadOptions, Progress, Quantity, ValueUnit, Volume,
    VolumeError,
};

/// Folder levels searched below the given folder (exports nest series a few levels deep).
const MAX_DEPTH: usize = 4;
/// Most files considered in a folder walk, so a mistaken `--volume /` fails instead of crawling.
const MAX_FILES: usize = 20_000;
/// Relative deviation of one slice gap from the median gap that still counts as even spacing
/// (positions are decimal strings rounded by the writer).
const GAP_TOLERANCE: f64 = 0.02;
/// Most frames whose geometry is read from one file (more than any 3D texture holds).
const MAX_FRAMES: u32 = 1 << 16;

/// Whether `path` is a DICOM Part 10 file (128-byte preamble, then `DICM`).
pub(crate) fn has_preamble(path: &Path) -> bool {
    let mut buf = [0u8; 132];
    File::open(path).and_then(|mut f| f.read_exact(&mut buf)).is_ok() && &buf[128..] == b"DICM"
}

fn invalid(file: &str, message: impl Into<String>) -> VolumeError {
    VolumeError::Invalid { file: file.to_owned(), message: message.into() }
}

/// The error and its causes on one line; a short read anywhere in the chain means a truncated file.
fn describe(e: &(dyn std::error::Error + 'static)) -> String {
    let mut parts = vec![e.to_string()];
    let mut truncated = false;
    let mut cur = e.source();
    while let Some(c) = cur {
        if c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::UnexpectedEof) {
            truncated = true;
        }
        let s = c.to_string();
        if parts.last() != Some(&s) {
            parts.push(s);
        }
        cur = c.source();
    }
    let text = parts.join(": ");
    if truncated {
        format!("file is truncated ({text})")
    } else {
        text
    }
}

fn text(obj: &InMemDicomObject, tag: Tag) -> Option<String> {
    let s = obj.get(tag)?.to_str().ok()?;
    let s = s.trim_matches(|c: char| c.is_whitespace() || c == '\0');
    (!s.is_empty()).then(|| s.to_owned())
}

fn floats(obj: &InMemDicomObject, tag: Tag) -> Option<Vec<f64>> {
    obj.get(tag)?.to_multi_float64().ok().filter(|v| !v.is_empty())
}

fn uint(obj: &InMemDicomObject, tag: Tag) -> Option<u32> {
    obj.get(tag)?.to_int::<u32>().ok()
}

/// Item `index` of sequence `tag`.
fn item(obj: &InMemDicomObject, tag: Tag, index: usize) -> Option<&InMemDicomObject> {
    obj.get(tag)?.items()?.get(index)
}

/// `attr` looked up in the file, then in the enhanced-IOD functional groups (`group` macro in the frame's
/// per-frame item, then in the shared item).
fn functional(obj: &InMemDicomObject, frame: usize, group: Tag, attr: Tag) -> Option<Vec<f64>> {
    floats(obj, attr)
        .or_else(|| floats(item(item(obj, tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE, frame)?, group, 0)?, attr))
        .or_else(|| floats(item(item(obj, tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE, 0)?, group, 0)?, attr))
}

/// What the header of one file says (read without the pixel data).
struct Header {
    path: PathBuf,
    name: String,
    series: String,
    description: Option<String>,
    modality: Option<String>,
    rescale_type: Option<String>,
    transfer_syntax: String,
    rows: u32,
    cols: u32,
    frames: u32,
    /// Per frame: position, orientation (row and column direction cosines) and (slope, intercept).
    position: Vec<Option<[f64; 3]>>,
    orientation: Vec<Option<[f64; 6]>>,
    rescale: Vec<(f64, f64)>,
    has_intercept: bool,
    pixel_spacing: Option<[f64; 2]>,
    /// `SpacingBetweenSlices`, else `SliceThickness`: the stack spacing when positions are missing.
    slice_spacing: Option<f64>,
}

/// The header of `path`, or `None` when the file is DICOM but no image (a report, a presentation state).
fn read_header(path: &Path) -> Result<Option<Header>, VolumeError> {
    let name = path.display().to_string();
    // Before the parser sees it: the parser reserves and zero-fills declared lengths.
    super::dicom_guard::check_lengths(path).map_err(|m| invalid(&name, format!("not a readable DICOM file: {m}")))?;
    let obj: DefaultDicomObject = OpenFileOptions::new()
        .read_until(tags::PIXEL_DATA)
        .open_file(path)
        .map_err(|e| invalid(&name, format!("not a readable DICOM file: {}", describe(&e))))?;
    let transfer_syntax = obj.meta().transfer_syntax().to_owned();
    let (Some(rows), Some(cols)) = (uint(&obj, tags::ROWS), uint(&obj, tags::COLUMNS)) else { return Ok(None) };
    let frames = match text(&obj, tags::NUMBER_OF_FRAMES) {
        None => 1,
        Some(t) => {
            t.parse::<u32>().map_err(|_| invalid(&name, format!("NumberOfFrames \"{t}\" is not a positive integer")))?
        }
    };
    if frames == 0 {
        return Err(invalid(&name, "NumberOfFrames is 0"));
    }
    // NumberOfFrames may lie; per-frame lists stop at a bound above any accepted depth, and
    // load() refuses a file whose frames exceed them.
    let n = frames.min(MAX_FRAMES) as usize;
    let mut position = Vec::new();
    let mut orientation = Vec::new();
    let mut rescale = Vec::new();
    let mut has_intercept = false;
    for f in 0..n {
        position.push(
            functional(&obj, f, tags::PLANE_POSITION_SEQUENCE, tags::IMAGE_POSITION_PATIENT)
                .filter(|v| v.len() == 3)
                .map(|v| [v[0], v[1], v[2]]),
        );
        orientation.push(
            functional(&obj, f, tags::PLANE_ORIENTATION_SEQUENCE, tags::IMAGE_ORIENTATION_PATIENT)
                .filter(|v| v.len() == 6)
                .map(|v| [v[0], v[1], v[2], v[3], v[4], v[5]]),
        );
        let g = tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE;
        let intercept = functional(&obj, f, g, tags::RESCALE_INTERCEPT).map(|v| v[0]);
        has_intercept |= intercept.is_some();
        // RT Dose scales its integers to Gy (or relative dose) with DoseGridScaling instead.
        let slope = functional(&obj, f, g, tags::RESCALE_SLOPE)
            .or_else(|| floats(&obj, tags::DOSE_GRID_SCALING))
            .map_or(1.0, |v| v[0]);
        rescale.push((slope, intercept.unwrap_or(0.0)));
    }
    if let Some(offsets) = floats(&obj, tags::GRID_FRAME_OFFSET_VECTOR).filter(|_| frames > 1) {
        grid_frame_positions(&name, &offsets, frames, &mut position, &orientation)?;
    }
    let pixel_spacing = functional(&obj, 0, tags::PIXEL_MEASURES_SEQUENCE, tags::PIXEL_SPACING)
        .filter(|v| v.len() == 2)
        .map(|v| [v[0], v[1]]);
    let slice_spacing = functional(&obj, 0, tags::PIXEL_MEASURES_SEQUENCE, tags::SPACING_BETWEEN_SLICES)
        .or_else(|| functional(&obj, 0, tags::PIXEL_MEASURES_SEQUENCE, tags::SLICE_THICKNESS))
        .map(|v| v[0])
        .filter(|s| s.is_finite() && *s > 0.0);
    Ok(Some(Header {
        path: path.to_path_buf(),
        series: text(&obj, tags::SERIES_INSTANCE_UID).unwrap_or_else(|| "(no SeriesInstanceUID)".into()),
        description: text(&obj, tags::SERIES_DESCRIPTION),
        modality: text(&obj, tags::MODALITY),
        rescale_type: text(&obj, tags::RESCALE_TYPE).or_else(|| text(&obj, tags::DOSE_UNITS)),
        transfer_syntax,
        rows,
        cols,
        frames,
        position,
        orientation,
        rescale,
        has_intercept,
        pixel_spacing,
        slice_spacing,
        name,
    }))
}

/// RT Dose: one `ImagePositionPatient` for the first frame and each frame's offset along the
/// normal in `GridFrameOffsetVector` (relative to that position when the first offset is 0,
/// else absolute coordinates along the normal: either way, position + (offset − first) × normal).
fn grid_frame_positions(
    name: &str,
    offsets: &[f64],
    frames: u32,
    position: &mut [Option<[f64; 3]>],
    orientation: &[Option<[f64; 6]>],
) -> Result<(), VolumeError> {
    if offsets.len() != frames as usize {
        return Err(invalid(
            name,
            format!("GridFrameOffsetVector has {} offsets but the file holds {frames} frames", offsets.len()),
        ));
    }
    let (Some(Some(p0)), Some(Some(o))) = (position.first(), orientation.first()) else {
        return Err(invalid(name, "GridFrameOffsetVector without ImagePositionPatient and ImageOrientationPatient"));
    };
    let (p0, n) = (*p0, cross([o[0], o[1], o[2]], [o[3], o[4], o[5]]));
    let len = dot(n, n).sqrt();
    if !offsets.iter().all(|v| v.is_finite()) || len.is_nan() || len <= 1e-6 {
        return Err(invalid(name, format!("GridFrameOffsetVector {offsets:?} with orientation {o:?} is not a stack")));
    }
    for (p, &d) in position.iter_mut().zip(offsets) {
        let t = d - offsets[0];
        *p = Some([0, 1, 2].map(|i| p0[i] + t * n[i] / len));
    }
    Ok(())
}

/// Files under `dir` (a few levels deep, hidden entries and `DICOMDIR` skipped), sorted for stable messages.
fn walk(dir: &Path, depth: usize, out: &mut Vec<PathBuf>) -> Result<(), VolumeError> {
    let io = |source| VolumeError::Io { file: dir.display().to_string(), source };
    let mut entries: Vec<PathBuf> =
        std::fs::read_dir(dir).map_err(io)?.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for p in entries {
        let hidden = p.file_name().and_then(|n| n.to_str()).is_none_or(|n| n.starts_with('.') || n == "DICOMDIR");
        if hidden {
            continue;
        }
        if p.is_dir() {
            if depth < MAX_DEPTH {
                walk(&p, depth + 1, out)?;
            }
        } else if out.len() >= MAX_FILES {
            return Err(invalid(
                &dir.display().to_string(),
                format!("more than {MAX_FILES} files below this folder: point --volume at one series' folder"),
            ));
        } else {
            out.push(p);
        }
    }
    Ok(())
}

fn series_list(groups: &BTreeMap<String, Vec<Header>>) -> String {
    groups
        .iter()
        .map(|(uid, hs)| {
            let h = &hs[0];
            let desc = h.description.as_deref().map(|d| format!(", \"{d}\"")).unwrap_or_default();
            format!("{uid} ({}, {} file(s){desc})", h.modality.as_deref().unwrap_or("?"), hs.len())
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// One slice of the stack: which file and frame, and where it lies.
struct Slice<'a> {
    header: &'a Header,
    frame: usize,
}

impl Slice<'_> {
    fn label(&self) -> String {
        if self.header.frames > 1 {
            format!("{} frame {}", self.header.name, self.frame + 1)
        } else {
            self.header.name.clone()
        }
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Orders the slices along the stack normal and returns the slice spacing.
fn order(file: &str, slices: &mut Vec<Slice<'_>>, warnings: &mut Vec<String>) -> Result<f64, VolumeError> {
    let fallback = slices[0].header.slice_spacing;
    if slices.len() == 1 {
        return Ok(fallback.unwrap_or(1.0));
    }
    let geo = |s: &Slice<'_>| {
        (s.header.position.get(s.frame).copied().flatten(), s.header.orientation.get(s.frame).copied().flatten())
    };
    let positioned = slices.iter().filter(|s| geo(s).0.is_some()).count();
    if positioned < slices.len() {
        let first = slices.iter().find(|s| geo(s).0.is_none()).map(Slice::label).unwrap_or_default();
        // A single multi-frame file without positions keeps the stored frame order, which is the
        // only order such a file defines; separate files cannot be ordered without positions.
        if positioned == 0 && slices.iter().all(|s| std::ptr::eq(s.header, slices[0].header)) {
            let s = fallback.unwrap_or(1.0);
            warnings.push(format!(
                "{file}: frames have no ImagePositionPatient; kept in stored order, {s} mm apart (SpacingBetweenSlices/SliceThickness{})",
                if fallback.is_none() { " missing, assumed 1" } else { "" }
            ));
            return Ok(s);
        }
        return Err(invalid(file, format!("{first} has no ImagePositionPatient, so the slices cannot be ordered")));
    }
    let o0 = geo(&slices[0]).1.ok_or_else(|| {
        invalid(file, format!("{} has no ImageOrientationPatient, so the slices cannot be ordered", slices[0].label()))
    })?;
    for s in slices.iter() {
        let o = geo(s).1.ok_or_else(|| {
            invalid(file, format!("{} has no ImageOrientationPatient, so the slices cannot be ordered", s.label()))
        })?;
        if o.iter().zip(&o0).any(|(a, b)| (a - b).abs() > 1e-3) {
            return Err(invalid(
                file,
                format!(
                    "{} is oriented {o:?} but {} is {o0:?}: the slices are not one stack",
                    s.label(),
                    slices[0].label()
                ),
            ));
        }
    }
    let normal = cross([o0[0], o0[1], o0[2]], [o0[3], o0[4], o0[5]]);
    let len = dot(normal, normal).sqrt();
    if len.is_nan() || len <= 1e-6 {
        return Err(invalid(
            file,
            format!("ImageOrientationPatient {o0:?} has parallel or zero row and column directions"),
        ));
    }
    let normal = normal.map(|c| c / len);
    let dist = |s: &Slice<'_>| geo(s).0.map_or(0.0, |p| dot(p, normal));
    slices.sort_by(|a, b| dist(a).total_cmp(&dist(b)));
    let gaps: Vec<f64> = slices.windows(2).map(|w| dist(&w[1]) - dist(&w[0])).collect();
    let mut sorted = gaps.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    for (i, &g) in gaps.iter().enumerate() {
        let (a, b) = (slices[i].label(), slices[i + 1].label());
        if g <= 1e-4 {
            return Err(invalid(
                file,
                format!(
                    "{a} and {b} lie at the same position ({:.3} mm along the slice normal): a duplicate slice, or two stacks in one series",
                    dist(&slices[i])
                ),
            ));
        }
        if (g - median).abs() > GAP_TOLERANCE * median + 1e-3 {
            let what = if g > 1.5 * median { "missing slice(s)" } else { "uneven slice spacing" };
            return Err(invalid(
                file,
                format!("{what}: {a} and {b} are {g:.4} mm apart, the other slices {median:.4} mm"),
            ));
        }
    }
    Ok((dist(&slices[slices.len() - 1]) - dist(&slices[0])) / gaps.len() as f64)
}

/// Decodes frames `frames` of `header`'s file and hands each one's rescaled values (x fastest) to `out`.
fn decode_into(header: &Header, frames: &[usize], out: FrameSink<'_>) -> Result<(), VolumeError> {
    let name = &header.name;
    let obj = OpenFileOptions::new()
        .open_file(&header.path)
        .map_err(|e| invalid(name, format!("cannot read DICOM data: {}", describe(&e))))?;
    if header.transfer_syntax.trim_end_matches('\0') == super::dicom_guard::RLE_LOSSLESS {
        // The RLE decoder indexes past short fragments and segments; check them first.
        let fragments = obj.element(tags::PIXEL_DATA).ok().and_then(|e| e.value().fragments()).unwrap_or(&[]);
        let samples = uint(&obj, tags::SAMPLES_PER_PIXEL).unwrap_or(1) as usize;
        let bytes = uint(&obj, tags::BITS_ALLOCATED).unwrap_or(8).div_ceil(8) as usize;
        let plane = header.rows as usize * header.cols as usize;
        super::dicom_guard::check_rle(fragments, header.frames, samples * bytes, plane)
            .map_err(|m| invalid(name, m))?;
    }
    let px =
        obj.decode_pixel_data().map_err(|e| invalid(name, format!("cannot decode pixel data: {}", describe(&e))))?;
    if px.samples_per_pixel() != 1 {
        return Err(invalid(
            name,
            format!("{} samples per pixel (colour image): only greyscale images are volumes", px.samples_per_pixel()),
        ));
    }
    if px.rows() != header.rows || px.columns() != header.cols {
        return Err(invalid(name, "decoded image size differs from the header's Rows/Columns"));
    }
    let bits = px.bits_allocated();
    let stored = px.bits_stored().clamp(1, bits.max(1));
    let bytes = match bits {
        8 | 16 | 32 => usize::from(bits / 8),
        b => return Err(invalid(name, format!("BitsAllocated {b} is not supported (8, 16 or 32)"))),
    };
    let signed = px.pixel_representation() == PixelRepresentation::Signed;
    let plane = header.rows as usize * header.cols as usize;
    let frame_bytes = plane * bytes;
    let data = px.data();
    let expected = frame_bytes as u64 * u64::from(header.frames);
    if (data.len() as u64) < expected {
        return Err(VolumeError::Truncated { file: name.clone(), expected, got: data.len() as u64 });
    }
    let mask: u32 = if stored >= 32 { u32::MAX } else { (1u32 << stored) - 1 };
    let shift = 32 - u32::from(stored.min(32));
    let mut values = Vec::with_capacity(plane);
    for &f in frames {
        let (slope, intercept) = header.rescale.get(f).copied().unwrap_or((1.0, 0.0));
        let raw = &data[f * frame_bytes..(f + 1) * frame_bytes];
        values.clear();
        values.extend(raw.chunks_exact(bytes).map(|c| {
            let mut word = [0u8; 4];
            word[..bytes].copy_from_slice(c);
            let v = u32::from_le_bytes(word) & mask;
            // Sign-extend from BitsStored: a 12-bit signed sample lives in the low bits of its word.
            let v = if signed { f64::from(((v << shift) as i32) >> shift) } else { f64::from(v) };
            (v * slope + intercept) as f32
        }));
        out(&values)?;
    }
    Ok(())
}

use super::dicom_bricks::SliceSink as FrameSink;

/// Loads a folder's series or one file, reporting the bytes of values decoded (and, into
/// bricks, of both passes).
pub(crate) fn load(path: &Path, opts: &LoadOptions, progress: Progress<'_>) -> Result<Volume, VolumeError> {
    let file = path.display().to_string();
    let mut headers = Vec::new();
    if path.is_dir() {
        let mut files = Vec::new();
        walk(path, 0, &mut files)?;
        let dicom: Vec<&PathBuf> = files.iter().filter(|f| has_preamble(f)).collect();
        for f in &dicom {
            headers.extend(read_header(f)?);
        }
        if headers.is_empty() {
            return Err(invalid(
                &file,
                format!(
                    "no DICOM images among the {} file(s) in this folder ({} DICOM file(s) without pixel data)",
                    files.len(),
                    dicom.len()
                ),
            ));
        }
    } else {
        let h = read_header(path)?.ok_or_else(|| invalid(&file, "DICOM file without Rows/Columns: not an image"))?;
        headers.push(h);
    }

    let mut groups: BTreeMap<String, Vec<Header>> = BTreeMap::new();
    for h in headers {
        groups.entry(h.series.clone()).or_default().push(h);
    }
    let series = match &opts.series {
        Some(uid) => groups
            .remove(uid)
            .ok_or_else(|| invalid(&file, format!("no series {uid} here; it holds: {}", series_list(&groups))))?,
        None if groups.len() > 1 => {
            return Err(invalid(
                &file,
                format!("holds {} series; pick one with --series UID: {}", groups.len(), series_list(&groups)),
            ))
        }
        None => groups.into_values().next().unwrap_or_default(),
    };
    let Some(first) = series.first() else { return Err(invalid(&file, "no images")) };

    for h in &series {
        if (h.rows, h.cols) != (first.rows, first.cols) {
            return Err(invalid(
                &file,
                format!(
                    "mixed slice sizes: {} is {}x{} but {} is {}x{}",
                    h.name, h.cols, h.rows, first.name, first.cols, first.rows
                ),
            ));
        }
        if series.len() > 1 && h.frames > 1 {
            return Err(invalid(
                &file,
                format!(
                    "{} holds {} frames: a series of multi-frame files is not supported; load one file",
                    h.name, h.frames
                ),
            ));
        }
        let ts = TransferSyntaxRegistry.get(&h.transfer_syntax);
        if !ts.is_some_and(|t| t.can_decode_all()) {
            let what = ts.map_or("unknown".to_owned(), |t| t.name().to_owned());
            return Err(invalid(
                &h.name,
                format!(
                    "unsupported transfer syntax {} ({what}); supported: uncompressed, deflate, RLE lossless, JPEG baseline/extended/lossless",
                    h.transfer_syntax
                ),
            ));
        }
    }
    let depth = if series.len() == 1 { u64::from(first.frames) } else { series.len() as u64 };
    let dims = [u64::from(first.cols), u64::from(first.rows), depth];
    let count = check_load_dims(&file, dims, opts)?;
    check_fits(&file, dims, opts)?;
    if series.len() == 1 && first.position.len() < first.frames as usize {
        return Err(invalid(&first.name, format!("NumberOfFrames {} is more than {MAX_FRAMES}", first.frames)));
    }

    let mut warnings = Vec::new();
    let mut slices: Vec<Slice<'_>> = if series.len() == 1 {
        (0..first.frames as usize).map(|frame| Slice { header: first, frame }).collect()
    } else {
        series.iter().map(|header| Slice { header, frame: 0 }).collect()
    };
    let dz = order(&file, &mut slices, &mut warnings)?;
    let [dy, dx] = match first.pixel_spacing {
        Some(s) => s,
        None => {
            warnings.push(format!("{file}: no PixelSpacing; assuming 1 mm"));
            [1.0, 1.0]
        }
    };
    if let Some(h) = series.iter().find(|h| h.pixel_spacing != first.pixel_spacing) {
        return Err(invalid(
            &file,
            format!(
                "{} has PixelSpacing {:?} but {} has {:?}",
                h.name, h.pixel_spacing, first.name, first.pixel_spacing
            ),
        ));
    }

    // Sorting put z along the normal; x and y run along the row and column directions.
    let orientation = slices[0].header.orientation.get(slices[0].frame).copied().flatten();
    let decode = |each: FrameSink<'_>| -> Result<(), VolumeError> {
        if series.len() == 1 {
            let frames: Vec<usize> = slices.iter().map(|s| s.frame).collect();
            decode_into(first, &frames, each)
        } else {
            slices.iter().try_for_each(|s| decode_into(s.header, &[0], each))
        }
    };
    let modality = first.modality.clone();
    let unit = match (modality.as_deref(), first.rescale_type.as_deref()) {
        (Some("CT"), None | Some("HU")) if first.has_intercept => ValueUnit::Hounsfield,
        (_, Some("HU")) => ValueUnit::Hounsfield,
        (_, Some(t)) if t != "US" => ValueUnit::Other(t.to_owned()),
        _ => ValueUnit::Unknown,
    };
    // check_dims bounded every axis by max_dimension (a u32).
    let dims = dims.map(|d| d as u32);
    let quantity = Quantity { modality, unit };
    let axes = orientation.map(|o| {
        let (row, col) = ([o[0], o[1], o[2]], [o[3], o[4], o[5]]);
        [row, col, cross(row, col)]
    });
    let spacing = [dx as f32, dy as f32, dz as f32];
    let want = super::bricked::wanted(dims, opts);
    if want != super::bricked::Want::No {
        let (geometry, mut slices) = ((dims, spacing, axes), |each: FrameSink<'_>| decode(each));
        return super::dicom_bricks::load(&file, geometry, opts, (quantity, warnings), want, progress, &mut slices);
    }
    let mut data = value_buffer(&file, count)?;
    decode(&mut |v: &[f32]| {
        data.extend_from_slice(v);
        progress(data.len() as u64 * 4, count * 4);
        Ok(())
    })?;
    let mut grid = Grid { dims, spacing, data };
    if let Some(axes) = axes {
        grid = to_lps(&file, grid, axes, &mut warnings)?;
    }
    let mut vol = finish_values(&file, grid.dims, grid.spacing, grid.data, opts, quantity, warnings)?;
    vol.patient_axes = true;
    Ok(vol)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_frame_offsets_must_match_the_frames() {
        let mut pos = vec![Some([0.0, 0.0, 10.0]); 3];
        let ori = vec![Some([1.0, 0.0, 0.0, 0.0, 1.0, 0.0]); 3];
        let e = grid_frame_positions("d.dcm", &[0.0, 5.0], 3, &mut pos, &ori).expect_err("2 offsets, 3 frames");
        assert!(e.to_string().starts_with("d.dcm: GridFrameOffsetVector has 2 offsets"), "{e}");
        grid_frame_positions("d.dcm", &[10.0, 15.0, 25.0], 3, &mut pos, &ori).expect("absolute");
        assert_eq!(pos, vec![Some([0.0, 0.0, 10.0]), Some([0.0, 0.0, 15.0]), Some([0.0, 0.0, 25.0])]);
    }
}
