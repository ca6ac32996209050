//! `vkengine.Volume`: a scalar volume from a numpy array, a file the engine's loaders read, or a
//! procedural scene.

use crate::arrays;
use crate::errors;
use numpy::{PyArrayDyn, PyUntypedArray};
use pyo3::prelude::*;
use std::path::PathBuf;
use vkengine::volume::data::{self, procedural, Endian, LoadOptions, Volume, VoxelType};

/// A scalar volume: values indexed `[z, y, x]`, voxel spacing and origin in physical units.
#[pyclass(name = "Volume", module = "vkengine", frozen)]
pub struct PyVolume {
    pub(crate) inner: Volume,
    pub(crate) origin: [f32; 3],
}

fn triple(v: Option<[f64; 3]>, default: [f32; 3], what: &str) -> PyResult<[f32; 3]> {
    let Some(v) = v else { return Ok(default) };
    if v.iter().any(|c| !c.is_finite()) {
        return Err(errors::value(format!("{what}={v:?}: every component must be finite")));
    }
    Ok(v.map(|c| c as f32))
}

#[pymethods]
impl PyVolume {
    /// A volume from a 3D numpy array indexed `[z, y, x]` (any real integer or float dtype,
    /// float16 included, in either byte order, with any strides: crops, steps, reversed axes,
    /// Fortran order), with voxel `spacing` and `origin` (x, y, z, physical units).
    #[new]
    #[pyo3(signature = (array, spacing=None, origin=None, name=None))]
    fn new(
        array: &Bound<'_, PyUntypedArray>,
        spacing: Option<[f64; 3]>,
        origin: Option<[f64; 3]>,
        name: Option<String>,
    ) -> PyResult<Self> {
        let spacing = triple(spacing, [1.0; 3], "spacing")?;
        if spacing.iter().any(|s| *s <= 0.0) {
            return Err(errors::value(format!("spacing={spacing:?}: every component must be > 0")));
        }
        let origin = triple(origin, [0.0; 3], "origin")?;
        let name = name.unwrap_or_else(|| "numpy array".into());
        let (dims, values) = errors::guarded(&name, || arrays::volume_values(array, &name))?;
        let nan = values.iter().filter(|v| v.is_nan()).count();
        if nan > 0 {
            // The file loaders replace NaN with a warning; an array is the caller's own data, so
            // the choice of a fill value is theirs.
            return Err(errors::value(format!(
                "{name}: {nan} NaN voxel(s); replace them first, e.g. np.nan_to_num(a, nan=a[~np.isnan(a)].min())"
            )));
        }
        let volume = errors::guarded("Volume", || Volume::new(dims, spacing, values, name).map_err(errors::volume))?;
        Ok(Self { inner: volume, origin })
    }

    /// Loads any file the engine reads (`.mhd`/`.mha`, `.nrrd`/`.nhdr`, `.nii`/`.nii.gz`,
    /// `.vdb`, DICOM file or folder, raw with `dims` and `dtype`).
    #[staticmethod]
    #[pyo3(signature = (path, dims=None, dtype=None, endian=None, spacing=None, series=None, frame=None, grid=None, allow_negative=false))]
    #[allow(clippy::too_many_arguments)] // the loader's options, each a keyword in Python
    fn load(
        path: PathBuf,
        dims: Option<[u32; 3]>,
        dtype: Option<String>,
        endian: Option<String>,
        spacing: Option<[f64; 3]>,
        series: Option<String>,
        frame: Option<u32>,
        grid: Option<String>,
        allow_negative: bool,
    ) -> PyResult<Self> {
        let voxel =
            match dtype.as_deref() {
                None => None,
                Some(t) => Some(VoxelType::from_name(t).ok_or_else(|| {
                    errors::value(format!("dtype={t:?}: unknown voxel type (u8, i16, u16, f32, ...)"))
                })?),
            };
        let endian = match endian.as_deref() {
            None => None,
            Some("little") => Some(Endian::Little),
            Some("big") => Some(Endian::Big),
            Some(e) => return Err(errors::value(format!("endian={e:?}: expected 'little' or 'big'"))),
        };
        let spacing = match spacing {
            Some(s) => Some(triple(Some(s), [1.0; 3], "spacing")?),
            None => None,
        };
        let opts =
            LoadOptions { dims, voxel, endian, spacing, allow_negative, series, frame, grid, ..Default::default() };
        let volume = errors::guarded("Volume.load", || data::load(&path, &opts).map_err(errors::volume))?;
        Ok(Self { inner: volume, origin: [0.0; 3] })
    }

