//! DICOM, NIfTI and OpenVDB loaders: files written by the reference tools (pydicom, nibabel, OpenVDB;
//! `tools/make_format_fixtures.py`, committed under `tests/data/formats`), and broken variants built
//! here, each of which must fail with a message naming the file and the problem.
//!
//! Ground truth of the fixtures: a 6x5x4 volume storing 300 z + 10 y + x, rescaled by 2 and −1000.
//!
//! The render tests at the end are consistency checks of the path from a file to the image: a
//! CT series and a VDB grid render exactly as the same voxels written here as MetaImage.

mod common;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

use vkengine::volume::data::{load, LoadOptions, ValueUnit, Volume};

const DIMS: [u32; 3] = [6, 5, 4];

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats").join(name)
}

fn tmpdir(name: &str) -> PathBuf {
    static N: AtomicU32 = AtomicU32::new(0);
    let n = N.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir()
        .join(format!("vkengine_volume_formats_{}", std::process::id()))
        .join(format!("{name}_{n}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create temp dir");
    dir
}

fn hu(x: u32, y: u32, z: u32) -> f32 {
    (300 * z + 10 * y + x) as f32 * 2.0 - 1000.0
}

fn ok(path: &Path, o: &LoadOptions) -> Volume {
    load(path, o).unwrap_or_else(|e| panic!("{} failed: {e}", path.display()))
}

/// Expects failure with a message that starts with `starts` and contains `phrase`.
fn fails(path: &Path, o: &LoadOptions, starts: &Path, phrase: &str) -> String {
    let msg = match load(path, o) {
        Ok(v) => panic!("{} loaded ({:?}) but should fail with \"{phrase}\"", path.display(), v.dims),
        Err(e) => e.to_string(),
    };
    assert!(msg.starts_with(&starts.display().to_string()), "message does not start with the file: {msg}");
    assert!(msg.contains(phrase), "message lacks \"{phrase}\": {msg}");
    assert!(!msg.contains('\n'), "message is not one line: {msg}");
    msg
}

fn assert_ramp(v: &Volume, spacing: [f32; 3]) {
    assert_eq!(v.dims, DIMS, "{}", v.source);
    for (a, b) in v.spacing.iter().zip(spacing) {
        assert!((a - b).abs() < 1e-4, "spacing {:?}, expected {spacing:?} ({})", v.spacing, v.source);
    }
    for z in 0..4 {
        for y in 0..5 {
            for x in 0..6 {
                assert_eq!(v.at(x, y, z), hu(x, y, z), "voxel ({x}, {y}, {z}) of {}", v.source);
            }
        }
    }
}

// ---------------------------------------------------------------- DICOM written by pydicom

#[test]
fn dicom_series_is_ordered_by_position_not_name_with_hounsfield_values() {
    let v = ok(&fixture("ct_series"), &LoadOptions::default());
    assert_ramp(&v, [0.6, 0.8, 2.5]);
    assert_eq!(v.quantity.modality.as_deref(), Some("CT"));
    assert_eq!(v.quantity.unit, ValueUnit::Hounsfield);
    assert_eq!(v.value_range, [-1000.0, hu(5, 4, 3)]);
}

#[test]
fn dicom_rle_series_and_multiframe_file_load() {
    assert_ramp(&ok(&fixture("ct_rle"), &LoadOptions::default()), [0.6, 0.8, 2.5]);
    // Frames are stored as z = 1, 3, 0, 2: only the per-frame positions give the right order.
    let v = ok(&fixture("ct_multiframe.dcm"), &LoadOptions::default());
    assert_ramp(&v, [0.6, 0.8, 2.5]);
    assert_eq!(v.quantity.unit, ValueUnit::Hounsfield);
}

#[test]
fn rt_dose_frames_are_placed_by_grid_frame_offset_vector() {
    // pydicom's own rtdose.dcm: 10x10, 15 frames 5 mm apart, u32 scaled by DoseGridScaling 1e-6.
    let v = ok(&fixture("rtdose.dcm"), &LoadOptions::default());
    assert_eq!(v.dims, [10, 10, 15]);
    assert_eq!(v.spacing, [10.0, 10.0, 5.0]);
    // Values from pydicom's pixel_array × 1e-6: (x 5, y 4, frame 3) and the maximum.
    assert!((v.at(5, 4, 3) - 1.026).abs() < 1e-6, "{}", v.at(5, 4, 3));
    assert!((v.value_range[1] - 1.254).abs() < 1e-6, "{:?}", v.value_range);
    assert_eq!(v.quantity.unit, ValueUnit::Other("RELATIVE".into()));
    // The same grid with absolute offsets, stored top frame first, is the same volume.
    let a = ok(&fixture("rtdose_absolute.dcm"), &LoadOptions::default());
    assert_eq!((a.dims, a.spacing, &a.data), (v.dims, v.spacing, &v.data));
}

#[test]
fn dicom_single_file_of_a_series_is_one_slice() {
    // b.dcm is z = 0.
    let v = ok(&fixture("ct_series/b.dcm"), &LoadOptions::default());
    assert_eq!(v.dims, [6, 5, 1]);
    assert_eq!(v.at(5, 4, 0), hu(5, 4, 0));
}

#[test]
fn dicom_folder_with_two_series_needs_series_and_lists_them() {
    let dir = fixture("two_series");
    let msg = fails(&dir, &LoadOptions::default(), &dir, "holds 2 series; pick one with --series UID");
    assert!(
        msg.contains("1.2.826.0.1.3680043.8.498.12 (CT, 2 file(s)") && msg.contains("1.2.826.0.1.3680043.8.498.13"),
        "{msg}"
    );
    let o = LoadOptions { series: Some("1.2.826.0.1.3680043.8.498.13".into()), ..LoadOptions::default() };
    let v = ok(&dir, &o);
    assert_eq!(v.dims, [6, 5, 2]);
    assert_eq!(v.at(1, 2, 1), hu(1, 2, 1));
    let o = LoadOptions { series: Some("9.9".into()), ..LoadOptions::default() };
    fails(&dir, &o, &dir, "no series 9.9 here; it holds: 1.2.826.0.1.3680043.8.498.12");
}

// ---------------------------------------------------------------- DICOM written here, broken on purpose

/// One explicit-VR little-endian element.
fn elem(out: &mut Vec<u8>, group: u16, element: u16, vr: &[u8; 2], value: &[u8]) {
    let mut v = value.to_vec();
    if v.len() % 2 == 1 {
        v.push(if vr == b"UI" || vr == b"OB" { 0 } else { b' ' });
    }
    out.extend(group.to_le_bytes());
    out.extend(element.to_le_bytes());
    out.extend(vr);
    if matches!(vr, b"OB" | b"OW" | b"SQ" | b"UN" | b"UT") {
        out.extend([0, 0]);
        out.extend((v.len() as u32).to_le_bytes());
    } else {
        out.extend((v.len() as u16).to_le_bytes());
    }
    out.extend(v);
}

/// Geometry and content of one hand-written CT slice.
struct Slice {
    series: &'static str,
    rows: u16,
    cols: u16,
    position: Option<[f64; 3]>,
    z: u32,
    transfer_syntax: &'static str,
}

impl Slice {
    fn at(z: f64, index: u32) -> Slice {
        Slice {
            series: "1.2.3.4",
            rows: 5,
            cols: 6,
            position: Some([0.0, 0.0, z]),
            z: index,
            transfer_syntax: "1.2.840.10008.1.2.1",
        }
    }

    fn bytes(&self) -> Vec<u8> {
        let sop = format!("1.2.3.4.{}.{}", self.z, self.position.map_or(0, |p| (p[2] * 1000.0) as i64));
        let mut meta = Vec::new();
        elem(&mut meta, 2, 1, b"OB", &[0, 1]);
        elem(&mut meta, 2, 2, b"UI", b"1.2.840.10008.5.1.4.1.1.2");
        elem(&mut meta, 2, 3, b"UI", sop.as_bytes());
        elem(&mut meta, 2, 0x10, b"UI", self.transfer_syntax.as_bytes());
        let mut out = vec![0u8; 128];
        out.extend(b"DICM");
        elem(&mut out, 2, 0, b"UL", &(meta.len() as u32).to_le_bytes());
        out.extend(meta);
        elem(&mut out, 8, 0x16, b"UI", b"1.2.840.10008.5.1.4.1.1.2");
        elem(&mut out, 8, 0x18, b"UI", sop.as_bytes());
        elem(&mut out, 8, 0x60, b"CS", b"CT");
        elem(&mut out, 0x20, 0x0e, b"UI", self.series.as_bytes());
        if let Some(p) = self.position {
            elem(&mut out, 0x20, 0x32, b"DS", format!("{}\\{}\\{}", p[0], p[1], p[2]).as_bytes());
        }
        elem(&mut out, 0x20, 0x37, b"DS", b"1\\0\\0\\0\\1\\0");
        elem(&mut out, 0x28, 0x02, b"US", &1u16.to_le_bytes());
        elem(&mut out, 0x28, 0x04, b"CS", b"MONOCHROME2");
        elem(&mut out, 0x28, 0x10, b"US", &self.rows.to_le_bytes());
        elem(&mut out, 0x28, 0x11, b"US", &self.cols.to_le_bytes());
        elem(&mut out, 0x28, 0x30, b"DS", b"0.8\\0.6");
        elem(&mut out, 0x28, 0x100, b"US", &16u16.to_le_bytes());
        elem(&mut out, 0x28, 0x101, b"US", &16u16.to_le_bytes());
        elem(&mut out, 0x28, 0x102, b"US", &15u16.to_le_bytes());
        elem(&mut out, 0x28, 0x103, b"US", &1u16.to_le_bytes());
        elem(&mut out, 0x28, 0x1052, b"DS", b"-1000");
        elem(&mut out, 0x28, 0x1053, b"DS", b"2");
        let mut px = Vec::new();
        for y in 0..u32::from(self.rows) {
            for x in 0..u32::from(self.cols) {
                px.extend(((300 * self.z + 10 * y + x) as i16).to_le_bytes());
            }
        }
        if self.transfer_syntax == "1.2.840.10008.1.2.4.90" {
            // Encapsulated: empty offset table, then one (bogus) fragment.
            out.extend([0xe0, 0x7f, 0x10, 0x00]);
            out.extend(b"OB\0\0");
            out.extend(u32::MAX.to_le_bytes());
            out.extend([0xfe, 0xff, 0x00, 0xe0, 0, 0, 0, 0]);
            out.extend([0xfe, 0xff, 0x00, 0xe0, 4, 0, 0, 0, 0xff, 0x4f, 0xff, 0x51]);
            out.extend([0xfe, 0xff, 0xdd, 0xe0, 0, 0, 0, 0]);
        } else {
            elem(&mut out, 0x7fe0, 0x10, b"OW", &px);
        }
        out
    }
}

fn write_series(dir: &Path, slices: &[Slice]) {
    for (i, s) in slices.iter().enumerate() {
        std::fs::write(dir.join(format!("IM{:04}", 1000 - i)), s.bytes()).expect("write slice");
    }
}

#[test]
fn dicom_written_here_orders_slices_by_position() {
    // Positions descend with the file index, and the names (IM1000, IM0999, ...) sort the other way
    // round; a loader ordering by name or write order gets z reversed.
    let dir = tmpdir("order");
    write_series(&dir, &[Slice::at(7.5, 3), Slice::at(5.0, 2), Slice::at(0.0, 0), Slice::at(2.5, 1)]);
    let v = ok(&dir, &LoadOptions::default());
    assert_ramp(&v, [0.6, 0.8, 2.5]);
    // Extensionless files are recognized by their DICM preamble.
    let one = ok(&dir.join("IM1000"), &LoadOptions::default());
    assert_eq!(one.at(0, 0, 0), hu(0, 0, 3));
}

#[test]
fn dicom_geometry_errors_name_the_files() {
    let dir = tmpdir("gap");
    write_series(&dir, &[Slice::at(0.0, 0), Slice::at(2.5, 1), Slice::at(7.5, 3), Slice::at(10.0, 4)]);
    let msg = fails(&dir, &LoadOptions::default(), &dir, "missing slice(s):");
    assert!(msg.contains("2.5000 mm apart") || msg.contains("5.0000 mm apart"), "{msg}");

    let dir = tmpdir("uneven");
    write_series(&dir, &[Slice::at(0.0, 0), Slice::at(2.5, 1), Slice::at(5.0, 2), Slice::at(6.0, 3)]);
    fails(&dir, &LoadOptions::default(), &dir, "uneven slice spacing");

    let dir = tmpdir("dup");
    write_series(&dir, &[Slice::at(0.0, 0), Slice::at(2.5, 1), Slice::at(2.5, 2)]);
    fails(&dir, &LoadOptions::default(), &dir, "lie at the same position");

    let dir = tmpdir("mixed");
    let mut big = Slice::at(2.5, 1);
    big.rows = 6;
    write_series(&dir, &[Slice::at(0.0, 0), big]);
    fails(&dir, &LoadOptions::default(), &dir, "mixed slice sizes");

    let dir = tmpdir("nopos");
    let mut lost = Slice::at(2.5, 1);
    lost.position = None;
    write_series(&dir, &[Slice::at(0.0, 0), lost]);
    fails(&dir, &LoadOptions::default(), &dir, "has no ImagePositionPatient, so the slices cannot be ordered");

    let dir = tmpdir("empty");
    std::fs::write(dir.join("notes.txt"), "not dicom").expect("write");
    fails(&dir, &LoadOptions::default(), &dir, "no DICOM images among the 1 file(s)");
}

#[test]
fn dicom_truncated_and_unsupported_files_fail_clearly() {
    let dir = tmpdir("trunc");
    write_series(&dir, &[Slice::at(0.0, 0), Slice::at(2.5, 1)]);
    let victim = dir.join("IM0999");
    let bytes = std::fs::read(&victim).expect("read");
    std::fs::write(&victim, &bytes[..bytes.len() - 20]).expect("truncate");
    fails(&dir, &LoadOptions::default(), &victim, "truncated");

    let dir = tmpdir("j2k");
    let mut s = Slice::at(0.0, 0);
    s.transfer_syntax = "1.2.840.10008.1.2.4.90";
    write_series(&dir, &[s]);
    fails(&dir, &LoadOptions::default(), &dir.join("IM1000"), "unsupported transfer syntax 1.2.840.10008.1.2.4.90");

    let bad = dir.join("bad.dcm");
    let mut bytes = vec![0u8; 128];
    bytes.extend(b"DICM garbage");
    std::fs::write(&bad, bytes).expect("write");
    fails(&bad, &LoadOptions::default(), &bad, "not a readable DICOM file");
}

// ---------------------------------------------------------------- NIfTI written by nibabel

#[test]
fn nifti_1_and_2_plain_and_gzipped_apply_slope_and_pixdim() {
    for name in ["ramp1.nii", "ramp1.nii.gz", "ramp2.nii", "ramp2.nii.gz"] {
        let o = LoadOptions { allow_negative: true, ..LoadOptions::default() };
        assert_ramp(&ok(&fixture(name), &o), [0.6, 0.8, 2.5]);
    }
    // Values below zero follow the ordinary rule: NIfTI does not say they are Hounsfield units.
    fails(&fixture("ramp1.nii"), &LoadOptions::default(), &fixture("ramp1.nii"), "negative voxel(s)");
}

#[test]
fn nifti_orientation_is_honoured() {
    // Stored right-to-left and anterior-to-posterior (RAS order), by sform and by qform alone:
    // reordered into the same patient-axis volume as the DICOM series.
    let o = LoadOptions { allow_negative: true, ..LoadOptions::default() };
    assert_ramp(&ok(&fixture("ramp_ras.nii.gz"), &o), [0.6, 0.8, 2.5]);
    assert_ramp(&ok(&fixture("ramp_ras_qform.nii"), &o), [0.6, 0.8, 2.5]);
    assert_eq!(ok(&fixture("ct_series"), &o).data, ok(&fixture("ramp_ras.nii.gz"), &o).data);
}

#[test]
fn nifti_4d_loads_first_or_chosen_frame() {
    let p = fixture("ramp_4d.nii.gz");
    let o = LoadOptions { allow_negative: true, ..LoadOptions::default() };
    let v = ok(&p, &o);
    assert!(v.warnings.iter().any(|w| w.contains("4D file with 2 volumes; loading volume 0")), "{:?}", v.warnings);
    let v1 = ok(&p, &LoadOptions { frame: Some(1), ..o.clone() });
    assert!(v1.warnings.is_empty(), "{:?}", v1.warnings);
    for (a, b) in v.data.iter().zip(&v1.data) {
        assert_eq!(*b, *a + 2.0);
    }
    fails(&p, &LoadOptions { frame: Some(2), ..o }, &p, "frame 2 requested but the file holds 2 volume(s)");
}

// ---------------------------------------------------------------- NIfTI written here, broken on purpose

/// A NIfTI-1 single-file header for `dims` of `datatype` (bitpix `bits`), data right after.
fn nifti1(dims: &[i16], datatype: i16, bits: i16) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    h[40..42].copy_from_slice(&(dims.len() as i16).to_le_bytes());
    for (i, d) in dims.iter().enumerate() {
        h[42 + 2 * i..44 + 2 * i].copy_from_slice(&d.to_le_bytes());
    }
    h[70..72].copy_from_slice(&datatype.to_le_bytes());
    h[72..74].copy_from_slice(&bits.to_le_bytes());
    for i in 0..4 {
        h[76 + 4 * i..80 + 4 * i].copy_from_slice(&1f32.to_le_bytes());
    }
    h[108..112].copy_from_slice(&352f32.to_le_bytes());
    h[344..348].copy_from_slice(b"n+1\0");
    h
}

