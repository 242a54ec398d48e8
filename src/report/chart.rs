//! Hand-written SVG line/scatter charts: named series, optional bands and error bars, nice ticks, legend.
//!
//! Coordinates are printed with two decimals and colours come from a fixed palette by series index, so the
//! output is byte-stable. Non-finite points break a line instead of poisoning it; an empty chart still renders
//! its axes and says that there is no data.

use std::fmt::Write;

use super::format::{escape, fmt_num};
use super::ticks::{Ticks, nice_ticks};

/// Colour-blind-safe palette (Okabe–Ito), assigned by series index.
pub const PALETTE: [&str; 8] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#F0E442",
];

const MARGIN_LEFT: f64 = 64.0;
const MARGIN_RIGHT: f64 = 16.0;
const MARGIN_TOP: f64 = 34.0;
const AXIS_BAND: f64 = 44.0;
const LEGEND_ROW: f64 = 18.0;
/// Fraction of the data span added on each side before ticking, so points never sit on the frame.
const PADDING: f64 = 0.04;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    Line,
    Points,
    LineAndPoints,
    /// A dashed line without markers (predictions, fitted curves).
    Dashed,
}

/// One named data series; `band` and `error_bars` hold absolute (low, high) values per point.
#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub mark: Mark,
    pub band: Option<Vec<(f64, f64)>>,
    pub error_bars: Option<Vec<(f64, f64)>>,
    /// A CSS colour; by default the palette colour of the series' index.
    pub color: Option<String>,
}

impl Series {
    pub fn new(name: impl Into<String>, mark: Mark, points: Vec<(f64, f64)>) -> Self {
        Series {
            name: name.into(),
            points,
            mark,
            band: None,
            error_bars: None,
            color: None,
        }
    }

    /// A shaded band (e.g. x̄ − k·s … x̄ + k·s) behind the series, one (low, high) per point.
    pub fn with_band(mut self, low_high: Vec<(f64, f64)>) -> Self {
        self.band = Some(low_high);
        self
    }

    /// Draws the series in `color` (any CSS colour), e.g. to pair a fitted curve with its data.
    pub fn with_color(mut self, color: impl Into<String>) -> Self {
        self.color = Some(color.into());
        self
    }

    /// Vertical error bars, one (low, high) per point.
    pub fn with_error_bars(mut self, low_high: Vec<(f64, f64)>) -> Self {
        self.error_bars = Some(low_high);
        self
    }
}

/// The points of a time series measured in several runs, at most about `max_points` of them: each run's rows
/// in order, rows without a value (NaN: no reading there) left out so a line joins the readings on either
/// side within a run, and a break (a non-finite point) between runs, so no line joins the end of one run to
/// the start of the next. Long series are thinned evenly, every k-th row of each run.
pub fn points_by_run(
    time: &[f64],
    values: &[f64],
    run_starts: &[usize],
    max_points: usize,
) -> Vec<(f64, f64)> {
    let n = time.len().min(values.len());
    let measured = values[..n].iter().filter(|v| !v.is_nan()).count();
    let k = measured.div_ceil(max_points.max(1)).max(1);
    let mut bounds: Vec<usize> = run_starts.iter().copied().filter(|&s| s < n).collect();
    bounds.push(n);
    let mut points = Vec::with_capacity(measured / k + run_starts.len());
    for run in bounds.windows(2) {
        let kept = (run[0]..run[1]).filter(|&i| !values[i].is_nan());
        let mut first = true;
        for i in kept.step_by(k) {
            if first && !points.is_empty() {
                points.push((f64::NAN, f64::NAN));
            }
            first = false;
            points.push((time[i], values[i]));
        }
    }
    points
}

/// A chart: title, axis labels (put units in them), size in px and the series.
#[derive(Debug, Clone)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub width: f64,
    pub height: f64,
    pub series: Vec<Series>,
    /// Labelled vertical reference lines (x, label), e.g. where a holdout window starts.
    pub markers: Vec<(f64, String)>,
}

