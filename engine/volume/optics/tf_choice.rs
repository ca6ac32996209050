//! The transfer function a loaded volume gets: presets defined in the data's physical units
//! (CT in Hounsfield units), a ramp chosen from the histogram when nothing says more, and the
//! one line that tells the user what was chosen and how to reproduce or change it.
//!
//! Functions here are written in data values and converted to the renderer's normalized axis
//! (`(v − min) / (max − min)` over the volume's value range) only at the end, so a preset means
//! the same tissue whatever range a scan happens to span.

use super::tf::{TfPoint, TransferFunction, TF_VALUES};
use crate::error::{Error, Result};
use crate::volume::data::{ValueUnit, Volume};

/// Every `tf=` name that depends on the volume (besides a JSON file).
const DATA_PRESETS: &str = "auto, mr, density, ct-bone, ct-soft, ct-lung, ramp:LO,HI";

/// Bins of the histogram the automatic choice reads.
const BINS: usize = 256;

/// A transfer function for `volume` from a `tf=` argument, or the automatic choice without one;
/// the second value is the line to print about an automatic choice.
pub fn for_volume(arg: Option<&str>, volume: &Volume) -> Result<(TransferFunction, Option<String>)> {
    let Some(arg) = arg else {
        let (name, why) = automatic(volume);
        let tf = named(&name, volume)?;
        let line = format!(
            "transfer function: {name} ({why}); --set tf={name} keeps it, tf=auto|mr|density|ct-bone|ct-soft|ct-lung|ramp:LO,HI|FILE.json changes it"
        );
        return Ok((tf, Some(line)));
    };
    Ok((named(arg, volume)?, None))
}

/// What the automatic choice picks for `volume`, and why (in words).
fn automatic(volume: &Volume) -> (String, String) {
    let hu = volume.quantity.unit == ValueUnit::Hounsfield;
    let modality = volume.quantity.modality.as_deref().unwrap_or("");
    if hu {
        // Bone is what a CT shows best; a scan without it (a soft-tissue phantom, a cropped
        // abdomen) would come out empty, so it gets the soft-tissue preset.
        let bone = fraction_at_least(volume, 300.0);
        if bone >= 0.002 {
            return ("ct-bone".into(), format!("a CT in Hounsfield units, {:.1} % of voxels ≥ 300 HU", bone * 100.0));
        }
        return ("ct-soft".into(), format!("a CT in Hounsfield units with {:.2} % of voxels ≥ 300 HU", bone * 100.0));
    }
    if volume.quantity.unit == ValueUnit::Density {
        return ("density".into(), "an OpenVDB density grid: extinction proportional to density, white".into());
    }
    if modality == "MR" {
        return ("mr".into(), "an MR scan: ramp from the histogram's background threshold".into());
    }
    let [lo, hi] = histogram_ramp(volume);
    (ramp_name(lo, hi), "Otsu threshold of the histogram to the 99.5th percentile above it, in data values".into())
}

/// `ramp:LO,HI` with values printed so they read back exactly.
fn ramp_name(lo: f32, hi: f32) -> String {
    format!("ramp:{lo},{hi}")
}

/// The function named `arg` (normalized preset, data preset, ramp or JSON file) for `volume`.
pub fn named(arg: &str, volume: &Volume) -> Result<TransferFunction> {
    let context = |e: String| Error::Input(format!("tf={arg}: {e}"));
    let data_tf = match arg {
        "auto" => {
            let (name, _) = automatic(volume);
            return named(&name, volume);
        }
        "mr" => {
            let [lo, hi] = histogram_ramp(volume);
            warm_ramp(lo, hi, [0.85, 0.75, 0.7])
        }
        // A medium: extinction ∝ value (40 per box length at the maximum), albedo-1 white.
        "density" => {
            let top = volume.value_range[1].max(f32::MIN_POSITIVE);
            let p = |value, extinction| TfPoint { value, color: [1.0; 3], extinction };
            TransferFunction::OneD { points: vec![p(0.0, 0.0), p(top, 40.0)] }
        }
        "ct-bone" | "ct-soft" | "ct-lung" => {
            if volume.quantity.unit != ValueUnit::Hounsfield {
                return Err(context(format!(
                    "a CT preset in Hounsfield units, but {}'s values are not in HU (use auto, mr or ramp:LO,HI)",
                    volume.source
                )));
            }
            ct_preset(arg)
        }
        _ if arg.starts_with("ramp:") => {
            let parts: Vec<f32> = arg[5..]
                .split(',')
                .map(|p| p.trim().parse::<f32>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| context("expected ramp:LO,HI with two numbers in the data's units".into()))?;
            match parts.as_slice() {
                &[lo, hi] if lo.is_finite() && hi.is_finite() && lo < hi => warm_ramp(lo, hi, [1.0, 0.95, 0.85]),
                _ => return Err(context("expected ramp:LO,HI with finite LO < HI".into())),
            }
        }
        _ if arg.ends_with(".json") => return TransferFunction::load_for(std::path::Path::new(arg), volume),
        _ => {
            return TransferFunction::preset(arg).map_err(|_| {
                Error::Input(format!(
                    "unknown transfer function `{arg}` (default, cloud, bone, edges, {DATA_PRESETS}, or a .json file)"
                ))
            })
        }
    };
    Ok(to_normalized(&data_tf, volume.value_range))
}

