//! SVG plots (plotters' SVG backend) with the CSV of every plotted point written next to them.
//!
//! Logarithmic axes are drawn by plotting `log10(value)` on a linear axis and labelling ticks
//! with the original values, so one code path serves every combination of linear and log axes.
//! Points that cannot be shown on a log axis (zero, negative, non-finite) are dropped from the
//! plot but kept in the CSV.

use crate::report::palette::{Marker, Style};
use anyhow::{Context, Result};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::CoordTranslate;
use plotters::prelude::*;
use std::path::Path;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    /// Connected line.
    Line,
    /// Markers only.
    Points,
    /// Line with markers.
    LinePoints,
    /// Staircase (performance profiles).
    Step,
    /// Dashed reference line, grey.
    Reference,
    /// A second marker of the series named by the colour key (a small cross in its colour,
    /// no legend entry of its own): the median beside a worst-case point.
    Secondary,
}

/// One named series of `(x, y)` points.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// Colour key (solver name): series with the same key share a colour.
    pub color_key: String,
    /// The points.
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub mark: Mark,
}

/// A plot's axes and labels.
#[derive(Debug, Clone)]
pub struct PlotSpec {
    /// Title.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Fixed y range (in data units), if any.
    pub y_range: Option<(f64, f64)>,
    /// Where the legend goes.
    pub legend: LegendAt,
}

/// Legend placement. Every legend is drawn in a panel right of the data area, never over the
/// data; the variants are kept for the callers, which chose a corner when the legend was drawn
/// inside.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LegendAt {
    /// Upper right corner (the default).
    #[default]
    UpperRight,
    /// Lower left corner.
    LowerLeft,
    /// Lower right corner.
    LowerRight,
}

fn rgb((r, g, b): (u8, u8, u8)) -> RGBColor {
    RGBColor(r, g, b)
}

fn tick_label(v: f64, log: bool) -> String {
    if log {
        if (v - v.round()).abs() < 1e-9 {
            format!("1e{}", v.round() as i64)
        } else {
            format!("{:.1e}", 10f64.powf(v))
        }
    } else if v != 0.0 && (v.abs() >= 1e4 || v.abs() < 1e-2) {
        format!("{v:.1e}")
    } else {
        format!("{v:.3}")
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_owned()
    }
}

fn to_axis(v: f64, log: bool) -> Option<f64> {
    if !v.is_finite() {
        return None;
    }
    if log {
        (v > 0.0).then(|| v.log10())
    } else {
        Some(v)
    }
}

/// Write the plotted data as CSV: `series,x,y`.
pub fn write_series_csv(path: &Path, series: &[Series]) -> Result<()> {
    let mut w = csv::Writer::from_path(path).with_context(|| format!("{}", path.display()))?;
    w.write_record(["series", "x", "y"])?;
    for s in series {
        for (x, y) in &s.points {
            w.write_record([s.name.clone(), format!("{x:e}"), format!("{y:e}")])?;
        }
    }
    w.flush()?;
    Ok(())
}

/// The chart every plot draws on: linear `f64` axes (log axes plot `log10` of the data).
type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

fn draw_err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("{e:?}")
}

