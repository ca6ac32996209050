//! Transfer functions: scalar value (× gradient magnitude) → emitted colour and extinction.
//!
//! Both kinds bake into one 2D table (value along x, normalized gradient magnitude along y) so
//! the shaders sample a single texture; a 1D function is constant along y.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

pub use crate::volume::data::stats::{TF_GRADIENTS, TF_VALUES};

/// One control point of a 1D transfer function.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TfPoint {
    /// Normalized scalar value in [0, 1].
    pub value: f32,
    /// Linear RGB emission colour.
    pub color: [f32; 3],
    /// Extinction coefficient σt per unit length (the volume's largest axis has length 1).
    pub extinction: f32,
}

/// A 2D widget: a box in (value, gradient magnitude) with colour and extinction.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TfBox {
    /// Value interval [lo, hi] in [0, 1].
    pub value: [f32; 2],
    /// Normalized gradient-magnitude interval [lo, hi] in [0, 1].
    pub gradient: [f32; 2],
    /// Linear RGB emission colour.
    pub color: [f32; 3],
    /// Extinction inside the box.
    pub extinction: f32,
}

/// A transfer function as stored in JSON (`{"points":[...]}` or `{"boxes":[...]}`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum TransferFunction {
    /// Piecewise-linear in value.
    OneD {
        /// Control points, sorted by value.
        points: Vec<TfPoint>,
    },
    /// Union (max extinction, colour of the densest box) of value × gradient boxes.
    TwoD {
        /// Widgets.
        boxes: Vec<TfBox>,
    },
}

impl TransferFunction {
    /// A ramp: transparent below `lo`, linear to `color`/`extinction` at `hi`, constant above.
    pub fn ramp(lo: f32, hi: f32, color: [f32; 3], extinction: f32) -> Self {
        let p = |value, e| TfPoint { value, color, extinction: e };
        TransferFunction::OneD { points: vec![p(0.0, 0.0), p(lo, 0.0), p(hi, extinction), p(1.0, extinction)] }
    }

    /// Constant colour and extinction for every value except exactly 0 (empty space stays empty).
    pub fn constant(color: [f32; 3], extinction: f32) -> Self {
        let p = |value, e| TfPoint { value, color, extinction: e };
        TransferFunction::OneD { points: vec![p(0.0, 0.0), p(1.0 / 65535.0, extinction), p(1.0, extinction)] }
    }

    /// Built-in presets by name.
    pub fn preset(name: &str) -> Result<Self> {
        Ok(match name {
            "default" | "warm" => Self::ramp(0.05, 0.6, [1.0, 0.55, 0.3], 40.0),
            "cloud" => Self::ramp(0.05, 0.7, [0.95, 0.85, 0.75], 8.0),
            "bone" => TransferFunction::OneD {
                points: vec![
                    TfPoint { value: 0.0, color: [0.0; 3], extinction: 0.0 },
                    TfPoint { value: 0.3, color: [0.8, 0.3, 0.2], extinction: 0.0 },
                    TfPoint { value: 0.4, color: [0.8, 0.3, 0.2], extinction: 8.0 },
                    TfPoint { value: 0.7, color: [1.0, 0.95, 0.85], extinction: 80.0 },
                    TfPoint { value: 1.0, color: [1.0, 1.0, 1.0], extinction: 120.0 },
                ],
            },
            "edges" => TransferFunction::TwoD {
                boxes: vec![TfBox {
                    value: [0.05, 1.0],
                    gradient: [0.1, 1.0],
                    color: [0.4, 0.8, 1.0],
                    extinction: 60.0,
                }],
            },
            _ => {
                return Err(Error::Input(format!(
                    "unknown transfer-function preset `{name}` (default, cloud, bone, edges, or a .json file)"
                )))
            }
        })
    }

    /// A preset name or a JSON file path.
    pub fn from_arg(arg: &str) -> Result<Self> {
        if arg.ends_with(".json") {
            Self::load(Path::new(arg))
        } else {
            Self::preset(arg)
        }
    }

    /// Reads and validates a JSON transfer function on the normalized axis (a file stating
    /// `"units"` needs the volume: [`TransferFunction::load_for`]).
    pub fn load(path: &Path) -> Result<Self> {
        let (tf, units) = Self::read(path)?;
        if let Some(u) = units {
            return Err(Error::Input(format!(
                "{}: values in `{u}` need a loaded volume to map them (this transfer function has none)",
                path.display()
            )));
        }
        Ok(tf)
    }

