//! `vkengine.Renderer`: the `volume` CLI's headless renderer behind a Python object. Progressive
//! frames accumulate on the GPU exactly as `volume --frames N` does; `accumulate` reads each
//! frame back into a float64 sum instead, so disjoint frame ranges rendered anywhere merge
//! exactly.

use crate::devices::Registered;
use crate::labels::LabelArgs;
use crate::locked::Locked;
use crate::settings::{demo_args, pairs};
use crate::tf::PyTransferFunction;
use crate::volume::PyVolume;
use crate::{arrays, errors, image_io};
use glam::Vec3;
use numpy::{PyArrayDyn, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;
use vkengine::vk::{Context, Validation};
use vkengine::volume::camera::{Camera, Rig};
use vkengine::volume::optics::envmap::EnvMap;
use vkengine::volume::optics::tf_choice;
use vkengine::volume::render::renderer::{render_frame, RenderSettings, Targets, VolumeRenderer};
use vkengine::volume::render::settings::{VolumeSetup, BUDGET_AUTO};
use vkengine_demos::stats::PassStats;
use vkengine_demos::volume_scene;

/// What the GPU holds: the device, the volume's GPU state and the accumulation targets.
struct Gpu {
    ctx: Context,
    renderer: VolumeRenderer,
    targets: Targets,
}

impl Gpu {
    /// View-dependent residency (`residency=view`) for the frame about to be rendered from
    /// `camera`: moves the device toward the view's cut within the upload budget; nothing without.
    fn stream(&mut self, camera: &Camera) -> PyResult<()> {
        let [w, h] = [self.targets.hdr.info.extent[0], self.targets.hdr.info.extent[1]];
        self.renderer.stream(&self.ctx, camera, w as f32 / h.max(1) as f32).map_err(errors::engine)?;
        Ok(())
    }
}

/// Where the volume's physical coordinates sit in the renderer's world (largest axis = 1).
#[derive(Clone, Copy)]
struct Placement {
    origin: Vec3,
    spacing: Vec3,
    extent: Vec3,
    max_extent: f32,
}

impl Placement {
    fn world(&self, p: Vec3) -> Vec3 {
        // Voxel i's centre is at texture coordinate (i + ½) / dims of a box centred at 0.
        (p - self.origin + 0.5 * self.spacing - 0.5 * self.extent) / self.max_extent
    }
}

/// A volume renderer with its own device, settings, camera and accumulation; one call at a
/// time (a second thread waits), and nothing after `close()`.
#[pyclass(name = "Renderer", module = "vkengine", frozen)]
pub struct PyRenderer {
    state: Locked<State>,
}

/// What a renderer holds between calls.
struct State {
    /// First, so it lets go of the device before `gpu` frees it.
    _registered: Registered,
    gpu: Gpu,
    setup: VolumeSetup,
    settings: RenderSettings,
    steered: RenderSettings,
    camera: Camera,
    /// The camera the settings gave (framing the object unless they state it).
    initial_camera: Camera,
    size: [u32; 2],
    /// The next frame's index (the Monte Carlo streams' frame number).
    frame: u64,
    stats: PassStats,
    wall_ms: f64,
    /// Of `wall_ms`: between frames, with the GIL re-taken (Ctrl-C check, `progress`).
    between_ms: f64,
    placement: Placement,
    volume_info: serde_json::Value,
    validation_seen: usize,
}

/// A Python int/float/None as a GPU timeout.
fn timeout(t: Option<f64>) -> PyResult<Option<std::time::Duration>> {
    match t {
        None => Ok(None),
        Some(s) => vkengine::vk::parse_gpu_timeout(&s.to_string())
            .map(Some)
            .map_err(|e| errors::value(format!("gpu_timeout={s}: {e}"))),
    }
}

fn env_from_array(a: &Bound<'_, PyAny>) -> PyResult<EnvMap> {
    let a = &arrays::aligned(a)?;
    let arr: PyReadonlyArrayDyn<'_, f32> =
        a.extract().map_err(|_| errors::value("env: expected a float32 array (height, width, 3) or a path"))?;
    let (h, w) = match arr.shape() {
        [h, w, 3] if *h > 0 && *w > 0 => (*h, *w),
        s => return Err(errors::value(format!("env: expected shape (height, width, 3), got {s:?}"))),
    };
    let flat: Vec<f32> = arr.as_array().iter().copied().collect();
    let texels: Vec<[f32; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    EnvMap::new(w as u32, h as u32, texels, "env array").map_err(errors::engine)
}

/// Between frames, on the thread that can receive Ctrl-C (Python delivers signals to the main
/// thread only) or with a `progress` callable: re-takes the GIL for the signal check and the
/// call. Other threads (a Dask worker's) never re-take it.
struct Between {
    progress: Option<Py<PyAny>>,
    signals: bool,
    /// Nanoseconds spent in the checks and calls (for the per-frame overhead's measurement).
    spent_ns: AtomicU64,
}

impl Between {
    fn new(py: Python<'_>, progress: Option<Py<PyAny>>) -> PyResult<Self> {
        let threading = py.import("threading")?;
        let signals = threading.call_method0("current_thread")?.is(&threading.call_method0("main_thread")?);
        Ok(Self { progress, signals, spent_ns: AtomicU64::new(0) })
    }

    /// After `done` of `total` frames: `KeyboardInterrupt` if Ctrl-C came, else `progress(done, total)`.
    fn frame(&self, done: u64, total: u64) -> PyResult<()> {
        if !self.signals && self.progress.is_none() {
            return Ok(());
        }
        let t0 = Instant::now();
        let result = Python::attach(|py| {
            py.check_signals()?;
            if let Some(p) = &self.progress {
                p.call1(py, (done, total))?;
            }
            Ok(())
        });
        let ns = u64::try_from(t0.elapsed().as_nanos()).unwrap_or(u64::MAX);
        self.spent_ns.fetch_add(ns, Ordering::Relaxed);
        result
    }

    fn spent_ms(&self) -> f64 {
        self.spent_ns.load(Ordering::Relaxed) as f64 * 1e-6
    }
}

impl State {
    /// Renders frames `frame..frame + n` progressively (the CLI's loop), GIL released; with
    /// `until_error` set, stops after the first frame whose estimated error reaches it.
    fn run_frames(&mut self, py: Python<'_>, n: u64, between: Between) -> PyResult<()> {
        let Self { gpu, camera, steered, frame, stats, wall_ms, between_ms, .. } = self;
        let start = Instant::now();
        let result = py.detach(|| {
            errors::guarded("render", || {
                for i in 0..n {
                    gpu.ctx.set_frame(*frame);
                    gpu.stream(camera)?;
                    let run = render_frame(&gpu.ctx, &gpu.renderer, &mut gpu.targets, camera, steered, *frame)
                        .map_err(errors::engine)?;
                    // Bounded work with `mc_frame_ms`: the budget follows the measured frame time.
                    steered.mc.budget = steered.mc.steer_budget(steered.mc.budget, run.gpu_ms());
                    stats.add(&run.timings);
                    *frame += 1;
                    between.frame(i + 1, n)?;
                    let c = &steered.mc.convergence;
                    if c.until_error > 0.0 && gpu.targets.error_estimate().is_some_and(|e| e.reached(c)) {
                        break;
                    }
                }
                Ok(())
            })
        });
        *wall_ms += start.elapsed().as_secs_f64() * 1e3;
        *between_ms += between.spent_ms();
        result?;
        self.check_validation()
    }

    fn check_validation(&mut self) -> PyResult<()> {
        errors::check_validation(&self.gpu.ctx, &mut self.validation_seen)
    }

    /// Starts the accumulation afresh at frame 0 (after any change of what is rendered).
    fn restart(&mut self) {
        self.gpu.targets.samples = 0;
        self.frame = 0;
        self.steered = self.settings;
        self.stats = PassStats::default();
        self.wall_ms = 0.0;
        self.between_ms = 0.0;
    }
}

#[pymethods]
impl PyRenderer {
    /// A renderer of `volume` (a `Volume`; `None`: the CLI's procedural scene from the `scene`
    /// and `n` settings) at `size` = (width, height). `tf`: a `TransferFunction` or the CLI's
    /// `tf=` text; `env`: an environment map, a float32 array (h, w, 3), a file path or `"sky"`;
    /// `labels`: a label file or an integer array `[z, y, x]` on the volume's grid; `label_colors`:
    /// a JSON file or a dict `{label: {"color": [r, g, b], "opacity": o, "visible": b}}`;
    /// every other keyword is a `--set` key of the `volume` CLI, checked by the same schema.
    #[new]
    #[pyo3(signature = (volume=None, *, size=(512, 512), tf=None, env=None, seed=0, jitter=true, device=None, validation=None, gpu_timeout=None, **settings))]
    #[allow(clippy::too_many_arguments)] // Python keywords
    fn new(
        py: Python<'_>,
        volume: Option<&Bound<'_, PyVolume>>,
        size: (u32, u32),
        tf: Option<&Bound<'_, PyAny>>,
        env: Option<&Bound<'_, PyAny>>,
        seed: u64,
        jitter: bool,
        device: Option<String>,
        validation: Option<bool>,
        gpu_timeout: Option<f64>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        // The label keywords that are Python objects (an array, a dict) are taken out first.
        let settings = settings.map(|d| d.copy()).transpose()?;
        let label_args = match &settings {
            Some(kw) => LabelArgs::take(kw)?,
            None => LabelArgs::default(),
        };
        let mut sets = pairs(settings.as_ref())?;
        let mut tf_object: Option<PyTransferFunction> = None;
        if let Some(t) = tf {
            match t.extract::<PyTransferFunction>() {
                Ok(obj) => tf_object = Some(obj),
                Err(_) => sets.push((
                    "tf".into(),
                    t.extract::<String>().map_err(|_| {
                        errors::value(
                            "tf: expected a TransferFunction or the CLI's tf= text (preset, ramp:LO,HI, FILE.json)",
                        )
                    })?,
                )),
            }
        }
        let mut env_array = None;
        if let Some(e) = env {
            match e.extract::<String>() {
                Ok(s) => sets.push(("env_map".into(), s)),
                Err(_) => env_array = Some(env_from_array(e)?),
            }
        }
        let size = [size.0, size.1];
        let mut args = demo_args(&sets, size, seed)?;
        let gpu_timeout = timeout(gpu_timeout)?;
        if gpu_timeout.is_some() {
            args.gpu_timeout = gpu_timeout;
        }
        // Built on the rendering thread: the options' display handle is not `Send`.
        let context_args = args.clone();
        let options = move || {
            let mut opts = context_args.context_options();
            match validation {
                Some(true) => opts.validation = Validation::Required,
                Some(false) => opts.validation = Validation::Off,
                None => {}
            }
            if device.is_some() {
                opts.device = device;
            }
            opts
        };
        let mut setup = volume_scene::volume_setup(&args).map_err(errors::engine)?;
        if env_array.is_some() {
            setup.render.mc.env_map = true;
        }
        let given = volume.map(|v| (v.get().inner.clone(), v.get().origin));
        let (gpu, camera, placement, info) = py.detach(|| {
            errors::guarded("Renderer", || {
                let ctx = Context::new(&options()).map_err(errors::engine)?;
                // Past the 3D-image limit a volume is stored in bricks, whose page table has the limit.
                let max = ctx.info.limits.max_image_dimension3_d.saturating_mul(vkengine::volume::data::bricks::BRICK);
                let (vol, origin, tf) = match given {
                    Some((vol, origin)) => {
                        let tf = match (&tf_object, &setup.tf) {
                            (Some(t), _) => t.inner.clone(),
                            (None, Some(name)) => tf_choice::named(name, &vol).map_err(errors::engine)?,
                            (None, None) => {
                                let (tf, line) = tf_choice::for_volume(None, &vol).map_err(errors::engine)?;
                                if let Some(line) = line {
                                    eprintln!("{line}");
                                }
                                tf
                            }
                        };
                        if vol.dims.iter().any(|d| *d > max) {
                            return Err(errors::value(format!(
                                "{}: dims {:?} exceed the device's limit of {max} voxels per axis (its 3D image limit in bricks)",
                                vol.source, vol.dims
                            )));
                        }
                        (vol, origin, tf)
                    }
                    None => {
                        let (vol, tf) = volume_scene::load_scene(&args, &setup, &ctx).map_err(errors::engine)?;
                        let tf = tf_object.as_ref().map_or(tf, |t| t.inner.clone());
                        (vol, [0.0; 3], tf)
                    }
                };
                let from_file = if label_args.has_array() {
                    None
                } else {
                    volume_scene::load_labels(&args, &setup, &vol).map_err(errors::engine)?
                };
                let labels = label_args.resolve(&vol, setup.labels.colors.as_deref(), from_file)?;
                // `residency=view` builds the renderer resident by the view (`Gpu::stream`).
                let mut renderer = volume_scene::renderer(&ctx, &vol, &tf, &setup).map_err(errors::engine)?;
                renderer.set_labels(&ctx, labels.as_ref().map(|(l, t)| (l, t))).map_err(errors::engine)?;
                let aspect = size[0] as f32 / size[1] as f32;
                let camera = volume_scene::camera(&setup, &vol, renderer.box_half(), aspect);
                let env = match env_array {
                    Some(e) => Some(e),
                    None => volume_scene::env_map(&setup).map_err(errors::engine)?,
                };
                renderer.set_environment(&ctx, env.as_ref()).map_err(errors::engine)?;
                volume_scene::set_temperature(&ctx, &mut renderer, &setup, &args, &vol).map_err(errors::engine)?;
                let targets = Targets::new(&ctx, size).map_err(errors::engine)?;
                let placement = Placement {
                    origin: Vec3::from(origin),
                    spacing: Vec3::from(vol.spacing),
                    extent: Vec3::from(vol.extent()),
                    max_extent: vol.max_extent(),
                };
                let info = serde_json::json!({
                    "source": vol.source, "dims": vol.dims, "spacing": vol.spacing,
                    "origin": origin, "value_range": vol.value_range,
                });
                Ok((Gpu { ctx, renderer, targets }, camera, placement, info))
            })
        })?;
        let mut settings = setup.render;
        settings.mc.seed = seed as u32;
        settings.jitter = jitter;
        let mut r = State {
            _registered: Registered::new(&gpu.ctx),
            gpu,
            setup,
            settings,
            steered: settings,
            camera,
            initial_camera: camera,
            size,
            frame: 0,
            stats: PassStats::default(),
            wall_ms: 0.0,
            between_ms: 0.0,
            placement,
            volume_info: info,
            validation_seen: 0,
        };
        r.check_validation()?;
        Ok(Self { state: Locked::new(r, "Renderer") })
    }

    /// Renders `frames` more frames into the progressive mean (fewer once the estimated error
    /// reaches `until_error`, when set) and returns `image()`. Ctrl-C
    /// stops it after the frame in flight (`KeyboardInterrupt`; the frames done stay
    /// accumulated); `progress(done, frames)` is called after every frame.
    #[pyo3(signature = (frames=1, progress=None))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        frames: u64,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let between = Between::new(py, progress)?;
        self.state.with(py, |s| {
            s.run_frames(py, frames, between)?;
            s.image(py)
        })
    }

    /// Renders one more frame into the progressive mean.
    fn step(&self, py: Python<'_>) -> PyResult<()> {
        let between = Between::new(py, None)?;
        self.state.with(py, |s| s.run_frames(py, 1, between))
    }

    /// Monte Carlo: the image's estimated relative error (foreground) from each pixel's second
    /// moment, or None (another renderer, or fewer than two paths per pixel so far).
    fn estimated_error(&self, py: Python<'_>) -> PyResult<Option<f64>> {
        self.state.with(py, |s| Ok(s.gpu.targets.error_estimate().and_then(|e| e.relative)))
    }

    /// The image shown: linear HDR float32, shape (height, width, 4); with `denoise=on` (Monte
    /// Carlo) the denoised image, otherwise the progressive mean.
    fn image<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        self.state.with(py, |s| s.image(py))
    }

    /// The unbiased progressive mean whatever `denoise` says: linear HDR float32, shape
    /// (height, width, 4).
    fn mean<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        self.state.with(py, |s| {
            let gpu = &s.gpu;
            image_io::frame_hdr(py, s.size, || gpu.targets.read_hdr(&gpu.ctx))
        })
    }

    /// The tone-mapped image: sRGB uint8, shape (height, width, 4).
    fn image_srgb<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
        self.state.with(py, |s| {
            let gpu = &s.gpu;
            image_io::frame_srgb(py, s.size, || gpu.targets.read_ldr(&gpu.ctx))
        })
    }

    /// The tone-mapped image as PNG bytes: how Jupyter shows a renderer.
    fn _repr_png_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyBytes>> {
        let png = self.state.with(py, |s| {
            let gpu = &s.gpu;
            let [w, h] = s.size;
            py.detach(|| {
                errors::guarded("_repr_png_", || {
                    let ldr = gpu.targets.read_ldr(&gpu.ctx).map_err(errors::engine)?;
                    image_io::png_bytes(w, h, &ldr)
                })
            })
        })?;
        Ok(pyo3::types::PyBytes::new(py, &png))
    }

    /// Forgets the accumulation: the next frame is frame 0 again.
    fn reset(&self, py: Python<'_>) -> PyResult<()> {
        self.state.with(py, |s| {
            s.restart();
            Ok(())
        })
    }

    /// Renders frames `start..stop` one by one and returns `(sum, count)`: the float64 sum of
    /// their HDR images (shape (height, width, 4)) and `stop - start`. Disjoint ranges rendered
    /// anywhere add up to the sum of the whole range; `sum / count` is the image. Leaves the
    /// progressive accumulation reset. Ctrl-C and `progress` as in `render`.
    #[pyo3(signature = (start, stop, progress=None))]
    fn accumulate<'py>(
        &self,
        py: Python<'py>,
        start: u64,
        stop: u64,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<(Bound<'py, PyArrayDyn<f64>>, u64)> {
        if stop < start {
            return Err(errors::value(format!("accumulate({start}, {stop}): stop must be >= start")));
        }
        let between = Between::new(py, progress)?;
        self.state.with(py, |s| s.accumulate(py, start, stop, between))
    }

    /// Places the orbit camera: yaw and pitch in radians, distance and target in world units
    /// (the volume's largest axis is 1, centred at 0). Unset arguments keep their values.
    #[pyo3(signature = (yaw=None, pitch=None, distance=None, target=None))]
    fn orbit(
        &self,
        py: Python<'_>,
        yaw: Option<f32>,
        pitch: Option<f32>,
        distance: Option<f32>,
        target: Option<[f32; 3]>,
    ) -> PyResult<()> {
        let finite = [yaw, pitch, distance].iter().flatten().chain(target.iter().flatten()).all(|v| v.is_finite());
        if !finite || distance.is_some_and(|d| d <= 0.0) {
            return Err(errors::value("orbit: values must be finite and the distance > 0"));
        }
        self.state.with(py, |s| {
            if let Rig::Orbit { target: t, distance: d, yaw: y, pitch: p } = &mut s.camera.rig {
                *y = yaw.unwrap_or(*y);
                *p = pitch.unwrap_or(*p);
                *d = distance.unwrap_or(*d);
                *t = target.map_or(*t, Vec3::from);
            }
            s.restart();
            Ok(())
        })
    }

    /// Looks from `eye` at `target`; with `physical=True` both are in the volume's physical
    /// coordinates (spacing and origin), else in world units.
    #[pyo3(signature = (eye, target, physical=false))]
    fn look_at(&self, py: Python<'_>, eye: [f32; 3], target: [f32; 3], physical: bool) -> PyResult<()> {
        self.state.with(py, |s| {
            let (mut e, mut t) = (Vec3::from(eye), Vec3::from(target));
            if physical {
                (e, t) = (s.placement.world(e), s.placement.world(t));
            }
            let d = e - t;
            let distance = d.length();
            if !distance.is_finite() || distance <= 1e-6 {
                return Err(errors::value(format!(
                    "look_at: eye {eye:?} and target {target:?} must be finite and apart"
                )));
            }
            // The orbit's direction in the rig's frame: (sin yaw cos pitch, sin pitch, cos yaw cos pitch).
            let local = s.camera.basis.transpose() * (d / distance);
            let pitch = local.y.clamp(-1.0, 1.0).asin();
            let yaw = local.x.atan2(local.z);
            s.camera.rig = Rig::Orbit { target: t, distance, yaw, pitch };
            s.restart();
            Ok(())
        })
    }

    /// Back to the camera the settings gave.
    fn reset_camera(&self, py: Python<'_>) -> PyResult<()> {
        self.state.with(py, |s| {
            s.camera = s.initial_camera;
            s.restart();
            Ok(())
        })
    }

    /// The camera: rig (`orbit` with target, distance, yaw, pitch) and projection.
    fn camera(&self, py: Python<'_>) -> PyResult<String> {
        self.state.with(py, |s| Ok(format!("{:?}", s.camera)))
    }

    /// Frames accumulated so far (the next frame's index).
    #[getter]
    fn frames(&self, py: Python<'_>) -> PyResult<u64> {
        self.state.with(py, |s| Ok(s.frame))
    }

    /// (width, height).
    #[getter]
    fn size(&self, py: Python<'_>) -> PyResult<(u32, u32)> {
        self.state.with(py, |s| Ok((s.size[0], s.size[1])))
    }

    /// The device: `#index name (driver) uuid:…`; `device="#index"` or `device="uuid:…"`
    /// chooses it again.
    #[getter]
    fn device(&self, py: Python<'_>) -> PyResult<String> {
        self.state.with(py, |s| {
            let i = &s.gpu.ctx.info;
            Ok(format!("#{} {} ({}) uuid:{}", i.index, i.name, i.driver, i.uuid))
        })
    }

    /// The figures of the CLI's JSON report: device (with the device memory this process's
    /// live renderers hold on it), volume, settings, frames, median GPU ms per pass and per
    /// frame, wall time, majorant violations.
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = self.state.with(py, |s| {
            let device: vkengine_demos::output::DeviceReport = (&s.gpu.ctx.info).into();
            let mut device = serde_json::to_value(device).map_err(|e| errors::value(e.to_string()))?;
            device["process_reserved_bytes"] = crate::devices::reserved_bytes(&s.gpu.ctx.info.uuid).into();
            let report = serde_json::json!({
                "demo": "python",
                "device": device,
                "volume": s.volume_info,
                "settings": s.settings,
                "scene": s.setup.scene,
                "size": s.size,
                "frames": s.frame,
                "passes": s.stats.pass_medians(),
                "frame_ms": s.stats.frame_median(),
                "wall_ms": s.wall_ms,
                "between_frames_ms": s.between_ms,
                "empty_block_fraction": s.gpu.renderer.empty_fraction,
                "majorant_violations": s.gpu.renderer.majorant_violations(),
            });
            serde_json::to_string(&report).map_err(|e| errors::value(e.to_string()))
        })?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// Writes the image: `.exr` linear HDR (as the CLI's `--out x.exr`), else PNG (sRGB).
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        self.state.with(py, |s| {
            let gpu = &s.gpu;
            image_io::save_frame(
                py,
                path,
                s.size,
                || gpu.targets.read_shown(&gpu.ctx),
                || gpu.targets.read_ldr(&gpu.ctx),
            )
        })
    }

    /// Frees the device, the volume and the images now; every later call raises `ValueError`.
    /// Closing twice is harmless. `with Renderer(...) as r:` closes at the block's end.
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        self.state.close(py)
    }

    /// Whether `close()` has run.
    #[getter]
    fn closed(&self, py: Python<'_>) -> bool {
        self.state.is_closed(py)
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_exc))]
    fn __exit__(&self, py: Python<'_>, _exc: &Bound<'_, pyo3::types::PyTuple>) -> PyResult<bool> {
        self.close(py)?;
        Ok(false)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        self.state
            .with(py, |s| {
                Ok(format!(
                    "Renderer({}, {}x{}, {} frames, {})",
                    s.settings.renderer.name(),
                    s.size[0],
                    s.size[1],
                    s.frame,
                    s.gpu.ctx.info.name
                ))
            })
            .unwrap_or_else(|_| "Renderer(closed)".into())
    }
}

