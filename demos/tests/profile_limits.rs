//! Device-limit micro-benchmarks (`demos/src/limits`) on lavapipe under validation + synchronization
//! validation, each run once at a tiny size and checked for the work it did: the copy equals its
//! source, the read kernels' sums and the write kernels' patterns are exact, trilinear fetches
//! match a CPU trilinear filter within the device's sub-texel precision, atomic counters hold
//! the exact totals (uint and float), every dispatch and draw landed, and the three LPV SH
//! layouts give bit-identical results equal to the CPU step. Plus the repeat-until-stable rule
//! and statistics on the CPU.

#[path = "../../tests/common/mod.rs"]
mod common;

use std::fmt::Debug;
use vkengine::profile::percentile;
use vkengine::vk::Context;
use vkengine_demos::limits::benches::{
    linear_rgba32f_unsupported, AtomicBench, BufferReadBench, BufferWriteBench, CopyBench, DispatchBench, DrawBench,
    ImageReadBench, ImageWriteBench, LpvLayoutBench, ShLayout, TextureBench,
};
use vkengine_demos::limits::cpu::{copy_word, lpv_reference, pattern, TEXTURE_FETCHES, TINY_MARKER};
use vkengine_demos::limits::{
    measure, relative_spread, run_all, run_case, Bench, LimitsConfig, StopReason, StopRule, Summary,
};

/// One graph of `reps` timed passes of `case`: their GPU ms.
fn run(ctx: &Context, bench: &dyn Bench, case: usize, reps: u32) -> Vec<f64> {
    run_case(ctx, bench, case, reps).unwrap_or_else(|e| panic!("{}: {e}", bench.cases()[case].name))
}

/// The first index where `got` and `want` differ (or their lengths), for a short failure message.
fn mismatch<T: PartialEq + Debug>(got: &[T], want: &[T]) -> Option<String> {
    if got.len() != want.len() {
        return Some(format!("length {} != expected {}", got.len(), want.len()));
    }
    got.iter().zip(want).position(|(a, b)| a != b).map(|i| format!("at {i}: got {:?}, want {:?}", got[i], want[i]))
}

fn assert_same<T: PartialEq + Debug>(what: &str, got: &[T], want: &[T]) {
    if let Some(m) = mismatch(got, want) {
        panic!("{what}: {m}");
    }
}

fn assert_timings(what: &str, ms: &[f64], reps: usize) {
    assert_eq!(ms.len(), reps, "{what}: one timing per timed pass");
    assert!(ms.iter().all(|&m| m.is_finite() && m > 0.0), "{what}: GPU times {ms:?}");
}

// ---- the stop rule and statistics (CPU) ----

#[test]
fn stop_rule_waits_for_a_stable_window() {
    let rule = StopRule { window: 4, tolerance: 0.05, max_samples: 100, max_seconds: 1e9 };
    // Noisy start; the last four samples first agree within 5 % once the 7th arrives.
    let seq = [10.0, 3.0, 7.0, 5.0, 5.1, 4.9, 5.0, 5.05];
    let first = (1..=seq.len()).find(|&i| rule.check(&seq[..i], 0.0).is_some());
    assert_eq!(first, Some(7));
    assert_eq!(rule.check(&seq[..7], 0.0), Some(StopReason::Stable));
    // Fewer samples than the window never count as stable, however close they are.
    assert_eq!(rule.check(&[5.0, 5.0, 5.0], 0.0), None);
}

#[test]
fn stop_rule_gives_up_on_samples_or_time() {
    let rule = StopRule { window: 3, tolerance: 0.05, max_samples: 6, max_seconds: 1.0 };
    let noisy = [1.0, 3.0, 1.0, 3.0, 1.0, 3.0];
    assert_eq!(rule.check(&noisy[..5], 0.5), None);
    assert_eq!(rule.check(&noisy, 0.5), Some(StopReason::MaxSamples));
    assert_eq!(rule.check(&noisy[..4], 1.5), Some(StopReason::MaxTime));
    // Out of time but no sample yet: keep going until there is something to report.
    assert_eq!(rule.check(&[], 5.0), None);
}

#[test]
fn measure_discards_the_warm_up_and_stops_when_stable() {
    let rule = StopRule { window: 4, tolerance: 0.05, max_samples: 100, max_seconds: 1e9 };
    // Batches of two samples: a slow warm-up, a noisy batch, then steady ones.
    let mut batches =
        vec![vec![100.0, 90.0], vec![9.0, 5.0], vec![5.0, 5.1], vec![5.05, 4.95], vec![5.0, 5.0]].into_iter();
    let m = measure(&rule, || Ok(batches.next().expect("measure asked for too many batches"))).expect("measure");
    assert_eq!(m.samples, [9.0, 5.0, 5.0, 5.1, 5.05, 4.95]);
    assert_eq!(m.stop, StopReason::Stable);
    // A batch without samples is an error, not an endless loop.
    assert!(measure(&rule, || Ok(vec![])).is_err());
}

