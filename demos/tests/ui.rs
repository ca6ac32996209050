//! The interactive UI under a real X server (Xvfb in CI): the demo binaries open a window, a
//! `--ui-script` clicks widgets by name, and the screenshots, transfer functions and scene
//! files the UI writes are checked against what the CLI renders headless. Each run is under the
//! validation layer; any message makes the demo exit non-zero.

#[path = "../../tests/common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use vkengine::volume::optics::tf::{TfPoint, TransferFunction};

fn demo(exe: &str) -> Command {
    let mut c = Command::new(exe);
    common::child_device(&mut c);
    c.env("VKENGINE_VALIDATION", common::child_validation());
    c
}

fn have_display() -> bool {
    common::have_display("the UI tests")
}

fn run(mut c: Command, what: &str) {
    let out = c.output().unwrap_or_else(|e| panic!("{what}: {e}"));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{what} failed ({}):\n{err}", out.status);
    assert!(!err.contains("vulkan validation"), "{what} printed validation messages:\n{err}");
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vkengine-ui-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

fn exr(path: &Path) -> Vec<[f32; 4]> {
    let img = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).into_rgba32f();
    img.pixels().map(|p| p.0).collect()
}

/// Root-mean-square difference over RGB.
fn rms(a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    assert_eq!(a.len(), b.len(), "image sizes differ");
    let s: f64 = a.iter().zip(b).map(|(x, y)| (0..3).map(|c| f64::from(x[c] - y[c]).powi(2)).sum::<f64>()).sum();
    (s / (3 * a.len()) as f64).sqrt()
}

const SIZE: &str = "480x360";

fn headless_volume(out: &Path, extra: &[&str]) -> Vec<[f32; 4]> {
    headless_volume_at(SIZE, out, extra)
}

fn headless_volume_at(size: &str, out: &Path, extra: &[&str]) -> Vec<[f32; 4]> {
    let mut c = demo(env!("CARGO_BIN_EXE_volume"));
    c.args(["--headless", "--size", size, "--set", "n=32", "--out"]).arg(out).args(extra);
    run(c, "headless volume");
    exr(out)
}

