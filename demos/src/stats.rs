//! Per-pass GPU times gathered over a headless run, reduced to medians for reports.

use vkengine::graph::trace::PassTiming;

/// GPU milliseconds per pass and per frame over many frames.
#[derive(Default)]
pub struct PassStats {
    passes: Vec<(String, Vec<f64>)>,
    frames: Vec<f64>,
    /// Every frame's timings, for `--profile` traces.
    pub timings: Vec<Vec<PassTiming>>,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

impl PassStats {
    /// Adds one frame's timings.
    pub fn add(&mut self, timings: &[PassTiming]) {
        for t in timings {
            let ms = t.gpu_ms();
            match self.passes.iter_mut().find(|(n, _)| *n == t.name) {
                Some((_, v)) => v.push(ms),
                None => self.passes.push((t.name.clone(), vec![ms])),
            }
        }
        self.frames.push(timings.last().map(|t| t.gpu_end_ns as f64 * 1e-6).unwrap_or(0.0));
        self.timings.push(timings.to_vec());
    }

    /// What each pass of the last frame recorded (dispatches, barriers, transfer bytes).
    pub fn last_commands(&self, pass: &str) -> vkengine::graph::Commands {
        let last = self.timings.last().map_or(&[][..], |f| f.as_slice());
        vkengine::graph::Commands::total(last.iter().filter(|t| t.name == pass).map(|t| &t.commands))
    }

    /// What the whole last frame recorded.
    pub fn frame_commands(&self) -> vkengine::graph::Commands {
        vkengine::graph::Commands::total(self.timings.last().into_iter().flatten().map(|t| &t.commands))
    }

    /// Median GPU ms of each pass, in first-seen order.
    pub fn pass_medians(&self) -> Vec<(String, f64)> {
        self.passes.iter().map(|(n, v)| (n.clone(), median(v.clone()))).collect()
    }

    /// Median GPU ms of a whole frame (first timestamp to last).
    pub fn frame_median(&self) -> f64 {
        median(self.frames.clone())
    }

    /// GPU ms of each pass summed over all frames and divided by the frame count (a pass some
    /// frames skip counts as 0 there): its share of an average frame, in first-seen order.
    pub fn pass_means(&self) -> Vec<(String, f64)> {
        let frames = self.frames.len().max(1) as f64;
        self.passes.iter().map(|(n, v)| (n.clone(), v.iter().sum::<f64>() / frames)).collect()
    }

    /// Mean and largest GPU ms of a whole frame.
    pub fn frame_mean_max(&self) -> (f64, f64) {
        let mean = self.frames.iter().sum::<f64>() / self.frames.len().max(1) as f64;
        (mean, self.frames.iter().copied().fold(0.0, f64::max))
    }
}

impl PassStats {
    /// Writes `--profile DIR` (if given) for a headless run of `demo` on `ctx`.
    pub fn write_profile(
        &self,
        args: &crate::cli::DemoArgs,
        demo: &str,
        ctx: &vkengine::vk::Context,
    ) -> vkengine::Result<()> {
        let Some(dir) = &args.profile else { return Ok(()) };
        let roofs = vkengine::profile::report::load_roofs(&args.limits, &ctx.info.name)?;
        if roofs.is_none() {
            eprintln!(
                "profile: no device limits for {} in {} (run `cargo run --release --bin device_limits`); efficiency left out",
                ctx.info.name,
                args.limits.display()
            );
        }
        let cmdline: Vec<String> = std::env::args().skip(1).collect();
        let profile = vkengine::profile::report::Profile::new(
            demo,
            cmdline,
            (&ctx.info).into(),
            args.warmup,
            &self.timings,
            roofs,
        );
        profile.write(dir, &self.timings)?;
        eprint!("{}", profile.table());
        eprintln!("wrote {}", dir.display());
        Ok(())
    }
}
