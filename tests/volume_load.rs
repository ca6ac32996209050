//! Volume loaders, procedural volumes and sanitizing: round trips through small files written here, and
//! every bad-input case producing an error that names the file and the problem.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

use flate2::write::{GzEncoder, ZlibEncoder};
use flate2::Compression;
use proptest::prelude::*;
use vkengine::volume::data::{load, procedural, Endian, LoadOptions, Volume, VolumeError, VoxelType};

/// A fresh, empty directory per call (tests run in parallel, possibly in several processes).
fn tmpdir(name: &str) -> PathBuf {
    static N: AtomicU32 = AtomicU32::new(0);
    let n = N.fetch_add(1, Ordering::Relaxed);
    let dir =
        std::env::temp_dir().join(format!("vkengine_volume_load_{}", std::process::id())).join(format!("{name}_{n}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create temp dir");
    dir
}

fn write(path: &Path, bytes: &[u8]) {
    std::fs::write(path, bytes).expect("write test file");
}

fn opts(dims: [u32; 3], voxel: VoxelType) -> LoadOptions {
    LoadOptions { dims: Some(dims), voxel: Some(voxel), ..LoadOptions::default() }
}

fn zlib(bytes: &[u8]) -> Vec<u8> {
    let mut e = ZlibEncoder::new(Vec::new(), Compression::default());
    e.write_all(bytes).expect("compress");
    e.finish().expect("compress")
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = GzEncoder::new(Vec::new(), Compression::default());
    e.write_all(bytes).expect("compress");
    e.finish().expect("compress")
}

/// Loads `path`, expects failure, and checks the message names the file and contains `phrase`.
fn load_err(path: &Path, o: &LoadOptions, phrase: &str) -> VolumeError {
    let err = match load(path, o) {
        Ok(v) => panic!("{} loaded ({:?}) but should have failed with \"{phrase}\"", path.display(), v.dims),
        Err(e) => e,
    };
    let msg = err.to_string();
    assert!(msg.starts_with(&path.display().to_string()), "message does not start with the path: {msg}");
    assert!(msg.contains(phrase), "message lacks \"{phrase}\": {msg}");
    err
}

fn ramp(n: usize) -> Vec<f32> {
    (0..n).map(|i| i as f32).collect()
}

fn u16_bytes(vals: &[u16], endian: Endian) -> Vec<u8> {
    vals.iter()
        .flat_map(|v| match endian {
            Endian::Little => v.to_le_bytes(),
            Endian::Big => v.to_be_bytes(),
        })
        .collect()
}

// ---------------------------------------------------------------- raw

#[test]
fn raw_u8_with_options() {
    let dir = tmpdir("raw_u8");
    let p = dir.join("vol.raw");
    let bytes: Vec<u8> = (0..24).collect();
    write(&p, &bytes);
    let v = load(&p, &opts([2, 3, 4], VoxelType::U8)).expect("load");
    assert_eq!(v.dims, [2, 3, 4]);
    assert_eq!(v.spacing, [1.0; 3]);
    assert_eq!(v.data, ramp(24));
    assert_eq!(v.value_range, [0.0, 23.0]);
    assert_eq!(v.at(1, 2, 3), 23.0);
    assert_eq!(v.at(1, 0, 0), 1.0);
    assert_eq!(v.at(0, 1, 0), 2.0);
    assert_eq!(v.at(0, 0, 1), 6.0);
    assert_eq!(v.get(2, 0, 0), None);
    assert_eq!(v.voxel_count(), 24);
    assert!(v.source.contains("vol.raw"));
    assert!(v.warnings.is_empty());
}

#[test]
fn raw_u16_little_and_big_endian() {
    let vals: Vec<u16> = (0..8).map(|i| i * 1000 + 258).collect();
    for endian in [Endian::Little, Endian::Big] {
        let dir = tmpdir("raw_u16");
        let p = dir.join("vol.bin");
        write(&p, &u16_bytes(&vals, endian));
        let o = LoadOptions { endian: Some(endian), ..opts([2, 2, 2], VoxelType::U16) };
        let v = load(&p, &o).expect("load");
        let expect: Vec<f32> = vals.iter().map(|&x| f32::from(x)).collect();
        assert_eq!(v.data, expect, "{endian}");
    }
}

#[test]
fn raw_f32_with_sidecar() {
    let dir = tmpdir("raw_f32_sidecar");
    let p = dir.join("head.raw");
    let vals = [0.0f32, 0.25, 0.5, 1.5, 2.0, 3.0];
    write(&p, &vals.iter().flat_map(|v| v.to_be_bytes()).collect::<Vec<_>>());
    write(&dir.join("head.raw.json"), br#"{"dims":[3,2,1],"type":"float","endian":"big","spacing":[1,1,1.5]}"#);
    let v = load(&p, &LoadOptions::default()).expect("load");
    assert_eq!(v.dims, [3, 2, 1]);
    assert_eq!(v.spacing, [1.0, 1.0, 1.5]);
    assert_eq!(v.data, vals);
    assert_eq!(v.extent(), [3.0, 2.0, 1.5]);
    assert_eq!(v.max_extent(), 3.0);
}

#[test]
fn raw_options_override_sidecar() {
    let dir = tmpdir("raw_override");
    let p = dir.join("v.raw");
    write(&p, &u16_bytes(&[1, 2, 3, 4], Endian::Little));
    // The sidecar is wrong on dims and type; options win for the fields they set, spacing still comes from it.
    write(&dir.join("v.raw.json"), br#"{"dims":[8,1,1],"type":"u8","spacing":[2,2,2]}"#);
    let v = load(&p, &opts([4, 1, 1], VoxelType::U16)).expect("load");
    assert_eq!(v.data, [1.0, 2.0, 3.0, 4.0]);
    assert_eq!(v.spacing, [2.0; 3]);
    let o = LoadOptions { spacing: Some([0.5, 0.5, 3.0]), ..opts([4, 1, 1], VoxelType::U16) };
    assert_eq!(load(&p, &o).expect("load").spacing, [0.5, 0.5, 3.0]);
}

// ---------------------------------------------------------------- MetaImage

fn mhd_header(dims: &str, ty: &str, extra: &str, data_file: &str) -> String {
    format!(
        "ObjectType = Image\nNDims = 3\nDimSize = {dims}\nElementType = {ty}\nElementSpacing = 0.5 0.5 2\n\
         Offset = 0 0 0\nTransformMatrix = 1 0 0 0 1 0 0 0 1\n{extra}ElementDataFile = {data_file}\n"
    )
}

#[test]
fn metaimage_local_uncompressed() {
    let dir = tmpdir("mha_local");
    let p = dir.join("vol.MHA");
    let mut bytes = mhd_header("2 2 2", "MET_SHORT", "BinaryDataByteOrderMSB = False\n", "LOCAL").into_bytes();
    let vals: [i16; 8] = [0, 1, 2, 3, 4, 5, 6, 300];
    bytes.extend(vals.iter().flat_map(|v| v.to_le_bytes()));
    write(&p, &bytes);
    let v = load(&p, &LoadOptions::default()).expect("load");
    assert_eq!(v.dims, [2, 2, 2]);
    assert_eq!(v.spacing, [0.5, 0.5, 2.0]);
    assert_eq!(v.data, vals.map(f32::from));
}

#[test]
fn metaimage_detached_big_endian() {
    let dir = tmpdir("mhd_be");
    let p = dir.join("vol.mhd");
    write(&p, mhd_header("4 1 2", "MET_USHORT", "ElementByteOrderMSB = True\n", "vol.raw").as_bytes());
    let vals: Vec<u16> = vec![1, 256, 513, 65535, 0, 7, 8, 9];
    write(&dir.join("vol.raw"), &u16_bytes(&vals, Endian::Big));
    let v = load(&p, &LoadOptions::default()).expect("load");
    assert_eq!(v.dims, [4, 1, 2]);
    assert_eq!(v.data, vals.iter().map(|&x| f32::from(x)).collect::<Vec<_>>());
}

#[test]
fn metaimage_zlib_local_and_detached() {
    let vals: Vec<f32> = (0..27).map(|i| i as f32 * 0.5).collect();
    let raw: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
    let z = zlib(&raw);

    let dir = tmpdir("mha_zlib");
    let p = dir.join("vol.mha");
    let extra = format!("CompressedData = True\nCompressedDataSize = {}\n", z.len());
    let mut bytes = mhd_header("3 3 3", "MET_FLOAT", &extra, "LOCAL").into_bytes();
    bytes.extend(&z);
    write(&p, &bytes);
    assert_eq!(load(&p, &LoadOptions::default()).expect("load mha").data, vals);

    let p = dir.join("vol.mhd");
    write(&p, mhd_header("3 3 3", "MET_FLOAT", "CompressedData = True\n", "data/vol.zraw").as_bytes());
    std::fs::create_dir_all(dir.join("data")).expect("mkdir");
    write(&dir.join("data/vol.zraw"), &z);
    assert_eq!(load(&p, &LoadOptions::default()).expect("load mhd").data, vals);
}

#[test]
fn metaimage_two_dimensional_and_header_size() {
    let dir = tmpdir("mhd_2d");
    let p = dir.join("slice.mhd");
    write(&p, b"NDims = 2\nDimSize = 3 2\nElementType = MET_UCHAR\nElementSize = 2 3\nHeaderSize = 4\nElementDataFile = s.raw\n");
    write(&dir.join("s.raw"), &[9, 9, 9, 9, 1, 2, 3, 4, 5, 6]);
    let v = load(&p, &LoadOptions::default()).expect("load");
    assert_eq!(v.dims, [3, 2, 1]);
    assert_eq!(v.spacing, [2.0, 3.0, 1.0]);
    assert_eq!(v.data, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);

    // HeaderSize = -1: the data is the last bytes of the file.
    write(&p, b"NDims = 2\nDimSize = 3 2\nElementType = MET_UCHAR\nHeaderSize = -1\nElementDataFile = s.raw\n");
    assert_eq!(load(&p, &LoadOptions::default()).expect("load").data, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
}

// ---------------------------------------------------------------- NRRD

fn nrrd_header(ty: &str, sizes: &str, encoding: &str, extra: &str) -> String {
    format!(
        "NRRD0004\n# Complete NRRD file format specification at:\n# http://teem.sourceforge.net/nrrd/format.html\n\
         type: {ty}\ndimension: 3\nsizes: {sizes}\nendian: little\nencoding: {encoding}\nmodality:=CT\n{extra}\n"
    )
}

#[test]
fn nrrd_attached_raw() {
    let dir = tmpdir("nrrd_raw");
    let p = dir.join("vol.nrrd");
    let mut bytes =
        nrrd_header("unsigned short", "2 2 2", "raw", "spacings: 1 2 3\nkinds: domain domain domain\n").into_bytes();
    let vals: Vec<u16> = (10..18).collect();
    bytes.extend(u16_bytes(&vals, Endian::Little));
    write(&p, &bytes);
    let v = load(&p, &LoadOptions::default()).expect("load");
    assert_eq!(v.dims, [2, 2, 2]);
    assert_eq!(v.spacing, [1.0, 2.0, 3.0]);
    assert_eq!(v.data, vals.iter().map(|&x| f32::from(x)).collect::<Vec<_>>());
}

#[test]
fn nrrd_attached_gzip() {
    let dir = tmpdir("nrrd_gzip");
    let p = dir.join("vol.nrrd");
    let vals: Vec<f32> = (0..64).map(|i| (i % 7) as f32).collect();
    let mut bytes = nrrd_header("float", "4 4 4", "gzip", "").into_bytes();
    bytes.extend(gzip(&vals.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>()));
    write(&p, &bytes);
    let v = load(&p, &LoadOptions::default()).expect("load");
    assert_eq!(v.data, vals);
    assert_eq!(v.value_range, [0.0, 6.0]);
}

#[test]
fn nrrd_detached_nhdr_with_skips() {
    let dir = tmpdir("nhdr");
    let p = dir.join("vol.nhdr");
    write(
        &p,
        b"NRRD0005\ntype: int16\ndimension: 3\nsizes: 2 1 2\nendian: big\nencoding: raw\n\
          data file: vol.dat\nline skip: 1\nbyte skip: 2\n",
    );
    let mut data = b"some text line\n".to_vec();
    data.extend([0xAA, 0xBB]);
    data.extend([0i16, 5, 300, 32767].iter().flat_map(|v| v.to_be_bytes()));
    write(&dir.join("vol.dat"), &data);
    let v = load(&p, &LoadOptions::default()).expect("load");
    assert_eq!(v.dims, [2, 1, 2]);
    assert_eq!(v.data, [0.0, 5.0, 300.0, 32767.0]);
}

#[test]
fn nrrd_space_directions_and_4d_single_channel() {
    let dir = tmpdir("nrrd_dirs");
    let p = dir.join("vol.nrrd");
    let header = "NRRD0004\ntype: uchar\ndimension: 4\nsizes: 1 2 2 1\nencoding: raw\nspace: left-posterior-superior\n\
                  space directions: none (0.6,0.8,0) (0, 2, 0) (0,0,-0.5)\nspace origin: (0,0,0)\n\n";
    let mut bytes = header.as_bytes().to_vec();
    bytes.extend([1u8, 2, 3, 4]);
    write(&p, &bytes);
    let v = load(&p, &LoadOptions::default()).expect("load");
    assert_eq!(v.dims, [2, 2, 1]);
    assert!((v.spacing[0] - 1.0).abs() < 1e-6 && v.spacing[1] == 2.0 && v.spacing[2] == 0.5, "{:?}", v.spacing);
    assert_eq!(v.data, [1.0, 2.0, 3.0, 4.0]);
}

#[test]
fn header_formats_warn_about_ignored_options() {
    let dir = tmpdir("ignored_opts");
    let p = dir.join("vol.nrrd");
    let mut bytes = nrrd_header("uint8", "2 1 1", "raw", "").into_bytes();
    bytes.extend([1u8, 2]);
    write(&p, &bytes);
    let v = load(&p, &opts([5, 5, 5], VoxelType::F32)).expect("load");
    assert_eq!(v.dims, [2, 1, 1]);
    assert!(v.warnings.iter().any(|w| w.contains("dims option")), "{:?}", v.warnings);
}

// ---------------------------------------------------------------- procedural + normalization

#[test]
fn procedural_homogeneous_and_box() {
    let v = procedural::homogeneous_box([4, 3, 2], 0.7).expect("box");
    assert!(v.data.iter().all(|&x| x == 0.7));
    assert_eq!(v.value_range, [0.7, 0.7]);
    assert!(v.normalized_u16().iter().all(|&x| x == 65535));

    let v = procedural::box_in_volume([10, 10, 10], [0.2, 0.0, 0.5], [0.5, 1.0, 1.0], 0.5).expect("box");
    // x centres 0.05, 0.15, ..., 0.95: indices 2..=4 are within [0.2, 0.5]; z indices 5..=9 within [0.5, 1].
    assert_eq!(v.at(2, 0, 5), 0.5);
    assert_eq!(v.at(4, 9, 9), 0.5);
    assert_eq!(v.at(1, 0, 5), 0.0);
    assert_eq!(v.at(5, 0, 5), 0.0);
    assert_eq!(v.at(3, 3, 4), 0.0);
    assert_eq!(v.data.iter().filter(|&&x| x > 0.0).count(), 3 * 10 * 5);
}

#[test]
fn procedural_sparse_clouds_fill_little_of_the_box() {
    let v = procedural::sparse_clouds([64; 3], 0).expect("sparse clouds");
    let filled = v.data.iter().filter(|&&x| x > 0.0).count() as f64 / v.data.len() as f64;
    // The majorant-grid benchmark needs a volume that fills well under 20 % of its box.
    assert!(filled > 0.005 && filled < 0.2, "filled fraction {filled}");
    assert!(v.data.iter().all(|&x| (0.0..=1.0).contains(&x)));
    // One dense puff: the maximum is far above the typical non-zero value.
    let mut nz: Vec<f32> = v.data.iter().copied().filter(|&x| x > 0.0).collect();
    nz.sort_by(f32::total_cmp);
    assert!(v.value_range[1] > 0.8 && nz[nz.len() / 2] < 0.5 * v.value_range[1], "{:?}", v.value_range);
    assert_eq!(v.data, procedural::sparse_clouds([64; 3], 0).expect("again").data, "deterministic");
}

#[test]
fn procedural_spheres() {
    let v = procedural::sphere([9, 9, 9], 0.3, 0.8).expect("sphere");
    assert_eq!(v.at(4, 4, 4), 0.8);
    assert_eq!(v.at(0, 0, 0), 0.0);
    assert_eq!(v.at(8, 4, 4), 0.0);
    assert_eq!(v.spacing, [1.0; 3]);

    let n = 10u32;
    let radius = 0.4f32;
    let v = procedural::smooth_sphere([n; 3], radius).expect("smooth");
    for (x, y, z) in [(5, 5, 5), (7, 5, 5), (0, 0, 0), (9, 2, 4)] {
        let p = [x, y, z].map(|i: u32| (i as f32 + 0.5) / n as f32 - 0.5);
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        let expect = (1.0 - r / radius).clamp(0.0, 1.0);
        assert!((v.at(x, y, z) - expect).abs() < 1e-6, "({x},{y},{z}): {} vs {expect}", v.at(x, y, z));
    }
    // Centre voxel (5,5,5) has r = 0.05*sqrt(3).
    assert!((v.at(5, 5, 5) - (1.0 - 0.05 * 3f32.sqrt() / radius)).abs() < 1e-6);
    assert_eq!(v.at(0, 0, 0), 0.0);
}

#[test]
fn procedural_cloud_is_deterministic_with_empty_border() {
    let dims = [24, 20, 16];
    let a = procedural::cloud(dims, 7).expect("cloud");
    let b = procedural::cloud(dims, 7).expect("cloud");
    let c = procedural::cloud(dims, 8).expect("cloud");
    assert_eq!(a.data, b.data);
    assert_ne!(a.data, c.data);
    assert!(a.data.iter().all(|&x| (0.0..=1.0).contains(&x)));
    assert!(a.value_range[1] > 0.1, "cloud is (almost) empty: {:?}", a.value_range);
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let border = [x, y, z].iter().zip(dims).any(|(&i, n)| i == 0 || i == n - 1);
                if border {
                    assert_eq!(a.at(x, y, z), 0.0, "border voxel ({x},{y},{z})");
                }
            }
        }
    }
}

#[test]
fn procedural_checker_shell() {
    let v = procedural::checker_shell([32; 3], 4).expect("shell");
    assert_eq!(v.at(16, 16, 16), 0.0, "centre is hollow");
    assert_eq!(v.at(0, 0, 0), 0.0, "corner is outside");
    let ones = v.data.iter().filter(|&&x| x == 1.0).count();
    assert!(ones > 100, "{ones}");
    assert!(v.data.iter().all(|&x| x == 0.0 || x == 1.0));
    // Along +x through the centre at r ~ 0.39 (x index 28, centre 0.890625): cell floor(3.56)=3, y/z cell 2 → odd.
    assert_eq!(v.at(28, 16, 16), 0.0);
    assert_eq!(v.at(4, 16, 16), 1.0); // x cell 0 + 2 + 2 = even, r ~ 0.36
}

#[test]
fn procedural_rejects_bad_parameters() {
    assert!(procedural::sphere([4; 3], 0.0, 1.0).is_err());
    assert!(procedural::homogeneous_box([4; 3], 1.5).is_err());
    assert!(procedural::checker_shell([4; 3], 0).is_err());
    let e = procedural::cloud([0, 4, 4], 1).expect_err("zero dim");
    assert!(e.to_string().contains("zero dimension"), "{e}");
}

#[test]
fn normalized_u16_is_exact_at_the_ends() {
    let v = Volume::new([4, 1, 1], [1.0; 3], vec![-3.0, 5.0, 1.0, -1.0], "mem").expect("volume");
    assert_eq!(v.value_range, [-3.0, 5.0]);
    assert_eq!(v.normalized_u16(), vec![0, 65535, 32768, 16384]);
    let zero = Volume::new([2, 1, 1], [1.0; 3], vec![0.0, 0.0], "mem").expect("volume");
    assert_eq!(zero.normalized_u16(), vec![0, 0]);
}

#[test]
fn volume_new_validates() {
    assert!(matches!(Volume::new([2, 2, 2], [1.0; 3], vec![0.0; 7], "mem"), Err(VolumeError::DataLength { .. })));
    assert!(matches!(Volume::new([0, 2, 2], [1.0; 3], vec![], "mem"), Err(VolumeError::ZeroDimension { .. })));
    assert!(matches!(Volume::new([1, 1, 1], [1.0, 0.0, 1.0], vec![0.0], "mem"), Err(VolumeError::BadSpacing { .. })));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn raw_u16_round_trip(dims in [1u32..6, 1u32..6, 1u32..6], seed in any::<u16>(), big in any::<bool>()) {
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let vals: Vec<u16> = (0..n).map(|i| seed.wrapping_mul(31).wrapping_add((i as u16).wrapping_mul(977))).collect();
        let endian = if big { Endian::Big } else { Endian::Little };
        let dir = tmpdir("prop_u16");
        let p = dir.join("v.raw");
        write(&p, &u16_bytes(&vals, endian));
        let v = load(&p, &LoadOptions { endian: Some(endian), ..opts(dims, VoxelType::U16) }).expect("load");
        prop_assert_eq!(v.data, vals.iter().map(|&x| f32::from(x)).collect::<Vec<_>>());
    }
}

// ---------------------------------------------------------------- bad input

#[test]
fn raw_truncated() {
    let dir = tmpdir("raw_trunc");
    let p = dir.join("v.raw");
    write(&p, &[0u8; 100]);
    let e = load_err(&p, &opts([5, 5, 5], VoxelType::U8), "truncated");
    assert!(e.to_string().contains("expected 125 bytes, got 100"), "{e}");
}

#[test]
fn raw_too_many_bytes_suggests_dims() {
    let dir = tmpdir("raw_big");
    let p = dir.join("v.raw");
    write(&p, &[0u8; 4096]);
    let e = load_err(&p, &opts([8, 8, 8], VoxelType::U8), "size mismatch");
    let msg = e.to_string();
    assert!(msg.contains("4096") && msg.contains("512"), "{msg}");
    assert!(msg.contains("16x16x16") && msg.contains("8x8x64"), "{msg}");
    assert!(matches!(e, VolumeError::SizeMismatch { expected: 512, got: 4096, .. }));
}

#[test]
fn zero_dimension() {
    let dir = tmpdir("zero_dim");
    let p = dir.join("v.raw");
    write(&p, &[0u8; 4]);
    load_err(&p, &opts([2, 0, 2], VoxelType::U8), "zero dimension");
    let p = dir.join("v.mhd");
    write(&p, mhd_header("4 0 1", "MET_UCHAR", "", "v.raw").as_bytes());
    load_err(&p, &LoadOptions::default(), "zero dimension");
}

#[test]
fn raw_missing_parameters() {
    let dir = tmpdir("raw_missing");
    let p = dir.join("v.raw");
    write(&p, &[0u8; 8]);
    let e = load_err(&p, &LoadOptions::default(), "missing dims and voxel type");
    assert!(e.to_string().contains("--dims") && e.to_string().contains("v.raw.json"), "{e}");
    load_err(&p, &LoadOptions { dims: Some([2, 2, 2]), ..LoadOptions::default() }, "missing voxel type");
    write(&dir.join("v.raw.json"), br#"{"type":"u8"}"#);
    load_err(&p, &LoadOptions::default(), "missing dims");
}

#[test]
fn bad_sidecar() {
    let dir = tmpdir("bad_sidecar");
    let p = dir.join("v.raw");
    write(&p, &[0u8; 8]);
    let side = dir.join("v.raw.json");
    write(&side, b"{\"dims\":[2,2,2],\n\"typo\":\"u8\"}");
    let e = load(&p, &LoadOptions::default()).expect_err("bad sidecar");
    let msg = e.to_string();
    assert!(msg.starts_with(&side.display().to_string()) && msg.contains(":2:") && msg.contains("typo"), "{msg}");
    write(&side, br#"{"dims":[2,2,2],"type":"complex64"}"#);
    let msg = load(&p, &LoadOptions::default()).expect_err("bad type").to_string();
    assert!(
        msg.starts_with(&side.display().to_string()) && msg.contains("unsupported voxel type \"complex64\""),
        "{msg}"
    );
}

#[test]
fn unparseable_header_values_report_line_numbers() {
    let dir = tmpdir("bad_header");
    let p = dir.join("v.mhd");
    write(&p, b"ObjectType = Image\nNDims = 3\nDimSize = 4 four 4\nElementType = MET_UCHAR\nElementDataFile = v.raw\n");
    let e = load_err(&p, &LoadOptions::default(), ":3: header error: DimSize value \"four\"");
    assert!(matches!(e, VolumeError::Header { line: 3, .. }));

    let p = dir.join("v.nrrd");
    write(&p, b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nspacings: 1 x 1\nencoding: raw\n\n12345678");
    let e = load_err(&p, &LoadOptions::default(), ":5: header error: spacings value \"x\"");
    assert!(matches!(e, VolumeError::Header { line: 5, .. }));

    write(&p, b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nbyte skip: -7\nencoding: raw\n\n12345678");
    load_err(&p, &LoadOptions::default(), ":5: header error: byte skip");

    let p = dir.join("notnrrd.nrrd");
    write(&p, b"P6\n2 2\n255\n");
    load_err(&p, &LoadOptions::default(), "not a NRRD file");
}

#[test]
fn unsupported_types() {
    let dir = tmpdir("bad_type");
    let p = dir.join("v.mha");
    write(&p, mhd_header("2 2 2", "MET_LONG_LONG", "", "LOCAL").as_bytes());
    let e = load_err(&p, &LoadOptions::default(), "unsupported voxel type \"MET_LONG_LONG\"");
    assert!(e.to_string().contains("line 4"), "{e}");
    let p = dir.join("v.nrrd");
    write(&p, nrrd_header("int64", "2 2 2", "raw", "").as_bytes());
    load_err(&p, &LoadOptions::default(), "unsupported voxel type \"int64\"");
}

#[test]
fn unsupported_encodings_rejected() {
    let dir = tmpdir("bzip2");
    let p = dir.join("v.nrrd");
    let mut bytes = nrrd_header("uchar", "2 2 2", "bzip2", "").into_bytes();
    bytes.extend(b"BZh91AY&SY");
    write(&p, &bytes);
    let e = load_err(&p, &LoadOptions::default(), "encoding \"bzip2\" is not supported");
    assert!(e.to_string().contains(":8:"), "{e}");
    write(&p, nrrd_header("uchar", "2 2 2", "ascii", "").as_bytes());
    load_err(&p, &LoadOptions::default(), "encoding \"ascii\" is not supported");
}

#[test]
fn multi_channel_rejected() {
    let dir = tmpdir("multichannel");
    let p = dir.join("v.mha");
    let mut bytes = mhd_header("2 2 2", "MET_UCHAR", "ElementNumberOfChannels = 3\n", "LOCAL").into_bytes();
    bytes.extend([0u8; 24]);
    write(&p, &bytes);
    load_err(&p, &LoadOptions::default(), "ElementNumberOfChannels = 3: only single-channel");

    let p = dir.join("v.nrrd");
    let mut bytes = b"NRRD0004\ntype: uchar\ndimension: 4\nsizes: 3 2 2 2\nencoding: raw\n\n".to_vec();
    bytes.extend([0u8; 24]);
    write(&p, &bytes);
    load_err(&p, &LoadOptions::default(), "only single-channel");
}

#[test]
fn corrupt_compressed_data() {
    let dir = tmpdir("corrupt_zlib");
    let p = dir.join("v.mha");
    let mut z = zlib(&[7u8; 64]);
    // After the 2-byte zlib header, 0xFF declares a final block of the reserved type 3, which is invalid.
    z[2] = 0xFF;
    let mut bytes = mhd_header("4 4 4", "MET_UCHAR", "CompressedData = True\n", "LOCAL").into_bytes();
    bytes.extend(&z);
    write(&p, &bytes);
    load_err(&p, &LoadOptions::default(), "cannot decompress");

    // Valid stream but too little data after decompression.
    let mut bytes = mhd_header("4 4 4", "MET_UCHAR", "CompressedData = True\n", "LOCAL").into_bytes();
    bytes.extend(zlib(&[7u8; 60]));
    write(&p, &bytes);
    load_err(&p, &LoadOptions::default(), "expected 64 bytes, got 60");

    let p = dir.join("g.nrrd");
    let mut bytes = nrrd_header("uchar", "4 4 4", "gzip", "").into_bytes();
    bytes.extend(gzip(&[7u8; 65]));
    write(&p, &bytes);
    load_err(&p, &LoadOptions::default(), "size mismatch");
}

#[test]
fn nan_is_replaced_with_a_warning() {
    let dir = tmpdir("nan");
    let p = dir.join("v.raw");
    let vals = [2.0f32, f32::NAN, 5.0, f32::NAN];
    write(&p, &vals.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>());
    let v = load(&p, &opts([2, 2, 1], VoxelType::F32)).expect("load");
    assert_eq!(v.data, [2.0, 2.0, 5.0, 2.0]);
    assert_eq!(v.value_range, [2.0, 5.0]);
    assert_eq!(v.warnings.len(), 1);
    assert!(v.warnings[0].contains("2 NaN voxel(s)") && v.warnings[0].contains("(1, 0, 0)"), "{:?}", v.warnings);

    write(&p, &[f32::NAN; 4].iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>());
    load_err(&p, &opts([2, 2, 1], VoxelType::F32), "4 non-finite voxel(s)");
}

#[test]
fn infinity_is_an_error() {
    let dir = tmpdir("inf");
    let p = dir.join("v.raw");
    let vals = [0.0f32, 1.0, 2.0, f32::INFINITY, 0.0, f32::NEG_INFINITY];
    write(&p, &vals.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>());
    let e = load_err(&p, &opts([3, 2, 1], VoxelType::F32), "2 non-finite voxel(s) (inf), first at (0, 1, 0)");
    assert!(matches!(e, VolumeError::NonFinite { count: 2, first: [0, 1, 0], .. }));
}

#[test]
fn negative_values_rejected_unless_allowed() {
    let dir = tmpdir("negative");
    let p = dir.join("v.raw");
    let vals: [i16; 4] = [100, -1000, 5, -3];
    write(&p, &vals.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>());
    let o = opts([2, 2, 1], VoxelType::I16);
    let e = load_err(&p, &o, "2 negative voxel(s), minimum -1000, first at (1, 0, 0)");
    assert!(e.to_string().contains("--allow-negative"), "{e}");
    let v = load(&p, &LoadOptions { allow_negative: true, ..o }).expect("allowed");
    assert_eq!(v.value_range, [-1000.0, 100.0]);
    assert_eq!(v.normalized_u16()[1], 0);
    assert_eq!(v.normalized_u16()[0], 65535);
}

#[test]
fn dims_over_max_dimension() {
    let dir = tmpdir("too_large");
    let p = dir.join("v.raw");
    write(&p, &[0u8; 16]);
    let o = LoadOptions { max_dimension: 8, ..opts([16, 1, 1], VoxelType::U8) };
    let e = load_err(&p, &o, "dims 16x1x1 exceed the largest accepted size, 8 voxels per axis");
    assert!(matches!(e, VolumeError::TooLarge { limit: 8, .. }));
    let p = dir.join("v.nrrd");
    write(&p, nrrd_header("uchar", "4096 2 2", "raw", "").as_bytes());
    load_err(&p, &LoadOptions::default(), "exceed the largest accepted size, 2048 voxels per axis");
}

#[test]
fn absurd_dims_do_not_overflow() {
    let dir = tmpdir("overflow");
    let huge = LoadOptions { max_dimension: u32::MAX, ..LoadOptions::default() };
    let p = dir.join("v.nrrd");
    write(&p, nrrd_header("double", "4294967295 4294967295 4294967295", "raw", "").as_bytes());
    load_err(&p, &huge, "too many voxels");
    // Larger than u32: rejected by the per-axis limit before any arithmetic.
    write(&p, nrrd_header("uchar", "99999999999999 1 1", "raw", "").as_bytes());
    load_err(&p, &huge, "exceed the largest accepted size");
    let p = dir.join("v.mhd");
    write(&p, mhd_header("2048 2048 2048", "MET_FLOAT", "", "v.raw").as_bytes());
    load_err(&p, &LoadOptions::default(), "too many voxels");
    let p = dir.join("v.raw");
    write(&p, &[0u8; 4]);
    load_err(
        &p,
        &LoadOptions { max_dimension: u32::MAX, ..opts([u32::MAX, u32::MAX, 2], VoxelType::F64) },
        "too many voxels",
    );
}

#[test]
fn bad_spacing() {
    let dir = tmpdir("spacing");
    let p = dir.join("v.mha");
    let mut bytes =
        b"NDims = 3\nDimSize = 1 1 1\nElementType = MET_UCHAR\nElementSpacing = 1 0 1\nElementDataFile = LOCAL\n"
            .to_vec();
    bytes.push(1);
    write(&p, &bytes);
    load_err(&p, &LoadOptions::default(), "bad spacing 1, 0, 1");
    let p = dir.join("v.raw");
    write(&p, &[1]);
    load_err(&p, &LoadOptions { spacing: Some([1.0, f32::NAN, 1.0]), ..opts([1, 1, 1], VoxelType::U8) }, "bad spacing");
}

#[test]
fn missing_files_are_io_errors() {
    let dir = tmpdir("missing");
    load_err(&dir.join("nope.raw"), &opts([1, 1, 1], VoxelType::U8), "cannot read");
    let p = dir.join("v.mhd");
    write(&p, mhd_header("1 1 1", "MET_UCHAR", "", "absent.raw").as_bytes());
    let e = load(&p, &LoadOptions::default()).expect_err("missing data file");
    assert!(e.to_string().contains("absent.raw") && e.to_string().contains("cannot read"), "{e}");
    let p = dir.join("v.nhdr");
    write(&p, b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n");
    load_err(&p, &LoadOptions::default(), "no \"data file\" field");
}
