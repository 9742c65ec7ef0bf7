//! Line charts written as SVG and PNG files.
//!
//! A [`Chart`] holds one or more [`Series`] of `(x, y)` points plus optional
//! labelled vertical marker lines. [`write_chart`] validates the chart, picks
//! axis ranges automatically, and writes `<stem>.svg` and `<stem>.png`, each
//! atomically. Text is rendered with the DejaVu Sans font embedded from the
//! `dejavu` crate, so no system fonts or font libraries are needed.

use std::ffi::OsString;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Width of the rendered chart in pixels.
pub const WIDTH: u32 = 1000;

/// Height of the rendered chart in pixels.
pub const HEIGHT: u32 = 650;

/// Font family name under which the embedded font is registered.
const FONT_FAMILY: &str = "sans-serif";

/// Distinguishable colours (the Tableau 10 palette), used in order and then reused.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Colour of vertical marker lines and their labels.
const VLINE_COLOUR: RGBColor = RGBColor(60, 60, 60);

/// How the points of a series are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SeriesStyle {
    /// The points are joined by straight line segments, without markers.
    #[default]
    Line,
    /// Each point is drawn as a filled circular marker, without joining lines.
    Points,
    /// The points are joined by line segments and each one also gets a marker.
    LineAndPoints,
    /// The points are joined by dashed line segments; a NaN y value breaks
    /// the line (one series may hold several dashed pieces).
    Dashed,
    /// As [`SeriesStyle::Line`], but a NaN y value breaks the line.
    Broken,
}

/// One line (or set of markers) in a chart.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// The name shown for this series in the legend.
    pub label: String,
    /// The x coordinates of the points, in drawing order.
    pub x: Vec<f64>,
    /// The y coordinates of the points; it must have the same length as `x`.
    pub y: Vec<f64>,
    /// How the points are drawn; the default is a plain line.
    pub style: SeriesStyle,
}

impl Series {
    /// Creates a line series with the given label and coordinates.
    pub fn new(label: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Self { label: label.into(), x, y, style: SeriesStyle::Line }
    }

    /// Returns this series with its drawing style replaced by `style`.
    pub fn with_style(mut self, style: SeriesStyle) -> Self {
        self.style = style;
        self
    }
}

/// A chart with a title, axis labels, data series and optional vertical markers.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Chart {
    /// The title drawn above the plot area.
    pub title: String,
    /// The caption of the horizontal axis.
    pub x_label: String,
    /// The caption of the vertical axis.
    pub y_label: String,
    /// The data series; at least one of them must contain a point.
    pub series: Vec<Series>,
    /// Vertical marker lines, each given as an x position and a label drawn beside it.
    pub vlines: Vec<(f64, String)>,
}

