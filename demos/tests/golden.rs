//! Output stability: a fixed set of configurations — every demo's default, every volume
//! renderer, LPV with each injection and propagation variant, each extension on — rendered to
//! linear EXR and compared pixel by pixel with the images the engine produced when they were
//! recorded (`tests/golden/*.exr`). Refactors must not change what the engine draws.
//!
//! This is a regression check, not an accuracy check: the goldens are the engine's own output.
//! They were recorded on lavapipe (llvmpipe 256-bit, Mesa 22.3.6); another driver rounds
//! differently, so the comparison runs only on lavapipe. Re-record deliberately with
//! `VKENGINE_BLESS=1 cargo test --test golden` and say why in the commit.

#[path = "../../tests/common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// Relative tolerance per pixel and channel (float-atomic variants sum in a racy order).
const REL: f32 = 1e-5;
/// Absolute floor, far below what an 8-bit display resolves.
const ABS: f32 = 1e-7;

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/golden")
}

/// `(name, binary, arguments)`, one line each in `tests/golden/configs.txt`.
fn configs() -> Vec<(String, String, Vec<String>)> {
    let text = std::fs::read_to_string(golden_dir().join("configs.txt")).expect("tests/golden/configs.txt");
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            let mut it = l.split_whitespace().map(String::from);
            let name = it.next().expect("name");
            let bin = it.next().expect("binary");
            (name, bin, it.collect())
        })
        .collect()
}

fn exe(bin: &str) -> &'static str {
    match bin {
        "volume" => env!("CARGO_BIN_EXE_volume"),
        "cornell" => env!("CARGO_BIN_EXE_cornell"),
        "atrium" => env!("CARGO_BIN_EXE_atrium"),
        "hello" => env!("CARGO_BIN_EXE_hello"),
        other => panic!("configs.txt names unknown binary `{other}`"),
    }
}

fn render(bin: &str, args: &[String], out: &Path) -> Result<(), String> {
    let icd = common::lavapipe_icd().ok_or("lavapipe ICD not installed (tools/setup.sh)")?;
    let res = Command::new(exe(bin))
        .env("VK_DRIVER_FILES", &icd)
        .env("VKENGINE_VALIDATION", common::child_validation())
        .arg("--headless")
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .map_err(|e| format!("{bin}: {e}"))?;
    if res.status.success() {
        Ok(())
    } else {
        Err(format!("{bin} {}: {}", args.join(" "), String::from_utf8_lossy(&res.stderr)))
    }
}

fn load(path: &Path) -> Result<(u32, u32, Vec<f32>), String> {
    let img = image::open(path).map_err(|e| format!("{}: {e}", path.display()))?.to_rgba32f();
    Ok((img.width(), img.height(), img.into_raw()))
}

/// The first differing pixel beyond tolerance and how many differ, if any.
fn compare(name: &str, golden: &Path, fresh: &Path) -> Result<(), String> {
    let (gw, gh, g) = load(golden)?;
    let (fw, fh, f) = load(fresh)?;
    if (gw, gh) != (fw, fh) {
        return Err(format!("{name}: size {fw}x{fh}, golden {gw}x{gh}"));
    }
    let mut bad = 0usize;
    let mut first = None;
    let mut worst = 0f32;
    for (i, (&a, &b)) in g.iter().zip(&f).enumerate() {
        let d = (a - b).abs();
        // A NaN on one side only makes `within` false, as it should.
        let within = d <= REL * a.abs().max(b.abs()) + ABS || (a.is_nan() && b.is_nan());
        if !within {
            bad += 1;
            worst = worst.max(d / a.abs().max(b.abs()).max(ABS));
            first.get_or_insert((i / 4, i % 4, a, b));
        }
    }
    match first {
        None => Ok(()),
        Some((p, c, a, b)) => Err(format!(
            "{name}: {bad} values differ (worst relative {worst:.2e}); first at pixel ({}, {}) channel {c}: golden {a}, now {b}",
            p as u32 % gw,
            p as u32 / gw
        )),
    }
}

#[test]
fn every_configuration_renders_as_recorded() {
    let bless = std::env::var("VKENGINE_BLESS").is_ok_and(|v| v == "1");
    let dir = std::env::temp_dir().join(format!("vkengine-golden-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut failures = Vec::new();
    let list = configs();
    assert!(list.len() >= 20, "configs.txt lost its configurations");
    for (name, bin, args) in &list {
        // `hello` writes only 8-bit PNG; everything else linear EXR.
        let file = if name.contains('.') { name.clone() } else { format!("{name}.exr") };
        let golden = golden_dir().join(&file);
        let fresh = if bless { golden.clone() } else { dir.join(&file) };
        if let Err(e) = render(bin, args, &fresh) {
            failures.push(e);
            continue;
        }
        if !bless {
            if let Err(e) = compare(name, &golden, &fresh) {
                failures.push(e);
            }
            // Renderers with depth output write `NAME-depth.exr` beside the image.
            let depth = |p: &Path| p.with_file_name(format!("{name}-depth.exr"));
            if args.iter().any(|a| a.starts_with("depth_threshold=")) {
                if let Err(e) = compare(&format!("{name} depth"), &depth(&golden), &depth(&fresh)) {
                    failures.push(e);
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        failures.is_empty(),
        "{} of {} configurations changed:\n{}",
        failures.len(),
        list.len(),
        failures.join("\n")
    );
}
