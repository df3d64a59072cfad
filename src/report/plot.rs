//! Plots: figures of season trajectories, learning curves and study reports, as PNG
//! (and, for figures meant for papers, SVG).
//!
//! Drawing uses `plotters` with its bitmap backend and the `ab_glyph` text
//! renderer; the DejaVu Sans font is embedded in the binary and registered
//! once as `"sans-serif"`, so no system font library is needed. The SVG backend writes
//! its text as text, in the viewer's sans-serif. Non-finite
//! values (and magnitudes beyond 1e100) are skipped, leaving gaps in the lines.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use std::sync::OnceLock;

/// DejaVu Sans, embedded so that rendering needs no system fonts.
static FONT: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/DejaVuSans.ttf"
));

/// Figure width in pixels.
const WIDTH: u32 = 1400;
/// Height of one panel row in pixels.
const ROW_HEIGHT: u32 = 260;
/// Height of the figure title strip in pixels.
const TITLE_HEIGHT: u32 = 50;
/// Most panel rows a figure may have (keeps the bitmap bounded).
const MAX_ROWS: usize = 60;
/// Values beyond this magnitude are treated as non-plottable.
const MAX_MAGNITUDE: f64 = 1e100;
/// Width of the legend column right of a panel, in pixels.
const LEGEND_WIDTH: i32 = 160;
/// Line colours, cycled within a panel.
const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// Error raised when a figure cannot be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Drawing or encoding failed for the PNG at `path`.
    #[error("cannot draw {path}: {message}")]
    Draw {
        /// Output file.
        path: String,
        /// What went wrong.
        message: String,
    },
}

/// One line in a panel.
#[derive(Debug, Clone)]
pub struct Line {
    /// Legend label.
    pub label: String,
    /// One value per x; non-finite values leave a gap.
    pub values: Vec<f64>,
}

/// One stacked panel sharing the x axis.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Panel title, e.g. "indoor CO₂".
    pub title: String,
    /// Y axis label, e.g. "ppm".
    pub unit: String,
    /// Lines drawn in the panel.
    pub lines: Vec<Line>,
    /// A shaded band (the soft constraint's [lo, hi]); either side may be infinite (then shade to the panel edge).
    pub band: Option<(f64, f64)>,
    /// Shaded ranges around lines (e.g. the minimum and maximum over scenarios), each in
    /// its line's colour.
    pub spreads: Vec<Spread>,
}

/// A range around one line of a panel, shaded in that line's colour: at each x, from
/// `lower` to `upper` (a non-finite side leaves a gap).
#[derive(Debug, Clone)]
pub struct Spread {
    /// Index of the line in [`Panel::lines`].
    pub line: usize,
    /// Lower edge, one value per x.
    pub lower: Vec<f64>,
    /// Upper edge, one value per x.
    pub upper: Vec<f64>,
}

/// A figure of panels stacked vertically (or in a grid of 2 columns when there are more than 4 panels) over a shared x axis.
#[derive(Debug, Clone)]
pub struct Figure {
    /// Figure title.
    pub title: String,
    /// X axis label, shown under the bottom panels.
    pub x_label: String,
    /// Shared x values.
    pub x: Vec<f64>,
    /// Panels, in reading order.
    pub panels: Vec<Panel>,
}

/// Draws `figure` into a PNG at `path` (width about 1400 px, ~260 px per panel row). NaN/inf values are skipped, not drawn; an all-NaN or empty panel is drawn empty with its title; a constant series gets a sensible non-degenerate y range. Never panics on any data.
///
/// # Examples
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::report::plot::{draw_png, Figure, Line, Panel};
///
/// let hours: Vec<f64> = (0..48).map(|k| k as f64 * 0.5).collect();
/// let temperature: Vec<f64> = hours.iter().map(|h| 15.0 + 5.0 * (h / 24.0 * 6.28).sin()).collect();
/// let mut heating = vec![50.0; 48];
/// heating[10] = f64::NAN; // a gap, not an error
/// let figure = Figure {
///     title: "one day".into(),
///     x_label: "hour".into(),
///     x: hours,
///     panels: vec![
///         Panel {
///             title: "indoor temperature".into(),
///             unit: "°C".into(),
///             lines: vec![Line { label: "temp".into(), values: temperature }],
///             band: Some((10.0, 20.0)),
///             spreads: Vec::new(),
///         },
///         Panel {
///             title: "heating".into(),
///             unit: "W m⁻²".into(),
///             lines: vec![Line { label: "heating".into(), values: heating }],
///             band: None,
///             spreads: Vec::new(),
///         },
///     ],
/// };
/// let dir = std::env::temp_dir().join(format!("ghm-doc-plot-{}", std::process::id()));
/// std::fs::create_dir_all(&dir)?;
/// let path = dir.join("day.png");
/// draw_png(&figure, &path)?;
/// let png = std::fs::read(&path)?;
/// assert_eq!(&png[1..4], b"PNG");
/// let width = u32::from_be_bytes([png[16], png[17], png[18], png[19]]);
/// assert_eq!(width, 1400);
/// std::fs::remove_dir_all(&dir)?;
/// # Ok(())
/// # }
/// ```
pub fn draw_png(figure: &Figure, path: &Path) -> Result<(), PlotError> {
    let root = prepare(path, BitMapBackend::new(path, figure_size(figure, path)?))?;
    draw_figure(&root, figure, path)
}

