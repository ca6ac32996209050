//! Benchmark plots: labelled log-log line charts written as PNG (plotters into our own buffer,
//! saved with `image`), labelled with DejaVu Sans from the system (Debian `fonts-dejavu-core`).

use crate::error::{Error, Result};
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

const FONT: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

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
        let bytes = std::fs::read(FONT).map_err(|e| format!("{FONT}: {e} (install fonts-dejavu-core)"))?;
        // Registered fonts must live for the program; one small leak, once.
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
            .map_err(|_| format!("{FONT}: not a usable TrueType font"))
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
        chart.configure_mesh().x_desc(x_label).y_desc(y_label).draw().map_err(|e| err(&e))?;
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
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.display().to_string(), source })?;
    }
    image::save_buffer(path, &buf, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| Error::Input(format!("{}: cannot write PNG: {e}", path.display())))
}

/// Horizontal bar chart of named values (e.g. GPU ms per pass), in the given order, as a PNG.
pub fn hbars(path: &Path, title: &str, x_label: &str, bars: &[(String, f64)]) -> Result<()> {
    register_font()?;
    if bars.is_empty() {
        return Err(Error::Input(format!("{}: nothing to plot", path.display())));
    }
    let max = bars.iter().map(|b| b.1).fold(0.0f64, f64::max).max(1e-9);
    let (w, h) = (900u32, 120 + 28 * bars.len() as u32);
    let label_width = bars.iter().map(|b| b.0.chars().count()).max().unwrap_or(4) as u32 * 8 + 20;
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let err = |e: &dyn std::fmt::Display| Error::Input(format!("{}: plot failed: {e}", path.display()));
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let n = bars.len() as i32;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(label_width.min(w / 2))
            .build_cartesian_2d(0.0..max * 1.15, (0..n).into_segmented())
            .map_err(|e| err(&e))?;
        // Bar i sits in segment n-1-i so the first pass is on top; labels at segment centres.
        let names: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
        let row = |i: usize| n - 1 - i as i32;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .y_labels(bars.len())
            .y_label_formatter(&|y| match y {
                SegmentValue::CenterOf(y) | SegmentValue::Exact(y) if (0..n).contains(y) => {
                    names[(n - 1 - *y) as usize].clone()
                }
                _ => String::new(),
            })
            .x_desc(x_label)
            .draw()
            .map_err(|e| err(&e))?;
        let color = Palette99::pick(0).to_rgba();
        chart
            .draw_series(bars.iter().enumerate().map(|(i, (_, v))| {
                let r = row(i);
                Rectangle::new([(0.0, SegmentValue::Exact(r)), (*v, SegmentValue::Exact(r + 1))], color.filled())
            }))
            .map_err(|e| err(&e))?;
        chart
            .draw_series(bars.iter().enumerate().map(|(i, (_, v))| {
                Text::new(format!("{v:.2}"), (*v + max * 0.01, SegmentValue::CenterOf(row(i))), ("sans-serif", 14))
            }))
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.display().to_string(), source })?;
    }
    image::save_buffer(path, &buf, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| Error::Input(format!("{}: cannot write PNG: {e}", path.display())))
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
