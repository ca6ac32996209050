//! Label maps' settings (`labels=FILE`, `label_colors=FILE.json`, `label_mode`, `label_hide`,
//! `label_opacity`),
//! declared once in the schema, and what the shaders read of them (`Params.label_*` in
//! `shaders_glsl/volume/common.glsl`).

use super::settings::VolumeSetup;
use crate::settings::{Key, Type};
use crate::volume::data::labels::MAX_LABEL;
use crate::volume::optics::label_table::LABELS;

/// How a label changes the transfer function's medium.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum LabelMode {
    /// The label's colour multiplies the transfer function's, its opacity scales the extinction.
    #[default]
    Tint,
    /// The label's colour replaces the transfer function's (label 0, "no label", keeps it); its
    /// opacity scales the extinction.
    Replace,
}

impl LabelMode {
    /// Names `label_mode` accepts.
    pub const NAMES: &'static [&'static str] = &["tint", "replace"];

    /// The setting's name.
    pub fn name(self) -> &'static str {
        match self {
            LabelMode::Tint => "tint",
            LabelMode::Replace => "replace",
        }
    }
}

/// Per-frame label settings: the mode, which labels are hidden and the opacity scales set over
/// the colour table's.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LabelSettings {
    /// Tint or replace.
    pub mode: LabelMode,
    /// Hidden labels, one bit per label value (bit `l % 32` of word `l / 32`).
    pub hidden: [u32; 8],
    /// Opacity scale per label value from `label_opacity`, over the colour table's; negative
    /// where the table's holds.
    #[serde(serialize_with = "serialize_opacity")]
    pub opacity: [f32; LABELS],
}

impl Default for LabelSettings {
    fn default() -> Self {
        Self { mode: LabelMode::default(), hidden: [0; 8], opacity: [-1.0; LABELS] }
    }
}

fn serialize_opacity<S: serde::Serializer>(o: &[f32; LABELS], s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&opacity_text(o))
}

impl LabelSettings {
    /// Whether label `l` is hidden.
    pub fn is_hidden(&self, l: u32) -> bool {
        l <= MAX_LABEL && self.hidden[(l / 32) as usize] & (1 << (l % 32)) != 0
    }

    /// `label_hide`'s value with label `l`'s visibility flipped (the window's segment boxes).
    pub fn hide_toggled(&self, l: u32) -> String {
        let mut t = *self;
        if l <= MAX_LABEL {
            t.hidden[(l / 32) as usize] ^= 1 << (l % 32);
        }
        hidden_text(&t)
    }

    /// `label_opacity`'s value with label `l`'s opacity scale set to `a` (the window's sliders).
    pub fn opacity_set(&self, l: u32, a: f32) -> String {
        let mut o = self.opacity;
        if let Some(x) = o.get_mut(l as usize) {
            *x = a.clamp(0.0, 1.0);
        }
        opacity_text(&o)
    }
}

fn parse_opacity(t: &str) -> std::result::Result<[f32; LABELS], String> {
    let mut o = [-1.0; LABELS];
    if matches!(t.trim(), "" | "none") {
        return Ok(o);
    }
    for p in t.split(',') {
        let bad = || {
            format!("`{}`: expected LABEL:OPACITY pairs (label 0..={MAX_LABEL}, opacity in [0, 1]), comma-separated, or `none`", p.trim())
        };
        let (l, a) = p.split_once(':').ok_or_else(bad)?;
        let l: usize = l.trim().parse().map_err(|_| bad())?;
        let a: f32 = a.trim().parse().map_err(|_| bad())?;
        if l > MAX_LABEL as usize || !(0.0..=1.0).contains(&a) {
            return Err(bad());
        }
        o[l] = a;
    }
    Ok(o)
}

fn opacity_text(o: &[f32; LABELS]) -> String {
    let l: Vec<String> = (0..LABELS).filter(|&l| o[l] >= 0.0).map(|l| format!("{l}:{}", o[l])).collect();
    if l.is_empty() {
        "none".into()
    } else {
        l.join(",")
    }
}

/// The label files a setup names (paths as given).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LabelFiles {
    /// The label volume (`labels=`, `--labels`).
    pub labels: Option<String>,
    /// The colour table (`label_colors=`), JSON.
    pub colors: Option<String>,
}

fn parse_hidden(t: &str) -> std::result::Result<[u32; 8], String> {
    let mut h = [0u32; 8];
    if matches!(t.trim(), "" | "none") {
        return Ok(h);
    }
    for p in t.split(',') {
        match p.trim().parse::<u32>() {
            Ok(l) if l <= MAX_LABEL => h[(l / 32) as usize] |= 1 << (l % 32),
            _ => {
                return Err(format!(
                    "`{}`: expected label values in 0..={MAX_LABEL}, comma-separated, or `none`",
                    p.trim()
                ))
            }
        }
    }
    Ok(h)
}