#[test]
fn nifti_bad_files_fail_clearly() {
    let dir = tmpdir("nifti");
    let p = dir.join("short.nii");
    let mut bytes = nifti1(&[4, 4, 4], 2, 8);
    bytes.extend([7u8; 60]);
    std::fs::write(&p, &bytes).expect("write");
    fails(&p, &LoadOptions::default(), &p, "expected 416 bytes, got 412");

    // A lying header (2^15-1 cubed voxels of f64) is refused before anything is allocated.
    let p = dir.join("huge.nii");
    std::fs::write(&p, nifti1(&[32767, 32767, 32767], 64, 64)).expect("write");
    fails(&p, &LoadOptions::default(), &p, "exceed the largest accepted size");

    let p = dir.join("rgb.nii");
    std::fs::write(&p, nifti1(&[1, 1, 1], 128, 24)).expect("write");
    fails(&p, &LoadOptions::default(), &p, "NIfTI datatype 128 (RGB24)");

    let p = dir.join("magic.nii");
    let mut bytes = nifti1(&[1, 1, 1], 2, 8);
    bytes[344..348].copy_from_slice(b"abc\0");
    std::fs::write(&p, &bytes).expect("write");
    fails(&p, &LoadOptions::default(), &p, "bad NIfTI-1 magic");

    let p = dir.join("junk.nii.gz");
    std::fs::write(&p, [0x1f, 0x8b, 8, 0, 1, 2, 3]).expect("write");
    fails(&p, &LoadOptions::default(), &p, "");

    let p = dir.join("tiny.nii");
    std::fs::write(&p, [1, 2, 3]).expect("write");
    fails(&p, &LoadOptions::default(), &p, "shorter than a NIfTI header");
}