/// Transparent below `lo`, then dark orange to `top` at `hi` (extinction 60 per box length:
/// opaque within a few percent of the volume, so surfaces read as surfaces).
fn warm_ramp(lo: f32, hi: f32, top: [f32; 3]) -> TransferFunction {
    let mid = lo + (hi - lo) * 0.3;
    TransferFunction::OneD {
        points: vec![
            TfPoint { value: lo, color: [0.8, 0.35, 0.2], extinction: 0.0 },
            TfPoint { value: mid, color: [0.9, 0.55, 0.35], extinction: 15.0 },
            TfPoint { value: hi, color: top, extinction: 60.0 },
        ],
    }
}

/// The CT presets, in Hounsfield units (air −1000, fat ≈ −100, water 0, soft tissue 20–80,
/// trabecular bone ≈ 300, cortical bone 1000 and up).
fn ct_preset(name: &str) -> TransferFunction {
    let p = |value, color, extinction| TfPoint { value, color, extinction };
    let bone = [1.0, 0.95, 0.85];
    let points = match name {
        "ct-bone" => vec![
            p(150.0, [0.8, 0.4, 0.3], 0.0),
            p(300.0, [0.9, 0.7, 0.55], 20.0),
            p(700.0, bone, 80.0),
            p(2000.0, [1.0; 3], 120.0),
        ],
        // Skin and fat faint, muscle and organs red, bone opaque.
        "ct-soft" => vec![
            p(-300.0, [0.9, 0.7, 0.55], 0.0),
            p(-100.0, [0.9, 0.7, 0.55], 0.5),
            p(0.0, [0.8, 0.3, 0.25], 2.0),
            p(80.0, [0.8, 0.3, 0.25], 12.0),
            p(300.0, bone, 60.0),
            p(2000.0, bone, 100.0),
        ],
        // Lung parenchyma (−900 … −500) visible, the body around it transparent, bone faint.
        _ => vec![
            p(-950.0, [0.75, 0.55, 0.5], 0.0),
            p(-800.0, [0.8, 0.55, 0.5], 6.0),
            p(-600.0, [0.9, 0.6, 0.5], 12.0),
            p(-400.0, [0.9, 0.6, 0.5], 0.0),
            p(250.0, bone, 0.0),
            p(500.0, bone, 20.0),
        ],
    };
    TransferFunction::OneD { points }
}

/// Rewrites a function over data values onto the normalized axis of a volume spanning `range`.
/// 1D functions are sampled at the table's own texels (so baking the result equals evaluating
/// the original there); box edges are mapped and clipped to the range.
pub fn to_normalized(tf: &TransferFunction, range: [f32; 2]) -> TransferFunction {
    let [lo, hi] = range.map(f64::from);
    let span = (hi - lo).max(f64::MIN_POSITIVE);
    match tf {
        TransferFunction::OneD { .. } => TransferFunction::OneD {
            points: (0..TF_VALUES)
                .map(|i| {
                    let t = i as f64 / (TF_VALUES - 1) as f64;
                    let e = tf.eval((lo + t * span) as f32, 0.0);
                    TfPoint { value: t as f32, color: [e[0], e[1], e[2]], extinction: e[3] }
                })
                .collect(),
        },
        TransferFunction::TwoD { boxes } => TransferFunction::TwoD {
            boxes: boxes
                .iter()
                .filter_map(|b| {
                    let v = b.value.map(|x| ((f64::from(x) - lo) / span).clamp(0.0, 1.0) as f32);
                    (v[0] < v[1]).then_some(super::tf::TfBox { value: v, ..*b })
                })
                .collect(),
        },
    }
}

