//! Label maps: a second, integer volume on the scan's grid (a segmentation), loaded through the
//! same loaders as the scan, with the segments' names and colours where the file carries them
//! (3D Slicer's `.seg.nrrd` header keys `SegmentN_Name`, `SegmentN_Color`, `SegmentN_LabelValue`,
//! `SegmentN_Layer`).

use super::{load, LoadOptions, Volume, VolumeError};
use std::path::Path;

/// Largest label value: the renderers' label table holds 256 entries (0 is "no label").
pub const MAX_LABEL: u32 = 255;

/// One segment a file names: its label value, name and colour (linear RGB in [0, 1]).
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// The voxel value that marks the segment.
    pub value: u32,
    /// The segment's name (`SegmentN_Name`).
    pub name: String,
    /// The segment's colour (`SegmentN_Color`), if given.
    pub color: Option<[f32; 3]>,
}

/// A label volume: one label value per voxel, x fastest, on the grid of the scan it belongs to.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelVolume {
    /// Size in voxels along x, y, z.
    pub dims: [u32; 3],
    /// Physical voxel size along x, y, z.
    pub spacing: [f32; 3],
    /// The label of each voxel (0..=[`MAX_LABEL`]).
    pub labels: Vec<u8>,
    /// The file, for messages.
    pub source: String,
    /// Segments the file names (Slicer's `.seg.nrrd`); empty for plain label maps.
    pub segments: Vec<Segment>,
    /// The axes are a patient's (as [`Volume::patient_axes`]).
    pub patient_axes: bool,
    /// Unit direction of each axis in the file's space, where the header gives them (NRRD).
    pub directions: Option<[[f64; 3]; 3]>,
}

fn invalid(file: &str, message: String) -> VolumeError {
    VolumeError::Invalid { file: file.to_owned(), message }
}

impl LabelVolume {
    /// Builds a label volume from a loaded volume whose values must be whole numbers in
    /// 0..=[`MAX_LABEL`].
    pub fn from_volume(v: &Volume) -> Result<Self, VolumeError> {
        let mut labels = Vec::with_capacity(v.voxel_count());
        for (i, x) in v.values().enumerate() {
            if x.fract() != 0.0 || !(0.0..=MAX_LABEL as f32).contains(&x) {
                let [nx, ny, _] = v.dims.map(|d| d as usize);
                let at = [i % nx, i / nx % ny, i / (nx * ny)];
                return Err(invalid(
                    &v.source,
                    format!("not a label map: voxel {at:?} holds {x}, labels must be whole numbers in 0..={MAX_LABEL}"),
                ));
            }
            labels.push(x as u8);
        }
        Ok(LabelVolume {
            dims: v.dims,
            spacing: v.spacing,
            labels,
            source: v.source.clone(),
            segments: Vec::new(),
            patient_axes: v.patient_axes,
            directions: None,
        })
    }

    /// Refuses a label volume whose grid differs from `scan`'s (dims, spacing, orientation), with
    /// one line naming the file and the difference. `scan_directions`: the scan's axis directions
    /// where its header gives them (NRRD).
    pub fn check_grid(&self, scan: &Volume, scan_directions: Option<[[f64; 3]; 3]>) -> Result<(), VolumeError> {
        let file = &self.source;
        if self.dims != scan.dims {
            return Err(invalid(
                file,
                format!("label volume dims {:?} differ from the scan's {:?} ({})", self.dims, scan.dims, scan.source),
            ));
        }
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-4 * a.abs().max(b.abs());
        if !(0..3).all(|i| close(self.spacing[i], scan.spacing[i])) {
            return Err(invalid(
                file,
                format!(
                    "label volume spacing {:?} differs from the scan's {:?} ({})",
                    self.spacing, scan.spacing, scan.source
                ),
            ));
        }
        let orientation = match (self.directions, scan_directions) {
            (Some(a), Some(b)) => (0..3).all(|i| (0..3).all(|j| (a[i][j] - b[i][j]).abs() <= 1e-4)),
            _ => self.patient_axes == scan.patient_axes,
        };
        if !orientation {
            return Err(invalid(
                file,
                format!("label volume orientation differs from the scan's ({}): axis directions differ", scan.source),
            ));
        }
        Ok(())
    }
}

