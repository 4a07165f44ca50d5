//! The error-against-time plot (PNG): one colour per variant and backend, path tracing as
//! a line, the Pareto front dashed. Text uses the embedded DejaVu Sans.

use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;
use plotters::style::FontStyle;

use super::accuracy::{group, Row};
use crate::error::{Error, Result};

static FONT: Once = Once::new();

fn register_font() {
    FONT.call_once(|| {
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, include_bytes!("font/DejaVuSans.ttf"));
    });
}

const COLORS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// Plots the rows of one scene into `path`.
///
/// Long by design: one chart, its axes, series and legend in the order plotters draws them.
pub fn error_vs_time(rows: &[Row], title: &str, path: &Path) -> Result<()> {
    register_font();
    let err = |e: Box<dyn std::error::Error>| Error::Output {
        path: path.into(),
        message: e.to_string(),
    };
    let pts: Vec<&Row> = rows.iter().filter(|r| r.seconds > 0.0 && r.headline() > 0.0).collect();
    if pts.is_empty() {
        return Err(Error::Output {
            path: path.into(),
            message: "nothing to plot".into(),
        });
    }
    let (mut t0, mut t1, mut e0, mut e1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for r in &pts {
        t0 = t0.min(r.seconds);
        t1 = t1.max(r.seconds);
        e0 = e0.min(r.headline());
        e1 = e1.max(r.headline());
    }
    let root = BitMapBackend::new(path, (1100, 750)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(Box::new(e)))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d((t0 / 1.5..t1 * 1.5).log_scale(), (e0 / 1.5..e1 * 1.5).log_scale())
        .map_err(|e| err(Box::new(e)))?;
    chart
        .configure_mesh()
        .x_desc("time to solution (s, log)")
        .y_desc("rel-RMS of indirect irradiance, worse stratum (log)")
        .x_label_formatter(&|v| format!("{v:.3}"))
        .y_label_formatter(&|v| format!("{:.1} %", v * 100.0))
        .label_style(("sans-serif", 15))
        .draw()
        .map_err(|e| err(Box::new(e)))?;
    let mut groups: Vec<String> = Vec::new();
    for r in &pts {
        let g = group(r);
        if !groups.contains(&g) {
            groups.push(g);
        }
    }
    for (i, g) in groups.iter().enumerate() {
        let color = if g == "path tracing" {
            BLACK
        } else {
            COLORS[i % COLORS.len()]
        };
        let mut series: Vec<(f64, f64)> = pts
            .iter()
            .filter(|r| group(r) == *g)
            .map(|r| (r.seconds, r.headline()))
            .collect();
        series.sort_by(|a, b| a.0.total_cmp(&b.0));
        if g == "path tracing" {
            chart
                .draw_series(LineSeries::new(series.clone(), color.stroke_width(2)))
                .map_err(|e| err(Box::new(e)))?;
        }
        chart
            .draw_series(series.iter().map(|&(t, e)| Circle::new((t, e), 5, color.filled())))
            .map_err(|e| err(Box::new(e)))?
            .label(g.clone())
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, color.filled()));
    }
    let mut front: Vec<(f64, f64)> = pts
        .iter()
        .filter(|r| r.pareto)
        .map(|r| (r.seconds, r.headline()))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    chart
        .draw_series(DashedLineSeries::new(front, 6, 4, RGBColor(90, 90, 90).stroke_width(2)))
        .map_err(|e| err(Box::new(e)))?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(90, 90, 90)));
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(Box::new(e)))?;
    root.present().map_err(|e| err(Box::new(e)))?;
    Ok(())
}

/// Named series of (seconds, error %) as points joined by lines, both axes logarithmic
/// (the image front: `bench::images`), into `path`.
pub fn lines(title: &str, series: &[(String, Vec<(f64, f64)>)], path: &Path) -> Result<()> {
    register_font();
    let err = |e: Box<dyn std::error::Error>| Error::Output {
        path: path.into(),
        message: e.to_string(),
    };
    let all: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|(_, p)| p.iter().copied())
        .filter(|&(t, e)| t > 0.0 && e > 0.0)
        .collect();
    if all.is_empty() {
        return Err(Error::Output {
            path: path.into(),
            message: "nothing to plot".into(),
        });
    }
    let (mut t0, mut t1, mut e0, mut e1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(t, e) in &all {
        (t0, t1, e0, e1) = (t0.min(t), t1.max(t), e0.min(e), e1.max(e));
    }
    let root = BitMapBackend::new(path, (1100, 750)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(Box::new(e)))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d((t0 / 1.5..t1 * 1.5).log_scale(), (e0 / 1.5..e1 * 1.5).log_scale())
        .map_err(|e| err(Box::new(e)))?;
    chart
        .configure_mesh()
        .x_desc("end-to-end time (s, log)")
        .y_desc("rel-RMS of the total image, all pixels (%, log)")
        .x_label_formatter(&|v| format!("{v:.2}"))
        .y_label_formatter(&|v| format!("{v:.1} %"))
        .label_style(("sans-serif", 15))
        .draw()
        .map_err(|e| err(Box::new(e)))?;
    for (i, (name, pts)) in series.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        let mut pts: Vec<(f64, f64)> = pts.iter().copied().filter(|&(t, e)| t > 0.0 && e > 0.0).collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
            .map_err(|e| err(Box::new(e)))?;
        chart
            .draw_series(pts.iter().map(|&(t, e)| Circle::new((t, e), 5, color.filled())))
            .map_err(|e| err(Box::new(e)))?
            .label(name.clone())
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, color.filled()));
    }
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(Box::new(e)))?;
    root.present().map_err(|e| err(Box::new(e)))?;
    Ok(())
}
