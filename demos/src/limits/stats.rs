//! The repeat-until-stable rule, order statistics and the report row of one measured limit.

use std::time::Instant;
use vkengine::profile::percentile;
use vkengine::{Error, Result};

/// When a repeated measurement stops.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct StopRule {
    /// Number of most recent samples the spread is judged on (also the minimum sample count).
    pub window: usize,
    /// Stop once `(p90 − p10) / median` of the window is at most this.
    pub tolerance: f64,
    /// Stop after this many samples even if never stable.
    pub max_samples: usize,
    /// Stop after this many seconds of measuring (warm-up excluded) even if never stable.
    pub max_seconds: f64,
}

impl Default for StopRule {
    fn default() -> Self {
        Self { window: 8, tolerance: 0.05, max_samples: 64, max_seconds: 4.0 }
    }
}

/// Why a measurement stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum StopReason {
    /// The last `window` samples were within the tolerance.
    Stable,
    /// `max_samples` reached.
    MaxSamples,
    /// `max_seconds` elapsed.
    MaxTime,
}

impl StopRule {
    /// Whether to stop after `samples` (oldest first) taken over `elapsed_s` seconds, and why.
    pub fn check(&self, samples: &[f64], elapsed_s: f64) -> Option<StopReason> {
        let window = self.window.max(1);
        if samples.len() >= window && relative_spread(&samples[samples.len() - window..]) <= self.tolerance {
            return Some(StopReason::Stable);
        }
        if samples.len() >= self.max_samples.max(1) {
            return Some(StopReason::MaxSamples);
        }
        if !samples.is_empty() && elapsed_s >= self.max_seconds {
            return Some(StopReason::MaxTime);
        }
        None
    }
}

/// `(p90 − p10) / median` of `samples`; infinite when the median is not positive.
pub fn relative_spread(samples: &[f64]) -> f64 {
    let mut s = samples.to_vec();
    s.sort_by(f64::total_cmp);
    let median = percentile(&s, 0.5);
    if median > 0.0 {
        (percentile(&s, 0.9) - percentile(&s, 0.1)) / median
    } else {
        f64::INFINITY
    }
}

/// Order statistics of a sample set.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Summary {
    /// Median.
    pub median: f64,
    /// 10th percentile.
    pub p10: f64,
    /// 90th percentile.
    pub p90: f64,
    /// Smallest sample.
    pub min: f64,
    /// Largest sample.
    pub max: f64,
    /// Number of samples.
    pub samples: usize,
}

impl Summary {
    /// Summarises `values` (any order).
    pub fn of(values: &[f64]) -> Self {
        let mut s = values.to_vec();
        s.sort_by(f64::total_cmp);
        Self {
            median: percentile(&s, 0.5),
            p10: percentile(&s, 0.1),
            p90: percentile(&s, 0.9),
            min: s.first().copied().unwrap_or(0.0),
            max: s.last().copied().unwrap_or(0.0),
            samples: s.len(),
        }
    }
}

/// The samples of one repeated measurement (warm-up excluded) and why it stopped.
#[derive(Clone, Debug)]
pub struct Measured {
    /// Samples in the order taken.
    pub samples: Vec<f64>,
    /// Why the loop ended.
    pub stop: StopReason,
}

/// Runs `batch` once as a warm-up, then repeatedly until `rule` says stop; every batch returns
/// one or more samples (e.g. GPU ms of each timed pass of one graph run).
pub fn measure(rule: &StopRule, mut batch: impl FnMut() -> Result<Vec<f64>>) -> Result<Measured> {
    batch()?;
    let start = Instant::now();
    let mut samples = Vec::new();
    loop {
        let got = batch()?;
        if got.is_empty() {
            return Err(Error::Graph("measurement batch produced no samples".into()));
        }
        samples.extend(got);
        if let Some(stop) = rule.check(&samples, start.elapsed().as_secs_f64()) {
            return Ok(Measured { samples, stop });
        }
    }
}

/// One measured device limit.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LimitRow {
    /// Short name, e.g. `buffer copy`.
    pub name: String,
    /// What was run, with sizes.
    pub detail: String,
    /// Unit of `median`/`p10`/`p90`/`min`/`max`, e.g. `GB/s`.
    pub unit: String,
    /// Median, p10, p90, min, max (in `unit`) and sample count (0 when skipped).
    #[serde(flatten)]
    pub stats: Summary,
    /// Whether the stop rule found the samples stable (rather than running out of samples or time).
    pub stable: bool,
    /// Median GPU milliseconds of one timed pass.
    pub median_ms: f64,
    /// Work done by one timed pass, in `work_unit`.
    pub work_per_run: f64,
    /// Unit of `work_per_run`: bytes, fetches, atomics, dispatches, draws, cells.
    pub work_unit: String,
    /// Why the benchmark did not run on this device, if it did not.
    pub skipped: Option<String>,
    /// Every sample's GPU milliseconds, in the order taken (warm-up excluded).
    pub samples_ms: Vec<f64>,
}

impl LimitRow {
    /// A row from per-pass GPU ms samples; `to_unit` converts one sample's ms into `unit`.
    pub fn from_ms(
        name: &str,
        detail: String,
        unit: &str,
        work: (f64, &str),
        m: &Measured,
        to_unit: impl Fn(f64) -> f64,
    ) -> Self {
        let values: Vec<f64> = m.samples.iter().map(|&ms| to_unit(ms)).collect();
        Self {
            name: name.into(),
            detail,
            unit: unit.into(),
            stats: Summary::of(&values),
            stable: m.stop == StopReason::Stable,
            median_ms: Summary::of(&m.samples).median,
            work_per_run: work.0,
            work_unit: work.1.into(),
            skipped: None,
            samples_ms: m.samples.clone(),
        }
    }

    /// A row for a benchmark the device cannot run.
    pub fn skipped(name: &str, detail: String, unit: &str, reason: String) -> Self {
        Self {
            name: name.into(),
            detail,
            unit: unit.into(),
            stats: Summary::default(),
            stable: false,
            median_ms: 0.0,
            work_per_run: 0.0,
            work_unit: String::new(),
            skipped: Some(reason),
            samples_ms: Vec::new(),
        }
    }
}