/// Draws `figure` into an SVG at `path`, laid out as [`draw_png`] lays it out.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::report::plot::{draw_svg, Figure, Line, Panel, Spread};
///
/// let figure = Figure {
///     title: "reward against horizon".into(),
///     x_label: "horizon (h)".into(),
///     x: vec![1.0, 2.0, 3.0],
///     panels: vec![Panel {
///         title: "cumulative reward".into(),
///         unit: "EUR m⁻²".into(),
///         lines: vec![Line { label: "MPC".into(), values: vec![3.1, 3.3, 3.35] }],
///         band: None,
///         spreads: vec![Spread { line: 0, lower: vec![3.0, 3.2, 3.3], upper: vec![3.2, 3.4, 3.4] }],
///     }],
/// };
/// let path = std::env::temp_dir().join(format!("ghm-doc-plot-{}.svg", std::process::id()));
/// draw_svg(&figure, &path)?;
/// let svg = std::fs::read_to_string(&path)?;
/// assert!(svg.starts_with("<svg") && svg.contains("reward against horizon"));
/// std::fs::remove_file(&path)?;
/// # Ok(())
/// # }
/// ```
pub fn draw_svg(figure: &Figure, path: &Path) -> Result<(), PlotError> {
    let root = prepare(path, SVGBackend::new(path, figure_size(figure, path)?))?;
    draw_figure(&root, figure, path)
}

/// The grid of `n` panels: (columns, rows), one column, or two past four panels.
fn grid(n: usize) -> (usize, usize) {
    let cols = if n > 4 { 2 } else { 1 };
    (cols, n.div_ceil(cols).max(1))
}

/// The figure's size in pixels: [`WIDTH`] wide, a row of panels per [`ROW_HEIGHT`].
fn figure_size(figure: &Figure, path: &Path) -> Result<(u32, u32), PlotError> {
    let n = figure.panels.len();
    let (_, rows) = grid(n);
    if rows > MAX_ROWS {
        return Err(fail(path, format!("too many panels ({n})")));
    }
    Ok((WIDTH, TITLE_HEIGHT + ROW_HEIGHT * rows as u32 + 20))
}

/// Draws `figure`'s title and panels (one column, or two past four panels) on `root`.
fn draw_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    figure: &Figure,
    path: &Path,
) -> Result<(), PlotError> {
    let n = figure.panels.len();
    let (cols, rows) = grid(n);
    let body = root
        .margin(10, 0, 0, 0)
        .titled(&figure.title, ("sans-serif", 26))
        .map_err(|e| fail(path, e))?;
    let x_range = range(&figure.x);
    for (i, area) in body.split_evenly((rows, cols)).iter().enumerate() {
        let Some(panel) = figure.panels.get(i) else {
            break;
        };
        let x_label = if i + cols >= n { &figure.x_label } else { "" };
        // Reserve a legend column per grid column so the x axes stay aligned.
        let mut column = figure.panels.iter().skip(i % cols).step_by(cols);
        let legend = column.any(|p| p.lines.len() > 1);
        draw_panel(area, panel, x_label, &figure.x, x_range, legend, path)?;
    }
    root.present().map_err(|e| fail(path, e))
}