// ---------------------------------------------------------------- OpenVDB written by OpenVDB 10

#[test]
fn vdb_sparse_grid_becomes_dense_box_with_background() {
    let p = fixture("sparse.vdb");
    let v = ok(&p, &LoadOptions::default());
    // Active bounds: x −4..=20, y 0..=9, z 0..=7 (the filled 8³ block reaches z = 7).
    assert_eq!(v.dims, [25, 10, 8]);
    assert_eq!(v.spacing, [0.5; 3]);
    let at = |x: i32, y: i32, z: i32| v.at((x + 4) as u32, y as u32, z as u32);
    assert_eq!(at(0, 0, 0), 1.0);
    assert_eq!(at(3, 1, 2), 2.5);
    assert_eq!(at(20, 9, 5), 0.75);
    assert_eq!(at(-4, 2, 1), 3.0);
    assert_eq!(at(8, 0, 0), 0.5);
    assert_eq!(at(15, 7, 7), 0.5);
    assert_eq!(at(1, 1, 1), 0.0, "inactive voxels take the background");
    let active = v.data.iter().filter(|&&d| d != 0.0).count();
    assert_eq!(active, 4 + 512);
}

#[test]
fn vdb_grid_choice_and_errors() {
    let p = fixture("sparse.vdb");
    let t = ok(&p, &LoadOptions { grid: Some("temperature".into()), ..LoadOptions::default() });
    assert_eq!(t.dims, [2, 2, 2]);
    assert!(t.data.iter().all(|&d| d == 4.0));
    fails(
        &p,
        &LoadOptions { grid: Some("nope".into()), ..LoadOptions::default() },
        &p,
        "no grid named nope; the file holds:",
    );
    fails(&p, &LoadOptions { grid: Some("velocity".into()), ..LoadOptions::default() }, &p, "only float grids");

    let s = ok(&fixture("smoke.vdb"), &LoadOptions::default());
    assert_eq!(s.dims, [40, 24, 16]);
    assert_eq!(s.spacing, [0.25; 3]);
    assert_eq!(s.at(0, 0, 0), 2.0);
    assert_eq!(s.at(39, 39 % 24, 39 % 16), 41.0);
    assert_eq!(s.at(1, 2, 3), 1.0);

    let dir = tmpdir("vdb");
    let bytes = std::fs::read(fixture("smoke.vdb")).expect("read");
    let cut = dir.join("cut.vdb");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).expect("write");
    fails(&cut, &LoadOptions::default(), &cut, "");
    let junk = dir.join("junk.vdb");
    std::fs::write(&junk, b"not a vdb file at all").expect("write");
    fails(&junk, &LoadOptions::default(), &junk, "not an OpenVDB file");
}