impl Chart {
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Chart {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            width: 720.0,
            height: 360.0,
            series: Vec::new(),
            markers: Vec::new(),
        }
    }

    pub fn size(mut self, width: f64, height: f64) -> Self {
        self.width = width;
        self.height = height;
        self
    }

    /// A dashed vertical line at `x` with `label` at its top; non-finite `x` is ignored.
    pub fn marker(mut self, x: f64, label: impl Into<String>) -> Self {
        self.markers.push((x, label.into()));
        self
    }

    pub fn series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    /// Renders the chart as one `<svg>` element.
    pub fn to_svg(&self) -> String {
        let legend = self.legend_layout();
        let legend_rows = legend.iter().map(|item| item.row + 1).max().unwrap_or(0);
        let plot = Frame {
            left: MARGIN_LEFT,
            top: MARGIN_TOP,
            right: self.width - MARGIN_RIGHT,
            bottom: self.height - AXIS_BAND - legend_rows as f64 * LEGEND_ROW,
        };
        let (x_axis, y_axis) = self.axes();
        let scale = Scale::new(&plot, &x_axis, &y_axis);

        let mut svg = String::new();
        let _ = write!(
            svg,
            r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {w} {h}" width="{w}" height="{h}" font-family="sans-serif" font-size="12" role="img" aria-label="{title}">"#,
            w = fmt_num(self.width, 0),
            h = fmt_num(self.height, 0),
            title = escape(&self.title),
        );
        svg.push('\n');
        let _ = writeln!(svg, "<title>{}</title>", escape(&self.title));
        let _ = writeln!(
            svg,
            r##"<rect x="0" y="0" width="{}" height="{}" fill="#ffffff"/>"##,
            fmt_num(self.width, 0),
            fmt_num(self.height, 0)
        );
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="20" text-anchor="middle" font-size="14" font-weight="bold">{}</text>"#,
            c(self.width / 2.0),
            escape(&self.title)
        );
        self.write_axes(&mut svg, &plot, &scale, &x_axis.ticks, &y_axis.ticks);
        let _ = writeln!(
            svg,
            r#"<clipPath id="{id}"><rect x="{}" y="{}" width="{}" height="{}"/></clipPath>"#,
            c(plot.left),
            c(plot.top),
            c(plot.right - plot.left),
            c(plot.bottom - plot.top),
            id = self.clip_id(),
        );
        let _ = writeln!(svg, r#"<g clip-path="url(#{})">"#, self.clip_id());
        for (index, series) in self.series.iter().enumerate() {
            write_series(&mut svg, series, series_color(series, index), &scale);
        }
        for (x, label) in self.markers.iter().filter(|(x, _)| x.is_finite()) {
            let px = c(scale.x(*x));
            let _ = writeln!(
                svg,
                r##"<line x1="{px}" y1="{}" x2="{px}" y2="{}" stroke="#555555" stroke-dasharray="3 3"/>"##,
                c(plot.top),
                c(plot.bottom)
            );
            let _ = writeln!(
                svg,
                r##"<text x="{}" y="{}" fill="#555555">{}</text>"##,
                c(scale.x(*x) + 4.0),
                c(plot.top + 14.0),
                escape(label)
            );
        }
        svg.push_str("</g>\n");
        if !self.has_data() {
            let _ = writeln!(
                svg,
                r##"<text x="{}" y="{}" text-anchor="middle" fill="#666666">no data</text>"##,
                c((plot.left + plot.right) / 2.0),
                c((plot.top + plot.bottom) / 2.0)
            );
        }
        let legend_top = self.height - legend_rows as f64 * LEGEND_ROW;
        for item in &legend {
            write_legend_item(&mut svg, item, &self.series[item.series], legend_top);
        }
        svg.push_str("</svg>\n");
        svg
    }

    /// Clip-path ids must be unique within one HTML page; derive one from the content so it is stable.
    fn clip_id(&self) -> String {
        let mut hash: u32 = 2_166_136_261;
        let size = format!("{}x{}", self.width, self.height);
        let names = self.series.iter().flat_map(|s| s.name.bytes());
        for byte in self
            .title
            .bytes()
            .chain(self.x_label.bytes())
            .chain(self.y_label.bytes())
            .chain(size.bytes())
            .chain(names)
        {
            hash = (hash ^ u32::from(byte)).wrapping_mul(16_777_619);
        }
        format!("plot-{hash:08x}")
    }

    fn has_data(&self) -> bool {
        self.series.iter().any(|s| {
            s.points
                .iter()
                .any(|&(x, y)| x.is_finite() && y.is_finite())
        })
    }

    fn axes(&self) -> (AxisRange, AxisRange) {
        let mut xs = Extent::default();
        let mut ys = Extent::default();
        for (x, _) in &self.markers {
            xs.add(*x);
        }
        for series in &self.series {
            for (i, &(x, y)) in series.points.iter().enumerate() {
                if !x.is_finite() {
                    continue;
                }
                xs.add(x);
                ys.add(y);
                for extra in [&series.band, &series.error_bars].into_iter().flatten() {
                    if let Some(&(low, high)) = extra.get(i) {
                        ys.add(low);
                        ys.add(high);
                    }
                }
            }
        }
        (xs.axis(8), ys.axis(6))
    }

    fn write_axes(
        &self,
        svg: &mut String,
        plot: &Frame,
        scale: &Scale,
        x_ticks: &Ticks,
        y_ticks: &Ticks,
    ) {
        svg.push_str(r##"<g stroke="#dddddd" stroke-width="1">"##);
        svg.push('\n');
        // A vertical line at each x tick, then a horizontal one at each y tick: (x1, y1, x2, y2).
        let vertical = x_ticks.values.iter().map(|&x| {
            let px = scale.x(x);
            (px, plot.top, px, plot.bottom)
        });
        let horizontal = y_ticks.values.iter().map(|&y| {
            let py = scale.y(y);
            (plot.left, py, plot.right, py)
        });
        for (x1, y1, x2, y2) in vertical.chain(horizontal) {
            let (x1, y1, x2, y2) = (c(x1), c(y1), c(x2), c(y2));
            let _ = writeln!(svg, r#"<line x1="{x1}" y1="{y1}" x2="{x2}" y2="{y2}"/>"#);
        }
        svg.push_str("</g>\n");
        let _ = writeln!(
            svg,
            r##"<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#333333"/>"##,
            c(plot.left),
            c(plot.top),
            c(plot.right - plot.left),
            c(plot.bottom - plot.top)
        );
        svg.push_str(r##"<g fill="#333333">"##);
        svg.push('\n');
        for &x in &x_ticks.values {
            let _ = writeln!(
                svg,
                r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
                c(scale.x(x)),
                c(plot.bottom + 16.0),
                fmt_num(x, x_ticks.decimals)
            );
        }
        for &y in &y_ticks.values {
            let _ = writeln!(
                svg,
                r#"<text x="{}" y="{}" text-anchor="end">{}</text>"#,
                c(plot.left - 6.0),
                c(scale.y(y) + 4.0),
                fmt_num(y, y_ticks.decimals)
            );
        }
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            c((plot.left + plot.right) / 2.0),
            c(plot.bottom + 34.0),
            escape(&self.x_label)
        );
        let mid_y = (plot.top + plot.bottom) / 2.0;
        let _ = writeln!(
            svg,
            r#"<text x="16" y="{0}" text-anchor="middle" transform="rotate(-90 16 {0})">{1}</text>"#,
            c(mid_y),
            escape(&self.y_label)
        );
        svg.push_str("</g>\n");
    }

    fn legend_layout(&self) -> Vec<LegendItem> {
        let usable = self.width - MARGIN_LEFT - MARGIN_RIGHT;
        let mut items = Vec::new();
        let (mut row, mut x) = (0, 0.0);
        for (index, series) in self.series.iter().enumerate() {
            // Without font metrics, 7 px per character is a safe over-estimate for 12 px sans-serif.
            let width = 30.0 + 7.0 * series.name.chars().count() as f64;
            if x > 0.0 && x + width > usable {
                row += 1;
                x = 0.0;
            }
            items.push(LegendItem {
                series: index,
                row,
                x: MARGIN_LEFT + x,
            });
            x += width + 12.0;
        }
        items
    }
}

struct LegendItem {
    series: usize,
    row: usize,
    x: f64,
}

fn write_legend_item(svg: &mut String, item: &LegendItem, series: &Series, legend_top: f64) {
    let color = series_color(series, item.series);
    let y = legend_top + item.row as f64 * LEGEND_ROW + 10.0;
    if series.band.is_some() {
        let _ = writeln!(
            svg,
            r#"<rect x="{}" y="{}" width="22" height="10" fill="{color}" fill-opacity="0.18"/>"#,
            c(item.x),
            c(y - 5.0)
        );
    }
    if series.mark != Mark::Points {
        let dash = if series.mark == Mark::Dashed {
            r#" stroke-dasharray="6 4""#
        } else {
            ""
        };
        let _ = writeln!(
            svg,
            r#"<line x1="{}" y1="{2}" x2="{}" y2="{2}" stroke="{color}" stroke-width="2"{dash}/>"#,
            c(item.x),
            c(item.x + 22.0),
            c(y)
        );
    }
    if matches!(series.mark, Mark::Points | Mark::LineAndPoints) {
        let _ = writeln!(
            svg,
            r#"<circle cx="{}" cy="{}" r="3" fill="{color}"/>"#,
            c(item.x + 11.0),
            c(y)
        );
    }
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="{}">{}</text>"#,
        c(item.x + 28.0),
        c(y + 4.0),
        escape(&series.name)
    );
}

