//! The settings schemas are the only declaration of each key: the CLI's keys, the UI's controls
//! and the keys scene and session files accept are all derived from them, and must agree.

use std::collections::BTreeMap;
use vkengine::mesh::settings::{MeshSetup, SCHEMA as MESH};
use vkengine::scene::load_scene;
use vkengine::settings::{Key, Origin, Schema, Setting, Type, Value};
use vkengine::ui::controls::{self, Kind};
use vkengine::volume::render::settings::{VolumeSetup, SCHEMA as VOLUME};
use vkengine_demos::mesh_scene::{keys, mesh_setup};

fn tmpdir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("vkengine-settings-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// A value of `key` other than the default, its text and TOML spelling.
fn other<S>(key: &Key<S>, defaults: &S) -> Option<(Value, String)> {
    let now = key.value(defaults);
    let v = match (controls::kind(key), &key.ty) {
        (Some(kind), _) => controls::moved(key.key, kind, &now),
        (None, Type::Bool { .. }) => Value::Bool(now != Value::Bool(true)),
        (None, Type::Choice { names, .. }) => {
            Value::Name(names.iter().find(|n| Value::Name(n.to_string()) != now)?.to_string())
        }
        (None, Type::Int { lo, step, .. }) => Value::Int(if now == Value::Int(*lo) { lo + step } else { *lo }),
        (None, Type::Float { range, .. }) if range.contains(0.5) && now != Value::Float(0.5) => Value::Float(0.5),
        (None, Type::Float { .. }) => Value::Float(0.25),
        (None, Type::Text { .. }) => return None, // paths and lists: covered by their own tests
    };
    let text = controls::format_value(&v);
    Some((v, text))
}

/// Every key of `schema` set from `--set` and from a file's settings reads back the same value,
/// and every UI control is a schema key whose widget range lies inside the key's range.
fn agree<S: Clone>(schema: &Schema<S>, defaults: &S, parse: impl Fn(&[Setting]) -> vkengine::Result<S>) {
    let names = schema.names();
    let mut unique = names.clone();
    unique.sort_unstable();
    unique.dedup();
    assert_eq!(unique.len(), names.len(), "{}: a key is declared twice", schema.name);
    for key in schema.keys() {
        let Some((v, text)) = other(key, defaults) else { continue };
        for origin in [Origin::Cli, Origin::File("scene.toml".into())] {
            // Keys that only make sense with the LPV on are set with it on.
            let mut sets = vec![];
            if key.key != "lpv" && names.contains(&"lpv") {
                sets.push(Setting::new("lpv", "true", origin.clone()));
            }
            sets.push(Setting::new(key.key, text.clone(), origin.clone()));
            let s = parse(&sets).unwrap_or_else(|e| panic!("{} from {origin:?}: {e}", key.key));
            assert_eq!(key.value(&s), v, "{} from {origin:?}", key.key);
        }
    }
    for (key, kind) in controls::controls(schema) {
        assert!(names.contains(&key.key), "control {} is no key", key.key);
        match (kind, &key.ty) {
            (Kind::Int { lo, hi, step }, Type::Int { lo: l, hi: h, step: st, .. }) => {
                assert_eq!((lo, hi, step), (*l, *h, *st), "{}: the slider is not the key's range", key.key)
            }
            (Kind::Float { lo, hi, .. }, Type::Float { range, .. }) => {
                assert!(range.covers(lo, hi), "{}: slider {lo}..{hi} leaves the range {range}", key.key)
            }
            (Kind::Choice(a), Type::Choice { names, .. }) => assert_eq!(a, *names, "{}", key.key),
            (Kind::Sliders(s), Type::Text { sliders: Some(t), .. }) => {
                assert!(std::ptr::eq(s, *t), "{}", key.key);
                assert!(s.spans.iter().all(|(_, lo, hi)| lo < hi), "{}: empty slider span", key.key);
            }
            (Kind::Choice(_), Type::Text { .. }) | (Kind::Toggle, Type::Bool { .. }) => {}
            (k, _) => panic!("{}: widget {k:?} does not fit the key's type", key.key),
        }
    }
    // The library's validation accepts the defaults.
    schema.check(defaults).unwrap_or_else(|e| panic!("{}: defaults rejected: {e}", schema.name));
}

#[test]
fn cli_ui_and_file_keys_agree_with_the_schemas() {
    let mesh_defaults = MeshSetup::default();
    agree(&MESH, &mesh_defaults, MeshSetup::parse);
    assert_eq!(keys(), MESH.names(), "the mesh demos' key list is the schema's");
    agree(&VOLUME, &VolumeSetup::default(), VolumeSetup::parse);
    // A real scene file: every non-text mesh key in its [settings], as TOML values of its type,
    // reads back as through --set.
    let dir = tmpdir("file");
    let path = dir.join("scene.toml");
    let mut toml = String::from("builtin = \"cornell\"\n[settings]\nlpv = true\n");
    let mut sets = vec![("lpv".to_string(), "1".to_string())];
    for key in MESH.keys().filter(|k| k.key != "lpv") {
        let Some((v, text)) = other(key, &mesh_defaults) else { continue };
        let lit = match v {
            Value::Bool(b) => b.to_string(),
            Value::Name(n) => format!("\"{n}\""),
            _ => text.clone(),
        };
        toml.push_str(&format!("{} = {lit}\n", key.key));
        sets.push((key.key.to_string(), text));
    }
    std::fs::write(&path, toml).expect("write");
    let scene = load_scene(&path).expect("scene");
    let from_file = mesh_setup("scene.toml", &scene.settings, &[]).expect("file settings");
    let from_cli = mesh_setup("none", &BTreeMap::new(), &sets).expect("--set settings");
    for key in MESH.keys() {
        assert_eq!(key.value(&from_file), key.value(&from_cli), "{}: file and --set disagree", key.key);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn scene_file_booleans_and_errors_that_name_the_file() {
    let dir = tmpdir("bool");
    let path = dir.join("scene.toml");
    for (lit, on) in [("true", true), ("false", false), ("1", true), ("0", false), ("\"true\"", true)] {
        std::fs::write(&path, format!("builtin = \"cornell\"\n[settings]\nlpv = {lit}\nfog = {lit}\n")).expect("write");
        let scene = load_scene(&path).expect("scene");
        let s = mesh_setup(&path.display().to_string(), &scene.settings, &[])
            .unwrap_or_else(|e| panic!("lpv = {lit}: {e}"));
        assert_eq!((s.settings.lpv.enabled, s.settings.fog.enabled), (on, on), "lpv = {lit}");
        assert_eq!(s.rsm_size(), if on { 256 } else { 0 }, "the LPV brings its RSM along");
    }
    std::fs::write(&path, "builtin = \"cornell\"\n[settings]\nlpv = \"maybe\"\n").expect("write");
    let scene = load_scene(&path).expect("scene");
    let e = mesh_setup(&path.display().to_string(), &scene.settings, &[]).expect_err("maybe").to_string();
    assert!(e.contains("scene.toml: settings.lpv=maybe") && e.contains("true, false, 1 or 0"), "{e}");
    assert!(!e.contains("--set"), "the error names a flag the user never passed: {e}");
    let e = mesh_setup("scene.toml", &BTreeMap::new(), &[("lpv_steps".into(), "999".into())]).expect_err("range");
    assert!(e.to_string().starts_with("--set lpv_steps=999: must be in 0..=256"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn library_validation_uses_the_schema_ranges() {
    use vkengine::volume::render::renderer::RenderSettings;
    let mut mesh = MeshSetup::default().settings;
    mesh.lpv.steps = 300;
    assert!(mesh.validate().expect_err("lpv_steps").to_string().contains("lpv_steps=300"));
    let bad = RenderSettings { iso: 7.0, ..Default::default() };
    assert!(bad.validate().expect_err("iso").to_string().contains("iso=7"));
    RenderSettings::default().validate().expect("defaults");
}

/// The key tables in `docs/settings.md`, between `<!-- settings:NAME -->` markers, are generated
/// from the schemas so that the documentation cannot drift from what `--set` accepts;
/// `VKENGINE_WRITE_DOCS=1 cargo test --test settings_schema` rewrites them.
#[test]
fn settings_doc_key_tables_are_the_schemas() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/settings.md");
    let mut doc = std::fs::read_to_string(path).expect("docs/settings.md");
    let tables = [("mesh", MESH.markdown(&MeshSetup::default())), ("volume", VOLUME.markdown(&VolumeSetup::default()))];
    let mut stale = Vec::new();
    for (name, table) in tables {
        let (open, close) = (format!("<!-- settings:{name} -->\n"), format!("<!-- /settings:{name} -->"));
        let start = doc.find(&open).unwrap_or_else(|| panic!("docs/settings.md has no {open}")) + open.len();
        let end = start + doc[start..].find(&close).unwrap_or_else(|| panic!("docs/settings.md has no {close}"));
        if doc[start..end] != table {
            stale.push(name);
            doc.replace_range(start..end, &table);
        }
    }
    if std::env::var_os("VKENGINE_WRITE_DOCS").is_some() {
        std::fs::write(path, doc).expect("write docs/settings.md");
    } else {
        assert!(
            stale.is_empty(),
            "docs/settings.md's {stale:?} key tables are stale: rerun with VKENGINE_WRITE_DOCS=1"
        );
    }
}

#[test]
fn clip_keys_refuse_absurd_planes_and_boxes_and_keep_the_side_the_normal_points_away_from() {
    use vkengine::volume::render::renderer::RenderSettings;
    let parse = |k: &str, v: &str| VolumeSetup::parse(&[Setting::new(k, v, Origin::Cli)]).map(|s| s.render.clip);
    for (k, v, needle) in [
        ("clip", "0,0,0,0,0,0", "the normal NX,NY,NZ is zero"),
        ("clip", "0,0,0,NaN,0,1", "six numbers"),
        ("clip6", "0,0,0,inf,0,1", "six numbers"),
        ("clip2", "0,0,0,1,0", "six numbers"),
        ("crop", "1,0,0,0,1,1", "empty or inverted"),
        ("crop", "0,0,0,0,1,1", "empty or inverted"),
        ("crop_rotation", "10,20", "three angles"),
        ("crop_rotation", "0,NaN,0", "three angles"),
        ("crop_rotation", "0,0,361", "three angles"),
        ("clip_shadows", "maybe", "off"),
    ] {
        let e = parse(k, v).expect_err(v).to_string();
        assert!(e.contains(&format!("{k}={v}")) && e.contains(needle), "{k}={v}: {e}");
    }
    // Set in code, bypassing the text: validate() refuses the same.
    let mut s = RenderSettings::default();
    s.clip.planes[3] = Some([0.0, 0.0, 0.0, f32::NAN, 0.0, 1.0]);
    assert!(s.validate().expect_err("NaN").to_string().contains("clip4"));
    assert!(parse("crop", "none").expect("none").crop.is_none());
    let c = parse("crop", "-0.5,-0.5,-0.5,0.5,0.5,0.25").expect("crop");
    let mut c2 = parse("clip", "0.1,0,0,2,0,0").expect("clip");
    c2.crop = c.crop;
    let (p, n) = c2.gpu_planes();
    assert_eq!(n, 7);
    let keeps = |x: [f32; 3]| p[..n as usize].iter().all(|q| q[0] * x[0] + q[1] * x[1] + q[2] * x[2] <= q[3]);
    assert!(keeps([0.0, 0.0, 0.0]));
    assert!(!keeps([0.2, 0.0, 0.0]), "beyond the plane x = 0.1, on the side its normal points to");
    assert!(!keeps([0.0, 0.0, 0.3]), "above the crop box's z1 = 0.25");
    assert!(!keeps([-0.6, 0.0, 0.0]), "below the crop box's x0");
    assert_eq!(RenderSettings::default().clip.gpu_planes().1, 0, "no clipping: no planes");
    // A thin slab y ∈ [-0.1, 0.1] turned 90° about z lies across x instead; about x, across z.
    let mut r = parse("crop", "-0.5,-0.1,-0.5,0.5,0.1,0.5").expect("crop");
    assert!(parse("crop_rotation", "none").expect("none").crop_rotation.is_none());
    r.crop_rotation = parse("crop_rotation", "0,0,90").expect("rotation").crop_rotation;
    let (p, n) = r.gpu_planes();
    assert_eq!(n, 6);
    let keeps = |x: [f32; 3]| p[..6].iter().all(|q| q[0] * x[0] + q[1] * x[1] + q[2] * x[2] <= q[3]);
    assert!(keeps([0.0, 0.3, 0.0]) && keeps([0.05, 0.45, 0.3]), "the slab now runs along y");
    assert!(!keeps([0.3, 0.0, 0.0]) && !keeps([0.15, 0.0, 0.0]), "and is thin across x");
    r.crop_rotation = Some([90.0, 0.0, 0.0]);
    let (p, _) = r.gpu_planes();
    let keeps = |x: [f32; 3]| p[..6].iter().all(|q| q[0] * x[0] + q[1] * x[1] + q[2] * x[2] <= q[3]);
    assert!(keeps([0.0, 0.3, 0.05]) && !keeps([0.0, 0.0, 0.15]), "about x: thin across z");
}