/// An error that prevented a chart from being written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The chart has no series, or none of its series contains a point.
    #[error("chart has no data points to plot")]
    EmptyChart,
    /// A series has a different number of x and y values.
    #[error("series '{series}' has {x_len} x values but {y_len} y values")]
    LengthMismatch {
        /// The label of the offending series.
        series: String,
        /// The number of x values in the series.
        x_len: usize,
        /// The number of y values in the series.
        y_len: usize,
    },
    /// A series contains a NaN or infinite coordinate.
    #[error("series '{series}' has a non-finite {axis} value ({value}) at index {index}")]
    NonFinite {
        /// The label of the offending series.
        series: String,
        /// The axis of the offending coordinate, either `"x"` or `"y"`.
        axis: &'static str,
        /// The position of the offending point within the series.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// A vertical marker line has a NaN or infinite x position.
    #[error("vertical marker '{label}' (index {index}) has a non-finite position ({value})")]
    NonFiniteMarker {
        /// The label of the offending marker line.
        label: String,
        /// The position of the offending marker within `Chart::vlines`.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// The data on one axis spans a range too wide to represent as an `f64`.
    #[error("the {axis} values span a range too wide to plot")]
    RangeTooLarge {
        /// The affected axis, either `"x"` or `"y"`.
        axis: &'static str,
    },
    /// The output stem has no file name component, so no file name can be derived from it.
    #[error("output path stem '{}' has no file name", path.display())]
    InvalidStem {
        /// The rejected stem.
        path: PathBuf,
    },
    /// Reading or writing a file failed.
    #[error("I/O error on '{}': {source}", path.display())]
    Io {
        /// The file that was being created, written or renamed.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The plotting backend or the embedded font reported an error.
    #[error("plotting backend error: {0}")]
    Backend(String),
}

/// Writes `<stem>.svg` and `<stem>.png` (1000x650 pixels) and returns their paths, SVG first.
///
/// The extensions are appended to `stem`, so a stem such as `out/run.v2` gives
/// `out/run.v2.svg`. Each file is first written to a temporary file in the same
/// directory and then renamed into place, so a reader never sees a partial file.
/// The chart is validated before anything is written: it must contain at least
/// one point, every series must have as many x values as y values, and every
/// coordinate and marker position must be finite.
pub fn write_chart(chart: &Chart, stem: &Path) -> Result<Vec<PathBuf>, PlotError> {
    validate(chart)?;
    if stem.file_name().is_none() {
        return Err(PlotError::InvalidStem { path: stem.to_path_buf() });
    }
    ensure_font()?;
    let (x_range, y_range) = axis_ranges(chart)?;

    let svg_path = with_suffix(stem, ".svg");
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, chart, &x_range, &y_range)?;
        root.present().map_err(backend_err)?;
    }
    write_atomic(&svg_path, svg.as_bytes())?;

    let png_path = with_suffix(stem, ".png");
    write_png_atomic(&png_path, |tmp| {
        let root = BitMapBackend::new(tmp, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, chart, &x_range, &y_range)?;
        root.present().map_err(backend_err)
    })?;

    Ok(vec![svg_path, png_path])
}

/// Checks the chart for emptiness, length mismatches and non-finite values.
fn validate(chart: &Chart) -> Result<(), PlotError> {
    for s in &chart.series {
        if s.x.len() != s.y.len() {
            return Err(PlotError::LengthMismatch {
                series: s.label.clone(),
                x_len: s.x.len(),
                y_len: s.y.len(),
            });
        }
        for (axis, values) in [("x", &s.x), ("y", &s.y)] {
            // A dashed series breaks its line at NaN y values (and only there).
            let breaks = matches!(s.style, SeriesStyle::Dashed | SeriesStyle::Broken);
            let allowed = |v: f64| v.is_finite() || (breaks && axis == "y" && v.is_nan());
            if let Some((index, &value)) = values.iter().enumerate().find(|(_, v)| !allowed(**v)) {
                return Err(PlotError::NonFinite { series: s.label.clone(), axis, index, value });
            }
        }
    }
    for (index, (value, label)) in chart.vlines.iter().enumerate() {
        if !value.is_finite() {
            return Err(PlotError::NonFiniteMarker { label: label.clone(), index, value: *value });
        }
    }
    if chart.series.iter().all(|s| s.x.is_empty()) {
        return Err(PlotError::EmptyChart);
    }
    Ok(())
}

/// Registers the embedded font with plotters once per process and reports whether that worked.
fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, dejavu::sans::regular()).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Backend("the embedded DejaVu Sans font could not be loaded".to_string()))
    }
}

/// Converts a plotters drawing error into a [`PlotError::Backend`].
fn backend_err<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
    PlotError::Backend(e.to_string())
}

