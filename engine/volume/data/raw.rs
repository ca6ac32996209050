//! Headerless raw volumes, described by `LoadOptions` and/or a `<file>.json` sidecar.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::read::{DataRegion, Start};
use super::{finish_region, Endian, Layout, LoadOptions, Progress, Volume, VolumeError, VoxelType};

/// Sidecar contents, e.g. `{"dims":[256,256,128],"type":"u16","endian":"little","spacing":[1,1,1.5]}`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct Sidecar {
    // Wider than the final types so out-of-range values get a precise error instead of a serde one.
    dims: Option<[u64; 3]>,
    #[serde(rename = "type")]
    voxel: Option<String>,
    endian: Option<String>,
    spacing: Option<[f64; 3]>,
}

/// Path of the sidecar for `path`: the full file name with `.json` appended.
fn sidecar_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".json");
    PathBuf::from(s)
}

fn read_sidecar(path: &Path) -> Result<Option<Sidecar>, VolumeError> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(VolumeError::Io { file: path.display().to_string(), source }),
    };
    serde_json::from_str(&text).map(Some).map_err(|e| VolumeError::Header {
        file: path.display().to_string(),
        line: e.line(),
        message: format!("invalid sidecar JSON: {e}"),
    })
}

pub(crate) fn load(path: &Path, opts: &LoadOptions, progress: Progress<'_>) -> Result<Volume, VolumeError> {
    let file = path.display().to_string();
    let side_path = sidecar_path(path);
    let side_name = side_path.display().to_string();
    let sidecar = read_sidecar(&side_path)?.unwrap_or_default();

    let dims = opts.dims.map(|d| d.map(u64::from)).or(sidecar.dims);
    let voxel = match (opts.voxel, &sidecar.voxel) {
        (Some(t), _) => Some(t),
        (None, Some(name)) => Some(VoxelType::from_name(name).ok_or_else(|| VolumeError::UnsupportedType {
            file: side_name.clone(),
            type_name: name.clone(),
            location: "sidecar field \"type\"".into(),
        })?),
        (None, None) => None,
    };
    let (dims, voxel) = match (dims, voxel) {
        (Some(d), Some(t)) => (d, t),
        (d, t) => {
            let missing = match (d.is_none(), t.is_none()) {
                (true, true) => "dims and voxel type",
                (true, false) => "dims",
                _ => "voxel type",
            };
            return Err(VolumeError::MissingRawParameters { file, missing: missing.into() });
        }
    };
    let endian = match (opts.endian, &sidecar.endian) {
        (Some(e), _) => e,
        (None, Some(name)) => Endian::from_name(name).ok_or_else(|| VolumeError::Header {
            file: side_name.clone(),
            line: 1,
            message: format!("sidecar field \"endian\" is \"{name}\"; expected \"little\" or \"big\""),
        })?,
        (None, None) => Endian::Little,
    };
    let spacing = opts.spacing.map(|s| s.map(f64::from)).or(sidecar.spacing).unwrap_or([1.0; 3]);

    let layout = Layout::validated(&file, dims, voxel, endian, spacing, opts)?;
    let region = DataRegion {
        path,
        offset: 0,
        line_skip: 0,
        start: Start::Skip(0),
        compressed: false,
        compressed_size: None,
        expected: layout.byte_len(),
    };
    finish_region(&file, &layout, &region, opts, Vec::new(), progress)
}