fn write_series(svg: &mut String, series: &Series, color: &str, scale: &Scale) {
    if let Some(band) = &series.band {
        for run in finite_runs(&series.points, Some(band)) {
            let mut path = String::new();
            for (k, &i) in run.iter().enumerate() {
                let _ = write!(
                    path,
                    "{}{} {} ",
                    if k == 0 { 'M' } else { 'L' },
                    c(scale.x(series.points[i].0)),
                    c(scale.y(band[i].1))
                );
            }
            for &i in run.iter().rev() {
                let _ = write!(
                    path,
                    "L{} {} ",
                    c(scale.x(series.points[i].0)),
                    c(scale.y(band[i].0))
                );
            }
            let _ = writeln!(
                svg,
                r#"<path d="{}Z" fill="{color}" fill-opacity="0.18" stroke="none"/>"#,
                path
            );
        }
    }
    if series.mark != Mark::Points {
        let dash = if series.mark == Mark::Dashed {
            r#" stroke-dasharray="6 4""#
        } else {
            ""
        };
        for run in finite_runs(&series.points, None) {
            let mut path = String::new();
            for (k, &i) in run.iter().enumerate() {
                let (x, y) = series.points[i];
                let _ = write!(
                    path,
                    "{}{} {}",
                    if k == 0 { "M" } else { " L" },
                    c(scale.x(x)),
                    c(scale.y(y))
                );
            }
            let _ = writeln!(
                svg,
                r#"<path d="{path}" fill="none" stroke="{color}" stroke-width="2"{dash}/>"#
            );
        }
    }
    if let Some(bars) = &series.error_bars {
        for (i, &(x, _)) in series.points.iter().enumerate() {
            let Some(&(low, high)) = bars.get(i) else {
                continue;
            };
            if !(x.is_finite() && low.is_finite() && high.is_finite()) {
                continue;
            }
            let (px, top, bottom) = (scale.x(x), scale.y(high), scale.y(low));
            let _ = writeln!(
                svg,
                r#"<path d="M{a} {top} L{b} {top} M{px} {top} L{px} {bottom} M{a} {bottom} L{b} {bottom}" stroke="{color}" stroke-width="1"/>"#,
                a = c(px - 4.0),
                b = c(px + 4.0),
                px = c(px),
                top = c(top),
                bottom = c(bottom),
            );
        }
    }
    if matches!(series.mark, Mark::Points | Mark::LineAndPoints) {
        for &(x, y) in &series.points {
            if x.is_finite() && y.is_finite() {
                let _ = writeln!(
                    svg,
                    r#"<circle cx="{}" cy="{}" r="3" fill="{color}"/>"#,
                    c(scale.x(x)),
                    c(scale.y(y))
                );
            }
        }
    }
}

