//! `vkengine.Renderer`: the `volume` CLI's headless renderer behind a Python object. Progressive
//! frames accumulate on the GPU exactly as `volume --frames N` does; `accumulate` reads each
//! frame back into a float64 sum instead, so disjoint frame ranges rendered anywhere merge
//! exactly.

use crate::settings::{demo_args, pairs};
use crate::tf::PyTransferFunction;
use crate::volume::PyVolume;
use crate::{arrays, errors, image_io};
use glam::Vec3;
use numpy::{PyArrayDyn, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
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

/// A volume renderer with its own device, settings, camera and accumulation.
#[pyclass(name = "Renderer", module = "vkengine")]
pub struct PyRenderer {
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

impl PyRenderer {
    /// Renders frames `frame..frame + n` progressively (the CLI's loop), GIL released; with
    /// `until_error` set, stops after the first frame whose estimated error reaches it.
    fn run_frames(&mut self, py: Python<'_>, n: u64) -> PyResult<()> {
        let Self { gpu, camera, steered, frame, stats, wall_ms, .. } = self;
        let start = Instant::now();
        py.detach(|| {
            errors::guarded("render", || {
                for _ in 0..n {
                    gpu.ctx.set_frame(*frame);
                    let run = render_frame(&gpu.ctx, &gpu.renderer, &mut gpu.targets, camera, steered, *frame)
                        .map_err(errors::engine)?;
                    // Bounded work with `mc_frame_ms`: the budget follows the measured frame time.
                    steered.mc.budget = steered.mc.steer_budget(steered.mc.budget, run.gpu_ms());
                    stats.add(&run.timings);
                    *frame += 1;
                    let c = &steered.mc.convergence;
                    if c.until_error > 0.0 && gpu.targets.error_estimate().is_some_and(|e| e.reached(c)) {
                        break;
                    }
                }
                Ok(())
            })
        })?;
        *wall_ms += start.elapsed().as_secs_f64() * 1e3;
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
    }
}

#[pymethods]
impl PyRenderer {
    /// A renderer of `volume` (a `Volume`; `None`: the CLI's procedural scene from the `scene`
    /// and `n` settings) at `size` = (width, height). `tf`: a `TransferFunction` or the CLI's
    /// `tf=` text; `env`: an environment map, a float32 array (h, w, 3), a file path or `"sky"`;
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
        let mut sets = pairs(settings)?;
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
                let mut renderer =
                    VolumeRenderer::with_layout(&ctx, &vol, &tf, setup.layout).map_err(errors::engine)?;
                let aspect = size[0] as f32 / size[1] as f32;
                let camera = volume_scene::camera(&setup, &vol, renderer.box_half(), aspect);
                let env = match env_array {
                    Some(e) => Some(e),
                    None => volume_scene::env_map(&setup).map_err(errors::engine)?,
                };
                renderer.set_environment(&ctx, env.as_ref()).map_err(errors::engine)?;
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
        let mut r = Self {
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
            placement,
            volume_info: info,
            validation_seen: 0,
        };
        r.check_validation()?;
        Ok(r)
    }

    /// Renders `frames` more frames into the progressive mean (fewer once the estimated error
    /// reaches `until_error`, when set) and returns `image()`.
    #[pyo3(signature = (frames=1))]
    fn render<'py>(&mut self, py: Python<'py>, frames: u64) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        self.run_frames(py, frames)?;
        self.image(py)
    }

    /// Renders one more frame into the progressive mean.
    fn step(&mut self, py: Python<'_>) -> PyResult<()> {
        self.run_frames(py, 1)
    }

    /// Monte Carlo: the image's estimated relative error (foreground) from each pixel's second
    /// moment, or None (another renderer, or fewer than two paths per pixel so far).
    fn estimated_error(&self) -> Option<f64> {
        self.gpu.targets.error_estimate().and_then(|e| e.relative)
    }

    /// The image shown: linear HDR float32, shape (height, width, 4); with `denoise=on` (Monte
    /// Carlo) the denoised image, otherwise the progressive mean.
    fn image<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let gpu = &self.gpu;
        image_io::frame_hdr(py, self.size, || gpu.targets.read_shown(&gpu.ctx))
    }

    /// The unbiased progressive mean whatever `denoise` says: linear HDR float32, shape
    /// (height, width, 4).
    fn mean<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let gpu = &self.gpu;
        image_io::frame_hdr(py, self.size, || gpu.targets.read_hdr(&gpu.ctx))
    }

    /// The tone-mapped image: sRGB uint8, shape (height, width, 4).
    fn image_srgb<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
        let gpu = &self.gpu;
        image_io::frame_srgb(py, self.size, || gpu.targets.read_ldr(&gpu.ctx))
    }

    /// Forgets the accumulation: the next frame is frame 0 again.
    fn reset(&mut self) {
        self.restart();
    }

    /// Renders frames `start..stop` one by one and returns `(sum, count)`: the float64 sum of
    /// their HDR images (shape (height, width, 4)) and `stop - start`. Disjoint ranges rendered
    /// anywhere add up to the sum of the whole range; `sum / count` is the image. Leaves the
    /// progressive accumulation reset.
    fn accumulate<'py>(
        &mut self,
        py: Python<'py>,
        start: u64,
        stop: u64,
    ) -> PyResult<(Bound<'py, PyArrayDyn<f64>>, u64)> {
        if stop < start {
            return Err(errors::value(format!("accumulate({start}, {stop}): stop must be >= start")));
        }
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
                    let run = render_frame(&gpu.ctx, &gpu.renderer, &mut gpu.targets, camera, &settings, f)
                        .map_err(errors::engine)?;
                    stats.add(&run.timings);
                    let hdr = gpu.targets.read_hdr(&gpu.ctx).map_err(errors::engine)?;
                    for (s, v) in sum.iter_mut().zip(hdr.iter().flatten()) {
                        *s += f64::from(*v);
                    }
                }
                Ok(sum)
            })
        })?;
        self.wall_ms += t0.elapsed().as_secs_f64() * 1e3;
        self.gpu.targets.samples = 0;
        self.check_validation()?;
        Ok((arrays::owned(py, sum, &[h, w, 4])?, stop - start))
    }

    /// Places the orbit camera: yaw and pitch in radians, distance and target in world units
    /// (the volume's largest axis is 1, centred at 0). Unset arguments keep their values.
    #[pyo3(signature = (yaw=None, pitch=None, distance=None, target=None))]
    fn orbit(
        &mut self,
        yaw: Option<f32>,
        pitch: Option<f32>,
        distance: Option<f32>,
        target: Option<[f32; 3]>,
    ) -> PyResult<()> {
        let finite = [yaw, pitch, distance].iter().flatten().chain(target.iter().flatten()).all(|v| v.is_finite());
        if !finite || distance.is_some_and(|d| d <= 0.0) {
            return Err(errors::value("orbit: values must be finite and the distance > 0"));
        }
        if let Rig::Orbit { target: t, distance: d, yaw: y, pitch: p } = &mut self.camera.rig {
            *y = yaw.unwrap_or(*y);
            *p = pitch.unwrap_or(*p);
            *d = distance.unwrap_or(*d);
            *t = target.map_or(*t, Vec3::from);
        }
        self.restart();
        Ok(())
    }

    /// Looks from `eye` at `target`; with `physical=True` both are in the volume's physical
    /// coordinates (spacing and origin), else in world units.
    #[pyo3(signature = (eye, target, physical=false))]
    fn look_at(&mut self, eye: [f32; 3], target: [f32; 3], physical: bool) -> PyResult<()> {
        let (mut e, mut t) = (Vec3::from(eye), Vec3::from(target));
        if physical {
            (e, t) = (self.placement.world(e), self.placement.world(t));
        }
        let d = e - t;
        let distance = d.length();
        if !distance.is_finite() || distance <= 1e-6 {
            return Err(errors::value(format!("look_at: eye {eye:?} and target {target:?} must be finite and apart")));
        }
        // The orbit's direction in the rig's frame: (sin yaw cos pitch, sin pitch, cos yaw cos pitch).
        let local = self.camera.basis.transpose() * (d / distance);
        let pitch = local.y.clamp(-1.0, 1.0).asin();
        let yaw = local.x.atan2(local.z);
        self.camera.rig = Rig::Orbit { target: t, distance, yaw, pitch };
        self.restart();
        Ok(())
    }

    /// Back to the camera the settings gave.
    fn reset_camera(&mut self) {
        self.camera = self.initial_camera;
        self.restart();
    }

    /// The camera: rig (`orbit` with target, distance, yaw, pitch) and projection.
    fn camera(&self) -> String {
        format!("{:?}", self.camera)
    }

    /// Frames accumulated so far (the next frame's index).
    #[getter]
    fn frames(&self) -> u64 {
        self.frame
    }

    /// (width, height).
    #[getter]
    fn size(&self) -> (u32, u32) {
        (self.size[0], self.size[1])
    }

    /// The device's name and driver.
    #[getter]
    fn device(&self) -> String {
        format!("{} ({})", self.gpu.ctx.info.name, self.gpu.ctx.info.driver)
    }

    /// The figures of the CLI's JSON report: device, volume, settings, frames, median GPU ms per
    /// pass and per frame, wall time, majorant violations.
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let device: vkengine_demos::output::DeviceReport = (&self.gpu.ctx.info).into();
        let report = serde_json::json!({
            "demo": "python",
            "device": device,
            "volume": self.volume_info,
            "settings": self.settings,
            "scene": self.setup.scene,
            "size": self.size,
            "frames": self.frame,
            "passes": self.stats.pass_medians(),
            "frame_ms": self.stats.frame_median(),
            "wall_ms": self.wall_ms,
            "empty_block_fraction": self.gpu.renderer.empty_fraction,
            "majorant_violations": self.gpu.renderer.majorant_violations(),
        });
        let text = serde_json::to_string(&report).map_err(|e| errors::value(e.to_string()))?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// Writes the image: `.exr` linear HDR (as the CLI's `--out x.exr`), else PNG (sRGB).
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        let gpu = &self.gpu;
        image_io::save_frame(
            py,
            path,
            self.size,
            || gpu.targets.read_shown(&gpu.ctx),
            || gpu.targets.read_ldr(&gpu.ctx),
        )
    }

    fn __repr__(&self) -> String {
        format!(
            "Renderer({}, {}x{}, {} frames, {})",
            self.settings.renderer.name(),
            self.size[0],
            self.size[1],
            self.frame,
            self.gpu.ctx.info.name
        )
    }
}