/// Draw `series` to `svg_path` (800×520) and write their data to the same path with `.csv`.
pub fn plot(svg_path: &Path, spec: &PlotSpec, series: &[Series]) -> Result<()> {
    write_series_csv(&svg_path.with_extension("csv"), series)?;
    let mapped: Vec<(&Series, Vec<(f64, f64)>)> = series
        .iter()
        .map(|s| {
            let pts = s
                .points
                .iter()
                .filter_map(|&(x, y)| Some((to_axis(x, spec.log_x)?, to_axis(y, spec.log_y)?)))
                .collect();
            (s, pts)
        })
        .collect();
    let (x0, x1, y0, y1) = axis_ranges(spec, &mapped);
    let keys: Vec<&str> = series.iter().map(|s| s.color_key.as_str()).collect();
    let styles = crate::report::palette::styles(&keys);
    let legend: Vec<(&Series, Style)> = series
        .iter()
        .zip(&styles)
        .filter(|(s, _)| !s.name.is_empty() && s.mark != Mark::Secondary)
        .map(|(s, st)| (s, *st))
        .collect();
    let secondary = series.iter().any(|s| s.mark == Mark::Secondary);
    // The legend panel right of the data: one line per entry (and one for the second marker).
    let lines = legend.len() + usize::from(secondary);
    let height = (540).max(60 + 18 * lines as u32);
    let root = SVGBackend::new(svg_path, (LEGEND_W + 640, height)).into_drawing_area();
    root.fill(&WHITE).map_err(draw_err)?;
    let (area, panel) = root.split_horizontally(640);
    let area = area.shrink((0, 0), (640, 540));
    let mut chart = ChartBuilder::on(&area)
        .caption(&spec.title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(draw_err)?;
    let (lx, ly) = (spec.log_x, spec.log_y);
    chart
        .configure_mesh()
        .x_desc(&spec.x_label)
        .y_desc(&spec.y_label)
        .x_label_formatter(&|v| tick_label(*v, lx))
        .y_label_formatter(&|v| tick_label(*v, ly))
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(draw_err)?;
    for ((s, pts), style) in mapped.iter().zip(&styles) {
        if !pts.is_empty() {
            draw_one(&mut chart, s, *style, pts, x1)?;
        }
    }
    draw_legend(&panel, &legend, secondary)?;
    root.present().map_err(draw_err)?;
    Ok(())
}

/// Width of the legend panel right of a plot's data area.
const LEGEND_W: u32 = 240;

/// The legend panel: each named series' marker (and line), then its name.
fn draw_legend(
    panel: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    entries: &[(&Series, Style)],
    secondary: bool,
) -> Result<()> {
    let font = ("sans-serif", 14).into_font();
    let mut y = 40;
    for (s, style) in entries {
        let colour = if s.mark == Mark::Reference {
            RGBColor(90, 90, 90)
        } else {
            rgb(style.colour)
        };
        if matches!(
            s.mark,
            Mark::Line | Mark::LinePoints | Mark::Step | Mark::Reference
        ) {
            panel
                .draw(&PathElement::new(
                    vec![(6, y), (30, y)],
                    ShapeStyle::from(&colour).stroke_width(2),
                ))
                .map_err(draw_err)?;
        }
        if matches!(s.mark, Mark::Points | Mark::LinePoints) {
            draw_marker_on(panel, (18, y), style.marker, colour, 5)?;
        }
        let label: String = s.name.chars().take(32).collect();
        panel
            .draw(&Text::new(label, (36, y - 7), font.clone()))
            .map_err(draw_err)?;
        y += 18;
    }
    if secondary {
        draw_marker_on(panel, (18, y), Marker::Cross, BLACK, 4)?;
        panel
            .draw(&Text::new("median of the same run", (36, y - 7), font))
            .map_err(draw_err)?;
    }
    Ok(())
}

/// Draw one marker at a pixel position of a drawing area.
fn draw_marker_on(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    at: (i32, i32),
    marker: Marker,
    colour: RGBColor,
    r: i32,
) -> Result<()> {
    draw_markers(area, &[at], marker, colour, r)
}

/// Draw `marker` at each of `pts` (in the area's coordinates).
fn draw_markers<DB: DrawingBackend, CT: CoordTranslate>(
    area: &DrawingArea<DB, CT>,
    pts: &[CT::From],
    marker: Marker,
    colour: RGBColor,
    r: i32,
) -> Result<()>
where
    CT::From: Clone,
{
    let filled = ShapeStyle::from(&colour).filled();
    let line = ShapeStyle::from(&colour).stroke_width(2);
    let tri = vec![(0, -r), (-r, r), (r, r), (0, -r)];
    let square = [(-r, -r), (r, r)];
    for p in pts {
        let at = || EmptyElement::at(p.clone());
        match marker {
            Marker::Circle => area.draw(&(at() + Circle::new((0, 0), r, filled))),
            Marker::HollowCircle => area.draw(&(at() + Circle::new((0, 0), r, line))),
            Marker::Triangle => area.draw(&(at() + Polygon::new(tri.clone(), filled))),
            Marker::HollowTriangle => area.draw(&(at() + PathElement::new(tri.clone(), line))),
            Marker::Square => area.draw(&(at() + Rectangle::new(square, filled))),
            Marker::HollowSquare => area.draw(&(at() + Rectangle::new(square, line))),
            Marker::Diamond => {
                area.draw(&(at() + Polygon::new(vec![(0, -r), (-r, 0), (0, r), (r, 0)], filled)))
            }
            Marker::Cross => area.draw(
                &(at()
                    + PathElement::new(vec![(-r, -r), (r, r)], line)
                    + PathElement::new(vec![(-r, r), (r, -r)], line)),
            ),
        }
        .map_err(draw_err)?;
    }
    Ok(())
}

/// The x and y ranges (in axis units) covering every shown point with a 5 % margin, or the
/// spec's fixed y range; the unit square when nothing is shown.
fn axis_ranges(spec: &PlotSpec, mapped: &[(&Series, Vec<(f64, f64)>)]) -> (f64, f64, f64, f64) {
    let all: Vec<(f64, f64)> = mapped.iter().flat_map(|(_, p)| p.iter().copied()).collect();
    let (mut x0, mut x1, mut y0, mut y1) = all.iter().fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), &(x, y)| (a.min(x), b.max(x), c.min(y), d.max(y)),
    );
    if all.is_empty() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    if let Some((lo, hi)) = spec.y_range {
        y0 = to_axis(lo, spec.log_y).unwrap_or(y0);
        y1 = to_axis(hi, spec.log_y).unwrap_or(y1);
    }
    let pad = |a: f64, b: f64| {
        let span = (b - a)
            .abs()
            .max(if a.abs() > 0.0 { a.abs() * 0.1 } else { 1.0 });
        (a - 0.05 * span, b + 0.05 * span)
    };
    let (x0, x1) = pad(x0, x1);
    let (y0, y1) = if spec.y_range.is_some() {
        (y0, y1)
    } else {
        pad(y0, y1)
    };
    (x0, x1, y0, y1)
}