fn series_color(series: &Series, index: usize) -> &str {
    series
        .color
        .as_deref()
        .unwrap_or(PALETTE[index % PALETTE.len()])
}

/// Index runs of consecutive points that are finite (and, with a band, whose band is finite too).
fn finite_runs(points: &[(f64, f64)], band: Option<&Vec<(f64, f64)>>) -> Vec<Vec<usize>> {
    let mut runs = Vec::new();
    let mut current = Vec::new();
    for (i, &(x, y)) in points.iter().enumerate() {
        let ok = match band {
            Some(band) => band
                .get(i)
                .is_some_and(|&(l, h)| x.is_finite() && l.is_finite() && h.is_finite()),
            None => x.is_finite() && y.is_finite(),
        };
        if ok {
            current.push(i);
        } else if !current.is_empty() {
            runs.push(std::mem::take(&mut current));
        }
    }
    if !current.is_empty() {
        runs.push(current);
    }
    runs
}

/// SVG coordinate with two decimals.
fn c(value: f64) -> String {
    fmt_num(value, 2)
}

struct Frame {
    left: f64,
    top: f64,
    right: f64,
    bottom: f64,
}

struct Scale {
    x0: f64,
    x_factor: f64,
    px0: f64,
    y0: f64,
    y_factor: f64,
    py0: f64,
}

