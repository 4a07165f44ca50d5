//! The error-against-time plot (PNG): one colour per variant and backend, path tracing as
//! a line, the Pareto front dashed. Text uses the embedded DejaVu Sans.

use std::path::Path;
use std::sync::Once;

use plotters::coord::combinators::LogCoord;
use plotters::coord::Shift;
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
    let pts: Vec<&Row> = rows.iter().filter(|r| r.seconds > 0.0 && r.headline() > 0.0).collect();
    let extent = extent(pts.iter().map(|r| (r.seconds, r.headline())), path)?;
    let root = BitMapBackend::new(path, (1100, 750)).into_drawing_area();
    let mut chart = log_chart(
        &root,
        title,
        extent,
        (
            "time to solution (s, log)",
            "rel-RMS of indirect irradiance, worse stratum (log)",
        ),
        &|v| format!("{v:.3}"),
        &|v| format!("{:.1} %", v * 100.0),
    )
    .map_err(|e| out_err(path, e))?;
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
                .map_err(|e| out_err(path, e))?;
        }
        chart
            .draw_series(series.iter().map(|&(t, e)| Circle::new((t, e), 5, color.filled())))
            .map_err(|e| out_err(path, e))?
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
        .map_err(|e| out_err(path, e))?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(90, 90, 90)));
    finish(&mut chart, &root).map_err(|e| out_err(path, e))
}

/// Named series of (seconds, error %) as points joined by lines, both axes logarithmic
/// (the image front: `bench::images`), into `path`.
pub fn lines(title: &str, series: &[(String, Vec<(f64, f64)>)], path: &Path) -> Result<()> {
    register_font();
    let extent = extent(
        series
            .iter()
            .flat_map(|(_, p)| p.iter().copied())
            .filter(|&(t, e)| t > 0.0 && e > 0.0),
        path,
    )?;
    let root = BitMapBackend::new(path, (1100, 750)).into_drawing_area();
    let mut chart = log_chart(
        &root,
        title,
        extent,
        (
            "end-to-end time (s, log)",
            "rel-RMS of the total image, all pixels (%, log)",
        ),
        &|v| format!("{v:.2}"),
        &|v| format!("{v:.1} %"),
    )
    .map_err(|e| out_err(path, e))?;
    for (i, (name, pts)) in series.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        let mut pts: Vec<(f64, f64)> = pts.iter().copied().filter(|&(t, e)| t > 0.0 && e > 0.0).collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
            .map_err(|e| out_err(path, e))?;
        chart
            .draw_series(pts.iter().map(|&(t, e)| Circle::new((t, e), 5, color.filled())))
            .map_err(|e| out_err(path, e))?
            .label(name.clone())
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, color.filled()));
    }
    finish(&mut chart, &root).map_err(|e| out_err(path, e))
}

/// The range `(t0, t1, e0, e1)` of the points to plot into `path`; an error naming it
/// when there are none.
fn extent(points: impl Iterator<Item = (f64, f64)>, path: &Path) -> Result<(f64, f64, f64, f64)> {
    let (t0, t1, e0, e1) = points.fold((f64::MAX, f64::MIN, f64::MAX, f64::MIN), |(t0, t1, e0, e1), (t, e)| {
        (t0.min(t), t1.max(t), e0.min(e), e1.max(e))
    });
    if t0 > t1 {
        return Err(Error::Output {
            path: path.into(),
            message: "nothing to plot".into(),
        });
    }
    Ok((t0, t1, e0, e1))
}

/// A chart of both axes logarithmic over `(t0, t1)` × `(e0, e1)` (widened by 1.5× each
/// way) on a white `root`, with its caption, axis descriptions and label formats.
fn log_chart<'a, 'b>(
    root: &'a DrawingArea<BitMapBackend<'b>, Shift>,
    title: &str,
    (t0, t1, e0, e1): (f64, f64, f64, f64),
    (x_desc, y_desc): (&str, &str),
    x_label: &dyn Fn(&f64) -> String,
    y_label: &dyn Fn(&f64) -> String,
) -> std::result::Result<LogChart<'a, 'b>, String> {
    root.fill(&WHITE).map_err(|x| x.to_string())?;
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d((t0 / 1.5..t1 * 1.5).log_scale(), (e0 / 1.5..e1 * 1.5).log_scale())
        .map_err(|x| x.to_string())?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(x_label)
        .y_label_formatter(y_label)
        .label_style(("sans-serif", 15))
        .draw()
        .map_err(|x| x.to_string())?;
    Ok(chart)
}

/// A chart of [`log_chart`].
type LogChart<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;

/// Draws the legend and writes the file.
fn finish<'a, 'b>(
    chart: &mut LogChart<'a, 'b>,
    root: &'a DrawingArea<BitMapBackend<'b>, Shift>,
) -> std::result::Result<(), String> {
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|x| x.to_string())?;
    root.present().map_err(|x| x.to_string())
}

/// A plot's error, naming its file.
fn out_err(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Output {
        path: path.into(),
        message: e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extent_spans_the_points_and_names_the_file_when_there_are_none() {
        let path = Path::new("front.png");
        let pts = [(2.0, 0.05), (0.5, 0.2), (8.0, 0.01)];
        assert_eq!(extent(pts.into_iter(), path).unwrap(), (0.5, 8.0, 0.01, 0.2));
        let err = extent(std::iter::empty(), path).unwrap_err().to_string();
        assert!(err.contains("front.png") && err.contains("nothing to plot"), "{err}");
    }
}