/// Fraction of `values` at or above `threshold`.
fn fraction_at_least(volume: &Volume, threshold: f32) -> f64 {
    let (mut hits, mut n) = (0u64, 0u64);
    for (v, count) in volume.value_counts() {
        hits += if v >= threshold { count } else { 0 };
        n += count;
    }
    if n == 0 {
        return 0.0;
    }
    hits as f64 / n as f64
}

/// `[Otsu threshold, 99.5th percentile of the values above it]` in data values, both below the
/// 99.9th percentile of the whole volume; the threshold
/// separates background from object by maximising the between-class variance of the histogram
/// (Otsu 1979), which needs no knowledge of the modality.
pub fn histogram_ramp(volume: &Volume) -> [f32; 2] {
    let [lo, hi] = volume.value_range;
    if hi <= lo || volume.voxel_count() == 0 {
        return [lo, lo + 1.0];
    }
    let scale = BINS as f64 / f64::from(hi - lo);
    let bin = |v: f32| ((f64::from(v - lo) * scale) as usize).min(BINS - 1);
    let mut counts = [0u64; BINS];
    for (v, count) in volume.value_counts() {
        counts[bin(v)] += count;
    }
    // A few extreme voxels (metal in a CT, a hot pixel) would otherwise be a class of their own:
    // the threshold is chosen below the 99.9th percentile.
    let total: u64 = counts.iter().sum();
    let mut cumulative = 0;
    let p999 = counts.iter().position(|&c| {
        cumulative += c;
        cumulative as f64 >= total as f64 * 0.999
    });
    let p999 = p999.unwrap_or(BINS - 1);
    let t = otsu(&counts[..=p999]).min(p999);
    let above: u64 = counts[t..=p999].iter().sum();
    let target = (above as f64 * 0.995).ceil() as u64;
    let mut seen = 0;
    let mut top = p999;
    for (i, &c) in counts.iter().enumerate().take(p999 + 1).skip(t) {
        seen += c;
        if seen >= target {
            top = i;
            break;
        }
    }
    let value = |b: usize| lo + (hi - lo) * b as f32 / BINS as f32;
    // The ramp starts at the threshold bin's lower edge and ends at the percentile bin's upper one.
    [value(t), value((top + 1).max(t + 1))]
}