/// A simple x–y chart with several lines (learning curves, reward vs horizon): same rules.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::report::plot::{draw_xy, Line};
///
/// let episodes = [1.0, 2.0, 3.0, 4.0];
/// let lines = [
///     Line { label: "train".into(), values: vec![-3.0, -2.0, -1.5, -1.2] },
///     Line { label: "eval".into(), values: vec![f64::NAN, -2.2, f64::NAN, -1.3] },
/// ];
/// let path = std::env::temp_dir().join(format!("ghm-doc-curve-{}.png", std::process::id()));
/// draw_xy("learning curve", "episode", "reward", &episodes, &lines, &path)?;
/// let png = std::fs::read(&path)?;
/// assert_eq!(u32::from_be_bytes([png[16], png[17], png[18], png[19]]), 1000); // width
/// assert_eq!(u32::from_be_bytes([png[20], png[21], png[22], png[23]]), 600); // height
/// std::fs::remove_file(&path)?;
/// # Ok(())
/// # }
/// ```
pub fn draw_xy(
    title: &str,
    x_label: &str,
    y_label: &str,
    x: &[f64],
    lines: &[Line],
    path: &Path,
) -> Result<(), PlotError> {
    let root = prepare(path, BitMapBackend::new(path, (1000, 600)))?;
    let panel = Panel {
        title: title.to_string(),
        unit: y_label.to_string(),
        lines: lines.to_vec(),
        band: None,
        spreads: Vec::new(),
    };
    let legend = lines.len() > 1;
    draw_panel(&root, &panel, x_label, x, range(x), legend, path)?;
    root.present().map_err(|e| fail(path, e))
}

/// Converts any error into a [`PlotError`] naming `path`.
fn fail(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Registers the embedded font (once) and clears `backend` (writing to `path`) to white.
fn prepare<DB: DrawingBackend>(
    path: &Path,
    backend: DB,
) -> Result<DrawingArea<DB, Shift>, PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_ok()
    });
    if !ok {
        return Err(fail(path, "embedded font is invalid"));
    }
    let root = backend.into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(path, e))?;
    Ok(root)
}

/// Whether `v` can be placed on an axis.
fn plottable(v: f64) -> bool {
    v.is_finite() && v.abs() < MAX_MAGNITUDE
}

/// A padded, non-degenerate axis range covering the plottable `values`.
fn range<'a>(values: impl IntoIterator<Item = &'a f64>) -> (f64, f64) {
    let (lo, hi) = (values.into_iter().copied())
        .filter(|v| plottable(*v))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return (0.0, 1.0);
    }
    let magnitude = lo.abs().max(hi.abs());
    if hi - lo < (magnitude * 1e-6).max(1e-9) {
        let mid = 0.5 * (lo + hi);
        let pad = (magnitude * 0.05).max(0.5);
        return (mid - pad, mid + pad);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
}

/// Splits the plottable (x, y) pairs into contiguous runs separated by skipped values.
fn segments(x: &[f64], y: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let pairs: Vec<(f64, f64)> = x.iter().copied().zip(y.iter().copied()).collect();
    let runs = pairs.split(|&(a, b)| !(plottable(a) && plottable(b)));
    runs.filter(|r| !r.is_empty()).map(<[_]>::to_vec).collect()
}

/// The contiguous runs of (x, lower, upper) where all three are plottable.
fn spread_runs(x: &[f64], spread: &Spread) -> Vec<Vec<(f64, f64, f64)>> {
    let triples: Vec<(f64, f64, f64)> = x
        .iter()
        .zip(spread.lower.iter().zip(&spread.upper))
        .map(|(&a, (&lo, &hi))| (a, lo, hi))
        .collect();
    let runs = triples.split(|&(a, lo, hi)| !(plottable(a) && plottable(lo) && plottable(hi)));
    runs.filter(|r| !r.is_empty()).map(<[_]>::to_vec).collect()
}

/// Formats an axis tick compactly (no trailing zeros, scientific when extreme).
fn tick(v: &f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        return format!("{v:.2e}");
    }
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

