//! Transfer functions: scalar value (× gradient magnitude) → emitted colour and extinction.
//!
//! Both kinds bake into one 2D table (value along x, normalized gradient magnitude along y) so
//! the shaders sample a single texture; a 1D function is constant along y.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Table resolution along the value axis.
pub const TF_VALUES: usize = 256;
/// Table resolution along the gradient-magnitude axis.
pub const TF_GRADIENTS: usize = 32;

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

    /// Reads and validates a JSON transfer function.
    pub fn load(path: &Path) -> Result<Self> {
        let text =
            std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.display().to_string(), source })?;
        let tf: Self = serde_json::from_str(&text)
            .map_err(|e| Error::Input(format!("{}: not a transfer function: {e}", path.display())))?;
        tf.validate().map_err(|e| Error::Input(format!("{}: {e}", path.display())))?;
        Ok(tf)
    }

    /// Checks ranges: values in [0,1], finite non-negative colours and extinctions, sorted points.
    pub fn validate(&self) -> std::result::Result<(), String> {
        let ok = |x: f32| x.is_finite() && x >= 0.0;
        match self {
            TransferFunction::OneD { points } => {
                if points.is_empty() {
                    return Err("transfer function has no points".into());
                }
                for (i, p) in points.iter().enumerate() {
                    if !(0.0..=1.0).contains(&p.value) {
                        return Err(format!("point {i}: value {} outside [0,1]", p.value));
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
                    if !unit(b.value) || !unit(b.gradient) {
                        return Err(format!("box {i}: ranges must be ascending within [0,1]"));
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
        let table = self.bake();
        (0..TF_VALUES).map(|x| (0..TF_GRADIENTS).map(|y| table[y * TF_VALUES + x][3]).fold(0.0, f32::max)).collect()
    }
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