/// Loads a label map (NIfTI, NRRD, Slicer's `.seg.nrrd`, MetaImage, raw with a sidecar, DICOM
/// through the scan loaders): whole numbers in 0..=[`MAX_LABEL`], with the segments a `.seg.nrrd`
/// header names.
pub fn load_labels(path: &Path, opts: &LoadOptions) -> Result<LabelVolume, VolumeError> {
    // Dense f32 values: labels are checked voxel by voxel, never streamed or bricked.
    let opts = LoadOptions { bricks: None, stream_above: u64::MAX, allow_negative: false, ..opts.clone() };
    let v = load(path, &opts)?;
    let mut l = LabelVolume::from_volume(&v)?;
    if is_nrrd(path) {
        let keys = nrrd_header(path)?;
        l.segments = segments(&l.source, &keys)?;
        l.directions = directions(&keys);
    }
    Ok(l)
}

/// Whether `path` names a NRRD file (`.nrrd`, `.nhdr`, `.seg.nrrd`).
pub fn is_nrrd(path: &Path) -> bool {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    matches!(ext.as_deref(), Some("nrrd" | "nhdr"))
}

/// The axis directions (unit vectors) of a NRRD file's `space directions`, where it has them.
pub fn nrrd_directions(path: &Path) -> Option<[[f64; 3]; 3]> {
    is_nrrd(path).then(|| nrrd_header(path).ok().and_then(|k| directions(&k))).flatten()
}

/// A NRRD header's fields and `key:=value` pairs, in order (keys as written, values trimmed).
fn nrrd_header(path: &Path) -> Result<Vec<(String, String)>, VolumeError> {
    let (lines, _) = super::metaimage::read_header_lines(path, |l| l.trim().is_empty())?;
    Ok(lines
        .iter()
        .skip(1)
        .filter_map(|l| {
            let t = l.text.trim();
            match t.split_once(":=") {
                Some((k, v)) => Some((k.trim().to_owned(), v.trim().to_owned())),
                None => t.split_once(':').map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_owned())),
            }
        })
        .collect())
}

fn directions(keys: &[(String, String)]) -> Option<[[f64; 3]; 3]> {
    let v = &keys.iter().find(|(k, _)| k == "space directions")?.1;
    let vectors: Vec<[f64; 3]> = v
        .split(')')
        .filter_map(|t| {
            let t = t.trim().strip_prefix('(')?;
            let c: Vec<f64> = t.split(',').filter_map(|c| c.trim().parse().ok()).collect();
            let n = c.iter().map(|x| x * x).sum::<f64>().sqrt();
            (c.len() == 3 && n > 0.0).then(|| [c[0] / n, c[1] / n, c[2] / n])
        })
        .collect();
    <[[f64; 3]; 3]>::try_from(vectors).ok()
}

