//! A fixed-seed share of `fuzz_loaders` in the suite: a few hundred mutated cases per loader, no
//! panic, no hang, no allocation beyond the case's limit, and every unmutated seed loads.

use std::time::Duration;
use vkengine_demos::fuzz::{self, CountingAlloc};

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

/// Cases per format in the suite (the command runs 10⁴ and more).
const CASES: u64 = 300;

#[test]
fn every_loader_survives_mutated_seeds() {
    assert!(fuzz::counting_active(), "the counting allocator is not installed");
    let work = std::env::temp_dir().join(format!("vkengine-fuzz-{}", std::process::id()));
    let mut failures = Vec::new();
    for format in fuzz::FORMATS {
        let report = fuzz::fuzz(format, CASES, 2024, Duration::from_secs(20), &work).expect("case files");
        assert_eq!(report.cases, CASES, "{}: stopped early", format.name);
        if let Some(e) = report.seed_error {
            failures.push(format!("{}: the unmutated seed does not load: {e}", format.name));
        }
        // Mutations must reach the parser's error paths, not only its happy path.
        if report.rejected == 0 {
            failures.push(format!("{}: no mutated case was rejected", format.name));
        }
        for f in report.findings {
            failures.push(format!("{} case {}: {:?} ({})", format.name, f.case, f.problem, f.saved.display()));
        }
    }
    let _ = std::fs::remove_dir_all(&work);
    assert!(failures.is_empty(), "{} failing cases:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn the_harness_catches_a_panic_and_an_over_allocation() {
    // Guards the guard: loaders that panic or trust a header's size must be reported.
    fn panics(_: &std::path::Path) -> Result<(), String> {
        panic!("deliberate")
    }
    fn hoards(_: &std::path::Path) -> Result<(), String> {
        let v = vec![1u8; 64 << 20];
        Err(format!("{}", v.len()))
    }
    let work = std::env::temp_dir().join(format!("vkengine-fuzz-guard-{}", std::process::id()));
    let seed = || vec![("x.bin".to_string(), vec![0u8; 16])];
    for (load, want) in [(panics as fn(&std::path::Path) -> Result<(), String>, "Panic"), (hoards, "Alloc")] {
        let f = fuzz::Format { name: "guard", seed, entry: "x.bin", load, claim_cap: 0 };
        let report = fuzz::fuzz(&f, 3, 1, Duration::from_secs(20), &work).expect("case files");
        assert_eq!(report.findings.len(), 3, "{want}: {report:?}");
        assert!(report.findings.iter().all(|f| format!("{:?}", f.problem).starts_with(want)), "{report:?}");
    }
    let _ = std::fs::remove_dir_all(&work);
}
