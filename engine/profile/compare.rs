//! Two profile reports side by side: per-pass ratio of median GPU times, and whether the change
//! is beyond the noise measured in the same reports. Absolute times on a shared or CPU device
//! drift between runs, so a change counts only if it clears every source of noise:
//! - **within a run**: a bootstrap 95 % interval of the ratio of medians (frames resampled);
//! - **drift over a run**: each report's first-half vs second-half median ratio;
//! - **between runs**: a second run of the baseline, if given, measures each pass's
//!   run-to-run change directly (|A′/A − 1|); otherwise a stated floor is assumed.
//!
//! The largest of the three deviations is allowed on either side of 1.

use super::report::{quantile, Profile};
use std::fmt::Write as _;

/// One pass present in both reports.
#[derive(Clone, Debug, PartialEq)]
pub struct PassChange {
    /// Pass name.
    pub name: String,
    /// Median GPU ms in A and in B.
    pub median_ms: [f64; 2],
    /// B / A.
    pub ratio: f64,
    /// Bootstrap 95 % interval of the ratio.
    pub interval: [f64; 2],
    /// Allowed deviation (largest of in-run drift and run-to-run floor): ratios within
    /// [1/(1+d), 1+d] are noise.
    pub drift: f64,
    /// `faster`, `slower` or `same`.
    pub verdict: &'static str,
}

/// SplitMix64: a deterministic stream for resampling (the comparison must not vary run to run).
struct SplitMix(u64);

impl SplitMix {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) % n as u64) as usize
    }
}

fn resampled_median(s: &[f64], rng: &mut SplitMix) -> f64 {
    let v: Vec<f64> = (0..s.len()).map(|_| s[rng.below(s.len())]).collect();
    quantile(&v, 0.5)
}

/// |median(first half) / median(second half) − 1| of a run's samples.
pub fn half_drift(s: &[f64]) -> f64 {
    if s.len() < 4 {
        return 0.0;
    }
    let (a, b) = s.split_at(s.len() / 2);
    let (ma, mb) = (quantile(a, 0.5), quantile(b, 0.5));
    if mb > 0.0 {
        (ma / mb - 1.0).abs()
    } else {
        0.0
    }
}