    /// Reads a JSON transfer function for `volume`. With `"units": "data"` (or `"HU"`, which
    /// the volume must be in) the values are the volume's own, mapped over its value range;
    /// without, they are normalized to [0, 1].
    pub fn load_for(path: &Path, volume: &crate::volume::data::Volume) -> Result<Self> {
        let (tf, units) = Self::read(path)?;
        match units.as_deref() {
            None | Some("normalized") => Ok(tf),
            Some("data") => Ok(super::tf_choice::to_normalized(&tf, volume.value_range)),
            Some("HU") if volume.quantity.unit == crate::volume::data::ValueUnit::Hounsfield => {
                Ok(super::tf_choice::to_normalized(&tf, volume.value_range))
            }
            Some("HU") => Err(Error::Input(format!(
                "{}: values in HU, but {}'s values are not in Hounsfield units (use \"units\": \"data\")",
                path.display(),
                volume.source
            ))),
            Some(u) => Err(Error::Input(format!(
                "{}: unknown \"units\": \"{u}\" (expected normalized, data or HU)",
                path.display()
            ))),
        }
    }

    fn read(path: &Path) -> Result<(Self, Option<String>)> {
        /// The file: a function plus the units its values are in.
        #[derive(Deserialize)]
        struct File {
            #[serde(default)]
            units: Option<String>,
            #[serde(flatten)]
            tf: TransferFunction,
        }
        let text =
            std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.display().to_string(), source })?;
        let f: File = serde_json::from_str(&text)
            .map_err(|e| Error::Input(format!("{}: not a transfer function: {e}", path.display())))?;
        let normalized = matches!(f.units.as_deref(), None | Some("normalized"));
        f.tf.check(normalized).map_err(|e| Error::Input(format!("{}: {e}", path.display())))?;
        Ok((f.tf, f.units))
    }

    /// Checks ranges: values in [0,1], finite non-negative colours and extinctions, sorted points.
    pub fn validate(&self) -> std::result::Result<(), String> {
        self.check(true)
    }

    /// [`TransferFunction::validate`], with values anywhere finite unless `normalized`.
    fn check(&self, normalized: bool) -> std::result::Result<(), String> {
        let ok = |x: f32| x.is_finite() && x >= 0.0;
        let in_domain = |v: f32| if normalized { (0.0..=1.0).contains(&v) } else { v.is_finite() };
        match self {
            TransferFunction::OneD { points } => {
                if points.is_empty() {
                    return Err("transfer function has no points".into());
                }
                for (i, p) in points.iter().enumerate() {
                    if !in_domain(p.value) {
                        let domain = if normalized { "outside [0,1]" } else { "not finite" };
                        return Err(format!("point {i}: value {} {domain}", p.value));
                    }
                    if !p.color.iter().all(|&c| ok(c)) || !ok(p.extinction) {
                        return Err(format!("point {i}: colour and extinction must be finite and ≥ 0"));
                    }
                    if i > 0 && p.value < points[i - 1].value {
                        return Err(format!("point {i}: values must be sorted ascending"));
                    }
                }
            }
            TransferFunction::TwoD { boxes } => {
                for (i, b) in boxes.iter().enumerate() {
                    let unit = |r: [f32; 2]| (0.0..=1.0).contains(&r[0]) && (0.0..=1.0).contains(&r[1]) && r[0] <= r[1];
                    let value_ok = in_domain(b.value[0]) && in_domain(b.value[1]) && b.value[0] <= b.value[1];
                    if !value_ok || !unit(b.gradient) {
                        return Err(format!(
                            "box {i}: ranges must be ascending, the gradient's within [0,1] (and the value's unless \"units\" says otherwise)"
                        ));
                    }
                    if !b.color.iter().all(|&c| ok(c)) || !ok(b.extinction) {
                        return Err(format!("box {i}: colour and extinction must be finite and ≥ 0"));
                    }
                }
            }
        }
        Ok(())
    }

    /// Evaluates at normalized value `v` and gradient magnitude `g`: (r, g, b, extinction).
    pub fn eval(&self, v: f32, g: f32) -> [f32; 4] {
        match self {
            TransferFunction::OneD { points } => {
                let first = points[0];
                if v <= first.value {
                    return [first.color[0], first.color[1], first.color[2], first.extinction];
                }
                for w in points.windows(2) {
                    let (a, b) = (w[0], w[1]);
                    if v <= b.value {
                        let t = if b.value > a.value { (v - a.value) / (b.value - a.value) } else { 1.0 };
                        let l = |x: f32, y: f32| x + (y - x) * t;
                        return [
                            l(a.color[0], b.color[0]),
                            l(a.color[1], b.color[1]),
                            l(a.color[2], b.color[2]),
                            l(a.extinction, b.extinction),
                        ];
                    }
                }
                let last = points[points.len() - 1];
                [last.color[0], last.color[1], last.color[2], last.extinction]
            }
            TransferFunction::TwoD { boxes } => boxes
                .iter()
                .filter(|b| (b.value[0]..=b.value[1]).contains(&v) && (b.gradient[0]..=b.gradient[1]).contains(&g))
                .map(|b| [b.color[0], b.color[1], b.color[2], b.extinction])
                .fold([0.0; 4], |acc, x| if x[3] > acc[3] { x } else { acc }),
        }
    }

    /// Bakes the table (`TF_VALUES` × `TF_GRADIENTS`, RGBA32F, value-major rows per gradient).
    /// Texel i along x sits at value i / (TF_VALUES - 1) so 0 and 1 are hit exactly.
    pub fn bake(&self) -> Vec<[f32; 4]> {
        let mut t = Vec::with_capacity(TF_VALUES * TF_GRADIENTS);
        for gy in 0..TF_GRADIENTS {
            let g = gy as f32 / (TF_GRADIENTS - 1) as f32;
            for vx in 0..TF_VALUES {
                t.push(self.eval(vx as f32 / (TF_VALUES - 1) as f32, g));
            }
        }
        t
    }

    /// Largest extinction over every gradient for each value texel: what empty-space skipping tests.
    pub fn max_extinction_per_value(&self) -> Vec<f32> {
        max_extinction_per_value(&self.bake())
    }
}