impl State {
    fn image<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let gpu = &self.gpu;
        image_io::frame_hdr(py, self.size, || gpu.targets.read_shown(&gpu.ctx))
    }

    fn accumulate<'py>(
        &mut self,
        py: Python<'py>,
        start: u64,
        stop: u64,
        between: Between,
    ) -> PyResult<(Bound<'py, PyArrayDyn<f64>>, u64)> {
        // Whole paths: `mc_budget=auto` could pick bounded work, whose paths carry over from
        // frame to frame (a device whose dispatch cannot hold whole paths then fails, naming it).
        let mut settings = self.settings;
        if settings.mc.budget == BUDGET_AUTO {
            settings.mc.budget = 0;
        }
        if settings.mc_bounded() {
            return Err(errors::value(format!(
                "mc_budget={}: bounded work carries paths from frame to frame, so frame ranges are not independent; use mc_budget=0 for exact accumulation",
                settings.mc.budget
            )));
        }
        self.restart();
        let [w, h] = self.size.map(|s| s as usize);
        let Self { gpu, camera, stats, .. } = self;
        let t0 = Instant::now();
        let sum = py.detach(|| {
            errors::guarded("accumulate", || {
                let mut sum = vec![0f64; w * h * 4];
                for f in start..stop {
                    // A mean of one frame: the accumulation pass copies the frame exactly.
                    gpu.targets.samples = 0;
                    gpu.ctx.set_frame(f);
                    gpu.stream(camera)?;
                    let run = render_frame(&gpu.ctx, &gpu.renderer, &mut gpu.targets, camera, &settings, f)
                        .map_err(errors::engine)?;
                    stats.add(&run.timings);
                    let hdr = gpu.targets.read_hdr(&gpu.ctx).map_err(errors::engine)?;
                    for (s, v) in sum.iter_mut().zip(hdr.iter().flatten()) {
                        *s += f64::from(*v);
                    }
                    between.frame(f + 1 - start, stop - start)?;
                }
                Ok(sum)
            })
        });
        self.wall_ms += t0.elapsed().as_secs_f64() * 1e3;
        self.between_ms += between.spent_ms();
        self.gpu.targets.samples = 0;
        let sum = sum?;
        self.check_validation()?;
        Ok((arrays::owned(py, sum, &[h, w, 4])?, stop - start))
    }
}