/// Draw one series' points (in axis units, not empty) in its mark and style; `x_end` is where
/// a staircase's last step ends. Legends are drawn apart ([`draw_legend`]).
fn draw_one(
    chart: &mut Chart,
    s: &Series,
    style: Style,
    pts: &[(f64, f64)],
    x_end: f64,
) -> Result<()> {
    let color = if s.mark == Mark::Reference {
        RGBColor(90, 90, 90)
    } else {
        rgb(style.colour)
    };
    let line = ShapeStyle::from(&color).stroke_width(2);
    let mark = if pts.len() == 1 && matches!(s.mark, Mark::Line | Mark::Step) {
        Mark::Points
    } else {
        s.mark
    };
    match mark {
        Mark::Line | Mark::Reference => {
            chart
                .draw_series(LineSeries::new(pts.to_vec(), line))
                .map_err(draw_err)?;
        }
        Mark::Step => {
            chart
                .draw_series(LineSeries::new(staircase(pts, x_end), line))
                .map_err(draw_err)?;
        }
        Mark::Points => draw_markers(chart.plotting_area(), pts, style.marker, color, 5)?,
        Mark::LinePoints => {
            chart
                .draw_series(LineSeries::new(pts.to_vec(), line))
                .map_err(draw_err)?;
            draw_markers(chart.plotting_area(), pts, style.marker, color, 4)?;
        }
        Mark::Secondary => draw_markers(chart.plotting_area(), pts, Marker::Cross, color, 3)?,
    }
    Ok(())
}

/// The corners of a staircase through `pts` (not empty), its last step extended to `x_end`.
fn staircase(pts: &[(f64, f64)], x_end: f64) -> Vec<(f64, f64)> {
    let mut stair = Vec::with_capacity(2 * pts.len());
    for (i, &(x, y)) in pts.iter().enumerate() {
        if i > 0 {
            stair.push((x, pts[i - 1].1));
        }
        stair.push((x, y));
    }
    stair.push((x_end, pts[pts.len() - 1].1));
    stair
}