    /// One of the CLI's procedural scenes (`cloud`, `sparse`, `sphere`, `box`, `checker`) at `n`³.
    #[staticmethod]
    #[pyo3(signature = (scene="cloud", n=128, seed=0))]
    fn procedural(scene: &str, n: u32, seed: u32) -> PyResult<Self> {
        if !(2..=1024).contains(&n) {
            return Err(errors::value(format!("n={n}: must be in 2..=1024")));
        }
        let d = [n; 3];
        let v = match scene {
            "cloud" => procedural::cloud(d, seed),
            "sparse" => procedural::sparse_clouds(d, seed),
            "sphere" => procedural::smooth_sphere(d, 0.45),
            "box" | "furnace" => procedural::homogeneous_box(d, 1.0),
            "checker" => procedural::checker_shell(d, 8),
            _ => {
                return Err(errors::value(format!(
                    "scene={scene:?}: unknown (cloud, sparse, sphere, box, checker, furnace)"
                )))
            }
        };
        Ok(Self { inner: v.map_err(errors::volume)?, origin: [0.0; 3] })
    }

    /// The decoded values as a float32 array indexed `[z, y, x]`.
    fn to_numpy<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        let [x, y, z] = self.inner.dims.map(|d| d as usize);
        let n = self.inner.voxel_count() as u64;
        if n > vkengine::volume::data::MAX_VOXELS {
            return Err(errors::value(format!(
                "{}: its box of {x}x{y}x{z} voxels, kept sparse, is too large for one array ({n} voxels)",
                self.inner.source
            )));
        }
        // A streamed file keeps only its normalized samples: the values they stand for.
        arrays::owned(py, self.inner.values().collect(), &[z, y, x])
    }

    /// Size in voxels as numpy's shape `(z, y, x)`.
    #[getter]
    fn shape(&self) -> (u32, u32, u32) {
        let [x, y, z] = self.inner.dims;
        (z, y, x)
    }

    /// Size in voxels along x, y, z.
    #[getter]
    fn dims(&self) -> [u32; 3] {
        self.inner.dims
    }

    /// Voxel size along x, y, z.
    #[getter]
    fn spacing(&self) -> [f32; 3] {
        self.inner.spacing
    }

    /// Position of voxel (0, 0, 0) in physical units.
    #[getter]
    fn origin(&self) -> [f32; 3] {
        self.origin
    }

    /// Smallest and largest value.
    #[getter]
    fn value_range(&self) -> [f32; 2] {
        self.inner.value_range
    }

    /// File path or description.
    #[getter]
    fn source(&self) -> String {
        self.inner.source.clone()
    }

    /// What loading noted (e.g. replaced NaN voxels of a file).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.inner.warnings.clone()
    }

    /// Pickles as its values, spacing, origin and source (what Dask ships to workers).
    #[allow(clippy::type_complexity)] // the tuple pickle wants
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyArrayDyn<f32>>, [f32; 3], [f32; 3], String))> {
        let cls = py.get_type::<Self>().into_any();
        Ok((cls, (self.to_numpy(py)?, self.inner.spacing, self.origin, self.inner.source.clone())))
    }

    fn __repr__(&self) -> String {
        let [x, y, z] = self.inner.dims;
        format!(
            "Volume({x}x{y}x{z}, spacing={:?}, origin={:?}, range={:?}, source={:?})",
            self.inner.spacing, self.origin, self.inner.value_range, self.inner.source
        )
    }
}
