//! The parameter-extreme sweep: every numeric setting of the volume and mesh renderers at both
//! ends of its range, one at a time, each frame checked for finite, non-negative pixels and a
//! bounded run time. A setting the engine refuses (one clear input error) passes; a panic, a
//! non-finite or negative pixel, any other error or a frame over the time limit fails.

use std::time::{Duration, Instant};
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::renderer::{render_frame as render_mesh, MeshRenderer, MeshTargets};
use vkengine::settings::{Origin, Setting, Type};
use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::procedural;
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::renderer::{render_frame, Targets, VolumeRenderer};
use vkengine::volume::render::settings::VolumeSetup;
use vkengine::Error;

/// What one case came to.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Rendered; every pixel finite and ≥ 0.
    Ok,
    /// Refused with one input error (the message).
    Refused(String),
    /// Anything else (the reason).
    Failed(String),
}

/// One setting at one end of its range, for one renderer.
#[derive(Debug, Clone)]
pub struct Case {
    /// `volume:RENDERER` or `mesh`.
    pub target: String,
    /// The key.
    pub key: &'static str,
    /// The value it was set to.
    pub value: String,
    /// What happened.
    pub outcome: Outcome,
    /// Wall time of the frames.
    pub ms: f64,
}

/// Which cases to run.
pub struct Selection<'a> {
    /// Volume renderers (`--renderer` names).
    pub renderers: &'a [&'a str],
    /// Keys to sweep (empty: every numeric key).
    pub keys: &'a [&'a str],
    /// Also sweep the mesh renderer on the Cornell box.
    pub mesh: bool,
    /// A case slower than this fails.
    pub limit: Duration,
}

/// Keys whose far end only sizes the input (a 1024³ procedural grid is 4 GiB of voxels): the
/// sweep caps them, and says so in the value column.
fn capped(key: &str, v: f64) -> f64 {
    match key {
        "n" => v.min(128.0),
        "shadow_tile" => v.min(4096.0),
        _ => v,
    }
}

/// Both finite ends of every numeric key of `keys`, as the text `--set` takes.
fn ends<S>(key: &vkengine::settings::Key<S>) -> Vec<String> {
    let (lo, hi, int) = match &key.ty {
        Type::Float { range, .. } => {
            // An open end is approached to within a part in 10⁶ of the range.
            let eps = ((range.hi - range.lo).abs() * 1e-6).clamp(1e-9, 1e-3);
            let lo = if range.lo_open { range.lo + eps } else { range.lo };
            let hi = if range.hi_open { range.hi - eps } else { range.hi };
            (lo, hi, false)
        }
        Type::Int { lo, hi, .. } => (*lo as f64, *hi as f64, true),
        _ => return vec![],
    };
    [lo, hi]
        .into_iter()
        .filter(|v| v.is_finite() && v.abs() < 1e30)
        .map(|v| capped(key.key, v))
        .map(|v| if int { format!("{}", v as i64) } else { format!("{v}") })
        .collect()
}

fn check(img: &[[f32; 4]]) -> Outcome {
    match img.iter().flatten().find(|v| !(v.is_finite() && **v >= 0.0)) {
        Some(v) => Outcome::Failed(format!("pixel value {v}")),
        None => Outcome::Ok,
    }
}

fn classify(r: vkengine::Result<Outcome>) -> Outcome {
    match r {
        Ok(o) => o,
        Err(Error::Input(m)) => Outcome::Refused(m),
        Err(e) => Outcome::Failed(e.to_string()),
    }
}

fn volume_case(ctx: &Context, renderer: &str, key: &str, value: &str) -> vkengine::Result<Outcome> {
    let mut sets = vec![Setting::new("renderer", renderer, Origin::Cli), Setting::new("n", "16", Origin::Cli)];
    sets.push(Setting::new(key, value, Origin::Cli));
    let setup = VolumeSetup::parse(&sets)?;
    let vol = procedural::cloud([setup.n; 3], 1).map_err(|e| Error::Input(e.to_string()))?;
    let tf = TransferFunction::preset("cloud")?;
    let r = VolumeRenderer::new(ctx, &vol, &tf)?;
    let cam =
        Camera::orbit(setup.distance.unwrap_or(2.0), setup.yaw, setup.pitch, Projection::Perspective { fov_y: 0.8 });
    let mut t = Targets::new(ctx, [16, 16])?;
    for f in 0..2 {
        render_frame(ctx, &r, &mut t, &cam, &setup.render, f)?;
    }
    Ok(check(&t.read_hdr(ctx)?))
}

