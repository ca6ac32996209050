//! Benchmark plots: labelled log-log line charts and horizontal bar charts written as PNG
//! (plotters into our own buffer, saved with `image`), labelled with the Ubuntu Light font that
//! egui already bundles (`epaint_default_fonts`): no system font is needed (a GPU machine without
//! DejaVu Sans ended every plotting benchmark with exit 2).

use crate::error::{Error, Result};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use std::sync::OnceLock;

/// One named line of (x, y) points.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// Points, x ascending; non-positive values are dropped (log axes).
    pub points: Vec<(f64, f64)>,
}

fn register_font() -> Result<()> {
    static DONE: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT)
            .map_err(|_| "the bundled Ubuntu Light font is not usable by plotters".to_string())
    })
    .clone()
    .map_err(Error::Input)
}

/// Draws `series` on log-log axes into a PNG.
pub fn loglog(path: &Path, title: &str, x_label: &str, y_label: &str, series: &[Series]) -> Result<()> {
    register_font()?;
    let pts: Vec<(f64, f64)> =
        series.iter().flat_map(|s| s.points.iter().copied()).filter(|&(x, y)| x > 0.0 && y > 0.0).collect();
    if pts.is_empty() {
        return Err(Error::Input(format!("{}: nothing to plot", path.display())));
    }
    let (x0, x1) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), &(x, _)| (a.min(x), b.max(x)));
    let (y0, y1) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), &(_, y)| (a.min(y), b.max(y)));
    let (w, h) = (900u32, 600u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let err = |e: &dyn std::fmt::Display| Error::Input(format!("{}: plot failed: {e}", path.display()));
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d((x0 * 0.8..x1 * 1.25).log_scale(), (y0 * 0.8..y1 * 1.25).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .draw()
            .map_err(|e| err(&e))?;
        for (i, s) in series.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let line: Vec<(f64, f64)> = s.points.iter().copied().filter(|&(x, y)| x > 0.0 && y > 0.0).collect();
            chart
                .draw_series(LineSeries::new(line.clone(), color.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(s.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
            chart.draw_series(line.iter().map(|&p| Circle::new(p, 3, color.filled()))).map_err(|e| err(&e))?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    save_rgb(path, &buf, w, h)
}

/// A log-scale tick value, whose steps add up to values like 0.30000000000000004, with three
/// significant digits and no trailing zeros.
fn tick(v: f64) -> String {
    let digits = (2.0 - v.abs().max(1e-12).log10().floor()).clamp(0.0, 12.0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// One bar: a label, its value and an optional (low, high) whisker such as p10–p90.
#[derive(Clone, Debug)]
pub struct Bar {
    /// Label left of the bar.
    pub label: String,
    /// Bar length.
    pub value: f64,
    /// Whisker drawn across the bar's end.
    pub range: Option<(f64, f64)>,
}

/// A panel of bars that share one axis (one unit).
#[derive(Clone, Debug)]
pub struct BarGroup {
    /// Panel caption, e.g. the unit.
    pub title: String,
    /// Bars, drawn top to bottom.
    pub bars: Vec<Bar>,
}

fn save_rgb(path: &Path, buf: &[u8], w: u32, h: u32) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.display().to_string(), source })?;
    }
    image::save_buffer(path, buf, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| Error::Input(format!("{}: cannot write PNG: {e}", path.display())))
}

/// Draws horizontal bar charts into a PNG, one panel per group stacked vertically (groups with
/// different units cannot share an axis); empty groups are left out.
pub fn bars(path: &Path, title: &str, groups: &[BarGroup]) -> Result<()> {
    register_font()?;
    let groups: Vec<&BarGroup> = groups.iter().filter(|g| !g.bars.is_empty()).collect();
    if groups.is_empty() {
        return Err(Error::Input(format!("{}: nothing to plot", path.display())));
    }
    // At least two bars' height per panel, so a one-bar panel keeps a readable axis.
    let heights: Vec<u32> = groups.iter().map(|g| 90 + 32 * g.bars.len().max(2) as u32).collect();
    let (w, h) = (1100u32, 50 + heights.iter().sum::<u32>());
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let err = |e: &dyn std::fmt::Display| Error::Input(format!("{}: plot failed: {e}", path.display()));
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let root = root.titled(title, ("sans-serif", 24)).map_err(|e| err(&e))?;
        let breaks: Vec<i32> = heights
            .iter()
            .scan(0i32, |y, &hh| {
                *y += hh as i32;
                Some(*y)
            })
            .take(heights.len() - 1)
            .collect();
        let panels = root.split_by_breakpoints(Vec::<i32>::new(), breaks);
        for (gi, (group, panel)) in groups.iter().zip(&panels).enumerate() {
            let n = group.bars.len();
            let top = group.bars.iter().map(|b| b.range.map_or(b.value, |r| r.1.max(b.value))).fold(0.0f64, f64::max);
            let x_max = if top > 0.0 && top.is_finite() { top * 1.12 } else { 1.0 };
            // Bar i sits in segment n - 1 - i so the first bar is on top; labels at segment centres.
            let mut chart = ChartBuilder::on(panel)
                .caption(&group.title, ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(30)
                .y_label_area_size(330)
                .build_cartesian_2d(0.0..x_max, (0..n as i32).into_segmented())
                .map_err(|e| err(&e))?;
            let label_of = |v: &SegmentValue<i32>| match v {
                SegmentValue::CenterOf(j) => usize::try_from(n as i32 - 1 - j)
                    .ok()
                    .and_then(|i| group.bars.get(i))
                    .map_or(String::new(), |b| b.label.clone()),
                _ => String::new(),
            };
            chart
                .configure_mesh()
                .disable_y_mesh()
                .x_label_style(("sans-serif", 13))
                .y_label_formatter(&label_of)
                .y_label_style(("sans-serif", 14))
                .draw()
                .map_err(|e| err(&e))?;
            let color = Palette99::pick(gi).to_rgba();
            let value_style = TextStyle::from(("sans-serif", 13).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
            for (i, b) in group.bars.iter().enumerate() {
                let j = (n - 1 - i) as i32;
                let mid = || SegmentValue::CenterOf(j);
                let shown = b.value.is_finite() && b.value > 0.0;
                if shown {
                    let mut r = Rectangle::new(
                        [(0.0, SegmentValue::Exact(j)), (b.value, SegmentValue::Exact(j + 1))],
                        color.filled(),
                    );
                    r.set_margin(5, 5, 0, 0);
                    chart.draw_series(std::iter::once(r)).map_err(|e| err(&e))?;
                }
                if let Some((lo, hi)) = b.range.filter(|r| shown && r.0.is_finite() && r.1.is_finite()) {
                    let whisker = PathElement::new(vec![(lo, mid()), (hi, mid())], BLACK.stroke_width(2));
                    chart.draw_series(std::iter::once(whisker)).map_err(|e| err(&e))?;
                    let ends = [lo, hi].map(|x| Circle::new((x, mid()), 3, BLACK.filled()));
                    chart.draw_series(ends).map_err(|e| err(&e))?;
                }
                let text = if shown { format!("{:.3}", b.value) } else { "skipped".into() };
                let right = if shown { b.range.map_or(b.value, |r| r.1.max(b.value)) } else { 0.0 };
                let at = (right + x_max * 0.01, mid());
                chart.draw_series(std::iter::once(Text::new(text, at, value_style.clone()))).map_err(|e| err(&e))?;
            }
        }
        root.present().map_err(|e| err(&e))?;
    }
    save_rgb(path, &buf, w, h)
}

/// Least-squares slope of log(y) against log(x): the convergence order of an error curve.
pub fn loglog_slope(points: &[(f64, f64)]) -> f64 {
    let p: Vec<(f64, f64)> =
        points.iter().filter(|&&(x, y)| x > 0.0 && y > 0.0).map(|&(x, y)| (x.ln(), y.ln())).collect();
    let n = p.len() as f64;
    let (mx, my) = (p.iter().map(|q| q.0).sum::<f64>() / n, p.iter().map(|q| q.1).sum::<f64>() / n);
    let cov: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    let var: f64 = p.iter().map(|q| (q.0 - mx).powi(2)).sum();
    cov / var
}

#[cfg(test)]
mod tests {
    #[test]
    fn slope_of_power_law() {
        let pts: Vec<(f64, f64)> = (1..8).map(|i| (2f64.powi(i), 3.0 * 2f64.powi(i).powf(-0.5))).collect();
        assert!((super::loglog_slope(&pts) + 0.5).abs() < 1e-9);
    }
}
