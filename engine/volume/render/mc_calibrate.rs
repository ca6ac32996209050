//! `mc_budget=auto`'s choice per device by measurement: of the two bounded ways to run Monte
//! Carlo, one whole path per pixel per frame (where the device's dispatch bound allows it,
//! `super::mc_mode`) and bounded work, the one that reaches a given error sooner. Each is run
//! on a small synthetic scene shaped like vpt's (a dense fBm cloud, up to 8 events, a white
//! environment), interleaved over a few rounds; its cost is the image's estimated relative
//! variance (from the pixels' second moments) times the GPU seconds it took, so the time to a
//! relative error e is cost / e². On llvmpipe, whose SIMD rows wait for their longest path,
//! bounded work regroups paths and wins at the sizes rendered (0.90–0.93× whole paths' cost on
//! vpt's scene at 256²) and ties here ([`WHOLE_MARGIN`] gives it the ties); on an H200 one whole
//! path per frame reached Mitsuba's error 1.17× sooner.
//! The choice changes the image (the two ways draw different random numbers), so it is measured
//! once per device, driver, build profile and shader, and kept on disk ([`cache_file`]): every
//! later run of the same command on that machine makes the same image, however the timing of the
//! day would have come out. The LPV's layout (`crate::lpv::passes::calibrate`) needs no such store:
//! its layouts make the same image.

use super::frame::{render_frame, Targets};
use super::renderer::VolumeRenderer;
use super::settings::VolumeSetup;
use crate::settings::{Origin, Setting};
use crate::vk::Context;
use crate::volume::camera::{Camera, Projection};
use crate::volume::data::procedural;
use crate::volume::optics::tf::TransferFunction;
use crate::Result;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// Both ways' cost on the synthetic scene: relative variance × GPU seconds (medians over the
/// rounds; lower reaches an error sooner).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Measured {
    /// One whole path per pixel per frame (`mc_budget=0`).
    pub whole_cost: f64,
    /// Bounded work of `super::mc_mode::AUTO_BUDGET` steps, 4 paths kept.
    pub bounded_cost: f64,
}

/// Whole paths must cost less than this share of bounded work's to be chosen; bounded work wins
/// ties. The measurement's 64² scene understates bounded work's lead at the sizes rendered: on
/// llvmpipe, once lavapipe no longer recompiled the shaders at every dispatch (their fixed cost
/// had weighed on whole paths' short frames), bounded / whole measured 0.89–1.11 here (4
/// processes) but 0.90–0.93 at 256² on vpt's scene, where bounded work reached vpt's error 1.1×
/// sooner. Before that fix the ratio was 0.61–0.79 in release builds and 0.66–0.85 in debug
/// builds under the validation layer. An H200 ran whole paths 1.17× faster (0.85 of bounded
/// work's cost), so it keeps them. Since the measurement is kept per device ([`cache_file`]), a
/// device near the margin still makes the same image in every run.
pub const WHOLE_MARGIN: f64 = 0.9;

impl Measured {
    /// Bounded work, unless whole paths reach an error sooner by the margin.
    pub fn bounded(&self) -> bool {
        self.whole_cost >= WHOLE_MARGIN * self.bounded_cost
    }

    /// Both costs are positive and finite: a measurement worth keeping.
    fn usable(&self) -> bool {
        [self.whole_cost, self.bounded_cost].iter().all(|c| c.is_finite() && *c > 0.0)
    }
}

/// Image edge of the measurement.
const SIZE: u32 = 64;
/// Rounds (each way once per round, interleaved).
const ROUNDS: u64 = 3;
/// Frames per way and round: enough that every pixel has the two paths a variance needs.
const FRAMES: u64 = 6;

/// Every measurement of this process: its key ([`cache_key`]), the device's name and the result.
static MEASURED: OnceLock<Mutex<BTreeMap<String, (String, Measured)>>> = OnceLock::new();

/// Bumped whenever [`measure`] changes what it measures (its scene, sizes, rounds, the bounded
/// budget): a kept measurement of an earlier version is not used.
const MEASURE_VERSION: u32 = 2;