/// Slicer's segment keys: `SegmentN_Name`, `SegmentN_Color` (three numbers in [0, 1]),
/// `SegmentN_LabelValue` (default N + 1 when absent, as older files), `SegmentN_Layer` (only
/// layer 0: a 3D file holds one layer).
fn segments(file: &str, keys: &[(String, String)]) -> Result<Vec<Segment>, VolumeError> {
    let get = |n: usize, what: &str| keys.iter().find(|(k, _)| *k == format!("Segment{n}_{what}")).map(|(_, v)| v);
    let mut out = Vec::new();
    for n in 0..=MAX_LABEL as usize + 1 {
        let Some(name) = get(n, "Name") else { break };
        let bad = |what: &str, v: &str| invalid(file, format!("Segment{n}_{what} \"{v}\" is not a number"));
        let value = match get(n, "LabelValue") {
            Some(v) => match v.parse::<u32>() {
                Ok(x) if x <= MAX_LABEL => x,
                _ => return Err(invalid(file, format!("Segment{n}_LabelValue \"{v}\": expected 0..={MAX_LABEL}"))),
            },
            None => n as u32 + 1,
        };
        if let Some(layer) = get(n, "Layer") {
            if layer.parse::<u32>().map_err(|_| bad("Layer", layer))? != 0 {
                return Err(invalid(
                    file,
                    format!("Segment{n}_Layer {layer}: only single-layer segmentations (layer 0) are supported"),
                ));
            }
        }
        let color = match get(n, "Color") {
            Some(c) => {
                let v: Vec<f32> = c.split_whitespace().filter_map(|x| x.parse().ok()).collect();
                match v[..] {
                    [r, g, b] if v.iter().all(|x| (0.0..=1.0).contains(x)) => Some([r, g, b]),
                    _ => {
                        return Err(invalid(
                            file,
                            format!("Segment{n}_Color \"{c}\": expected three numbers in [0, 1]"),
                        ))
                    }
                }
            }
            None => None,
        };
        out.push(Segment { value, name: name.clone(), color });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
        pairs.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
    }

    #[test]
    fn slicer_segments_are_read_and_bad_colours_refused() {
        let k = keys(&[
            ("Segment0_Name", "liver"),
            ("Segment0_Color", "0.5 0.25 1"),
            ("Segment0_LabelValue", "3"),
            ("Segment0_Layer", "0"),
            ("Segment1_Name", "bone"),
        ]);
        let s = segments("f", &k).expect("valid");
        assert_eq!(s[0], Segment { value: 3, name: "liver".into(), color: Some([0.5, 0.25, 1.0]) });
        assert_eq!(s[1], Segment { value: 2, name: "bone".into(), color: None });
        let bad = keys(&[("Segment0_Name", "x"), ("Segment0_Color", "2 0 0")]);
        assert!(segments("f", &bad).unwrap_err().to_string().contains("Segment0_Color"));
        let layered = keys(&[("Segment0_Name", "x"), ("Segment0_Layer", "1")]);
        assert!(segments("f", &layered).unwrap_err().to_string().contains("Layer"));
    }

    #[test]
    fn non_integer_values_are_not_labels() {
        let v = Volume::new([2, 1, 1], [1.0; 3], vec![1.0, 2.5], "half.nrrd").expect("volume");
        let e = LabelVolume::from_volume(&v).unwrap_err().to_string();
        assert!(e.contains("half.nrrd") && e.contains("2.5"), "{e}");
        let v = Volume::new([2, 1, 1], [1.0; 3], vec![1.0, 256.0], "big.nrrd").expect("volume");
        assert!(LabelVolume::from_volume(&v).is_err());
    }

    #[test]
    fn grids_must_match() {
        let scan = Volume::new([2, 2, 2], [1.0; 3], vec![0.0; 8], "scan.nrrd").expect("scan");
        let l = LabelVolume::from_volume(&scan).expect("labels");
        assert!(l.check_grid(&scan, None).is_ok());
        let other = Volume::new([2, 2, 1], [1.0; 3], vec![0.0; 4], "scan2").expect("scan");
        assert!(l.check_grid(&other, None).unwrap_err().to_string().contains("dims"));
        let other = Volume::new([2, 2, 2], [1.0, 1.0, 2.0], vec![0.0; 8], "scan3").expect("scan");
        assert!(l.check_grid(&other, None).unwrap_err().to_string().contains("spacing"));
        let flipped = LabelVolume { directions: Some([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), ..l };
        let id = Some([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        assert!(flipped.check_grid(&scan, id).unwrap_err().to_string().contains("orientation"));
    }
}