/// Per table column (value), the largest extinction over the gradient rows of a baked table
/// ([`TransferFunction::bake`]).
pub fn max_extinction_per_value(table: &[[f32; 4]]) -> Vec<f32> {
    (0..TF_VALUES).map(|x| (0..TF_GRADIENTS).map(|y| table[y * TF_VALUES + x][3]).fold(0.0, f32::max)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_interpolates_and_clamps() {
        let tf = TransferFunction::ramp(0.2, 0.6, [1.0, 0.5, 0.0], 10.0);
        assert_eq!(tf.eval(0.1, 0.0)[3], 0.0);
        assert!((tf.eval(0.4, 0.0)[3] - 5.0).abs() < 1e-5);
        assert_eq!(tf.eval(0.9, 0.3)[3], 10.0);
        let table = tf.bake();
        assert_eq!(table.len(), TF_VALUES * TF_GRADIENTS);
        assert_eq!(table[TF_VALUES - 1][3], 10.0);
    }

    #[test]
    fn two_d_boxes_depend_on_gradient() {
        let tf = TransferFunction::preset("edges").expect("preset");
        assert_eq!(tf.eval(0.5, 0.0)[3], 0.0);
        assert_eq!(tf.eval(0.5, 0.5)[3], 60.0);
        assert_eq!(tf.max_extinction_per_value()[128], 60.0);
    }

    #[test]
    fn json_round_trip_and_validation() {
        let tf = TransferFunction::preset("bone").expect("preset");
        let text = serde_json::to_string(&tf).expect("json");
        let back: TransferFunction = serde_json::from_str(&text).expect("parse");
        assert_eq!(back, tf);
        let bad = TransferFunction::OneD { points: vec![TfPoint { value: 1.5, color: [0.0; 3], extinction: 1.0 }] };
        assert!(bad.validate().unwrap_err().contains("outside [0,1]"));
        let neg = TransferFunction::OneD { points: vec![TfPoint { value: 0.5, color: [0.0; 3], extinction: -1.0 }] };
        assert!(neg.validate().is_err());
        assert!(TransferFunction::preset("nope").is_err());
    }
}