#[test]
fn a_dicom_length_or_vr_the_file_cannot_hold_is_refused_before_parsing() {
    // dicom-object reserves and zero-fills a declared length before reading it: a corrupt VR or
    // length in a 1 KB file cost up to 4 GB (found by fuzz_loaders). The guard refuses it first.
    let dir = tmpdir("dicom_guard");
    let bytes = std::fs::read(fixture("ct_multiframe.dcm")).expect("fixture");
    // The transfer syntax UID's VR `UI` becomes the unknown `TI`, read as UN with a 4-byte
    // length taken from the UID's text: ~775 MB.
    let at = bytes.windows(4).position(|w| w == [0x02, 0x00, 0x10, 0x00]).expect("(0002,0010)") + 4;
    let mut bad = bytes.clone();
    bad[at] = b'T';
    let p = dir.join("vr.dcm");
    std::fs::write(&p, &bad).expect("write");
    let msg = fails(&p, &LoadOptions::default(), &p, "claims");
    assert!(msg.contains("(0002,0010)") && msg.contains("remain"), "{msg}");
    let mut bad = bytes.clone();
    bad[at] = b'0';
    std::fs::write(&p, &bad).expect("write");
    fails(&p, &LoadOptions::default(), &p, "no valid value representation");
    ok(&fixture("ct_multiframe.dcm"), &LoadOptions::default());
}