impl Scale {
    fn new(plot: &Frame, x: &AxisRange, y: &AxisRange) -> Self {
        let (x_lo, x_hi) = (x.lo, x.hi);
        let (y_lo, y_hi) = (y.lo, y.hi);
        Scale {
            x0: x_lo,
            x_factor: (plot.right - plot.left) / (x_hi - x_lo),
            px0: plot.left,
            y0: y_lo,
            y_factor: (plot.bottom - plot.top) / (y_hi - y_lo),
            py0: plot.bottom,
        }
    }

    fn x(&self, value: f64) -> f64 {
        self.px0 + (value - self.x0) * self.x_factor
    }

    fn y(&self, value: f64) -> f64 {
        self.py0 - (value - self.y0) * self.y_factor
    }
}

#[derive(Default)]
struct Extent {
    lo: Option<f64>,
    hi: Option<f64>,
}

impl Extent {
    fn add(&mut self, value: f64) {
        if value.is_finite() {
            self.lo = Some(self.lo.map_or(value, |lo| lo.min(value)));
            self.hi = Some(self.hi.map_or(value, |hi| hi.max(value)));
        }
    }

    /// The data range padded by [`PADDING`] with the nice ticks inside it; a degenerate range (one value,
    /// or none) spans the enclosing ticks instead.
    fn axis(&self, target: usize) -> AxisRange {
        let (lo, hi) = match (self.lo, self.hi) {
            (Some(lo), Some(hi)) if hi > lo => (lo, hi),
            (Some(lo), Some(hi)) => return AxisRange::enclosing(nice_ticks(lo, hi, target)),
            _ => return AxisRange::enclosing(nice_ticks(0.0, 1.0, target)),
        };
        let pad = (hi - lo) * PADDING;
        let (lo, hi) = (lo - pad, hi + pad);
        let mut ticks = nice_ticks(lo, hi, target);
        let tolerance = ticks.step * 1e-9;
        ticks
            .values
            .retain(|&v| v >= lo - tolerance && v <= hi + tolerance);
        AxisRange { lo, hi, ticks }
    }
}

/// The span one axis shows and the ticks labelled on it.
struct AxisRange {
    lo: f64,
    hi: f64,
    ticks: Ticks,
}