#[test]
fn summary_statistics() {
    let v: Vec<f64> = (1..=10).rev().map(f64::from).collect();
    let s = Summary::of(&v);
    assert_eq!((s.median, s.min, s.max, s.samples), (5.5, 1.0, 10.0, 10));
    assert!((s.p10 - 1.9).abs() < 1e-12 && (s.p90 - 9.1).abs() < 1e-12, "{s:?}");
    assert_eq!(percentile(&[], 0.5), 0.0);
    assert_eq!(percentile(&[4.0], 0.9), 4.0);
    assert!((relative_spread(&[1.0, 2.0, 3.0]) - 0.8).abs() < 1e-12);
    assert_eq!(relative_spread(&[0.0, 0.0]), f64::INFINITY);
}

// ---- the benchmarks on the GPU ----

#[test]
fn copy_and_storage_buffer_kernels_are_exact() {
    common::gpu_test(|ctx| {
        let cfg = LimitsConfig::tiny();
        let copy = CopyBench::new(ctx, cfg.copy_bytes).expect("copy bench");
        assert_timings("copy", &run(ctx, &copy, 0, 2), 2);
        let want: Vec<u8> = (0..(copy.bytes() / 4) as u32).flat_map(|i| copy_word(i).to_le_bytes()).collect();
        assert_same("copy destination", &copy.read_dst().expect("read"), &want);

        let read = BufferReadBench::new(ctx, cfg.buffer_bytes).expect("read bench");
        assert_timings("ssbo read", &run(ctx, &read, 0, 2), 2);
        assert_same("ssbo read sums", &read.read_sums().expect("read"), &read.expected());

        let write = BufferWriteBench::new(ctx, cfg.buffer_bytes).expect("write bench");
        assert_timings("ssbo write", &run(ctx, &write, 0, 1), 1);
        let want: Vec<[f32; 4]> = (0..write.len()).map(pattern).collect();
        assert_same("ssbo write pattern", &write.read_dst().expect("read"), &want);
    });
}

#[test]
fn storage_image_kernels_are_exact() {
    common::gpu_test(|ctx| {
        let cfg = LimitsConfig::tiny();
        let read = ImageReadBench::new(ctx, cfg.image_edge).expect("image read bench");
        assert_timings("image read", &run(ctx, &read, 0, 2), 2);
        assert_same("image read sums", &read.read_sums().expect("read"), &read.expected());

        let write = ImageWriteBench::new(ctx, cfg.image_edge).expect("image write bench");
        assert_timings("image write", &run(ctx, &write, 0, 1), 1);
        let n = write.edge();
        let want: Vec<[f32; 4]> = (0..n * n * n).map(pattern).collect();
        assert_same("image write pattern", &write.read_image().expect("read"), &want);
    });
}

#[test]
fn trilinear_fetches_match_a_cpu_filter() {
    common::gpu_test(|ctx| {
        if let Some(reason) = linear_rgba32f_unsupported(ctx) {
            eprintln!("skipping: {reason}");
            return;
        }
        let cfg = LimitsConfig::tiny();
        let b = TextureBench::new(ctx, cfg.texture_edge, cfg.fetch_grid).expect("texture bench");
        // A texture linear in x, y, z with gradients up to 3 per texel: quantising a coordinate
        // to the device's sub-texel precision moves a fetch by at most 3·2^-bits.
        let bits = ctx.info.limits.sub_texel_precision_bits;
        let per_fetch = 3.0 * 0.5f32.powi(bits as i32);
        for scattered in [false, true] {
            assert_timings("texture", &run(ctx, &b, usize::from(scattered), 1), 1);
            let got = b.read_sums().expect("read");
            let want = b.expected(scattered);
            assert_eq!(got.len(), want.len());
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                for c in 0..4 {
                    let tol = TEXTURE_FETCHES as f32 * per_fetch + 1e-5 * w[c].abs();
                    assert!(
                        (g[c] - w[c]).abs() <= tol,
                        "scattered={scattered} invocation {i} channel {c}: got {}, CPU trilinear {} (tolerance {tol})",
                        g[c],
                        w[c]
                    );
                }
            }
        }
    });
}