// ---------------------------------------------------------------- the same voxels, the same image

/// A MetaImage (`.mha`, float voxels, x fastest) of `values`, written here from the fixtures'
/// ground truth rather than by any loader.
fn write_mha(path: &Path, dims: [u32; 3], spacing: [f32; 3], values: &[f32]) {
    let mut bytes = format!(
        "ObjectType = Image\nNDims = 3\nDimSize = {} {} {}\nElementType = MET_FLOAT\nElementSpacing = {} {} {}\n\
         BinaryDataByteOrderMSB = False\nElementDataFile = LOCAL\n",
        dims[0], dims[1], dims[2], spacing[0], spacing[1], spacing[2]
    )
    .into_bytes();
    values.iter().for_each(|v| bytes.extend_from_slice(&v.to_le_bytes()));
    std::fs::write(path, bytes).expect("write mha");
}

/// EAM image of `v` under a fixed transfer function, framed obliquely (the box's extent, the
/// value range's normalization and the voxels all reach the pixels).
fn eam_image(ctx: &vkengine::vk::Context, v: &Volume) -> Vec<[f32; 4]> {
    use vkengine::volume::camera::{Camera, Projection};
    use vkengine::volume::optics::tf::{TfPoint, TransferFunction};
    use vkengine::volume::render::renderer::{render_frame, RenderSettings, Targets, VolumeRenderer};
    // Nothing transparent: the smoke's minimum (1.0) is its bulk.
    let tf = TransferFunction::OneD {
        points: vec![
            TfPoint { value: 0.0, color: [0.3, 0.5, 0.9], extinction: 3.0 },
            TfPoint { value: 1.0, color: [1.0, 0.8, 0.6], extinction: 40.0 },
        ],
    };
    let r = VolumeRenderer::new(ctx, v, &tf).expect("renderer");
    let cam = Camera::orbit(1.0, 0.6, 0.3, Projection::Perspective { fov_y: 0.8 }).framed(
        glam::Vec3::ZERO,
        r.box_half(),
        1.0,
        0.9,
    );
    let mut t = Targets::new(ctx, [48, 48]).expect("targets");
    render_frame(ctx, &r, &mut t, &cam, &RenderSettings::default(), 0).expect("render");
    t.read_hdr(ctx).expect("readback")
}

