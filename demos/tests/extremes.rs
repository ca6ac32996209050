//! A small subset of the parameter-extreme sweep (`sweep_extremes` runs all of it): EAM and
//! bounded/classic MCM with the settings most likely to blow up at their ends, and the fog and
//! LPV keys of the mesh renderer; every frame finite and non-negative, or refused clearly.

#[path = "../../tests/common/mod.rs"]
mod common;

use vkengine_demos::extremes::{sweep, Outcome, Selection};

#[test]
fn extreme_settings_render_finite_non_negative_frames_or_are_refused_clearly() {
    common::gpu_test(|ctx| {
        let sel = Selection {
            renderers: &["eam", "mcm"],
            keys: &[
                "density",
                "g",
                "exposure",
                "step",
                "bounces",
                "env",
                "mc_budget",
                "sun",
                "fog_density",
                "fog_g",
                "lpv_steps",
                "ambient",
            ],
            mesh: true,
            limit: std::time::Duration::from_secs(30),
        };
        let cases = sweep(ctx, &sel);
        assert!(cases.len() >= 24, "only {} cases ran", cases.len());
        let failed: Vec<_> = cases.iter().filter(|c| matches!(c.outcome, Outcome::Failed(_))).collect();
        assert!(failed.is_empty(), "{failed:#?}");
    });
}