/// Draws one panel (title, band, lines) into `area`, with its legend in a right-hand column when `legend`.
fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
    x_label: &str,
    x: &[f64],
    (x_lo, x_hi): (f64, f64),
    legend: bool,
    path: &Path,
) -> Result<(), PlotError> {
    let width = area.dim_in_pixel().0 as i32;
    let (area, legend_area) = area.split_horizontally(if legend {
        (width - LEGEND_WIDTH).max(0)
    } else {
        width
    });
    let band_edges: Vec<f64> = panel.band.iter().flat_map(|&(lo, hi)| [lo, hi]).collect();
    let (y_lo, y_hi) = range(
        panel
            .lines
            .iter()
            .flat_map(|l| &l.values)
            .chain(&band_edges)
            .chain(
                panel
                    .spreads
                    .iter()
                    .flat_map(|s| s.lower.iter().chain(&s.upper)),
            ),
    );
    let mut chart = ChartBuilder::on(&area)
        .caption(&panel.title, ("sans-serif", 20))
        .margin(8)
        .margin_right(20)
        .x_label_area_size(if x_label.is_empty() { 25 } else { 45 })
        .y_label_area_size(80)
        .build_cartesian_2d(x_lo..x_hi, y_lo..y_hi)
        .map_err(|e| fail(path, e))?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(&panel.unit)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .axis_desc_style(("sans-serif", 16))
        .label_style(("sans-serif", 14))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .draw()
        .map_err(|e| fail(path, e))?;
    if let Some((lo, hi)) = panel.band {
        let (lo, hi) = (lo.max(y_lo), hi.min(y_hi));
        if lo < hi {
            let fill = RGBColor(60, 170, 60).mix(0.15).filled();
            let band = Rectangle::new([(x_lo, lo), (x_hi, hi)], fill);
            chart
                .draw_series(std::iter::once(band))
                .map_err(|e| fail(path, e))?;
        }
    }
    for spread in &panel.spreads {
        let color = PALETTE[spread.line % PALETTE.len()];
        for run in spread_runs(x, spread) {
            // The upper edge left to right, the lower edge back: one closed polygon.
            let outline: Vec<(f64, f64)> = run
                .iter()
                .map(|&(a, _, hi)| (a, hi))
                .chain(run.iter().rev().map(|&(a, lo, _)| (a, lo)))
                .collect();
            let shade = Polygon::new(outline, color.mix(0.18).filled());
            chart
                .draw_series(std::iter::once(shade))
                .map_err(|e| fail(path, e))?;
        }
    }
    // Thick strokes over dense data look ragged; thin lines stay crisp.
    let plot_width = chart.plotting_area().dim_in_pixel().0 as usize;
    let stroke = if x.len() * 4 > plot_width { 1 } else { 2 };
    for (i, line) in panel.lines.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        for run in segments(x, &line.values) {
            if let [(a, b)] = run[..] {
                let dot = Circle::new((a, b), 3, color.filled());
                chart
                    .draw_series(std::iter::once(dot))
                    .map_err(|e| fail(path, e))?;
            } else {
                let series = LineSeries::new(run, color.stroke_width(stroke));
                chart.draw_series(series).map_err(|e| fail(path, e))?;
            }
        }
        if legend && panel.lines.len() > 1 {
            let y = 45 + 22 * i as i32;
            let key = PathElement::new([(4, y), (28, y)], color.stroke_width(3));
            legend_area.draw(&key).map_err(|e| fail(path, e))?;
            let font = ("sans-serif", 14)
                .into_font()
                .into_text_style(&legend_area)
                .pos(Pos::new(HPos::Left, VPos::Center));
            let text = Text::new(line.label.as_str(), (34, y), font);
            legend_area.draw(&text).map_err(|e| fail(path, e))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> std::path::PathBuf {
        let file = format!("ghm_plot_{}_{name}.png", std::process::id());
        std::env::temp_dir().join(file)
    }

    /// The file at `path` is a PNG of `width` × `height` pixels (signature, then the IHDR
    /// chunk's size fields); removes it.
    fn check_png(path: &Path, (width, height): (u32, u32)) {
        let bytes = std::fs::read(path).unwrap();
        let _ = std::fs::remove_file(path);
        assert!(bytes.len() > 24, "{} bytes", bytes.len());
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(&bytes[12..16], b"IHDR");
        let field = |at: usize| {
            u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
        };
        assert_eq!((field(16), field(20)), (width, height), "width, height");
    }

    /// Pixel size of a [`draw_png`] figure of `rows` panel rows (title strip, rows, margin).
    fn figure_size(rows: u32) -> (u32, u32) {
        (1400, 50 + 260 * rows + 20)
    }

    /// Pixel size of a [`draw_xy`] chart.
    const XY_SIZE: (u32, u32) = (1000, 600);

    fn line(label: &str, values: Vec<f64>) -> Line {
        let label = label.into();
        Line { label, values }
    }

    fn panel(title: &str, unit: &str, lines: Vec<Line>, band: Option<(f64, f64)>) -> Panel {
        let (title, unit) = (title.into(), unit.into());
        Panel {
            title,
            unit,
            lines,
            band,
            spreads: Vec::new(),
        }
    }

    /// A 4-panel season of `n` quarter-hour steps with a gap and three kinds of band.
    fn season(n: usize) -> Figure {
        let x: Vec<f64> = (0..n).map(|i| i as f64 / 96.0).collect();
        let wave = |a: f64, b: f64, p: f64| x.iter().map(|t| a + b * (t * p).sin()).collect();
        let mut co2: Vec<f64> = wave(700.0, 250.0, 6.3);
        co2[100.min(n)..140.min(n)].fill(f64::NAN);
        let co2 = vec![line("CO₂", co2)];
        let (t_in, t_out) = (wave(18.0, 4.0, 6.3), wave(8.0, 6.0, 6.0));
        let temps = vec![line("indoor", t_in), line("outdoor", t_out)];
        let (supply, heat) = (wave(0.5, 0.5, 3.0), wave(40.0, 30.0, 2.0));
        let controls = vec![line("CO₂ supply", supply), line("heating", heat)];
        let rh = vec![line("RH", wave(75.0, 12.0, 5.0))];
        let panels = vec![
            panel("indoor CO₂", "ppm", co2, Some((400.0, 1e3))),
            panel("air temperature", "°C", temps, Some((10.0, f64::INFINITY))),
            panel("humidity", "%", rh, Some((f64::NEG_INFINITY, 85.0))),
            panel("controls", "g m⁻² s⁻¹ / W m⁻²", controls, None),
        ];
        let (title, x_label) = ("Season — lettuce".into(), "time [d]".into());
        Figure {
            title,
            x_label,
            x,
            panels,
        }
    }

    #[test]
    fn draws_four_panel_season() {
        let path = temp("season");
        draw_png(&season(1920), &path).unwrap();
        check_png(&path, figure_size(4));
    }

    /// Degenerate data (empty, all-NaN, constant, a single point, infinities, a range far
    /// below the values' magnitude) is drawn, not refused: every figure comes out at its
    /// full size. More than four panels go into two columns.
    #[test]
    fn degenerate_data_is_drawn() {
        let nan = f64::NAN;
        let cases: Vec<(Vec<f64>, Vec<f64>)> = vec![
            (vec![], vec![]),
            (vec![0.0, 1.0, 2.0], vec![nan; 3]),
            (vec![0.0, 1.0, 2.0], vec![5.0; 3]),
            (vec![3.0], vec![7.0]),
            (vec![nan, f64::INFINITY], vec![1e300, -f64::INFINITY]),
            (vec![0.0, 1.0], vec![1e10, 1e10 + 1e-6]),
        ];
        for (i, (x, y)) in cases.into_iter().enumerate() {
            let path = temp(&format!("degenerate{i}"));
            let lines = vec![line("a", y), line("b", vec![])];
            let panels = vec![
                panel("p", "", lines.clone(), Some((nan, 1.0))),
                panel("", "", vec![], None),
            ];
            let (title, x_label, x) = (String::new(), String::new(), x.clone());
            let figure = Figure {
                title,
                x_label,
                x,
                panels,
            };
            let drawn = draw_png(&figure, &path);
            assert!(drawn.is_ok(), "case {i}: {drawn:?}");
            check_png(&path, figure_size(2));
            let drawn = draw_xy("", "", "", &figure.x, &lines, &path);
            assert!(drawn.is_ok(), "case {i}: {drawn:?}");
            check_png(&path, XY_SIZE);
        }
        let mut grid = season(200);
        grid.panels.extend(grid.panels[..2].to_vec());
        let path = temp("grid");
        draw_png(&grid, &path).unwrap();
        check_png(&path, figure_size(3));
        grid.panels.clear();
        draw_png(&grid, &path).unwrap();
        check_png(&path, figure_size(1));
        let bad = std::env::temp_dir().join("ghm_no_such_dir/x.png");
        assert!(matches!(draw_png(&grid, &bad), Err(PlotError::Draw { .. })));
    }

    fn learning_curve(path: &Path) -> Result<(), PlotError> {
        let x: Vec<f64> = (1..=50).map(f64::from).collect();
        let train = line("train", x.iter().map(|e| -100.0 / e).collect());
        let eval = line("eval", x.iter().map(|e| -120.0 / e - 2.0).collect());
        let y_label = "reward [€ m⁻²]";
        draw_xy(
            "learning curve",
            "episode",
            y_label,
            &x,
            &[train, eval],
            path,
        )
    }

    #[test]
    fn draws_xy_with_two_lines() {
        let path = temp("xy");
        learning_curve(&path).unwrap();
        check_png(&path, XY_SIZE);
    }
}