/// Returns `stem` with `suffix` appended to its last component.
fn with_suffix(stem: &Path, suffix: &str) -> PathBuf {
    let mut s: OsString = stem.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// Computes the x and y axis ranges, with a margin, covering all points and marker lines.
fn axis_ranges(chart: &Chart) -> Result<(Range<f64>, Range<f64>), PlotError> {
    let xs =
        chart.series.iter().flat_map(|s| s.x.iter().copied()).chain(chart.vlines.iter().map(|(x, _)| *x));
    let ys = chart.series.iter().flat_map(|s| s.y.iter().copied());
    let x = padded_range(xs).ok_or(PlotError::RangeTooLarge { axis: "x" })?;
    let y = padded_range(ys).ok_or(PlotError::RangeTooLarge { axis: "y" })?;
    Ok((x, y))
}

/// Spans smaller than this (in absolute terms) are treated as a constant value.
const MIN_SPAN: f64 = 1e-200;

/// Spans smaller than this fraction of the largest magnitude are treated as a constant value.
const MIN_RELATIVE_SPAN: f64 = 1e-12;

/// Returns the span of `values` widened by 5% on each side, or a non-zero span around a constant.
///
/// The result always has `start < end` and a finite width, and contains every value.
/// It returns `None` when the values are so far apart that the width of the range
/// overflows `f64`. An empty iterator gives `0.0..1.0`.
fn padded_range(values: impl Iterator<Item = f64>) -> Option<Range<f64>> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !(lo.is_finite() && hi.is_finite()) {
        return Some(0.0..1.0);
    }
    let span = hi - lo;
    if !span.is_finite() {
        return None;
    }
    let max_abs = lo.abs().max(hi.abs());
    let margin = if span >= MIN_SPAN && span >= max_abs * MIN_RELATIVE_SPAN {
        span * 0.05
    } else if max_abs >= MIN_SPAN {
        // A (numerically) constant series: show it in the middle of a +-10% band.
        max_abs * 0.1
    } else {
        1.0
    };
    // Shrink the margin if it would push the width of the range past f64::MAX.
    for m in [margin, margin / 2.0, 0.0] {
        let start = (lo - m).max(f64::MIN);
        let end = (hi + m).min(f64::MAX);
        if start < end && (end - start).is_finite() {
            return Some(start..end);
        }
    }
    None
}