#[test]
fn clicking_the_renderer_switches_it_and_a_saved_session_replays_headless() {
    if !have_display() {
        return;
    }
    let d = dir("volume");
    let script = "3:screenshot;5:click=renderer;8:click=renderer:mip;11:screenshot;12:save-scene;14:quit";
    let mut c = demo(env!("CARGO_BIN_EXE_volume"));
    c.args(["--window", "--size", SIZE, "--set", "n=32", "--renderer", "eam", "--ui-script", script, "--out"])
        .arg(d.join("shot.png"));
    run(c, "windowed volume");
    let (before, after) = (exr(&d.join("shot-001.exr")), exr(&d.join("shot-002.exr")));
    let eam = headless_volume(&d.join("eam.exr"), &["--renderer", "eam"]);
    let mip = headless_volume(&d.join("mip.exr"), &["--renderer", "mip"]);
    let gap = rms(&eam, &mip);
    assert!(gap > 0.01, "EAM and MIP must differ for this test to mean anything (rms {gap})");
    // Each screenshot matches its renderer's headless image far better than the other one's
    // (the window accumulates jittered frames, headless renders pixel centres).
    let (b_eam, b_mip) = (rms(&before, &eam), rms(&before, &mip));
    let (a_eam, a_mip) = (rms(&after, &eam), rms(&after, &mip));
    eprintln!("rms EAM↔MIP {gap:.4}; before: to EAM {b_eam:.4}, to MIP {b_mip:.4}; after: to MIP {a_mip:.4}, to EAM {a_eam:.4}");
    assert!(b_eam < 0.2 * b_mip, "before the click: rms to EAM {b_eam}, to MIP {b_mip}");
    assert!(a_mip < 0.2 * a_eam, "after the click: rms to MIP {a_mip}, to EAM {a_eam}");
    // The saved session reproduces the window's view headless.
    let session = d.join("shot-scene.toml");
    let text = std::fs::read_to_string(&session).expect("session written");
    assert!(text.contains("renderer = \"mip\""), "{text}");
    let mut c = demo(env!("CARGO_BIN_EXE_volume"));
    c.args(["--headless", "--size", SIZE, "--scene"]).arg(&session).arg("--out").arg(d.join("replay.exr"));
    run(c, "session replay");
    let replay = exr(&d.join("replay.exr"));
    let r = rms(&replay, &after);
    eprintln!("replay vs window {r:.4}");
    assert!(r < 0.2 * a_eam, "replayed session vs window screenshot: rms {r} (EAM is {a_eam} away)");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn the_clipping_panel_turns_a_clip_plane_on_and_the_saved_session_keeps_it() {
    if !have_display() {
        return;
    }
    let d = dir("clip");
    // Close the open groups, open Clipping, tick `clip` (on at its initial plane 0,0,0,1,0,0), then save.
    // A tall window, so that the panel's scroll area shows the Clipping group without scrolling.
    let size = "320x960";
    let script = "2:click=Renderer;3:click=Display;5:click=Clipping;8:click=clip;11:screenshot;12:save-scene;14:quit";
    let mut c = demo(env!("CARGO_BIN_EXE_volume"));
    c.args(["--window", "--size", size, "--set", "n=32", "--renderer", "eam", "--ui-script", script, "--out"])
        .arg(d.join("shot.png"));
    run(c, "windowed volume");
    let text = std::fs::read_to_string(d.join("shot-scene.toml")).expect("session written");
    assert!(text.contains("clip = \"0,0,0,1,0,0\""), "{text}");
    let shot = exr(&d.join("shot-001.exr"));
    let cut = headless_volume_at(size, &d.join("cut.exr"), &["--renderer", "eam", "--set", "clip=0,0,0,1,0,0"]);
    let whole = headless_volume_at(size, &d.join("whole.exr"), &["--renderer", "eam"]);
    let (to_cut, to_whole) = (rms(&shot, &cut), rms(&shot, &whole));
    eprintln!("window after ticking clip: rms to the clipped image {to_cut:.4}, to the whole {to_whole:.4}");
    assert!(to_cut < 0.2 * to_whole, "the window should show the clipped volume: {to_cut} vs {to_whole}");
    let _ = std::fs::remove_dir_all(&d);
}

/// A 32³ label map for `--set n=32`: label 1 in the half x < 16, label 2 in the other.
fn two_label_halves(d: &Path) -> PathBuf {
    let path = d.join("halves.raw");
    let row: Vec<u8> = (0..32).map(|x| if x < 16 { 1 } else { 2 }).collect();
    std::fs::write(&path, row.repeat(32 * 32)).expect("label file");
    std::fs::write(d.join("halves.raw.json"), r#"{"dims":[32,32,32],"type":"u8"}"#).expect("sidecar");
    path
}

#[test]
fn the_segments_panel_hides_a_label_sets_an_opacity_and_the_saved_session_keeps_both() {
    if !have_display() {
        return;
    }
    let d = dir("segments");
    let labels = two_label_halves(&d);
    let labels = labels.to_str().expect("utf-8 temp path");
    // Open Segments (the panel's first group with a label map), untick label 2, press label 1's
    // opacity slider (which moves it to its middle), then save. Wide enough that the
    // profiler window does not cover the panel.
    let size = "640x960";
    let script = "5:click=Segments;8:click=segment:2;10:press=segment-opacity:1;13:screenshot;14:save-scene;16:quit";
    let mut c = demo(env!("CARGO_BIN_EXE_volume"));
    c.args([
        "--window",
        "--size",
        size,
        "--set",
        "n=32",
        "--renderer",
        "eam",
        "--labels",
        labels,
        "--ui-script",
        script,
    ])
    .arg("--out")
    .arg(d.join("shot.png"));
    run(c, "windowed volume with labels");
    let text = std::fs::read_to_string(d.join("shot-scene.toml")).expect("session written");
    assert!(text.contains("label_hide = \"2\""), "{text}");
    let opacity = text
        .lines()
        .find_map(|l| l.strip_prefix("label_opacity = \"1:")?.strip_suffix('"'))
        .unwrap_or_else(|| panic!("label 1's opacity saved: {text}"));
    let a: f32 = opacity.parse().expect("an opacity");
    assert!(a > 0.05 && a < 0.95, "the click should move the slider inside its range: {a}");
    let shot = exr(&d.join("shot-001.exr"));
    let base = ["--renderer", "eam", "--labels", labels];
    let set = format!("label_opacity=1:{opacity}");
    let edited = [&base[..], &["--set", "label_hide=2", "--set", &set]].concat();
    let edited = headless_volume_at(size, &d.join("edited.exr"), &edited);
    let hidden = headless_volume_at(size, &d.join("hidden.exr"), &[&base[..], &["--set", "label_hide=2"]].concat());
    let both = headless_volume_at(size, &d.join("both.exr"), &base);
    let (to_edited, to_hidden, to_both) = (rms(&shot, &edited), rms(&shot, &hidden), rms(&shot, &both));
    eprintln!(
        "window after unticking label 2 and setting label 1's opacity to {a}: rms to that image {to_edited:.4}, to label 2 hidden alone {to_hidden:.4}, to both labels {to_both:.4}"
    );
    assert!(to_edited < 0.2 * to_both, "the window should hide label 2: {to_edited} vs {to_both}");
    assert!(to_edited < 0.2 * to_hidden, "the window should show label 1's new opacity: {to_edited} vs {to_hidden}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_transfer_function_saved_from_the_editor_loads_identically_from_the_cli() {
    if !have_display() {
        return;
    }
    let d = dir("tf");
    let tf_path = d.join("shot.tf.json");
    // Open the editor, pick the bone preset, add a point after the first, save, screenshot.
    let script = "2:click=tf:open;5:click=tf:preset:bone;8:click=tf:add;11:click=tf:save;14:screenshot;16:quit";
    let mut c = demo(env!("CARGO_BIN_EXE_volume"));
    c.args(["--window", "--size", SIZE, "--set", "n=32", "--renderer", "eam", "--ui-script", script, "--out"])
        .arg(d.join("shot.png"));
    run(c, "windowed volume with the TF editor");
    let saved = TransferFunction::load(&tf_path).expect("the CLI's loader reads the editor's file");
    // What the clicks should have made: bone, with a point halfway between its first two.
    let TransferFunction::OneD { mut points } = TransferFunction::preset("bone").expect("preset") else {
        panic!("bone is 1D")
    };
    let mid = TfPoint { value: 0.5 * (points[0].value + points[1].value), ..points[0] };
    points.insert(1, mid);
    assert_eq!(saved, TransferFunction::OneD { points }, "saved TF");
    assert_eq!(saved.bake(), TransferFunction::load(&tf_path).expect("reload").bake(), "bakes identically");
    // The window rendered with exactly that function: it matches the CLI's render with
    // `--set tf=FILE` far better than the default (cloud) function's.
    let shot = exr(&d.join("shot-001.exr"));
    let tf_arg = format!("tf={}", tf_path.display());
    let with_tf = headless_volume(&d.join("cli-tf.exr"), &["--renderer", "eam", "--set", &tf_arg]);
    let default = headless_volume(&d.join("cli-default.exr"), &["--renderer", "eam"]);
    let (near, far) = (rms(&shot, &with_tf), rms(&shot, &default));
    eprintln!("window vs CLI: with the saved TF {near:.4}, with the default TF {far:.4}");
    assert!(near < 0.2 * far, "window vs CLI with the saved TF: rms {near}; vs default TF: {far}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn mesh_window_toggles_the_lpv_and_its_saved_scene_replays_headless() {
    if !have_display() {
        return;
    }
    let d = dir("mesh");
    // The LPV section is open by default; its first control is the on/off switch.
    let script = "3:screenshot;4:click=lpv;7:screenshot;8:save-scene;10:quit";
    let mut c = demo(env!("CARGO_BIN_EXE_cornell"));
    c.args(["--window", "--size", SIZE, "--ui-script", script, "--out"]).arg(d.join("cornell.png"));
    run(c, "windowed cornell");
    let (off, on) = (exr(&d.join("cornell-001.exr")), exr(&d.join("cornell-002.exr")));
    let scene = d.join("cornell-scene.toml");
    let text = std::fs::read_to_string(&scene).expect("scene written");
    assert!(text.contains("lpv = \"1\""), "{text}");
    let mut c = demo(env!("CARGO_BIN_EXE_scene"));
    c.args(["--headless", "--size", SIZE, "--scene"]).arg(&scene).arg("--out").arg(d.join("replay.exr"));
    run(c, "scene replay");
    let replay = exr(&d.join("replay.exr"));
    let gap = rms(&off, &on);
    assert!(gap > 1e-3, "turning the LPV on must change the image (rms {gap})");
    let r = rms(&replay, &on);
    eprintln!("LPV off→on {gap:.4}; replay vs window {r:.6}");
    assert!(r < 0.05 * gap, "replayed scene vs window with LPV: rms {r}, LPV off→on changed it by {gap}");
    let _ = std::fs::remove_dir_all(&d);
}

/// Width and height of an image file.
fn dims(path: &Path) -> (u32, u32) {
    let img = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (img.width(), img.height())
}

#[test]
fn every_demo_window_matches_its_headless_image_after_a_resize_and_a_minimize() {
    if !have_display() {
        return;
    }
    // Each demo opens at 160×120, is resized to 128×96 (the swapchain and every target follow),
    // minimized and restored (a no-op without a window manager, as under a bare Xvfb), then takes
    // a scene screenshot: it must be 128×96 and match the headless image of the same settings —
    // far closer than the headless image of a different renderer or setting.
    let d = dir("smoke");
    let script = "3:resize=128x96;5:minimize;7:restore;12:screenshot;14:quit";
    let glossy = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/glossy-room.toml");
    type Case<'a> = (&'a str, &'a str, Vec<&'a str>, Vec<&'a str>);
    let cases: Vec<Case> = vec![
        ("atrium", env!("CARGO_BIN_EXE_atrium"), vec![], vec!["--set", "ambient=0.3"]),
        ("scene", env!("CARGO_BIN_EXE_scene"), vec!["--scene", glossy], vec!["--set", "ambient=0.3"]),
        (
            "mcm",
            env!("CARGO_BIN_EXE_volume"),
            vec!["--set", "n=32", "--renderer", "mcm"],
            vec!["--set", "renderer=eam"],
        ),
        (
            "lao",
            env!("CARGO_BIN_EXE_volume"),
            vec!["--set", "n=32", "--renderer", "lao"],
            vec!["--set", "renderer=eam"],
        ),
        (
            "dos",
            env!("CARGO_BIN_EXE_volume"),
            vec!["--set", "n=32", "--renderer", "dos"],
            vec!["--set", "renderer=eam"],
        ),
    ];
    for (name, exe, args, other) in cases {
        let mut c = demo(exe);
        c.args(["--window", "--size", "160x120", "--ui-script", script])
            .args(&args)
            .arg("--out")
            .arg(d.join(format!("{name}.png")));
        run(c, &format!("windowed {name}"));
        let shot = d.join(format!("{name}-001.exr"));
        assert_eq!(dims(&shot), (128, 96), "{name}: the screenshot after the resize");
        let headless = |file: &str, extra: &[&str]| {
            let out = d.join(file);
            let mut c = demo(exe);
            // Several frames: the window jitters and accumulates, so the headless run does too.
            c.args(["--headless", "--size", "128x96", "--frames", "8"]).args(&args).args(extra).arg("--out").arg(&out);
            run(c, &format!("headless {name}"));
            exr(&out)
        };
        let window = exr(&shot);
        let same = headless(&format!("{name}-same.exr"), &[]);
        let changed = headless(&format!("{name}-other.exr"), &other);
        let (near, far) = (rms(&window, &same), rms(&window, &changed));
        eprintln!("{name}: window vs headless {near:.5}, vs {other:?} {far:.5}");
        assert!(near < 0.25 * far, "{name}: window vs headless rms {near}, vs {other:?} {far}");
    }
    let _ = std::fs::remove_dir_all(&d);
}
