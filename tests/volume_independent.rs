//! Files written by independent tools (nibabel, pydicom; `tools/independent_volumes.py`, run at
//! test time with the project's `.venv`, which `tools/setup.sh --python` provides): loaded in
//! memory and straight into bricks, their values match what those tools read themselves
//! (nibabel's scaling and reorientation, pydicom's pixel data, rescale and frame order).

use std::path::{Path, PathBuf};
use std::process::Command;

use vkengine::volume::data::bricks::Bricks;
use vkengine::volume::data::stats::gradient_magnitudes;
use vkengine::volume::data::{load, IntoBricks, LoadOptions};

/// The Python with nibabel and pydicom: `VKENGINE_PYTHON`, else the project's `.venv`.
fn python() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("VKENGINE_PYTHON") {
        return Some(PathBuf::from(p));
    }
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python");
    venv.exists().then_some(venv)
}

/// Values the tools read (x fastest, patient axes) and their dims.
fn expected(dir: &Path, name: &str) -> ([u32; 3], Vec<f32>) {
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join(format!("{name}.json"))).expect("json")).expect("json");
    let dims = [0, 1, 2].map(|i| meta["dims"][i].as_u64().expect("dims") as u32);
    let bytes = std::fs::read(dir.join(format!("{name}.f32"))).expect("values");
    (dims, bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
}

#[test]
fn nibabel_and_pydicom_files_load_as_those_tools_read_them() {
    let Some(py) = python() else {
        // tools/test.sh always has it (setup.sh --python); a bare `cargo test` may not.
        eprintln!("skipped: no .venv/bin/python (run tools/setup.sh --python)");
        return;
    };
    let dir = std::env::temp_dir().join(format!("vkengine-independent-{}", std::process::id()));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/independent_volumes.py");
    let out = Command::new(&py).arg(&script).arg(&dir).output().expect("run python");
    assert!(out.status.success(), "{}: {}", script.display(), String::from_utf8_lossy(&out.stderr));
    let o = LoadOptions { allow_negative: true, ..LoadOptions::default() };
    let bricks = LoadOptions { bricks: Some(IntoBricks { always: true, max_image_3d: 4096 }), ..o.clone() };
    let nifti = ["nib_scaled.nii.gz", "nib_float.nii", "nib_ras.nii", "nib_reversed.nii.gz"];
    let dicom = ["pydicom_series", "pydicom_series_reversed", "pydicom_multiframe.dcm", "pydicom_rtdose.dcm"];
    for name in nifti.into_iter().chain(dicom) {
        let (dims, want) = expected(&dir, name);
        let p = dir.join(name);
        let v = load(&p, &o).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(v.dims, dims, "{name}");
        // In memory: the decoded values themselves (f64 rescale rounded to f32 on both sides).
        let first = v.data.iter().zip(&want).position(|(a, b)| a != b);
        assert_eq!(first.map(|i| (i, v.data[i], want[i])), None, "{name}: first voxel differing from the tool's");
        // In bricks: each voxel within half a quantization step of the tool's value (the
        // volume keeps 16-bit normalized samples), plus the f32 rounding of the range.
        let b = load(&p, &bricks).unwrap_or_else(|e| panic!("{e}"));
        let built = b.bricks_only().unwrap_or_else(|| panic!("{name}: not loaded into bricks"));
        // And (a consistency check) bit for bit the bricks the renderer builds from the volume.
        let q = v.normalized_u16();
        assert!(built.bricks == Bricks::build(&q, &gradient_magnitudes(&q, v.dims), v.dims).expect("bricks"), "{name}");
        assert_eq!((b.dims, b.value_range), (v.dims, v.value_range), "{name}");
        let [lo, hi] = v.value_range;
        let tol = f64::from(hi - lo) / 65535.0 / 2.0 + f64::from(hi.abs().max(lo.abs())) * f64::from(f32::EPSILON);
        let worst = b.values().zip(&want).map(|(a, &w)| (f64::from(a) - f64::from(w)).abs()).fold(0.0, f64::max);
        assert!(worst <= tol, "{name}: a voxel in bricks is {worst} from the tool's value (bound {tol})");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
