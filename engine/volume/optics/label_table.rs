//! Each label's colour, opacity scale and name: a fixed palette, then the segment colours a file
//! carries (Slicer's `.seg.nrrd`), then a JSON colour table (`label_colors=FILE`, docs/labels.md).

use crate::error::{Error, Result};
use crate::volume::data::labels::{LabelVolume, MAX_LABEL};
use std::collections::BTreeMap;
use std::path::Path;

/// Entries of the table (label values 0..=255).
pub const LABELS: usize = MAX_LABEL as usize + 1;

/// Colours of labels 1, 2, … (repeating every 10): Tableau 10, linear RGB as written (sRGB-looking
/// values used as is). Label 0, the unlabelled rest of the scan, is white (a tint that changes nothing).
pub const PALETTE: [[f32; 3]; 10] = [
    [0.122, 0.467, 0.706],
    [1.000, 0.498, 0.055],
    [0.173, 0.627, 0.173],
    [0.839, 0.153, 0.157],
    [0.580, 0.404, 0.741],
    [0.549, 0.337, 0.294],
    [0.890, 0.467, 0.761],
    [0.498, 0.498, 0.498],
    [0.737, 0.741, 0.133],
    [0.090, 0.745, 0.812],
];

/// Per label: colour (rgb) and opacity scale (a, in [0, 1]; 0 for a label shown nowhere).
#[derive(Clone, Debug, PartialEq)]
pub struct LabelTable {
    /// `[r, g, b, opacity]` per label value.
    pub entries: Vec<[f32; 4]>,
    /// Names given by the file or the table.
    pub names: BTreeMap<u32, String>,
}

impl Default for LabelTable {
    fn default() -> Self {
        let mut entries = vec![[1.0; 4]; LABELS];
        for (l, e) in entries.iter_mut().enumerate().skip(1) {
            let [r, g, b] = PALETTE[(l - 1) % PALETTE.len()];
            *e = [r, g, b, 1.0];
        }
        LabelTable { entries, names: BTreeMap::new() }
    }
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    color: Option<[f32; 3]>,
    opacity: Option<f32>,
    visible: Option<bool>,
    name: Option<String>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    labels: BTreeMap<String, Entry>,
}

impl LabelTable {
    /// The palette with the segments' colours and names of `labels` (where its file gave them).
    pub fn for_volume(labels: &LabelVolume) -> Self {
        let mut t = Self::default();
        for s in &labels.segments {
            if let Some([r, g, b]) = s.color {
                t.entries[s.value as usize] = [r, g, b, 1.0];
            }
            t.names.insert(s.value, s.name.clone());
        }
        t
    }

    /// [`Self::for_volume`] with the JSON colour table at `colors` over it (where given), which
    /// may name only the labels `labels` holds.
    pub fn with_colors(labels: &LabelVolume, colors: Option<&Path>) -> Result<Self> {
        let mut t = Self::for_volume(labels);
        if let Some(path) = colors {
            t.apply_json(path, Some(&present(labels)))?;
        }
        Ok(t)
    }

    /// Applies the JSON colour table at `path` (format: docs/labels.md). `present`: the label
    /// values the volume holds, where known; a table naming any other label is refused.
    pub fn apply_json(&mut self, path: &Path, present: Option<&[bool]>) -> Result<()> {
        let file = path.display();
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::Input(format!("label_colors {file}: cannot read: {e}")))?;
        self.apply_json_text(&text, present).map_err(|e| Error::Input(format!("label_colors {file}: {e}")))
    }

    /// [`Self::apply_json`] on the file's text; the error says what is wrong, without the file.
    pub fn apply_json_text(&mut self, text: &str, present: Option<&[bool]>) -> std::result::Result<(), String> {
        let f: File = serde_json::from_str(text).map_err(|e| e.to_string())?;
        for (key, e) in f.labels {
            let l = match key.trim().parse::<u32>() {
                Ok(l) if l <= MAX_LABEL => l as usize,
                _ => return Err(format!("label \"{key}\": expected a label value in 0..={MAX_LABEL}")),
            };
            if present.is_some_and(|p| !p.get(l).copied().unwrap_or(false)) {
                return Err(format!("label {l} does not occur in the label volume"));
            }
            if let Some(c) = e.color {
                if !c.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)) {
                    return Err(format!("label {l}: color {c:?} must be three numbers in [0, 1]"));
                }
                self.entries[l][..3].copy_from_slice(&c);
            }
            if let Some(o) = e.opacity {
                if !(0.0..=1.0).contains(&o) {
                    return Err(format!(
                        "label {l}: opacity {o} must be in [0, 1] (a scale of the transfer function's)"
                    ));
                }
                self.entries[l][3] = o;
            }
            if e.visible == Some(false) {
                self.entries[l][3] = 0.0;
            }
            if let Some(n) = e.name {
                self.names.insert(l as u32, n);
            }
        }
        Ok(())
    }
}

/// Which label values occur in `labels`.
pub fn present(labels: &LabelVolume) -> Vec<bool> {
    let mut p = vec![false; LABELS];
    for &l in &labels.labels {
        p[l as usize] = true;
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_table_overrides_the_palette_and_refuses_bad_entries() {
        let mut t = LabelTable::default();
        assert_eq!(t.entries[0], [1.0; 4]);
        assert_eq!(t.entries[11][..3], PALETTE[0]);
        let json =
            r#"{"labels": {"2": {"color": [1, 0, 0], "opacity": 0.5, "name": "tumour"}, "3": {"visible": false}}}"#;
        t.apply_json_text(json, None).expect("valid");
        assert_eq!(t.entries[2], [1.0, 0.0, 0.0, 0.5]);
        assert_eq!(t.entries[3][3], 0.0);
        assert_eq!(t.names[&2], "tumour");
        let mut present = vec![false; LABELS];
        present[2] = true;
        let e = t.apply_json_text(json, Some(&present)).unwrap_err();
        assert!(e.contains("label 3"), "{e}");
        for bad in [
            r#"{"labels": {"256": {}}}"#,
            r#"{"labels": {"1": {"color": [2, 0, 0]}}}"#,
            r#"{"labels": {"1": {"opacity": 1.5}}}"#,
            r#"{"labels": {"1": {"colour": [1, 0, 0]}}}"#,
        ] {
            assert!(t.apply_json_text(bad, None).is_err(), "{bad} accepted");
        }
    }
}