/// The measurement for `ctx`'s device: this process's, else the one kept on disk for this device,
/// driver, build and shaders ([`cache_file`]), else made now (reported on stderr) and kept.
pub fn cached(ctx: &Context) -> Result<Measured> {
    let map = MEASURED.get_or_init(|| Mutex::new(BTreeMap::new()));
    // Held while measuring: threads rendering at once wait for one measurement.
    let mut map = map.lock().unwrap_or_else(|e| e.into_inner());
    let key = cache_key(ctx);
    if let Some((_, m)) = map.get(&key) {
        return Ok(*m);
    }
    let file = cache_file();
    let kept = file.as_deref().and_then(|f| load(f, &key));
    // Processes that start together on a machine without the measurement take turns: the first
    // measures, the others wait for it and find its result, so they all make the same image.
    let _turn = if kept.is_none() { file.as_deref().and_then(measure_lock) } else { None };
    let (m, how) = match kept.or_else(|| file.as_deref().and_then(|f| load(f, &key))) {
        Some(m) => (m, "kept from an earlier measurement".to_string()),
        None => {
            let m = measure(ctx)?;
            let how = match &file {
                None => "measured now; VKENGINE_CACHE_DIR=off keeps nothing".to_string(),
                Some(_) if !m.usable() => "measured now; not kept, it saw no variance".to_string(),
                Some(f) => match store(f, &key, m) {
                    Ok(()) => format!("measured now, kept in {}", f.display()),
                    Err(e) => format!("measured now; not kept in {}: {e}", f.display()),
                },
            };
            (m, how)
        }
    };
    eprintln!(
        "mc_budget=auto on {}: bounded work {:.3e}, one whole path per frame {:.3e} (relative variance x GPU s, {how}): {}",
        ctx.info.name,
        m.bounded_cost,
        m.whole_cost,
        if m.bounded() { "bounded work" } else { "whole paths where they fit" }
    );
    map.insert(key, (ctx.info.name.clone(), m));
    Ok(m)
}

/// The measurements made so far in this process, by device name (for reports).
pub fn measured() -> Vec<(String, Measured)> {
    MEASURED.get().map_or_else(Vec::new, |m| m.lock().unwrap_or_else(|e| e.into_inner()).values().cloned().collect())
}

/// Where measurements are kept between processes: `$VKENGINE_CACHE_DIR` (`off`: nowhere, measure
/// in every process), else `$XDG_CACHE_HOME/vkengine`, else `$HOME/.cache/vkengine`.
pub fn cache_file() -> Option<PathBuf> {
    let var = |name| std::env::var_os(name).filter(|v| !v.is_empty());
    let dir = match var("VKENGINE_CACHE_DIR") {
        Some(d) if d == "off" => return None,
        Some(d) => PathBuf::from(d),
        None => match var("XDG_CACHE_HOME") {
            Some(d) => PathBuf::from(d).join("vkengine"),
            None => PathBuf::from(var("HOME")?).join(".cache").join("vkengine"),
        },
    };
    Some(dir.join("mc_budget_auto.json"))
}

/// What a measurement holds for: the device and its driver, the CPU threads a CPU driver such
/// as llvmpipe runs on, the build profile and the validation layer (both change the ratio: see
/// [`WHOLE_MARGIN`]), the Monte Carlo shaders and [`MEASURE_VERSION`].
fn cache_key(ctx: &Context) -> String {
    let profile = if cfg!(debug_assertions) { "debug" } else { "release" };
    let validation = if ctx.info.validation { "validation" } else { "no validation" };
    let threads = match std::env::var("LP_NUM_THREADS") {
        Ok(n) => format!("LP_NUM_THREADS={n}"),
        Err(_) => format!("{} CPUs", std::thread::available_parallelism().map_or(0, |n| n.get())),
    };
    format!(
        "{} {} / {} / {threads} / {profile}, {validation} / shaders {:016x} / measure v{MEASURE_VERSION}",
        ctx.info.name,
        ctx.info.uuid,
        ctx.info.driver,
        shaders_hash()
    )
}

/// The hash of the Monte Carlo shaders' SPIR-V (about 1.8 MB), taken once per process: the key
/// is looked up every frame that resolves `mc_budget=auto`.
fn shaders_hash() -> u64 {
    static HASH: OnceLock<u64> = OnceLock::new();
    *HASH.get_or_init(|| {
        let words = [
            &crate::shaders::VOLUME_MC_COMP,
            &crate::shaders::VOLUME_MC_BOUNDED_COMP,
            &crate::shaders::VOLUME_MC_ACCUMULATE_COMP,
            &crate::shaders::VOLUME_MC_TILES_COMP,
        ]
        .into_iter()
        .flat_map(|s| s.words.iter());
        fnv1a(words)
    })
}