impl AxisRange {
    fn enclosing(ticks: Ticks) -> Self {
        let (lo, hi) = ticks.range();
        AxisRange { lo, hi, ticks }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_are_drawn_apart_and_gaps_within_a_run_are_joined() {
        let t = [0.0, 1.0, 2.0, 0.0, 1.0, 2.0];
        let v = [1.0, f64::NAN, 3.0, 4.0, 5.0, f64::NAN];
        let p = points_by_run(&t, &v, &[0, 3], 100);
        assert_eq!(p.len(), 5, "{p:?}");
        assert_eq!((p[0], p[1]), ((0.0, 1.0), (2.0, 3.0)));
        assert!(p[2].0.is_nan(), "a break between the runs: {p:?}");
        assert_eq!((p[3], p[4]), ((0.0, 4.0), (1.0, 5.0)));
        let svg = Chart::new("t", "time in min", "drift in µm")
            .series(Series::new("runs", Mark::Line, p))
            .to_svg();
        assert_eq!(svg.matches("<path d=\"M").count(), 2, "one line per run");
        // A run without a reading adds no break of its own.
        let p = points_by_run(
            &t,
            &[1.0, 2.0, 3.0, f64::NAN, f64::NAN, f64::NAN],
            &[0, 3],
            100,
        );
        assert_eq!(p.len(), 3);
        assert!(p.iter().all(|(x, _)| x.is_finite()));
    }

    #[test]
    fn long_series_are_thinned_without_losing_the_breaks() {
        let t: Vec<f64> = (0..1000).map(|i| f64::from(i % 500)).collect();
        let v: Vec<f64> = (0..1000).map(f64::from).collect();
        let p = points_by_run(&t, &v, &[0, 500], 100);
        assert!(p.len() <= 102, "{}", p.len());
        assert_eq!(p.iter().filter(|(x, _)| x.is_nan()).count(), 1);
        assert_eq!(p[0], (0.0, 0.0));
    }

    fn small_chart() -> Chart {
        Chart::new("Deviation <X> & more", "position in mm", "deviation in µm")
            .size(400.0, 240.0)
            .series(
                Series::new(
                    "plus x̄",
                    Mark::LineAndPoints,
                    vec![(0.0, 1.0), (50.0, 9.0), (100.0, 4.0)],
                )
                .with_band(vec![(-2.0, 4.0), (-1.17, 19.17), (1.0, 7.0)]),
            )
            .series(
                Series::new(
                    "minus",
                    Mark::Points,
                    vec![(0.0, -3.0), (50.0, f64::NAN), (100.0, -6.0)],
                )
                .with_error_bars(vec![(-4.0, -2.0), (f64::NAN, 0.0), (-8.0, -4.0)]),
            )
            .series(Series::new(
                "spline",
                Mark::Dashed,
                vec![(0.0, -1.0), (25.0, 0.5), (50.0, 0.0)],
            ))
    }

    #[test]
    fn small_chart_svg_snapshot() {
        insta::assert_snapshot!(small_chart().to_svg());
    }

    #[test]
    fn nan_breaks_lines_and_never_reaches_the_output() {
        let chart = Chart::new("t", "x", "y").series(Series::new(
            "s",
            Mark::Line,
            vec![
                (0.0, 1.0),
                (1.0, 2.0),
                (2.0, f64::NAN),
                (3.0, 1.0),
                (4.0, 0.0),
            ],
        ));
        let svg = chart.to_svg();
        assert!(!svg.contains("NaN") && !svg.contains("inf"), "{svg}");
        let lines = svg.matches(r##"fill="none" stroke="#0072B2""##).count();
        assert_eq!(lines, 2, "a NaN must split the line in two");
    }

    #[test]
    fn empty_chart_renders_axes_and_says_so() {
        let svg = Chart::new("nothing", "x", "y")
            .series(Series::new("s", Mark::Line, vec![]))
            .to_svg();
        assert!(svg.contains(">no data</text>"));
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(!svg.contains("NaN"));
    }

    #[test]
    fn band_and_error_bars_widen_the_y_range() {
        let svg = Chart::new("t", "x", "y")
            .series(
                Series::new("s", Mark::Points, vec![(0.0, 0.0), (1.0, 1.0)])
                    .with_band(vec![(-50.0, 0.0), (0.0, 1.0)]),
            )
            .to_svg();
        assert!(svg.contains(">-50</text>"), "{svg}");
    }

    #[test]
    fn markers_draw_inside_the_plot_and_widen_the_x_range() {
        let svg = Chart::new("t", "time in min", "µm")
            .series(Series::new("s", Mark::Line, vec![(0.0, 1.0), (100.0, 2.0)]))
            .marker(960.0, "holdout <from>")
            .marker(f64::NAN, "ignored")
            .to_svg();
        assert!(svg.contains(">holdout &lt;from&gt;</text>"), "{svg}");
        assert!(!svg.contains("ignored"));
        assert!(
            svg.contains(">800</text>"),
            "x axis reaches the marker: {svg}"
        );
        assert_eq!(svg.matches(r#"stroke-dasharray="3 3""#).count(), 1);
    }

    #[test]
    fn labels_are_escaped() {
        let svg = small_chart().to_svg();
        assert!(svg.contains("Deviation &lt;X&gt; &amp; more"));
        assert!(!svg.contains("<X>"));
    }
}