fn mesh_case(ctx: &Context, key: &str, value: &str) -> vkengine::Result<Outcome> {
    let sc = vkengine::scene::procedural::builtin("cornell").ok_or_else(|| Error::Input("no cornell".into()))?;
    let sets = [("lpv", "1"), ("rsm", "64"), (key, value)].map(|(k, v)| Setting::new(k, v, Origin::Cli));
    let setup = vkengine::mesh::settings::MeshSetup::parse(&sets)?;
    let gpu = GpuScene::upload(ctx, &sc)?;
    let renderer = MeshRenderer::new(ctx)?;
    let mut targets = MeshTargets::new(ctx, [32, 24], setup.rsm_size())?;
    let view = crate::mesh_scene::view_at(&sc, 0, 1);
    render_mesh(ctx, &renderer, &gpu, &mut targets, &view, &setup.settings)?;
    Ok(check(&targets.read_hdr(ctx)?))
}

/// Runs the selected cases, printing one line per case to stderr.
pub fn sweep(ctx: &Context, sel: &Selection) -> Vec<Case> {
    let mut cases = Vec::new();
    let wanted = |k: &str| sel.keys.is_empty() || sel.keys.contains(&k);
    let mut run = |target: String, key: &'static str, value: String, f: &dyn Fn() -> vkengine::Result<Outcome>| {
        let start = Instant::now();
        let outcome = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
            Ok(r) => classify(r),
            Err(_) => Outcome::Failed("panic".into()),
        };
        let elapsed = start.elapsed();
        let outcome = match outcome {
            Outcome::Ok if elapsed > sel.limit => Outcome::Failed(format!("took {:.1} s", elapsed.as_secs_f64())),
            o => o,
        };
        eprintln!("{target:<14} {key:<20} {value:<12} {:>8.0} ms  {outcome:?}", elapsed.as_secs_f64() * 1e3);
        cases.push(Case { target, key, value, outcome, ms: elapsed.as_secs_f64() * 1e3 });
    };
    for &renderer in sel.renderers {
        for key in vkengine::volume::render::settings::SCHEMA.keys().filter(|k| wanted(k.key)) {
            for value in ends(key) {
                run(format!("volume:{renderer}"), key.key, value.clone(), &|| {
                    volume_case(ctx, renderer, key.key, &value)
                });
            }
        }
    }
    if sel.mesh {
        for key in vkengine::mesh::settings::SCHEMA.keys().filter(|k| wanted(k.key)) {
            for value in ends(key) {
                run("mesh".into(), key.key, value.clone(), &|| mesh_case(ctx, key.key, &value));
            }
        }
    }
    cases
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pixel_check_and_the_classification_catch_what_they_should() {
        assert_eq!(check(&[[0.0, 1.0, 2.0, 1.0]]), Outcome::Ok);
        assert!(matches!(check(&[[0.0, f32::NAN, 0.0, 1.0]]), Outcome::Failed(_)));
        assert!(matches!(check(&[[0.0, -1e-9, 0.0, 1.0]]), Outcome::Failed(_)));
        assert!(matches!(check(&[[f32::INFINITY, 0.0, 0.0, 1.0]]), Outcome::Failed(_)));
        assert!(matches!(classify(Err(Error::Input("x".into()))), Outcome::Refused(_)));
        assert!(matches!(classify(Err(Error::Graph("x".into()))), Outcome::Failed(_)));
    }

    #[test]
    fn both_finite_ends_of_each_numeric_key() {
        let k = vkengine::volume::render::settings::SCHEMA.key("density").expect("density");
        assert_eq!(ends(k), ["0.000001", "1000000"]);
        let n = vkengine::volume::render::settings::SCHEMA.key("n").expect("n");
        assert_eq!(ends(n), ["2", "128"], "n is capped at 128");
        let yaw = vkengine::volume::render::settings::SCHEMA.key("yaw").expect("yaw");
        assert!(ends(yaw).is_empty(), "an unbounded key has no ends");
    }
}