/// Formats a tick value with a precision suited to the axis range it belongs to.
///
/// Axes with large magnitudes or very fine tick spacing use scientific notation
/// (`2.5e7`); the others use fixed notation with just enough decimals (`0.15`).
fn format_tick(v: f64, range: &Range<f64>) -> String {
    // Plotters places at most ten ticks, so their spacing is at least `step`.
    let step = (range.end - range.start) / 10.0;
    let step_exp = if step > 0.0 && step.is_finite() { (step.log10() + 1e-9).floor() } else { 0.0 };
    let max_abs = range.start.abs().max(range.end.abs());
    if v == 0.0 {
        return "0".to_string();
    }
    if max_abs >= 1e6 || step < 1e-3 {
        let v_exp = v.abs().log10().floor();
        let decimals = (v_exp - step_exp).clamp(0.0, 16.0) as usize;
        return trim_scientific(&format!("{v:.decimals$e}"));
    }
    let decimals = (-step_exp).clamp(0.0, 8.0) as usize;
    let s = format!("{v:.decimals$}");
    if s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        // Avoid printing "-0" or "-0.00".
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// Removes trailing zeros from the mantissa of a number in `{:e}` format.
fn trim_scientific(s: &str) -> String {
    match s.split_once('e') {
        Some((mantissa, exponent)) if mantissa.contains('.') => {
            let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
            format!("{mantissa}e{exponent}")
        }
        _ => s.to_string(),
    }
}

/// Returns the palette colour for the series at `index`.
fn colour(index: usize) -> RGBColor {
    PALETTE[index % PALETTE.len()]
}

/// Draws the whole chart onto a drawing area of any backend.
fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    chart: &Chart,
    x_range: &Range<f64>,
    y_range: &Range<f64>,
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(backend_err)?;

    let mut ctx = ChartBuilder::on(root)
        .caption(&chart.title, (FONT_FAMILY, 28).into_font())
        .margin(20)
        .x_label_area_size(60)
        .y_label_area_size(95)
        .build_cartesian_2d(x_range.clone(), y_range.clone())
        .map_err(backend_err)?;

    let y_span = y_range.end - y_range.start;
    let x_fmt = |v: &f64| format_tick(*v, x_range);
    let y_fmt = |v: &f64| format_tick(*v, y_range);
    ctx.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .x_labels(10)
        .y_labels(10)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .label_style((FONT_FAMILY, 16).into_font())
        .axis_desc_style((FONT_FAMILY, 20).into_font())
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(205, 205, 205))
        .draw()
        .map_err(backend_err)?;

    for (i, (x, label)) in chart.vlines.iter().enumerate() {
        let style = VLINE_COLOUR.stroke_width(1);
        ctx.draw_series(DashedLineSeries::new([(*x, y_range.start), (*x, y_range.end)], 8, 5, style))
            .map_err(backend_err)?;
        if !label.is_empty() {
            // Stagger labels vertically so that nearby markers do not overlap completely.
            let y = y_range.end - y_span * (0.02 + 0.045 * (i % 4) as f64);
            let text_style = TextStyle::from((FONT_FAMILY, 15).into_font())
                .color(&VLINE_COLOUR)
                .pos(Pos::new(HPos::Left, VPos::Top));
            ctx.draw_series(std::iter::once(
                EmptyElement::at((*x, y)) + Text::new(label.clone(), (5, 0), text_style),
            ))
            .map_err(backend_err)?;
        }
    }

    for (i, s) in chart.series.iter().enumerate() {
        let c = colour(i);
        let points = s.x.iter().copied().zip(s.y.iter().copied());
        let line_style = c.stroke_width(2);
        let marker_style = c.filled();
        let style = s.style;
        let label = s.label.clone();
        let has_line = matches!(style, SeriesStyle::Line | SeriesStyle::LineAndPoints);
        let has_points = matches!(style, SeriesStyle::Points | SeriesStyle::LineAndPoints);

        if matches!(style, SeriesStyle::Dashed | SeriesStyle::Broken) {
            let xy: Vec<(f64, f64)> = points.clone().collect();
            let mut labelled = false;
            for piece in xy.split(|(_, y)| y.is_nan()).filter(|p| !p.is_empty()) {
                let it = piece.iter().copied();
                let anno = if style == SeriesStyle::Dashed {
                    ctx.draw_series(DashedLineSeries::new(it, 8, 5, line_style)).map_err(backend_err)?
                } else {
                    ctx.draw_series(LineSeries::new(it, line_style)).map_err(backend_err)?
                };
                if !labelled {
                    let dashed = style == SeriesStyle::Dashed;
                    anno.label(s.label.clone()).legend(move |(x, y)| {
                        let gap = if dashed { 6 } else { 0 };
                        EmptyElement::at((x, y))
                            + PathElement::new(vec![(0, 0), (8, 0)], line_style)
                            + PathElement::new(vec![(8 + gap, 0), (24, 0)], line_style)
                    });
                    labelled = true;
                }
            }
        }
        if has_line {
            let anno = ctx.draw_series(LineSeries::new(points.clone(), line_style)).map_err(backend_err)?;
            anno.label(label);
            if has_points {
                anno.legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(0, 0), (24, 0)], line_style)
                        + Circle::new((12, 0), 4, marker_style)
                });
            } else {
                anno.legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], line_style));
            }
        }
        if has_points {
            let anno =
                ctx.draw_series(points.map(|p| Circle::new(p, 3, marker_style))).map_err(backend_err)?;
            if !has_line {
                anno.label(s.label.clone()).legend(move |(x, y)| Circle::new((x + 12, y), 4, marker_style));
            }
        }
    }

    ctx.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .margin(12)
        .legend_area_size(30)
        .label_font((FONT_FAMILY, 16).into_font())
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(160, 160, 160))
        .draw()
        .map_err(backend_err)?;

    Ok(())
}

/// Writes `bytes` to `target` atomically ([`crate::files::write_durable`]).
pub fn write_atomic(target: &Path, bytes: &[u8]) -> Result<(), PlotError> {
    Ok(crate::files::write_durable(target, bytes)?)
}

/// Lets `render` write a PNG to a temporary path (ending in `.png`) and renames it to `target`.
fn write_png_atomic(
    target: &Path,
    render: impl FnOnce(&Path) -> Result<(), PlotError>,
) -> Result<(), PlotError> {
    // The bitmap backend picks the image format from the extension, so keep `.png` last.
    crate::files::write_durable_with(target, ".png", render)
}

impl From<crate::files::FileError> for PlotError {
    fn from(e: crate::files::FileError) -> Self {
        PlotError::Io { path: e.path, source: e.error }
    }
}

#[cfg(test)]
mod tests;
