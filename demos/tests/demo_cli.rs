//! The default demo as a user runs it: headless PNG + report, and clear errors for bad flags.

#[path = "../../tests/common/mod.rs"]
mod common;

use std::process::Command;

/// A demo executable on the device the suite tests (lavapipe unless VKENGINE_TEST_DEVICE=system).
fn demo(exe: &str) -> Command {
    let mut c = Command::new(exe);
    common::child_device(&mut c);
    c
}

/// A demo executable pinned to lavapipe, under the validation layer (required in CI).
fn validated(exe: &str) -> Command {
    let mut c = demo(exe);
    c.env("VKENGINE_VALIDATION", common::child_validation());
    c
}

#[test]
fn hello_renders_png_and_report_headless() {
    let dir = std::env::temp_dir().join(format!("vkengine-demo-{}", std::process::id()));
    let (png, report) = (dir.join("hello.png"), dir.join("hello.json"));
    let out = validated(env!("CARGO_BIN_EXE_hello"))
        .args(["--headless", "--size", "48x32", "--frames", "2", "--out"])
        .arg(&png)
        .arg("--report")
        .arg(&report)
        .output()
        .expect("run hello");
    assert!(out.status.success(), "hello failed: {}", String::from_utf8_lossy(&out.stderr));
    let img = image::open(&png).expect("PNG readable").to_rgba8();
    assert_eq!(img.dimensions(), (48, 32));
    // The sphere's centre is lit and warm; the corner is sky (blue dominates).
    let c = img.get_pixel(24, 16);
    assert!(c[0] > c[2], "centre should be the orange sphere: {c:?}");
    let k = img.get_pixel(0, 0);
    assert!(k[2] > k[0], "corner should be sky: {k:?}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    let names: Vec<_> =
        json["passes"].as_array().expect("passes").iter().map(|p| p["name"].as_str().unwrap_or("")).collect();
    assert_eq!(names, ["scene", "tonemap"]);
    assert!(json["device"]["name"].as_str().is_some_and(|n| n.contains("llvmpipe")));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_arguments_exit_2_with_one_clear_line() {
    let out = Command::new(env!("CARGO_BIN_EXE_hello")).args(["--headless", "--size", "0x10"]).output().expect("run");
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--size") && err.contains("0x10"), "{err}");
}

#[test]
fn a_gpu_timeout_ends_the_run_with_exit_1_and_one_clear_line() {
    // 1 µs is shorter than any submission on lavapipe: the first wait (an upload or the first
    // frame) times out. The run must end promptly, name the setting, and stay validation-clean.
    let dir = std::env::temp_dir().join(format!("vkengine-timeout-{}", std::process::id()));
    let start = std::time::Instant::now();
    let out = validated(env!("CARGO_BIN_EXE_volume"))
        .args(["--headless", "--renderer", "mcm", "--size", "64x64", "--gpu-timeout", "0.000001", "--out"])
        .arg(dir.join("t.png"))
        .output()
        .expect("run volume");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    let line = err.lines().find(|l| l.starts_with("error:")).unwrap_or_default();
    assert!(line.contains("GPU timeout") && line.contains("--gpu-timeout"), "{err}");
    assert!(line.contains("frame ") || line.contains("submission "), "the line names no work: {err}");
    assert!(!err.contains("VUID") && !err.contains("Validation"), "validation spoke: {err}");
    assert!(start.elapsed() < std::time::Duration::from_secs(60), "took {:?}", start.elapsed());
    let bad = demo(env!("CARGO_BIN_EXE_hello")).args(["--headless", "--gpu-timeout", "0"]).output().expect("run");
    assert_eq!(bad.status.code(), Some(2), "a zero timeout is bad input");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn volume_demo_renders_each_renderer_and_writes_exr() {
    let dir = std::env::temp_dir().join(format!("vkengine-volume-demo-{}", std::process::id()));
    for (renderer, ext) in [("mip", "png"), ("iso", "png"), ("eam", "exr")] {
        let out_path = dir.join(format!("v-{renderer}.{ext}"));
        let out = validated(env!("CARGO_BIN_EXE_volume"))
            .args([
                "--headless",
                "--size",
                "40x32",
                "--set",
                "n=24",
                "--set",
                "scene=sphere",
                "--renderer",
                renderer,
                "--out",
            ])
            .arg(&out_path)
            .output()
            .expect("run volume");
        assert!(out.status.success(), "volume --renderer {renderer} failed: {}", String::from_utf8_lossy(&out.stderr));
        let img = image::open(&out_path).expect("output readable");
        assert_eq!((img.width(), img.height()), (40, 32));
        // The sphere fills the centre: something other than the background is there.
        let c = img.to_rgba32f().get_pixel(20, 16).0;
        let k = img.to_rgba32f().get_pixel(0, 0).0;
        assert!((c[0] - k[0]).abs() > 0.05, "{renderer}: centre {c:?} looks like background {k:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bricks_past_the_device_are_refused_after_the_first_pass_with_exit_2() {
    // 64³ u16 voxels varying in every brick: 512 slots of 9³ texels (1458 bytes each per
    // quantity), past 4 atlases of 44 slots each under a 64 KiB largest allocation; lod=0 asks
    // for them (without it a coarser level is shown: a_volume_past_gpu_memory_renders_at_…).
    let dir = std::env::temp_dir().join(format!("vkengine-volume-fit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let p = dir.join("varying.raw");
    let bytes: Vec<u8> = (0..64 * 64 * 64usize)
        .flat_map(|i| ((((i % 64) * 7 + (i / 64 % 64) * 13 + (i / 4096) * 29) % 4001) as u16).to_le_bytes())
        .collect();
    std::fs::write(&p, bytes).expect("write");
    let out = validated(env!("CARGO_BIN_EXE_volume"))
        .env("VKENGINE_MAX_ALLOCATION", "65536")
        .args(["--headless", "--frames", "1", "--set", "lod=0", "--dims", "64,64,64", "--type", "u16", "--volume"])
        .arg(&p)
        .output()
        .expect("run volume");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let line = err.lines().find(|l| l.contains("varying.raw")).unwrap_or_default();
    for part in ["512 brick slots (512 of 512 bricks stored)", "past 4 atlases", "65536 bytes", "before bricking"] {
        assert!(line.contains(part), "lacks {part}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn volume_demo_rejects_bad_input_with_exit_2() {
    let dir = std::env::temp_dir().join(format!("vkengine-volume-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let truncated = dir.join("truncated.raw");
    std::fs::write(&truncated, [0u8; 100]).expect("write");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "--volume".into(),
                truncated.display().to_string(),
                "--dims".into(),
                "8,8,8".into(),
                "--type".into(),
                "u8".into(),
            ],
            "truncated.raw",
        ),
        (vec!["--volume".into(), dir.join("missing.nrrd").display().to_string()], "missing.nrrd"),
        (vec!["--set".into(), "scene=teapot".into()], "scene=teapot"),
        (vec!["--renderer".into(), "raytrace".into()], "raytrace"),
        (vec!["--set".into(), "iso=7".into()], "iso=7"),
        (vec!["--set".into(), "lao_light_pos=1,2".into()], "lao_light_pos=1,2"),
        (vec!["--set".into(), "lao_light_pos=1,x,2".into()], "lao_light_pos=1,x,2"),
        (vec!["--set".into(), "lao_light_radius=-1".into()], "lao_light_radius"),
        (vec!["--set".into(), "lao_light_samples=0".into()], "lao_light_samples"),
        // The built-in cloud has no Hounsfield units.
        (vec!["--set".into(), "tf=ct-bone".into()], "tf=ct-bone"),
        (vec!["--set".into(), "tf=ramp:5,1".into()], "tf=ramp:5,1"),
        (vec!["--set".into(), "clip=0,0,0,0,0,0".into()], "clip=0,0,0,0,0,0: the normal"),
        (vec!["--set".into(), "clip3=0,0,0,NaN,0,1".into()], "clip3=0,0,0,NaN,0,1"),
        (vec!["--set".into(), "clip2=0,0,1".into()], "clip2=0,0,1"),
        (vec!["--set".into(), "crop=0.5,0,0,-0.5,1,1".into()], "crop=0.5,0,0,-0.5,1,1: the box is empty or inverted"),
    ];
    for (args, needle) in cases {
        let out = demo(env!("CARGO_BIN_EXE_volume")).arg("--headless").args(&args).output().expect("run volume");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: message should name `{needle}`: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_loaded_scan_gets_a_transfer_function_whose_printed_name_reproduces_it() {
    let dir = std::env::temp_dir().join(format!("vkengine-volume-tf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let ct = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/formats/ct_series");
    let run = |name: &str, extra: &[&str]| {
        let out = dir.join(name);
        let o = validated(env!("CARGO_BIN_EXE_volume"))
            .args(["--headless", "--volume", ct, "--size", "24x24", "--frames", "1", "--out"])
            .arg(&out)
            .args(extra)
            .output()
            .expect("run volume");
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(o.status.success(), "{extra:?}: {err}");
        (std::fs::read(&out).expect("image"), err)
    };
    let (auto, err) = run("auto.exr", &[]);
    let line = err
        .lines()
        .find(|l| l.starts_with("transfer function: "))
        .unwrap_or_else(|| panic!("no choice printed: {err}"));
    assert!(line.contains("ct-bone") && line.contains("Hounsfield"), "a CT in HU gets the bone preset: {line}");
    let (kept, err) = run("kept.exr", &["--set", "tf=ct-bone"]);
    assert!(!err.contains("transfer function: "), "an explicit tf= is not announced: {err}");
    assert!(auto == kept, "--set tf=ct-bone must reproduce the automatic image");
    let (soft, _) = run("soft.exr", &["--set", "tf=ct-soft"]);
    assert!(auto != soft, "another preset gives another image");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn cornell_demo_renders_png_and_report_with_per_pass_times() {
    let dir = std::env::temp_dir().join(format!("vkengine-cornell-{}", std::process::id()));
    let (png, report) = (dir.join("cornell.png"), dir.join("cornell.json"));
    let out = validated(env!("CARGO_BIN_EXE_cornell"))
        .args(["--headless", "--size", "64x48", "--set", "shadow_tile=256", "--out"])
        .arg(&png)
        .arg("--report")
        .arg(&report)
        .output()
        .expect("run cornell");
    assert!(out.status.success(), "cornell failed: {}", String::from_utf8_lossy(&out.stderr));
    let img = image::open(&png).expect("PNG readable").to_rgba8();
    assert_eq!(img.dimensions(), (64, 48));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    let names: Vec<_> =
        json["passes"].as_array().expect("passes").iter().map(|p| p[0].as_str().unwrap_or("")).collect();
    // No RSM was asked for, so the frame graph has none.
    assert_eq!(names, ["upload frame", "shadow maps", "gbuffer", "lighting", "tonemap"]);
    assert!(json["scene"]["triangles"].as_u64().is_some_and(|t| t > 10));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn mesh_demos_reject_bad_input_with_exit_2() {
    let dir = std::env::temp_dir().join(format!("vkengine-badscene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let broken = dir.join("broken.gltf");
    std::fs::write(&broken, "{ not json").expect("write");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec!["--scene".into(), dir.join("missing.glb").display().to_string()], "missing.glb"),
        (vec!["--scene".into(), broken.display().to_string()], "broken.gltf"),
        (vec!["--scene".into(), dir.join("model.fbx").display().to_string()], "model.fbx"),
        (vec!["--set".into(), "cascades=9".into()], "cascades"),
        (vec!["--set".into(), "colour=red".into()], "colour"),
    ];
    for (args, needle) in cases {
        let out = demo(env!("CARGO_BIN_EXE_scene")).arg("--headless").args(&args).output().expect("run scene");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: the error should name `{needle}`: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
    // Light grids past the device's storage-buffer range (4 cascades of 128³ need 384 MiB;
    // lavapipe binds 128 MiB): one clear line and exit 2, not validation errors.
    let lpv = ["lpv=1", "lpv_size=128", "lpv_cascades=4", "lpv_extent=2.5"];
    let out = demo(env!("CARGO_BIN_EXE_atrium"))
        .args(["--size", "32x32", "--frames", "1", "--out"])
        .arg(std::env::temp_dir().join(format!("vkengine-lpv128-{}.png", std::process::id())))
        .args(lpv.iter().flat_map(|kv| ["--set", kv]))
        .output()
        .expect("run atrium");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("maxStorageBufferRange") && err.contains("lpv_size=128"), "{err}");
}

#[test]
fn profile_run_writes_a_report_folder_and_compare_finds_no_change_against_itself() {
    let dir = std::env::temp_dir().join(format!("vkengine-profile-{}", std::process::id()));
    let out = validated(env!("CARGO_BIN_EXE_profile"))
        .args(["run", "cornell", "--size", "32x32", "--frames", "6", "--warmup", "1", "--set", "rsm=32"])
        .args(["--set", "lpv=1", "--set", "lpv_size=8", "--set", "lpv_steps=2", "--set", "lpv_reuse=0"])
        .args(["--limits", "/nonexistent/limits.json", "--out"])
        .arg(dir.join("cornell.png"))
        .arg("--profile")
        .arg(&dir)
        .output()
        .expect("run profile");
    assert!(out.status.success(), "profile run failed: {}", String::from_utf8_lossy(&out.stderr));
    for f in ["profile.json", "passes.md", "trace.json", "budget.png"] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    let p = vkengine::profile::report::Profile::load(&dir).expect("profile.json");
    assert_eq!((p.frames, p.warmup), (6, 1));
    let prop = p.passes.iter().find(|x| x.name == "lpv propagate 1 (gather)").expect("propagation pass");
    assert_eq!(prop.samples_ms.len(), 6);
    // Declared work: 8³ cells × (6 neighbours + the step's write + half an accumulation
    // read-modify-write + half a previous-step read: steps accumulate in pairs) of 48 B, plus GV
    // fetches.
    assert!(prop.work.declared && prop.work.bytes >= 512 * (6 * 48 + 48 + 48 + 24), "{:?}", prop.work);
    assert!(p.passes.iter().all(|x| x.gpu_median_ms >= 0.0 && x.gpu_p95_ms >= x.gpu_median_ms));
    let cmp = Command::new(env!("CARGO_BIN_EXE_profile")).arg("compare").arg(&dir).arg(&dir).output().expect("compare");
    assert!(cmp.status.success());
    let text = String::from_utf8_lossy(&cmp.stdout);
    assert!(text.contains("lighting") && !text.contains("faster") && !text.contains("slower"), "{text}");
    let bad = Command::new(env!("CARGO_BIN_EXE_profile"))
        .args(["compare", "/nonexistent-a", "/nonexistent-b"])
        .output()
        .expect("compare");
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("nonexistent-a"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn monte_carlo_picks_bounded_work_in_dense_media_and_refuses_an_unbounded_path() {
    let dir = std::env::temp_dir().join(format!("vkengine-mc-budget-{}", std::process::id()));
    let run = |extra: &[&str]| {
        validated(env!("CARGO_BIN_EXE_volume"))
            .args(["--headless", "--renderer", "mcm", "--size", "8x8", "--set", "n=16", "--out"])
            .arg(dir.join("mc.png"))
            .args(extra)
            .output()
            .expect("run volume")
    };
    let ok = |extra: &[&str]| {
        let out = run(extra);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    // The default cloud's whole paths fit every device's bound: bounded work only where this
    // device measured it faster (llvmpipe), and the message says so.
    let default = ok(&[]);
    let chose_bounded = default.contains("mc_budget=auto: bounded work");
    assert!(!chose_bounded || default.contains("measured to reach an error sooner on this device"), "{default}");
    // ×1e6: millions of steps a path, past every device's bound (1e3 fits a GPU's 100 ms here).
    let dense = ok(&["--set", "density=1000000"]);
    assert!(
        dense.contains("mc_budget=auto: bounded work") && dense.contains("past what one dispatch may take"),
        "{dense}"
    );
    let bounded = ok(&["--set", "density=1000000", "--set", "mc_budget=256"]);
    assert!(!bounded.contains("tracking steps"), "bounded work is bounded: {bounded}");
    // One whole path per frame asked for where it cannot be bounded: refused, exit 2, naming why.
    let refused = run(&["--set", "density=1000000", "--set", "mc_budget=0"]);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(2), "{err}");
    assert!(err.contains("mc_budget=0") && err.contains("tracking steps"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn lao_splits_its_work_under_llvmpipes_loop_budget_or_refuses_clearly() {
    if common::skip_pinned_to_lavapipe("LAO's split follows llvmpipe's loop limit") {
        return;
    }
    // LAO with the spherical light on a 64³ volume needs far more than llvmpipe's 65,535 loop
    // iterations per pixel: it runs as several dispatches, with no warning. A single sample that
    // alone exceeds the limit is refused, naming the settings to lower.
    let dir = std::env::temp_dir().join(format!("vkengine-lao-budget-{}", std::process::id()));
    let run = |extra: &[&str]| {
        validated(env!("CARGO_BIN_EXE_volume"))
            .args(["--headless", "--renderer", "lao", "--size", "16x16", "--set", "n=64", "--out"])
            .arg(dir.join("lao.png"))
            .args(extra)
            .output()
            .expect("run volume")
    };
    let lit = run(&["--set", "lao_light=2"]);
    let err = String::from_utf8_lossy(&lit.stderr);
    assert!(lit.status.success(), "{err}");
    assert!(!err.contains("loop iterations"), "{err}");
    assert!(err.contains("lao 1/"), "the light's work is split over dispatches: {err}");
    let huge = run(&["--set", "lao_light=2", "--set", "lao_light_samples=256", "--set", "step=0.001"]);
    let err = String::from_utf8_lossy(&huge.stderr);
    assert_eq!(huge.status.code(), Some(2), "{err}");
    assert!(err.contains("lao_light_samples") && err.lines().count() <= 2, "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_volume_the_device_cannot_hold_is_refused_with_the_numbers_and_the_report_states_sizes() {
    let dir = std::env::temp_dir().join(format!("vkengine-volume-budget-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    // Pinned to lavapipe (2 GiB device-local heap) whatever the suite's device: the numbers are its.
    let lavapipe = |c: &mut Command| {
        c.env("VK_DRIVER_FILES", common::lavapipe_icd().expect("lavapipe ICD installed (tools/setup.sh)"));
    };
    // 8 bytes claiming 512 × 512 × 3000 u16, dense: refused before the file is read (else:
    // truncated). Under `auto` the load builds bricks, which may fit where the dense images do
    // not, so only what they take once built can be refused (`tests/volume_stream.rs`).
    let big = dir.join("big.raw");
    std::fs::write(&big, [0u8; 8]).expect("write");
    let mut c = Command::new(env!("CARGO_BIN_EXE_volume"));
    lavapipe(&mut c);
    let out = c
        .args(["--headless", "--set", "volume_layout=dense", "--volume"])
        .arg(&big)
        .args(["--dims", "512,512,3000", "--type", "u16"])
        .output()
        .expect("run volume");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let line = err.lines().find(|l| l.contains("big.raw")).unwrap_or_default();
    for part in ["512x512x3000", "need 3145728000 bytes", "device-local heap holds 2147483648 bytes"] {
        assert!(line.contains(part), "lacks `{part}`: {err}");
    }

    // A procedural scene too, before its 4 GiB of values are generated.
    let mut c = Command::new(env!("CARGO_BIN_EXE_volume"));
    lavapipe(&mut c);
    let out = c.args(["--headless", "--set", "n=1024"]).output().expect("run volume");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("procedural cloud 1024x1024x1024: dims 1024x1024x1024 need 4294967296 bytes"), "{err}");

    // A volume that fits: the report states its dense size and what went to the GPU.
    let small = dir.join("small.raw");
    let bytes: Vec<u8> = (0..24 * 20 * 16).flat_map(|i: u32| ((i * 37 % 1000) as u16).to_le_bytes()).collect();
    std::fs::write(&small, bytes).expect("write");
    // The small volume rendered with `volume_layout`, and its report.
    let report_of = |layout: &str| -> serde_json::Value {
        let report = dir.join(format!("{layout}.json"));
        let mut c = Command::new(env!("CARGO_BIN_EXE_volume"));
        lavapipe(&mut c);
        c.env("VKENGINE_VALIDATION", common::child_validation());
        let out = c
            .args(["--headless", "--size", "16x16", "--renderer", "mip", "--set"])
            .arg(format!("volume_layout={layout}"))
            .arg("--volume")
            .arg(&small)
            .args(["--dims", "24,20,16", "--type", "u16", "--out"])
            .arg(dir.join(format!("{layout}.png")))
            .arg("--report")
            .arg(&report)
            .output()
            .expect("run volume");
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json")
    };
    // The default layout keeps a volume this small dense.
    let r = report_of("auto");
    let v = &r["volume"];
    assert_eq!(v["dense_voxels"], 7680, "{v}");
    assert_eq!(v["dense_bytes"], 15360, "{v}");
    // What was allocated: at least the two images' 30720 bytes (drivers pad rows and slices).
    let gpu = v["gpu_bytes"].as_u64().unwrap_or(0);
    assert!((30720..=4 * 30720).contains(&gpu), "{v}");
    let l = &v["layout"];
    assert_eq!(
        (l["layout"].as_str(), l["bricks"].as_u64(), l["stored_bricks"].as_u64()),
        (Some("Dense"), Some(18), Some(18)),
        "{v}"
    );
    // The same volume in bricks: every brick varies (no shared slot), 18 stored of 18.
    let r = report_of("sparse");
    let l = &r["volume"]["layout"];
    assert_eq!(
        (l["layout"].as_str(), l["bricks"].as_u64(), l["stored_bricks"].as_u64()),
        (Some("Sparse"), Some(18), Some(18)),
        "{l}"
    );
    assert_eq!(l["skipped_fraction"].as_f64(), Some(0.0), "{l}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A raw volume longer than lavapipe's 3D-image limit (4096) along z loads (the loader's limit is
/// the page table's, 8 × 4096) and renders in bricks, exit 0; its report names the layout.
#[test]
fn a_volume_past_the_3d_image_limit_renders_from_a_file_in_bricks() {
    let dir = std::env::temp_dir().join(format!("vkengine-volume-long-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let (n, len) = (16u32, 4500u32);
    let path = dir.join("long.raw");
    let bytes: Vec<u8> = (0..n * n * len).map(|i| ((i % n) * 7 + (i / (n * n)) % 50) as u8).collect();
    std::fs::write(&path, bytes).expect("write");
    let report = dir.join("r.json");
    let mut c = Command::new(env!("CARGO_BIN_EXE_volume"));
    c.env("VK_DRIVER_FILES", common::lavapipe_icd().expect("lavapipe ICD installed (tools/setup.sh)"));
    c.env("VKENGINE_VALIDATION", common::child_validation());
    let out = c
        .args(["--headless", "--size", "16x16", "--renderer", "mip", "--volume"])
        .arg(&path)
        .args(["--dims", &format!("{n},{n},{len}"), "--type", "u8", "--out"])
        .arg(dir.join("r.png"))
        .arg("--report")
        .arg(&report)
        .output()
        .expect("run volume");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    let l = &r["volume"]["layout"];
    assert_eq!((l["layout"].as_str(), l["bricks"].as_u64()), (Some("Sparse"), Some(2 * 2 * 563)), "{l}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn until_error_stops_a_monte_carlo_run_at_its_estimate_and_bad_targets_exit_2() {
    let dir = std::env::temp_dir().join(format!("vkengine-until-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let report = dir.join("r.json");
    let out = validated(env!("CARGO_BIN_EXE_volume"))
        .args(["--headless", "--size", "32x32", "--set", "n=24", "--renderer", "mcs", "--frames", "400"])
        .args(["--until-error", "0.08", "--out"])
        .arg(dir.join("a.png"))
        .arg("--report")
        .arg(&report)
        .output()
        .expect("run volume");
    assert!(out.status.success(), "volume failed: {}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    let e = &json["estimated_error"];
    let (rel, frames) = (e["relative"].as_f64().expect("estimate"), json["frames"].as_u64().expect("frames"));
    // Stopped at the first frame whose estimate is at most 0.08, with at least 16 paths per pixel.
    assert_eq!(json["reached_until_error"].as_bool(), Some(true), "{json}");
    assert!(rel <= 0.08 && (16..400).contains(&frames), "relative {rel} after {frames} frames");
    for (args, what) in [
        (vec!["--until-error", "2"], "--until-error 2"),
        (vec!["--until-error", "0.02", "--renderer", "eam"], "Monte Carlo"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_volume"))
            .args(["--headless", "--size", "16x16", "--set", "n=16"])
            .args(&args)
            .output()
            .expect("run");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(what), "{args:?}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The voxel the level-of-detail volume holds at (x, y, z) of `dims`: inside a ball of radius
/// 0.45 of the width (about 38 % of the bricks vary), a smooth field with noise; 0 outside; a
/// 2 × 2 × 2 block of 65535 at the origin, so the volume and its halving share their range.
fn lod_ball(x: u32, y: u32, z: u32, dims: [u32; 3]) -> u16 {
    if x < 2 && y < 2 && z < 2 {
        return 65535;
    }
    let c = dims.map(|d| f64::from(d) / 2.0);
    let d2 =
        (f64::from(x) + 0.5 - c[0]).powi(2) + (f64::from(y) + 0.5 - c[1]).powi(2) + (f64::from(z) + 0.5 - c[2]).powi(2);
    if d2 >= (0.45 * f64::from(dims[0])).powi(2) {
        return 0;
    }
    let s = ((f64::from(x) * 0.05).sin() + (f64::from(y) * 0.04).cos() + (f64::from(z) * 0.03).sin() + 3.0) / 6.0;
    let n = (((u64::from(x) * 2_654_435_761) ^ (u64::from(y) * 40503) ^ (u64::from(z) * 97)) % 997) as f64 / 997.0;
    (1000.0 + 50000.0 * s + 4000.0 * n) as u16
}

/// A volume whose bricks exceed `gpu_memory` renders at pyramid level 1 with a warning naming
/// the level and the voxel size, and its report says both; its MIP equals, within rounding, the
/// MIP of the volume halved by block means (computed here from the voxel function, not by the
/// engine) and written as its own file. `lod=0` refuses it with the numbers, exit 2, and a budget
/// that not even the coarsest level fits gets one line, exit 2. `scale` divides the
/// 1024 × 1024 × 1100 volume's edges; `gpu_memory` is set below its level-0 bricks.
fn renders_the_level_that_fits(scale: u32, gpu_memory: u64) {
    let dir = std::env::temp_dir().join(format!("vkengine-volume-lod-{}-{scale}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let dims = [1024 / scale, 1024 / scale, 1100 / scale / 2 * 2];
    let full = dir.join("full.raw");
    common::write_sparse_u16(&full, dims, |x, y, z| lod_ball(x, y, z, dims));
    // The reference: means of 2 × 2 × 2 blocks (the dims are even), rounded to nearest.
    let half = dims.map(|d| d / 2);
    let reference = dir.join("half.raw");
    common::write_sparse_u16(&reference, half, |x, y, z| {
        let s: f64 = (0..8).map(|i| f64::from(lod_ball(2 * x + i % 2, 2 * y + i / 2 % 2, 2 * z + i / 4, dims))).sum();
        (s / 8.0).round() as u16
    });
    let run = |path: &std::path::Path, d: [u32; 3], spacing: &str, name: &str, extra: &[&str]| {
        let (img, report) = (dir.join(format!("{name}.exr")), dir.join(format!("{name}.json")));
        let out = validated(env!("CARGO_BIN_EXE_volume"))
            .args(["--headless", "--size", "32x32", "--frames", "1", "--renderer", "mip", "--volume"])
            .arg(path)
            .args(["--dims", &format!("{},{},{}", d[0], d[1], d[2]), "--type", "u16", "--spacing", spacing])
            .args(["--set", "camera=ortho", "--set", "height=1.2", "--set", "distance=3", "--set", "target=0,0,0"])
            .args(["--set", "yaw=0", "--set", "pitch=0", "--set", "tf=ramp:1000,56000"])
            .args(["--set", "volume_layout=sparse", "--out"])
            .arg(&img)
            .arg("--report")
            .arg(&report)
            .args(extra)
            .output()
            .expect("run volume");
        (out, img, report)
    };
    let budget = format!("gpu_memory={gpu_memory}");
    let (out, img, report) = run(&full, dims, "1,1,1", "lod", &["--set", &budget]);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{err}");
    let warning = err.lines().find(|l| l.starts_with("warning:") && l.contains("pyramid level")).unwrap_or_default();
    let voxels = format!("{}x{}x{} voxels of 2 x 2 x 2", half[0], half[1], half[2]);
    assert!(warning.contains("pyramid level 1") && warning.contains(&voxels), "{err}");
    assert!(warning.contains(&format!("{gpu_memory} bytes are available")), "{warning}");
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    let v = &r["volume"];
    assert_eq!(v["lod_level"], 1, "{v}");
    assert_eq!(v["voxel_size"], serde_json::json!([2.0, 2.0, 2.0]), "{v}");
    let (out, want, _) = run(&reference, half, "2,2,2", "reference", &[]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let load = |p: &std::path::Path| image::open(p).expect("exr").to_rgba32f().into_raw();
    let (got, want) = (load(&img), load(&want));
    assert_eq!(got.len(), want.len());
    // Equal up to the means' rounding (a voxel differs by at most 1 of 65535).
    let worst = got.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    let lit = want.chunks(4).filter(|p| p[0] > 0.05).count();
    eprintln!("level 1 against the halved file: largest difference {worst}, {lit} of 1024 pixels lit");
    assert!(worst <= 1e-3 && lit > 50, "largest difference {worst}, {lit} pixels lit");
    // lod=0: the refusal with the numbers.
    let (out, _, _) = run(&full, dims, "1,1,1", "lod0", &["--set", &budget, "--set", "lod=0"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let line = err.lines().find(|l| l.contains("full.raw")).unwrap_or_default();
    for part in [
        "brick slots",
        "need at least",
        &format!("the gpu_memory setting allows {gpu_memory} bytes"),
        "before bricking",
    ] {
        assert!(line.contains(part), "lacks {part}: {err}");
    }
    // Nothing fits 1000 bytes.
    let (out, _, _) = run(&full, dims, "1,1,1", "none", &["--set", "gpu_memory=1000"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let line = err.lines().find(|l| l.contains("full.raw")).unwrap_or_default();
    assert!(line.contains("even at pyramid level") && line.contains("the coarsest"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_volume_past_gpu_memory_renders_at_the_level_that_fits() {
    // 128 × 128 × 136 (an eighth of each edge of the volume below): its level-0 bricks take
    // about 5 MB (both quantities); 3 MB holds level 1.
    renders_the_level_that_fits(8, 3_000_000);
}

/// The 1024 × 1024 × 1100 u16 volume of the issue: 2.3 GB of voxels, about 2.5 GB of level-0
/// bricks, past 2 GB. Ignored in the suite for its cost: 6 min 27 s in the dev profile on a
/// 2-core VM under a load average near 7 (the files written, the volume read four times),
/// 1.25 GB max RSS; `cargo test -p vkengine-demos --test demo_cli -- --ignored a_1024`.
#[test]
#[ignore = "minutes: a 2.3 GB volume written, read twice and rendered; run with --ignored"]
fn a_1024_by_1024_by_1100_volume_renders_at_level_1_under_2_gb() {
    renders_the_level_that_fits(1, 2_000_000_000);
}

/// A NRRD file of unsigned bytes (raw encoding) with the given sizes and spacings.
fn write_nrrd(path: &std::path::Path, sizes: [u32; 3], spacings: [f32; 3], data: &[u8]) {
    let [x, y, z] = sizes;
    let [sx, sy, sz] = spacings;
    let mut f = format!(
        "NRRD0004\ntype: unsigned char\ndimension: 3\nsizes: {x} {y} {z}\nspacings: {sx} {sy} {sz}\nencoding: raw\n\n"
    )
    .into_bytes();
    f.extend_from_slice(data);
    std::fs::write(path, f).expect("write nrrd");
}

#[test]
fn label_maps_off_the_scan_grid_or_with_unknown_labels_exit_2() {
    let dir = std::env::temp_dir().join(format!("vkengine-volume-labels-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let scan = dir.join("scan.nrrd");
    write_nrrd(&scan, [4, 4, 4], [1.0; 3], &[200; 64]);
    write_nrrd(&dir.join("labels.nrrd"), [4, 4, 4], [1.0; 3], &[1; 64]);
    write_nrrd(&dir.join("short.nrrd"), [4, 4, 2], [1.0; 3], &[1; 32]);
    write_nrrd(&dir.join("spaced.nrrd"), [4, 4, 4], [1.0, 1.0, 2.0], &[1; 64]);
    std::fs::write(dir.join("unknown.json"), r#"{"labels": {"9": {"color": [1, 0, 0]}}}"#).expect("json");
    // A broken colour table (cut off mid-entry), a label file whose voxels stop early, one that is
    // not a NRRD file at all, and a scan and label map whose axes are permuted against each other.
    std::fs::write(dir.join("cut.json"), r#"{"labels": {"1": {"color": [1, 0"#).expect("json");
    let mut truncated = b"NRRD0004\ntype: unsigned char\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n\n".to_vec();
    truncated.extend([1u8; 10]);
    std::fs::write(dir.join("truncated.nrrd"), truncated).expect("nrrd");
    std::fs::write(dir.join("garbage.nrrd"), b"\x89PNG not a label map\n").expect("garbage");
    let oriented = |directions: &str, value: u8| {
        let mut f = format!(
            "NRRD0004\ntype: unsigned char\ndimension: 3\nsizes: 4 4 4\nspace: left-posterior-superior\nspace directions: {directions}\nencoding: raw\n\n"
        )
        .into_bytes();
        f.extend([value; 64]);
        f
    };
    std::fs::write(dir.join("lps.nrrd"), oriented("(1,0,0) (0,1,0) (0,0,1)", 200)).expect("nrrd");
    std::fs::write(dir.join("swapped.nrrd"), oriented("(0,1,0) (1,0,0) (0,0,1)", 1)).expect("nrrd");
    let p = |name: &str| dir.join(name).display().to_string();
    let cases: Vec<(Vec<String>, String)> = vec![
        (vec!["--labels".into(), p("short.nrrd")], format!("{}: label volume dims [4, 4, 2] differ", p("short.nrrd"))),
        (vec!["--labels".into(), p("spaced.nrrd")], format!("{}: label volume spacing", p("spaced.nrrd"))),
        (vec!["--labels".into(), p("missing.nrrd")], "missing.nrrd".into()),
        (
            vec!["--labels".into(), p("labels.nrrd"), "--set".into(), format!("label_colors={}", p("unknown.json"))],
            "label 9 does not occur in the label volume".into(),
        ),
        (vec!["--set".into(), "label_hide=1,300".into()], "label_hide=1,300".into()),
        (vec!["--set".into(), "label_opacity=1:1.5".into()], "label_opacity=1:1.5".into()),
        (vec!["--set".into(), "label_opacity=1:0.5".into()], "label_opacity: no label map is loaded".into()),
        (
            vec!["--labels".into(), p("labels.nrrd"), "--set".into(), "label_opacity=9:0.5".into()],
            "label_opacity: label 9 does not occur in the label map".into(),
        ),
        (
            vec!["--labels".into(), p("labels.nrrd"), "--set".into(), format!("label_colors={}", p("cut.json"))],
            format!("label_colors {}", p("cut.json")),
        ),
        (vec!["--labels".into(), p("truncated.nrrd")], p("truncated.nrrd")),
        (vec!["--labels".into(), p("garbage.nrrd")], p("garbage.nrrd")),
    ];
    for (args, needle) in cases {
        let out = demo(env!("CARGO_BIN_EXE_volume"))
            .args(["--headless", "--size", "8x8", "--volume"])
            .arg(&scan)
            .args(&args)
            .output()
            .expect("run volume");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(&needle), "{args:?}: message should name `{needle}`: {err}");
        assert_eq!(err.lines().filter(|l| l.starts_with("error")).count(), 1, "{args:?}: one line: {err}");
    }
    // Axes permuted against the scan's (both NRRD with space directions): the same dims and
    // spacing, another orientation.
    let out = demo(env!("CARGO_BIN_EXE_volume"))
        .args(["--headless", "--size", "8x8", "--volume", &p("lps.nrrd"), "--labels", &p("swapped.nrrd")])
        .output()
        .expect("run volume");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains(&format!("{}: label volume orientation differs", p("swapped.nrrd"))), "{err}");
    assert_eq!(err.lines().filter(|l| l.starts_with("error")).count(), 1, "one line: {err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `residency=view` through the volume demo: a procedural 96³ cloud under a `gpu_memory` below
/// its level-0 bricks, Monte Carlo, a still camera. Each frame uploads at most `upload_budget`
/// and writes no more than it budgets; residency settles (nothing pending) with part of the
/// volume at level 0 and the rest coarser; the majorant grids bound what is shown (no
/// violations); every frame in which residency changed restarted the mean, so the paths per
/// pixel count the frames after the last change. Bad values of either setting exit 2 naming it.
#[test]
fn residency_view_streams_within_the_upload_budget_and_restarts_the_mean() {
    let dir = std::env::temp_dir().join(format!("vkengine-volume-residency-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let (img, report) = (dir.join("r.png"), dir.join("r.json"));
    let out = validated(env!("CARGO_BIN_EXE_volume"))
        .args(["--headless", "--size", "48x48", "--frames", "14", "--renderer", "mcm", "--set", "n=96"])
        .args(["--set", "residency=view", "--set", "gpu_memory=1M", "--set", "upload_budget=128K"])
        .args(["--set", "mc_budget=0", "--out"])
        .arg(&img)
        .arg("--report")
        .arg(&report)
        .output()
        .expect("run volume");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    let res = &r["volume"]["residency"];
    let list = |k: &str| -> Vec<u64> {
        res[k].as_array().unwrap_or_else(|| panic!("{k}: {res}")).iter().filter_map(|v| v.as_u64()).collect()
    };
    let (bytes, written, changed) = (list("bytes_per_frame"), list("written_per_frame"), list("changed_frames"));
    assert_eq!(bytes.len(), 14, "{res}");
    assert!(bytes.iter().all(|&b| b <= 128 << 10), "{res}");
    assert!(bytes.iter().zip(&written).all(|(b, w)| w <= b), "{res}");
    assert_eq!(res["pending"], 0, "{res}");
    let shown = list("shown_levels");
    assert!(shown[0] > 0 && shown[1..].iter().sum::<u64>() > 0, "{res}");
    assert_eq!(r["majorant_violations"], 0, "{r}");
    let last = *changed.last().expect("residency changed at least once");
    assert!(last < 13, "{res}: not settled before the last frame");
    let paths = r["estimated_error"]["min_paths"].as_u64().expect("min_paths");
    assert_eq!(paths, 14 - last, "{res}: the mean restarted at frame {last}");
    eprintln!("{res}");
    for (set, key) in [("residency=maybe", "residency"), ("upload_budget=0", "upload_budget")] {
        let out = demo(env!("CARGO_BIN_EXE_volume"))
            .args(["--headless", "--size", "8x8", "--set", set])
            .output()
            .expect("run volume");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{set}: {err}");
        assert!(err.contains(key), "{set}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