/// FNV-1a over 32-bit words: a hash that stays the same across toolchains.
fn fnv1a<'a>(words: impl Iterator<Item = &'a u32>) -> u64 {
    words.fold(0xcbf2_9ce4_8422_2325, |h, w| (h ^ u64::from(*w)).wrapping_mul(0x0000_0100_0000_01b3))
}

/// The measurement kept in `file` under `key`; none where the file is missing or unreadable
/// (then it is measured again and the file rewritten).
pub fn load(file: &Path, key: &str) -> Option<Measured> {
    let text = std::fs::read_to_string(file).ok()?;
    let map: BTreeMap<String, Measured> = serde_json::from_str(&text).ok()?;
    map.get(key).copied().filter(Measured::usable)
}

/// Keeps `m` under `key` in `file` beside the other devices' measurements; written to a temporary
/// file and renamed, so a process reading at the same time sees the old file or the new one.
pub fn store(file: &Path, key: &str, m: Measured) -> std::io::Result<()> {
    let mut map: BTreeMap<String, Measured> =
        std::fs::read_to_string(file).ok().and_then(|t| serde_json::from_str(&t).ok()).unwrap_or_default();
    map.insert(key.to_string(), m);
    if let Some(dir) = file.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let tmp = file.with_extension(format!("json.{}", std::process::id()));
    let written = serde_json::to_string_pretty(&map)
        .map_err(std::io::Error::other)
        .and_then(|text| std::fs::write(&tmp, text))
        .and_then(|()| std::fs::rename(&tmp, file));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// This process's turn to measure for `file`: an exclusive lock on a file beside it, held until
/// the returned handle is dropped. The operating system releases it when the process ends,
/// however it ends, so an interrupted measurement leaves no lock behind. None where no lock can
/// be had (an unwritable directory, a file system without locks): each process then measures for
/// itself, as without a store.
fn measure_lock(file: &Path) -> Option<std::fs::File> {
    let path = file.with_extension("json.lock");
    std::fs::create_dir_all(path.parent()?).ok()?;
    let lock = std::fs::OpenOptions::new().create(true).truncate(false).write(true).open(&path).ok()?;
    match lock.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => {
            eprintln!("mc_budget=auto: waiting for another process measuring this device ({})", path.display());
            lock.lock().ok()?;
        }
        Err(std::fs::TryLockError::Error(_)) => return None,
    }
    Some(lock)
}

fn setup(extra: &[(&str, &str)]) -> Result<VolumeSetup> {
    let base = [("renderer", "mcm"), ("env", "1"), ("sun", "0"), ("bounces", "8"), ("phase", "iso")];
    let all: Vec<Setting> =
        base.iter().chain(extra).map(|(k, v)| Setting::new(*k, v.to_string(), Origin::Cli)).collect();
    VolumeSetup::parse(&all)
}

fn measure(ctx: &Context) -> Result<Measured> {
    let volume = procedural::cloud([64; 3], 3).map_err(|e| crate::Error::Input(e.to_string()))?;
    // vpt's table shape: extinction ramping to 100 over the middle of the value range.
    let tf = TransferFunction::ramp(0.25, 0.75, [0.9; 3], 100.0);
    let renderer = VolumeRenderer::new(ctx, &volume, &tf)?;
    let cam = Camera::orbit(2.0, 0.0, 0.0, Projection::Perspective { fov_y: 0.8 });
    let budget = super::mc_mode::AUTO_BUDGET.to_string();
    let ways = [setup(&[("mc_budget", "0")])?, setup(&[("mc_budget", &budget), ("mc_paths", "4")])?];
    let mut costs = [Vec::new(), Vec::new()];
    for round in 0..ROUNDS {
        for (way, s) in ways.iter().enumerate() {
            let mut t = Targets::new(ctx, [SIZE; 2])?;
            let mut gpu_s = 0.0;
            for f in 0..FRAMES {
                gpu_s += render_frame(ctx, &renderer, &mut t, &cam, &s.render, 2_000_000 + round * FRAMES + f)?
                    .gpu_ms()
                    * 1e-3;
            }
            if let Some(rel) = t.error_estimate().and_then(|e| e.relative) {
                costs[way].push(rel * rel * gpu_s);
            }
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::INFINITY)
    };
    let [mut whole, mut bounded] = costs;
    Ok(Measured { whole_cost: median(&mut whole), bounded_cost: median(&mut bounded) })
}