#[test]
fn atomic_counters_hold_exact_totals() {
    common::gpu_test(|ctx| {
        let cfg = LimitsConfig::tiny();
        let b = AtomicBench::new(ctx, cfg.atomic_invocations, cfg.atomics_per_invocation).expect("atomic bench");
        let floats = AtomicBench::float_unsupported(ctx).is_none();
        if !floats {
            eprintln!("float atomics not available: checking uint only");
        }
        for float in [false, true].into_iter().filter(|&f| !f || floats) {
            for contended in [false, true] {
                assert_timings("atomics", &run(ctx, &b, AtomicBench::case(float, contended), 2), 2);
                let want = b.expected(contended);
                let what = format!("float={float} contended={contended}");
                if contended {
                    let per = cfg.atomic_invocations / 64 * cfg.atomics_per_invocation;
                    assert!(want[..64].iter().all(|&v| v == per), "{what}: CPU expectation");
                }
                let words = b.read_counters().expect("read");
                if float {
                    // Small integer totals: float atomics are exact too.
                    let got: Vec<f32> = words.into_iter().map(f32::from_bits).collect();
                    let want: Vec<f32> = want.iter().map(|&v| v as f32).collect();
                    assert_same(&what, &got, &want);
                } else {
                    assert_same(&what, &words, &want);
                }
            }
        }
    });
}

#[test]
fn every_dispatch_and_draw_lands() {
    common::gpu_test(|ctx| {
        let cfg = LimitsConfig::tiny();
        let d = DispatchBench::new(ctx, cfg.dispatches).expect("dispatch bench");
        assert_timings("dispatch", &run(ctx, &d, 0, 2), 2);
        let want = vec![TINY_MARKER; d.count() as usize];
        assert_same("dispatch slots", &d.read_slots().expect("read"), &want);

        let r = DrawBench::new(ctx, cfg.draws).expect("draw bench");
        assert_timings("draw", &run(ctx, &r, 0, 2), 2);
        let got = r.read_target().expect("read");
        let want: Vec<u32> = (0..got.len() as u32).map(|i| if i < r.count() { i + 1 } else { 0 }).collect();
        assert_same("draw target", &got, &want);
    });
}

#[test]
fn lpv_layouts_agree_bit_for_bit() {
    common::gpu_test(|ctx| {
        // 6³ is not a whole number of 4³ workgroups; both sizes have boundary cells.
        for n in LimitsConfig::tiny().lpv_sizes {
            let b = LpvLayoutBench::new(ctx, n).expect("lpv layout bench");
            let input = b.input();
            let want = lpv_reference(n, &input);
            assert!(want != input, "the step must change the grid");
            for layout in ShLayout::ALL {
                assert_timings("lpv", &run(ctx, &b, layout.case(), 2), 2);
                assert_same(&format!("{n}³ {layout:?}"), &b.output(layout).expect("read"), &want);
            }
        }
    });
}

#[test]
fn suite_rows_are_finite_and_positive() {
    common::gpu_test(|ctx| {
        let cfg = LimitsConfig::tiny();
        let mut seen = 0;
        let rows = run_all(ctx, &cfg, |_| seen += 1).expect("suite");
        assert_eq!(seen, rows.len(), "progress is called once per row");
        let names: Vec<&str> = rows.iter().map(|r| r.name.as_str()).collect();
        let mut expected = vec![
            "buffer copy",
            "ssbo read",
            "ssbo write",
            "image read",
            "image write",
            "texture coherent",
            "texture scattered",
            "atomic uint uncontended",
            "atomic uint contended",
            "atomic float uncontended",
            "atomic float contended",
            "dispatch",
            "draw",
        ];
        let lpv: Vec<String> =
            cfg.lpv_sizes.iter().flat_map(|n| ["soa", "aos", "images"].map(|l| format!("lpv {l} {n}"))).collect();
        expected.extend(lpv.iter().map(String::as_str));
        assert_eq!(names, expected);
        for r in &rows {
            match &r.skipped {
                Some(reason) => assert!(!reason.is_empty(), "{}: skipped without a reason", r.name),
                None => {
                    let vals = [
                        r.stats.median,
                        r.stats.p10,
                        r.stats.p90,
                        r.stats.min,
                        r.stats.max,
                        r.median_ms,
                        r.work_per_run,
                    ];
                    assert!(vals.iter().all(|v| v.is_finite() && *v > 0.0), "{}: {r:?}", r.name);
                    assert!(
                        r.stats.min <= r.stats.p10
                            && r.stats.p10 <= r.stats.median
                            && r.stats.median <= r.stats.p90
                            && r.stats.p90 <= r.stats.max,
                        "{r:?}"
                    );
                    assert!(r.stats.samples >= 1 && !r.unit.is_empty() && !r.work_unit.is_empty(), "{r:?}");
                    assert_eq!(r.samples_ms.len(), r.stats.samples, "{}: raw samples kept", r.name);
                }
            }
        }
    });
}
