//! A two-grid OpenVDB fireball written by OpenVDB's own Python module
//! (tools/make_vdb_fireball.py, /usr/bin/python3 with Debian's python3-openvdb): `density` and
//! `temperature` chosen by name render a glowing ball in MCM; a temperature grid on another box,
//! a NaN temperature, a missing grid and a bad range each get one error line and exit 2.

#[path = "../../tests/common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Writes the files, or (None) skips where pyopenvdb is missing — a failure where validation is
/// required (CI), where tools/setup.sh installs it.
fn files() -> Option<PathBuf> {
    let python = common::openvdb_python()?;
    let dir = std::env::temp_dir().join(format!("vkengine-vdb-fire-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tools/make_vdb_fireball.py");
    let out = Command::new(python).arg(script).arg(&dir).output().expect("run the script");
    assert!(out.status.success(), "make_vdb_fireball.py: {}", String::from_utf8_lossy(&out.stderr));
    Some(dir)
}

/// `volume` on `file` in MCM with the temperature grid, plus `extra` settings, into `out`.
fn render(file: &Path, extra: &[&str], out: &Path) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_volume"));
    common::child_device(&mut c);
    c.env("VKENGINE_VALIDATION", common::child_validation())
        .args(["--headless", "--renderer", "mcm", "--size", "32x32", "--frames", "4", "--seed", "1"])
        .arg("--volume")
        .arg(file)
        .args(["--set", "tf=ramp:0,1", "--set", "density=0.1", "--set", "sun=0", "--set", "env=0"])
        .args(["--set", "emission=4", "--set", "albedo=0.3", "--set", "temperature_grid=temperature"]);
    for s in extra {
        c.args(["--set", s]);
    }
    c.arg("--out").arg(out).output().expect("run volume")
}

/// Mean linear radiance of an EXR.
fn mean(path: &Path) -> f64 {
    let img = image::open(path).expect("exr").to_rgba32f();
    let px = img.pixels().map(|p| f64::from(p.0[0] + p.0[1] + p.0[2])).sum::<f64>();
    px / f64::from(img.width() * img.height())
}

#[test]
fn a_two_grid_fireball_glows_and_bad_grids_are_refused() {
    let Some(dir) = files() else { return };
    let fire = dir.join("fireball.vdb");
    // Without a light only the emission shows: a glowing ball; above the hottest temperature
    // (range 4000–5000 K) nothing emits, and the image is black.
    let out = render(&fire, &["temperature_range=700,3000"], &dir.join("hot.exr"));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && !err.contains("VUID"), "{err}");
    let cold = render(&fire, &["temperature_range=4000,5000"], &dir.join("cold.exr"));
    assert!(cold.status.success(), "{}", String::from_utf8_lossy(&cold.stderr));
    let (hot, cold) = (mean(&dir.join("hot.exr")), mean(&dir.join("cold.exr")));
    eprintln!("mean radiance: 700–3000 K {hot:.4}, 4000–5000 K {cold}");
    assert!(hot > 0.01 && cold == 0.0, "hot {hot}, cold {cold}");
    for (file, extra, says) in [
        ("shifted.vdb", "temperature_range=700,3000", "resampling is not supported"),
        ("nan.vdb", "temperature_range=700,3000", "temperatures must be finite"),
        ("fireball.vdb", "temperature_grid=heat", "no grid named heat"),
        ("fireball.vdb", "temperature_range=-5,3000", "temperature_range"),
        ("fireball.vdb", "temperature_range=3000,700", "temperature_range"),
    ] {
        let out = render(&dir.join(file), &[extra], &dir.join("bad.exr"));
        let err = String::from_utf8_lossy(&out.stderr);
        let line = err.lines().find(|l| l.starts_with("error:")).unwrap_or_default();
        assert_eq!(out.status.code(), Some(2), "{file} {extra}: {err}");
        assert!(line.contains(says), "{file} {extra}: `{line}` does not say `{says}`");
    }
    std::fs::remove_dir_all(&dir).ok();
}
