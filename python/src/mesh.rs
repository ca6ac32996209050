//! `vkengine.MeshRenderer`: the mesh demos' headless renderer (direct light, shadows, cascaded
//! LPV, fog) behind a Python object; the same scene and settings give the CLI's image.

use crate::settings::{cli_args, pairs};
use crate::{errors, image_io};
use numpy::PyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::time::Instant;
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::renderer::{render_frame, MeshRenderer, MeshSettings, MeshTargets};
use vkengine::scene::Scene;
use vkengine::vk::{Context, Validation};
use vkengine_demos::mesh_scene;
use vkengine_demos::stats::PassStats;

/// What the GPU holds: the device, the uploaded scene, the renderer's pipelines and targets.
struct Gpu {
    ctx: Context,
    scene: GpuScene,
    renderer: MeshRenderer,
    targets: MeshTargets,
}

/// A mesh-scene renderer with its own device.
#[pyclass(name = "MeshRenderer", module = "vkengine")]
pub struct PyMeshRenderer {
    gpu: Gpu,
    scene: Scene,
    source: String,
    settings: MeshSettings,
    size: [u32; 2],
    frames: u64,
    stats: PassStats,
    wall_ms: f64,
    validation_seen: usize,
}

#[pymethods]
impl PyMeshRenderer {
    /// A renderer of `scene` (a `.toml` description, `.gltf`/`.glb`/`.obj` model) or, without
    /// one, the built-in scene `builtin` (`cornell`, `atrium`) at `size` = (width, height); every
    /// other keyword is a `--set` key of the mesh demos, layered over the scene file's settings.
    #[new]
    #[pyo3(signature = (scene=None, *, builtin="cornell", size=(512, 512), device=None, validation=None, gpu_timeout=None, **settings))]
    #[allow(clippy::too_many_arguments)] // Python keywords
    fn new(
        py: Python<'_>,
        scene: Option<std::path::PathBuf>,
        builtin: &str,
        size: (u32, u32),
        device: Option<String>,
        validation: Option<bool>,
        gpu_timeout: Option<f64>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let sets = pairs(settings)?;
        let size = [size.0, size.1];
        let path = scene.as_ref().map(|p| p.display().to_string());
        let mut args = cli_args(&sets, size, 0, path.as_deref())?;
        if let Some(t) = gpu_timeout {
            args.gpu_timeout = Some(
                vkengine::vk::parse_gpu_timeout(&t.to_string())
                    .map_err(|e| errors::value(format!("gpu_timeout={t}: {e}")))?,
            );
        }
        let builtin = builtin.to_string();
        let (gpu, loaded, setup) = py.detach(|| {
            errors::guarded("MeshRenderer", || {
                let (loaded, _) = mesh_scene::load(&args, &builtin).map_err(errors::engine)?;
                let origin = mesh_scene::settings_origin(&args, &builtin);
                let setup = mesh_scene::mesh_setup(&origin, &loaded.settings, &args.set).map_err(errors::engine)?;
                let mut opts = args.context_options();
                match validation {
                    Some(true) => opts.validation = Validation::Required,
                    Some(false) => opts.validation = Validation::Off,
                    None => {}
                }
                if device.is_some() {
                    opts.device = device;
                }
                let ctx = Context::new(&opts).map_err(errors::engine)?;
                let scene = GpuScene::upload(&ctx, &loaded).map_err(errors::engine)?;
                let renderer = MeshRenderer::new(&ctx).map_err(errors::engine)?;
                let targets = MeshTargets::new(&ctx, size, setup.rsm_size()).map_err(errors::engine)?;
                Ok((Gpu { ctx, scene, renderer, targets }, loaded, setup))
            })
        })?;
        let source = path.unwrap_or_else(|| format!("builtin:{builtin}"));
        let mut r = Self {
            gpu,
            scene: loaded,
            source,
            settings: setup.settings,
            size,
            frames: 0,
            stats: PassStats::default(),
            wall_ms: 0.0,
            validation_seen: 0,
        };
        r.check_validation()?;
        Ok(r)
    }

    /// Renders `frames` frames along the scene's camera path (its camera without one), as the
    /// CLI's `--frames`, and returns the last frame's linear HDR image, float32 (h, w, 4).
    #[pyo3(signature = (frames=1))]
    fn render<'py>(&mut self, py: Python<'py>, frames: u64) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let frames = frames.max(1);
        let Self { gpu, scene, settings, stats, .. } = self;
        let t0 = Instant::now();
        py.detach(|| {
            errors::guarded("render", || {
                for frame in 0..frames {
                    gpu.ctx.set_frame(frame);
                    let view = mesh_scene::view_at(scene, frame, frames);
                    let run = render_frame(&gpu.ctx, &gpu.renderer, &gpu.scene, &mut gpu.targets, &view, settings)
                        .map_err(errors::engine)?;
                    stats.add(&run.timings);
                }
                Ok(())
            })
        })?;
        self.wall_ms += t0.elapsed().as_secs_f64() * 1e3;
        self.frames += frames;
        self.check_validation()?;
        self.image(py)
    }

    /// The last frame: linear HDR float32, shape (height, width, 4).
    fn image<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let gpu = &self.gpu;
        image_io::frame_hdr(py, self.size, || gpu.targets.read_hdr(&gpu.ctx))
    }

    /// The tone-mapped last frame: sRGB uint8, shape (height, width, 4).
    fn image_srgb<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
        let gpu = &self.gpu;
        image_io::frame_srgb(py, self.size, || gpu.targets.read_ldr(&gpu.ctx))
    }

    /// Device, scene, settings, frames, median GPU ms per pass and per frame, wall ms.
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let device: vkengine_demos::output::DeviceReport = (&self.gpu.ctx.info).into();
        let report = serde_json::json!({
            "demo": "python-mesh",
            "device": device,
            "scene": {"source": self.source, "meshes": self.scene.meshes.len(),
                      "triangles": self.scene.triangle_count(), "warnings": self.scene.warnings},
            "settings": self.settings,
            "size": self.size,
            "frames": self.frames,
            "passes": self.stats.pass_medians(),
            "frame_ms": self.stats.frame_median(),
            "wall_ms": self.wall_ms,
        });
        let text = serde_json::to_string(&report).map_err(|e| errors::value(e.to_string()))?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// Writes the last frame: `.exr` linear HDR (as the CLI's `--out x.exr`), else PNG.
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        let gpu = &self.gpu;
        image_io::save_frame(py, path, self.size, || gpu.targets.read_hdr(&gpu.ctx), || gpu.targets.read_ldr(&gpu.ctx))
    }

    /// Frames rendered so far.
    #[getter]
    fn frames(&self) -> u64 {
        self.frames
    }

    fn __repr__(&self) -> String {
        format!("MeshRenderer({}, {}x{}, {})", self.source, self.size[0], self.size[1], self.gpu.ctx.info.name)
    }
}

impl PyMeshRenderer {
    fn check_validation(&mut self) -> PyResult<()> {
        errors::check_validation(&self.gpu.ctx, &mut self.validation_seen)
    }
}