/// Compares one pass's samples; `floor` is the run-to-run deviation allowed besides the drift.
pub fn compare_samples(name: &str, a: &[f64], b: &[f64], floor: f64) -> PassChange {
    let (ma, mb) = (quantile(a, 0.5), quantile(b, 0.5));
    let ratio = if ma > 0.0 { mb / ma } else { f64::NAN };
    let mut rng = SplitMix(0x5EED);
    let mut ratios: Vec<f64> = (0..2000)
        .filter_map(|_| {
            let (ra, rb) = (resampled_median(a, &mut rng), resampled_median(b, &mut rng));
            (ra > 0.0).then(|| rb / ra)
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    let interval = if ratios.is_empty() { [f64::NAN; 2] } else { [quantile(&ratios, 0.025), quantile(&ratios, 0.975)] };
    let drift = half_drift(a).max(half_drift(b)).max(floor);
    let verdict = if interval[1] < 1.0 / (1.0 + drift) {
        "faster"
    } else if interval[0] > 1.0 + drift {
        "slower"
    } else {
        "same"
    };
    PassChange { name: name.into(), median_ms: [ma, mb], ratio, interval, drift, verdict }
}

/// Run-to-run noise assumed when no repeat of the baseline is given. Measured on llvmpipe (2
/// cores): passes of 10 ms and more moved 1–4 % between runs of the same build, passes under
/// ~5 ms up to 40 %; give repeats rather than trust this.
pub const DEFAULT_FLOOR: f64 = 0.10;

/// Changes smaller than this fraction of the baseline's frame time are not flagged.
pub const MIN_FRAME_FRACTION: f64 = 0.01;

/// What a pass's time may move between two runs of the same build.
pub enum Floor<'a> {
    /// The same fraction for every pass.
    Fixed(f64),
    /// Measured per pass from more runs of the baseline: the largest change among them.
    Repeats(&'a [Profile]),
}

/// Every pass found in both reports, in A's order, plus the whole frame's median ratio.
pub fn compare(a: &Profile, b: &Profile, floor: &Floor<'_>) -> (Vec<PassChange>, f64) {
    let changes = a
        .passes
        .iter()
        .filter_map(|pa| {
            let pb = b.passes.iter().find(|p| p.name == pa.name)?;
            let f = match floor {
                Floor::Fixed(f) => *f,
                // A pass missing from every repeat gets the fixed default.
                Floor::Repeats(rs) => rs
                    .iter()
                    .filter_map(|r| r.passes.iter().find(|p| p.name == pa.name))
                    .map(|p| {
                        let ratio = p.gpu_median_ms / pa.gpu_median_ms.max(1e-12);
                        ratio.max(1.0 / ratio.max(1e-12)) - 1.0
                    })
                    .reduce(f64::max)
                    .unwrap_or(DEFAULT_FLOOR),
            };
            let mut c = compare_samples(&pa.name, &pa.samples_ms, &pb.samples_ms, f);
            // Sub-millisecond passes on a CPU device jump by multiples between runs; a change
            // too small to matter to the frame is not reported as one.
            if (c.median_ms[1] - c.median_ms[0]).abs() < MIN_FRAME_FRACTION * a.frame_median_ms {
                c.verdict = "same";
            }
            Some(c)
        })
        .collect();
    (changes, b.frame_median_ms / a.frame_median_ms.max(1e-12))
}

/// The comparison as a text table, noting passes present in only one report.
pub fn format(a: &Profile, b: &Profile, floor: &Floor<'_>) -> String {
    let (changes, frame) = compare(a, b, floor);
    let mut out = String::new();
    match floor {
        Floor::Fixed(f) => {
            let _ = writeln!(out, "run-to-run floor: ±{:.0} % assumed (give a repeat of A to measure it)", f * 100.0);
        }
        Floor::Repeats(rs) => {
            let _ = writeln!(out, "run-to-run floor: the largest change of each pass over {} repeat(s) of A", rs.len());
        }
    }
    let _ = writeln!(
        out,
        "changes under {:.0} % of A's frame ({:.2} ms) are not flagged",
        MIN_FRAME_FRACTION * 100.0,
        MIN_FRAME_FRACTION * a.frame_median_ms
    );
    for (tag, p) in [("A", a), ("B", b)] {
        let _ = writeln!(
            out,
            "{tag}: {} on {} ({}), commit {}, {} frames",
            p.demo,
            p.device.name,
            p.device.driver,
            p.commit.as_deref().unwrap_or("?"),
            p.frames
        );
    }
    if a.device.name != b.device.name || a.device.driver != b.device.driver {
        out += "warning: the reports come from different devices or drivers\n";
    }
    let width = changes.iter().map(|c| c.name.len()).max().unwrap_or(4).max(4);
    let _ = writeln!(
        out,
        "{:<width$}  {:>9}  {:>9}  {:>6}  {:>15}  {:>6}  verdict",
        "pass", "A ms", "B ms", "B/A", "95 % interval", "noise"
    );
    for c in &changes {
        let _ = writeln!(
            out,
            "{:<width$}  {:>9.3}  {:>9.3}  {:>6.3}  [{:>6.3}, {:>6.3}]  {:>5.1}%  {}",
            c.name,
            c.median_ms[0],
            c.median_ms[1],
            c.ratio,
            c.interval[0],
            c.interval[1],
            c.drift * 100.0,
            c.verdict
        );
    }
    let _ = writeln!(out, "frame median B/A: {frame:.3}");
    for (tag, only, other) in [("A", a, b), ("B", b, a)] {
        for p in only.passes.iter().filter(|p| !other.passes.iter().any(|q| q.name == p.name)) {
            let _ = writeln!(out, "only in {tag}: {}", p.name);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples around `m` with a deterministic ±`spread` wobble.
    fn samples(m: f64, spread: f64, n: usize) -> Vec<f64> {
        (0..n).map(|i| m * (1.0 + spread * (((i * 7919) % 13) as f64 / 6.0 - 1.0))).collect()
    }

    #[test]
    fn the_same_distribution_is_not_a_change() {
        let c = compare_samples("p", &samples(10.0, 0.05, 40), &samples(10.0, 0.05, 40), 0.0);
        assert_eq!(c.verdict, "same", "{c:?}");
        assert!(c.interval[0] <= 1.0 && c.interval[1] >= 1.0);
    }

    #[test]
    fn a_clear_speedup_is_flagged_and_a_noisy_one_is_not() {
        let c = compare_samples("p", &samples(10.0, 0.05, 40), &samples(8.0, 0.05, 40), 0.05);
        assert_eq!(c.verdict, "faster", "{c:?}");
        assert!((c.ratio - 0.8).abs() < 0.02);
        let c = compare_samples("p", &samples(10.0, 0.05, 40), &samples(12.0, 0.05, 40), 0.05);
        assert_eq!(c.verdict, "slower", "{c:?}");
        // A 3 % change inside ±30 % frame-to-frame noise is not significant.
        let c = compare_samples("p", &samples(10.0, 0.3, 12), &samples(9.7, 0.3, 12), 0.0);
        assert_eq!(c.verdict, "same", "{c:?}");
    }

    #[test]
    fn drift_within_a_run_widens_what_counts_as_noise() {
        // A drifts by 20 % from its first to its second half; a 10 % difference is within it.
        let mut a = samples(10.0, 0.01, 20);
        a.extend(samples(12.0, 0.01, 20));
        let b = samples(12.1, 0.01, 40);
        assert!(half_drift(&a) > 0.15);
        assert_eq!(compare_samples("p", &a, &b, 0.0).verdict, "same");
    }

    #[test]
    fn a_measured_run_to_run_floor_absorbs_a_change_of_its_size() {
        // 8 % slower with tight frames: a change without a floor, noise with a 10 % floor.
        let (a, b) = (samples(10.0, 0.01, 40), samples(10.8, 0.01, 40));
        assert_eq!(compare_samples("p", &a, &b, 0.0).verdict, "slower");
        assert_eq!(compare_samples("p", &a, &b, 0.10).verdict, "same");
    }
}