/// Otsu's threshold: the first bin of the upper class that maximises the between-class variance.
fn otsu(counts: &[u64]) -> usize {
    let total: f64 = counts.iter().map(|&c| c as f64).sum();
    let sum: f64 = counts.iter().enumerate().map(|(i, &c)| i as f64 * c as f64).sum();
    let (mut w0, mut s0, mut best, mut best_t) = (0.0, 0.0, -1.0, 1);
    for (t, &c) in counts.iter().enumerate().take(counts.len().saturating_sub(1)) {
        w0 += c as f64;
        s0 += t as f64 * c as f64;
        let w1 = total - w0;
        if w0 == 0.0 || w1 == 0.0 {
            continue;
        }
        let (m0, m1) = (s0 / w0, (sum - s0) / w1);
        let between = w0 * w1 * (m0 - m1) * (m0 - m1);
        if between > best {
            best = between;
            best_t = t + 1;
        }
    }
    best_t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::data::Quantity;

    fn volume(data: Vec<f32>, unit: ValueUnit) -> Volume {
        let lo = data.iter().cloned().fold(f32::MAX, f32::min);
        let hi = data.iter().cloned().fold(f32::MIN, f32::max);
        Volume {
            dims: [data.len() as u32, 1, 1],
            spacing: [1.0; 3],
            value_range: [lo, hi],
            data,
            source: "test".into(),
            warnings: vec![],
            quantity: Quantity { modality: None, unit },
            patient_axes: false,
            normalized: None,
            sparse: None,
            bricks: None,
            lod: None,
            index_origin: None,
        }
    }

    #[test]
    fn otsu_splits_two_clusters_between_them_whatever_an_outlier_does() {
        // 9,000 voxels at 0..4 (background), 1,000 at 20..30 (object), ten at 255 (metal, 0.1 %,
        // enough to be Otsu's best split over the whole histogram): the
        // threshold must separate background from object (the midpoint of the range would not)
        // and the ramp end at the object's top, not the outlier.
        let mut d: Vec<f32> = (0..9000).map(|i| (i % 5) as f32).collect();
        d.extend((0..1000).map(|i| 20.0 + (i % 11) as f32));
        d.extend([255.0; 10]);
        let v = volume(d, ValueUnit::Unknown);
        let [lo, hi] = histogram_ramp(&v);
        assert!(lo > 4.0 && lo <= 20.0, "threshold {lo} should lie between the clusters");
        assert!((30.0..=32.0).contains(&hi), "top {hi} should be the object's top");
    }

    #[test]
    fn a_hu_preset_means_the_same_tissue_whatever_the_range() {
        // Two CTs spanning different ranges: 500 HU must get the same extinction in both.
        for range in [[-1024.0, 3071.0], [-1000.0, 1500.0]] {
            let n = to_normalized(&ct_preset("ct-bone"), range);
            let t = (500.0 - range[0]) / (range[1] - range[0]);
            let want = ct_preset("ct-bone").eval(500.0, 0.0)[3];
            // Sampled at texels 1/255 apart: within one texel's change of the ramp.
            let got = n.eval(t, 0.0)[3];
            assert!((got - want).abs() < 0.5, "range {range:?}: {got} vs {want}");
            assert_eq!(n.eval(0.0, 0.0)[3], 0.0, "air is transparent");
        }
    }

    #[test]
    fn ct_presets_need_hounsfield_units() {
        let v = volume(vec![0.0, 1.0, 2.0], ValueUnit::Unknown);
        let e = named("ct-bone", &v).unwrap_err().to_string();
        assert!(e.contains("tf=ct-bone") && e.contains("not in HU"), "{e}");
        let e = named("ramp:5,1", &v).unwrap_err().to_string();
        assert!(e.contains("LO < HI"), "{e}");
    }

    #[test]
    fn the_automatic_choice_reproduces_from_its_printed_name() {
        let mut d: Vec<f32> = (0..900).map(|i| (i % 7) as f32).collect();
        d.extend((0..100).map(|i| 100.0 + i as f32));
        let v = volume(d, ValueUnit::Unknown);
        let (auto, line) = for_volume(None, &v).expect("auto");
        let line = line.expect("an automatic choice is printed");
        let name = line.split_whitespace().nth(2).expect("name");
        assert_eq!(named(name, &v).expect("printed name parses"), auto, "{line}");
        let mut ct = volume(vec![-1000.0; 990], ValueUnit::Hounsfield);
        ct.data.extend([1200.0; 10]);
        ct.value_range = [-1000.0, 1200.0];
        assert!(for_volume(None, &ct).expect("ct").1.expect("line").contains("ct-bone"));
    }

    #[test]
    fn a_json_function_in_data_units_is_mapped_over_the_value_range() {
        let dir = std::env::temp_dir().join(format!("vkengine-tf-units-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let p = dir.join("tf.json");
        let write = |units: &str| {
            let text = format!(
                r#"{{{units} "points": [{{"value": 100, "color": [1, 1, 1], "extinction": 0}},
                   {{"value": 300, "color": [1, 1, 1], "extinction": 20}}]}}"#
            );
            std::fs::write(&p, text).expect("write");
        };
        // Values 0..=400: 200 is normalized 0.5, halfway up the ramp.
        let v = volume((0..=400).map(|i| i as f32).collect(), ValueUnit::Unknown);
        write(r#""units": "data","#);
        let tf = TransferFunction::load_for(&p, &v).expect("data units");
        assert!((tf.eval(0.5, 0.0)[3] - 10.0).abs() < 1e-3, "{:?}", tf.eval(0.5, 0.0));
        let e = TransferFunction::load(&p).unwrap_err().to_string();
        assert!(e.contains("tf.json") && e.contains("need a loaded volume"), "{e}");
        write(r#""units": "HU","#);
        let e = TransferFunction::load_for(&p, &v).unwrap_err().to_string();
        assert!(e.contains("not in Hounsfield units"), "{e}");
        write(r#""units": "furlongs","#);
        let e = TransferFunction::load_for(&p, &v).unwrap_err().to_string();
        assert!(e.contains("unknown \"units\""), "{e}");
        // Without units the values must be normalized: 100 is outside [0, 1].
        write("");
        let e = TransferFunction::load_for(&p, &v).unwrap_err().to_string();
        assert!(e.contains("outside [0,1]"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