fn show_hidden(s: &LabelSettings) -> Option<String> {
    Some(hidden_text(s))
}

fn hidden_text(s: &LabelSettings) -> String {
    let l: Vec<String> = (0..=MAX_LABEL).filter(|&l| s.is_hidden(l)).map(|l| l.to_string()).collect();
    if l.is_empty() {
        "none".into()
    } else {
        l.join(",")
    }
}

fn path(t: &str) -> Option<String> {
    (!matches!(t.trim(), "" | "none")).then(|| t.trim().to_string())
}

const GROUP: &str = "Labels";

/// The label keys (part of the volume renderers' schema).
pub(super) static LABEL_KEYS: [Key<VolumeSetup>; 5] = [
    Key {
        key: "labels",
        group: GROUP,
        doc: "label map on the scan's grid (NIfTI, NRRD, Slicer .seg.nrrd, MetaImage; also `--labels`): each label tints or replaces the transfer function, in every renderer",
        ui: false,
        ty: Type::Text {
            hint: "FILE | none",
            presets: &[],
            sliders: None,
            get: |s| s.labels.labels.clone(),
            set: |s, t| {
                s.labels.labels = path(t);
                Ok(())
            },
        },
    },
    Key {
        key: "label_colors",
        group: GROUP,
        doc: "label colours, opacity scales, visibility and names (JSON, docs/labels.md); default: the file's segment colours, then a fixed palette",
        ui: false,
        ty: Type::Text {
            hint: "FILE.json | none",
            presets: &[],
            sliders: None,
            get: |s| s.labels.colors.clone(),
            set: |s, t| {
                s.labels.colors = path(t);
                Ok(())
            },
        },
    },
    Key {
        key: "label_mode",
        group: GROUP,
        doc: "tint: the label colour multiplies the transfer function's; replace: it replaces it (label 0 keeps it); both scale the extinction by the label's opacity",
        ui: true,
        ty: Type::Choice {
            names: LabelMode::NAMES,
            get: |s| s.render.labels.mode.name(),
            set: |s, n| s.render.labels.mode = if n == "replace" { LabelMode::Replace } else { LabelMode::Tint },
        },
    },
    Key {
        key: "label_hide",
        group: GROUP,
        doc: "labels that contribute nothing (0 is the unlabelled rest of the scan)",
        ui: false,
        ty: Type::Text {
            hint: "L1,L2,… | none",
            presets: &[],
            sliders: None,
            get: |s| show_hidden(&s.render.labels),
            set: |s, t| {
                s.render.labels.hidden = parse_hidden(t)?;
                Ok(())
            },
        },
    },
    Key {
        key: "label_opacity",
        group: GROUP,
        doc: "opacity scales of single labels over the colour table's (`LABEL:OPACITY` pairs, opacity in [0, 1]); the window's segment sliders write it",
        ui: false,
        ty: Type::Text {
            hint: "L:A,… | none",
            presets: &[],
            sliders: None,
            get: |s| Some(opacity_text(&s.render.labels.opacity)),
            set: |s, t| {
                s.render.labels.opacity = parse_opacity(t)?;
                Ok(())
            },
        },
    },
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opacity_pairs_parse_and_refuse() {
        let o = parse_opacity("2:0.5, 255:0,0:1").expect("valid");
        assert_eq!((o[2], o[255], o[0], o[1]), (0.5, 0.0, 1.0, -1.0));
        assert_eq!(opacity_text(&o), "0:1,2:0.5,255:0");
        assert_eq!(parse_opacity("none").expect("none"), [-1.0; LABELS]);
        for bad in ["2", "2:1.5", "2:-0.1", "256:0.5", "a:0.5", "2:nan", "2:0.5,"] {
            let e = parse_opacity(bad).expect_err(bad);
            assert!(e.contains("LABEL:OPACITY"), "{bad}: {e}");
        }
        let s = LabelSettings::default();
        assert_eq!(s.opacity_set(3, 0.25), "3:0.25");
    }

    #[test]
    fn hidden_lists_parse_and_refuse() {
        let h = parse_hidden("2, 255,0").expect("valid");
        let s = LabelSettings { hidden: h, ..Default::default() };
        assert!(s.is_hidden(0) && s.is_hidden(2) && s.is_hidden(255) && !s.is_hidden(1));
        assert_eq!(show_hidden(&s).as_deref(), Some("0,2,255"));
        assert!(parse_hidden("256").is_err());
        assert!(parse_hidden("a").is_err());
        assert_eq!(parse_hidden("none"), Ok([0; 8]));
    }
}