/// Distinct colours of the parts of [`stacked_bars`], in order.
const PHASE_COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// Horizontal stacked bars: one bar per category (top to bottom in the given order), made of
/// one segment per part, the parts in order from the left, each part a colour with a legend
/// entry. `parts[k].1[i]` is part `k`'s length in category `i` (non-finite or negative values
/// count as zero). Writes the SVG (820 wide) and the CSV of the values (`series,x,y`: part,
/// category index, value) next to it.
pub fn stacked_bars(
    svg_path: &Path,
    title: &str,
    x_label: &str,
    categories: &[String],
    parts: &[(String, Vec<f64>)],
) -> Result<()> {
    let series: Vec<Series> = parts
        .iter()
        .map(|(name, values)| Series {
            name: name.clone(),
            color_key: name.clone(),
            points: values
                .iter()
                .enumerate()
                .map(|(i, v)| (i as f64, *v))
                .collect(),
            mark: Mark::Points,
        })
        .collect();
    write_series_csv(&svg_path.with_extension("csv"), &series)?;
    let clean = |v: f64| if v.is_finite() && v > 0.0 { v } else { 0.0 };
    let totals: Vec<f64> = (0..categories.len())
        .map(|i| {
            parts
                .iter()
                .map(|(_, v)| clean(v.get(i).copied().unwrap_or(0.0)))
                .sum()
        })
        .collect();
    let x_max = totals.iter().copied().fold(0.0_f64, f64::max).max(1e-12) * 1.05;
    let n = categories.len().max(1) as f64;
    // Room below the bars for the legend, one line per part.
    let legend_rows = parts.len() as f64 * 0.45 + 0.3;
    let height = (140.0 + 46.0 * (n + legend_rows)).min(2400.0) as u32;
    let root = SVGBackend::new(svg_path, (820, height)).into_drawing_area();
    root.fill(&WHITE).map_err(draw_err)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(20)
        .build_cartesian_2d(0.0..x_max, -legend_rows..n)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_labels(0)
        .x_label_formatter(&|v| tick_label(*v, false))
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(draw_err)?;
    // Each bar's category is written just above it, at the left.
    chart
        .draw_series(categories.iter().enumerate().map(|(i, label)| {
            Text::new(
                label.clone(),
                (0.005 * x_max, n - i as f64 - 0.02),
                ("sans-serif", 13).into_font(),
            )
        }))
        .map_err(draw_err)?;
    for (k, (name, values)) in parts.iter().enumerate() {
        let color = PHASE_COLOURS[k % PHASE_COLOURS.len()];
        let mut rects = Vec::new();
        for i in 0..categories.len() {
            let start: f64 = parts
                .iter()
                .take_while(|(other, _)| other != name)
                .map(|(_, v)| clean(v.get(i).copied().unwrap_or(0.0)))
                .sum();
            let len = clean(values.get(i).copied().unwrap_or(0.0));
            let top = n - i as f64 - 0.3;
            let bottom = n - i as f64 - 0.9;
            rects.push(Rectangle::new(
                [(start, bottom), (start + len, top)],
                ShapeStyle::from(&color).filled(),
            ));
        }
        chart
            .draw_series(rects)
            .map_err(draw_err)?
            .label(name.clone())
            .legend(move |(x, y)| {
                Rectangle::new(
                    [(x, y - 5), (x + 14, y + 5)],
                    ShapeStyle::from(&color).filled(),
                )
            });
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .position(SeriesLabelPosition::LowerRight)
        .draw()
        .map_err(draw_err)?;
    root.present().map_err(draw_err)?;
    Ok(())
}

/// Least-squares slope and intercept of `log10 y` against `log10 x` (positive points only).
pub fn loglog_fit(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .map(|(x, y)| (x.log10(), y.log10()))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx == 0.0 {
        return None;
    }
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let slope = sxy / sxx;
    Some((slope, my - slope * mx))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_recovers_a_power_law() {
        let pts: Vec<(f64, f64)> = [10.0, 20.0, 40.0, 80.0]
            .iter()
            .map(|&x: &f64| (x, 3.0 * x.powf(2.5)))
            .collect();
        let (slope, _) = loglog_fit(&pts).unwrap();
        assert!((slope - 2.5).abs() < 1e-12);
    }

    #[test]
    fn stacked_bars_write_svg_and_csv() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bars.svg");
        let categories = vec!["scene a".to_owned(), "scene b".to_owned()];
        let parts = vec![
            ("collision".to_owned(), vec![1.0, 2.0]),
            ("solve".to_owned(), vec![3.0, f64::NAN]),
        ];
        stacked_bars(&path, "t", "ms", &categories, &parts).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.contains("<svg") && svg.contains("collision") && svg.contains("scene b"));
        let csv = std::fs::read_to_string(path.with_extension("csv")).unwrap();
        assert_eq!(csv.lines().count(), 5);
    }

    #[test]
    fn plot_writes_svg_and_csv() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.svg");
        let series = vec![Series {
            name: "pgs".into(),
            color_key: "pgs".into(),
            points: vec![(1.0, 1e-2), (10.0, 1e-6), (0.0, 1.0)],
            mark: Mark::LinePoints,
        }];
        let spec = PlotSpec {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            log_x: true,
            log_y: true,
            y_range: None,
            legend: LegendAt::default(),
        };
        plot(&path, &spec, &series).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.contains("<svg") && svg.contains("pgs"));
        let csv = std::fs::read_to_string(path.with_extension("csv")).unwrap();
        assert_eq!(csv.lines().count(), 4);
    }
}