fn assert_same_image(a: &[[f32; 4]], b: &[[f32; 4]], what: &str) {
    let lit = a.iter().filter(|p| p[0] > 1e-3).count();
    assert!(lit > a.len() / 10, "{what}: only {lit} of {} pixels show the volume", a.len());
    let worst = a.iter().flatten().zip(b.iter().flatten()).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max);
    assert!(worst <= 1e-6, "{what}: images differ by up to {worst}");
}

#[test]
fn a_ct_series_renders_as_the_same_voxels_in_a_metaimage() {
    common::gpu_test(|ctx| {
        let ct = ok(&fixture("ct_series"), &LoadOptions::default());
        let values: Vec<f32> =
            (0..4).flat_map(|z| (0..5).flat_map(move |y| (0..6).map(move |x| hu(x, y, z)))).collect();
        let p = tmpdir("ct_as_mha").join("ct.mha");
        write_mha(&p, DIMS, [0.6, 0.8, 2.5], &values);
        let mha = ok(&p, &LoadOptions { allow_negative: true, ..Default::default() });
        assert_same_image(&eam_image(ctx, &ct), &eam_image(ctx, &mha), "CT series vs MetaImage");
    });
}

#[test]
fn a_sparse_vdb_renders_as_its_dense_equivalent() {
    common::gpu_test(|ctx| {
        // smoke.vdb (tools/make_format_fixtures.py): 1.0 over x 0..=39, y 0..=23, z 0..=15, then
        // 2 + i at (i, i mod 24, i mod 16); voxel size 0.25.
        let dims = [40u32, 24, 16];
        let mut values = vec![1.0f32; (dims[0] * dims[1] * dims[2]) as usize];
        for i in 0..40u32 {
            values[(((i % 16) * dims[1] + i % 24) * dims[0] + i) as usize] = 2.0 + i as f32;
        }
        let p = tmpdir("vdb_as_mha").join("smoke.mha");
        write_mha(&p, dims, [0.25; 3], &values);
        let vdb = ok(&fixture("smoke.vdb"), &LoadOptions::default());
        let dense = ok(&p, &LoadOptions::default());
        assert_same_image(&eam_image(ctx, &vdb), &eam_image(ctx, &dense), "VDB vs dense MetaImage");
    });
}
