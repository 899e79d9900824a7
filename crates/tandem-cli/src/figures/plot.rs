//! Paper-style figures from plain data (slices of `f64`); no knowledge of the simulator.
//!
//! A figure is a grid of [`Panel`]s. Each panel has a title, axis labels with units, a legend
//! (drawn in a strip above the axes, so it never covers data), any number of line [`Series`],
//! horizontal bound lines (`±k_c`, drawn dashed black) and optionally an equal aspect ratio for
//! XY paths. Every figure is written twice: `<stem>.png` (bitmap) and `<stem>.svg` (vector), each
//! file atomically (temporary file + rename).
//!
//! Robustness rules, so that any run can be plotted:
//! - empty data, a series with `x.len() != y.len()` or a panel with no finite point is an error
//!   naming the panel and the series;
//! - a constant series (zero range) gets a padded axis range;
//! - non-finite points break the line instead of poisoning the axis range;
//! - series longer than [`MAX_DRAWN_POINTS`] are decimated by min/max buckets, so spikes stay
//!   visible; lines are clipped to the axes when a fixed range is given;
//! - tick values are "nice" (1, 2, 2.5, 5 × 10^k) with one common number of decimals; labels
//!   that would need more than 3 decimals, or values from 10⁴ up, get a common engineering
//!   factor (`×10⁻³`, `×10³`, …) in the axis label.
//!
//! plotters 0.3.7 pitfalls worked around here (each is explained where it is handled):
//! - a path wider than 1 px becomes one polygon with unlimited miter joins on bitmaps, so noisy
//!   signals grow spikes: bitmap lines are drawn segment by segment (`draw_line`);
//! - with `ab_glyph`, glyphs lose their left bearing on bitmaps ("ob ject"): bitmap text is laid
//!   out glyph by glyph from the embedded font's metrics (`draw_text`);
//! - `with_key_points` drops the `f64` value formatter, so the mesh cannot be configured: a small
//!   coordinate type (`Axis`) carries the ticks, and the axes are drawn here;
//! - lines are not clipped to the plotting area: they are clipped before drawing.
//!
//! Fonts: the DejaVu Sans font embedded in the binary is registered with plotters' `ab_glyph`
//! backend under every family name used here ([`register_fonts`], called automatically), so no
//! system font is ever needed.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::{Context, Result, anyhow, bail};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, FontTransform, register_font};

use crate::files;

/// The embedded font (DejaVu Sans, see `assets/DejaVu-LICENSE.txt`).
static FONT_BYTES: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// The font family every text of a figure uses.
pub const FONT: &str = "sans-serif";

/// Family names mapped to the embedded font (plotters' defaults use some of them).
const FONT_FAMILIES: [&str; 4] = ["sans-serif", "serif", "monospace", "DejaVu Sans"];

/// At most this many points of one series are drawn; longer series are min/max decimated.
pub const MAX_DRAWN_POINTS: usize = 4000;

/// Width of a figure in pixels for one or two columns (wider for more columns).
pub const FIGURE_WIDTH: u32 = 1200;
/// Height of one row of panels in pixels.
pub const ROW_HEIGHT: u32 = 350;

/// The line colours, in order (matplotlib's "tab10": blue, orange, green, red, purple, brown,
/// pink, grey, olive, cyan).
pub const PALETTE: [(u8, u8, u8); 10] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

// Layout constants (pixels).
const FIGURE_TITLE_PX: u32 = 22;
const PANEL_TITLE_PX: u32 = 18;
const LEGEND_PX: u32 = 15;
const LEGEND_ROW_PX: u32 = 21;
const LEGEND_SAMPLE_PX: i32 = 30;
const TICK_PX: u32 = 14;
const AXIS_DESC_PX: u32 = 16;
const X_LABEL_AREA_PX: u32 = 50;

const TEXT: RGBColor = RGBColor(25, 25, 25);
const GRID: RGBColor = RGBColor(222, 222, 222);
const BOUND: RGBColor = RGBColor(0, 0, 0);

/// A line colour: an index into [`PALETTE`] (wrapping around) or an explicit RGB value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Colour {
    /// `PALETTE[i % PALETTE.len()]`.
    Palette(usize),
    /// An explicit colour.
    Rgb(u8, u8, u8),
}

impl Colour {
    fn rgb(self) -> RGBColor {
        match self {
            Colour::Palette(i) => {
                let (r, g, b) = PALETTE[i % PALETTE.len()];
                RGBColor(r, g, b)
            }
            Colour::Rgb(r, g, b) => RGBColor(r, g, b),
        }
    }
}

/// How a line is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Style {
    /// Line colour.
    pub colour: Colour,
    /// Dashed (e.g. a desired value or a bound) instead of solid.
    pub dashed: bool,
    /// Stroke width in pixels (same number in the PNG and the SVG).
    pub width: u32,
}

impl Style {
    /// A solid line in palette colour `i`, 2 px wide.
    pub fn solid(i: usize) -> Self {
        Self {
            colour: Colour::Palette(i),
            dashed: false,
            width: 2,
        }
    }

    /// A dashed line in palette colour `i`, 2 px wide.
    pub fn dashed(i: usize) -> Self {
        Self {
            dashed: true,
            ..Self::solid(i)
        }
    }

    /// The style of bounds (`±k_c`): dashed black.
    pub fn bound() -> Self {
        Self {
            colour: Colour::Rgb(BOUND.0, BOUND.1, BOUND.2),
            dashed: true,
            width: 2,
        }
    }

    /// The same style with another stroke width.
    pub fn width(self, width: u32) -> Self {
        Self { width, ..self }
    }

    fn shape(self) -> ShapeStyle {
        self.colour.rgb().stroke_width(self.width.max(1))
    }
}

impl Default for Style {
    fn default() -> Self {
        Self::solid(0)
    }
}

/// One line: `y` against `x` (equal lengths), with a legend label (empty: not in the legend).
#[derive(Clone, Debug)]
pub struct Series<'a> {
    /// Legend text, e.g. `"x_o"` or `"NN"`; empty to leave the series out of the legend.
    pub label: String,
    /// Abscissae (time, or x for a path).
    pub x: &'a [f64],
    /// Ordinates, same length as `x`.
    pub y: &'a [f64],
    /// Colour, dash and width.
    pub style: Style,
}

impl<'a> Series<'a> {
    /// A series with the given label, data and style.
    pub fn new(label: impl Into<String>, x: &'a [f64], y: &'a [f64], style: Style) -> Self {
        Self {
            label: label.into(),
            x,
            y,
            style,
        }
    }
}

/// One set of axes of a figure.
#[derive(Clone, Debug, Default)]
pub struct Panel<'a> {
    /// Title above the axes, e.g. `"tracking error z1"`.
    pub title: String,
    /// Horizontal axis label with unit, e.g. `"t [s]"`.
    pub x_label: String,
    /// Vertical axis label with unit, e.g. `"z1,x [m]"`.
    pub y_label: String,
    /// Lines, drawn in order (later ones on top) and listed in the legend in order.
    pub series: Vec<Series<'a>>,
    /// Horizontal lines `(y, label)` drawn dashed black on top of the data, e.g. `±k_c`; lines
    /// sharing a label appear once in the legend. They are always inside the automatic y range.
    pub hlines: Vec<(f64, String)>,
    /// A dashed black box `|x| < kx, |y| < ky` with its legend label (XY paths).
    pub bound_box: Option<(f64, f64, String)>,
    /// Fixed x range; `None`: the data's range. Use it to zoom into a transient.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; `None`: the range of the data inside the x range (and of the bounds), padded.
    pub y_range: Option<(f64, f64)>,
    /// One metre on x is as long as one metre on y (XY paths); the automatic ranges are widened
    /// to achieve it (not applied when `x_range` or `y_range` is fixed).
    pub equal_aspect: bool,
}

impl<'a> Panel<'a> {
    /// A panel with a title and axis labels (with units) and nothing in it yet.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            ..Self::default()
        }
    }

    /// Adds a series.
    pub fn with(mut self, series: Series<'a>) -> Self {
        self.series.push(series);
        self
    }

    /// Adds a horizontal dashed line at `y`.
    pub fn hline(mut self, y: f64, label: impl Into<String>) -> Self {
        self.hlines.push((y, label.into()));
        self
    }

    /// Adds the symmetric bounds `+k` and `−k` with one legend entry.
    pub fn bounds(self, k: f64, label: impl Into<String>) -> Self {
        let label = label.into();
        self.hline(k, label.clone()).hline(-k, label)
    }

    /// Fixes the x range.
    pub fn x_range(mut self, lo: f64, hi: f64) -> Self {
        self.x_range = Some((lo, hi));
        self
    }

    /// Fixes the y range.
    pub fn y_range(mut self, lo: f64, hi: f64) -> Self {
        self.y_range = Some((lo, hi));
        self
    }

    /// Makes the axes equally scaled (for XY paths).
    pub fn equal_aspect(mut self) -> Self {
        self.equal_aspect = true;
        self
    }
}

/// Registers the embedded font for every family name used by the figures. Idempotent; the
/// drawing functions call it themselves.
pub fn register_fonts() -> Result<()> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        FONT_FAMILIES.iter().all(|name| {
            [FontStyle::Normal, FontStyle::Bold]
                .into_iter()
                .all(|style| register_font(name, style, FONT_BYTES).is_ok())
        })
    });
    if ok {
        Ok(())
    } else {
        bail!("the embedded DejaVuSans font could not be loaded")
    }
}

/// Heights of the rows of a grid (pixels, before any rescaling): [`ROW_HEIGHT`], or taller for a
/// row holding an equal-aspect (XY) panel, so that a path is not squeezed into a strip.
fn row_heights(panels: &[Panel], columns: usize, width: u32) -> Vec<u32> {
    let columns = columns.clamp(1, panels.len().max(1));
    panels
        .chunks(columns)
        .map(|row| {
            if row.iter().any(|p| p.equal_aspect) {
                (width / columns as u32 * 4 / 5).clamp(ROW_HEIGHT, 700)
            } else {
                ROW_HEIGHT
            }
        })
        .collect()
}

/// The pixel size [`panels`] uses: 1200 px wide (500 px per column beyond two), 350 px per row
/// (rows with an XY panel are taller), plus the title.
pub fn figure_size(panels: &[Panel], columns: usize) -> (u32, u32) {
    let columns = columns.clamp(1, panels.len().max(1));
    let width = FIGURE_WIDTH.max(500 * columns as u32);
    let rows: u32 = row_heights(panels, columns, width).iter().sum();
    (width, rows.max(ROW_HEIGHT) + FIGURE_TITLE_PX + 16)
}

/// Writes `<stem>.png` and `<stem>.svg`: the `panels` in a grid of `columns` columns under the
/// figure `title`, at the size [`figure_size`] gives (1200 px wide, 350 px per row).
pub fn panels(path_stem: &Path, title: &str, panels: &[Panel], columns: usize) -> Result<()> {
    panels_sized(
        path_stem,
        title,
        panels,
        columns,
        figure_size(panels, columns),
    )
}

/// Like [`panels`] with an explicit figure size in pixels.
pub fn panels_sized(
    path_stem: &Path,
    title: &str,
    panels: &[Panel],
    columns: usize,
    size: (u32, u32),
) -> Result<()> {
    let write = || -> Result<()> {
        let png = with_ext(path_stem, "png");
        let tmp = files::temp_sibling(&png)?;
        let drawn = (|| -> Result<()> {
            let root = BitMapBackend::new(&tmp, size).into_drawing_area();
            draw_figure(&root, title, panels, columns, Target::Bitmap)?;
            root.present().map_err(plot_err)
        })();
        if let Err(e) = drawn {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
        files::rename_into_place(&tmp, &png)?;
        let svg = render_svg(title, panels, columns, size)?;
        files::write_text_atomic(&with_ext(path_stem, "svg"), &svg)
    };
    write().with_context(|| format!("cannot draw figure {}", path_stem.display()))
}

/// Renders the figure into an RGB buffer (`3·w·h` bytes), e.g. for tests or other encoders.
pub fn render_rgb(
    title: &str,
    panels: &[Panel],
    columns: usize,
    size: (u32, u32),
) -> Result<Vec<u8>> {
    let mut buf = vec![0u8; 3 * size.0 as usize * size.1 as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        draw_figure(&root, title, panels, columns, Target::Bitmap)?;
        root.present().map_err(plot_err)?;
    }
    Ok(buf)
}

/// Renders the figure as an SVG document.
pub fn render_svg(
    title: &str,
    panels: &[Panel],
    columns: usize,
    size: (u32, u32),
) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        draw_figure(&root, title, panels, columns, Target::Vector)?;
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

/// The XY-path panel: the actual path (solid blue), the desired path (dashed orange, on top),
/// the bound box `|x| < kx, |y| < ky` (dashed black) and any `extra` series, equally scaled.
pub fn xy_panel<'a>(
    title: &str,
    actual: (&'a [f64], &'a [f64]),
    desired: (&'a [f64], &'a [f64]),
    bounds: Option<(f64, f64)>,
    extra: &[Series<'a>],
) -> Panel<'a> {
    let mut p = Panel::new(title, "x [m]", "y [m]")
        .equal_aspect()
        .with(Series::new("actual", actual.0, actual.1, Style::solid(0)))
        .with(Series::new(
            "desired",
            desired.0,
            desired.1,
            Style::dashed(1),
        ));
    p.series.extend(extra.iter().cloned());
    p.bound_box = bounds.map(|(kx, ky)| (kx, ky, String::from("bounds ±k_c")));
    p
}

/// Writes `<stem>.png` and `<stem>.svg` with the XY path (see [`xy_panel`]), 800 px square axes.
pub fn xy_path(
    path_stem: &Path,
    title: &str,
    actual: (&[f64], &[f64]),
    desired: (&[f64], &[f64]),
    bounds: Option<(f64, f64)>,
    extra: &[Series],
) -> Result<()> {
    let panel = xy_panel("", actual, desired, bounds, extra);
    panels_sized(path_stem, title, &[panel], 1, (820, 900))
}

// ---------------------------------------------------------------------------------------------
// Drawing.

/// Maps a plotters error (whose type depends on the backend) to an `anyhow` error.
fn plot_err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("plotting failed: {e}")
}

/// `stem` with `.ext` appended (the stem may itself contain dots, e.g. `fig.v2`).
fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_os_string();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// What kind of backend is drawn on; lines are drawn differently (see [`draw_line`]).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Target {
    Bitmap,
    Vector,
}

/// Draws the figure title and the grid of panels on `root`.
fn draw_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    panels: &[Panel],
    columns: usize,
    target: Target,
) -> Result<()> {
    register_fonts()?;
    if panels.is_empty() {
        bail!("a figure needs at least one panel");
    }
    // Validate everything before drawing anything.
    let prepared: Vec<Prepared> = panels.iter().map(prepare).collect::<Result<_>>()?;
    root.fill(&WHITE).map_err(plot_err)?;
    let columns = columns.clamp(1, panels.len());
    let rows = panels.len().div_ceil(columns);
    let body = if title.is_empty() {
        root.margin(6, 0, 0, 0)
    } else {
        let (w, _) = root.dim_in_pixel();
        let (head, body) = root.split_vertically(FIGURE_TITLE_PX + 16);
        let pos = (w as i32 / 2, (FIGURE_TITLE_PX / 2 + 8) as i32);
        draw_text(
            &head,
            target,
            title,
            pos,
            FIGURE_TITLE_PX,
            (HPos::Center, VPos::Center),
            false,
        )?;
        body
    };
    // Rows share the height in proportion to their nominal heights; columns split evenly.
    let (width, height) = body.dim_in_pixel();
    let nominal = row_heights(panels, columns, width);
    let total: u32 = nominal.iter().sum::<u32>().max(1);
    let mut rest = body;
    let mut used = 0u32;
    for (r, (row_panels, row_preps)) in panels
        .chunks(columns)
        .zip(prepared.chunks(columns))
        .enumerate()
    {
        let h = if r + 1 == rows {
            height - used
        } else {
            (u64::from(height) * u64::from(nominal[r]) / u64::from(total)) as u32
        };
        used += h;
        let (row_area, below) = rest.split_vertically(h);
        rest = below;
        let cells = row_area.split_evenly((1, columns));
        for ((cell, panel), prep) in cells.iter().zip(row_panels).zip(row_preps) {
            draw_panel(&cell.margin(4, 6, 8, 10), panel, prep, target)
                .with_context(|| format!("in panel '{}'", panel.title))?;
        }
    }
    Ok(())
}

/// A panel's data checked and reduced to what is drawn.
struct Prepared {
    /// Per series: runs of finite points, decimated.
    lines: Vec<Vec<Vec<(f64, f64)>>>,
    /// Data range before padding: (x_lo, x_hi, y_lo, y_hi).
    x: (f64, f64),
    y: (f64, f64),
}

/// Checks a panel's data and computes its (unpadded) ranges.
fn prepare(p: &Panel) -> Result<Prepared> {
    let mut lines = Vec::with_capacity(p.series.len());
    for s in &p.series {
        if s.x.len() != s.y.len() {
            bail!(
                "panel '{}', series '{}': x has {} points, y has {}",
                p.title,
                s.label,
                s.x.len(),
                s.y.len()
            );
        }
        let runs = finite_runs(s.x, s.y);
        let total: usize = runs.iter().map(|r| r.len()).sum();
        let runs = if p.equal_aspect {
            runs.into_iter()
                .map(|r| thin_path(&r, MAX_DRAWN_POINTS * r.len() / total.max(1)))
                .collect()
        } else {
            runs.into_iter()
                .map(|r| decimate_min_max(&r, MAX_DRAWN_POINTS * r.len() / total.max(1)))
                .collect()
        };
        lines.push(runs);
    }

    // x range: fixed, or all finite data (plus the bound box).
    let mut xr = Extent::default();
    for run in lines.iter().flatten() {
        for &(x, _) in run {
            xr.add(x);
        }
    }
    if let Some((kx, _, _)) = &p.bound_box {
        xr.add(-kx);
        xr.add(*kx);
    }
    let x = match p.x_range {
        Some((lo, hi)) => checked_range(lo, hi, "x_range")?,
        None => xr.get().ok_or_else(|| {
            anyhow!(
                "panel '{}' has no data to plot (no series with a finite point)",
                p.title
            )
        })?,
    };

    // y range: fixed, or the data inside the x range, the hlines and the bound box.
    let y = match p.y_range {
        Some((lo, hi)) => checked_range(lo, hi, "y_range")?,
        None => {
            let mut yr = Extent::default();
            for run in lines.iter().flatten() {
                for &(xv, yv) in run {
                    if xv >= x.0 && xv <= x.1 {
                        yr.add(yv);
                    }
                }
            }
            for (v, _) in &p.hlines {
                yr.add(*v);
            }
            if let Some((_, ky, _)) = &p.bound_box {
                yr.add(-ky);
                yr.add(*ky);
            }
            yr.get().ok_or_else(|| {
                anyhow!("panel '{}' has no finite data inside its x range", p.title)
            })?
        }
    };
    Ok(Prepared { lines, x, y })
}

fn checked_range(lo: f64, hi: f64, what: &str) -> Result<(f64, f64)> {
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        bail!("{what} ({lo}, {hi}) must be finite and increasing");
    }
    Ok((lo, hi))
}

/// Running min/max of finite values.
#[derive(Default)]
struct Extent(Option<(f64, f64)>);

impl Extent {
    fn add(&mut self, v: f64) {
        if v.is_finite() {
            self.0 = Some(match self.0 {
                None => (v, v),
                Some((lo, hi)) => (lo.min(v), hi.max(v)),
            });
        }
    }
    fn get(&self) -> Option<(f64, f64)> {
        self.0
    }
}

/// Widens a range by `frac` of its span on each side; a (near-)zero span is padded to a visible
/// one (±10 % of the value, or ±1 around zero).
fn pad_range((lo, hi): (f64, f64), frac: f64) -> (f64, f64) {
    let span = hi - lo;
    let scale = lo.abs().max(hi.abs());
    if span <= 1e-12 * scale.max(f64::MIN_POSITIVE) || span == 0.0 {
        let mid = 0.5 * (lo + hi);
        let pad = if scale > 0.0 { 0.1 * scale } else { 1.0 };
        (mid - pad, mid + pad)
    } else {
        (lo - frac * span, hi + frac * span)
    }
}

/// Splits a series into runs of consecutive finite points.
fn finite_runs(x: &[f64], y: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut cur = Vec::new();
    for (&a, &b) in x.iter().zip(y) {
        if a.is_finite() && b.is_finite() {
            cur.push((a, b));
        } else if !cur.is_empty() {
            runs.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        runs.push(cur);
    }
    runs
}

/// Keeps at most about `max_points` of a time series: consecutive buckets each contribute their
/// minimum and maximum (in time order), plus the first and last point, so that spikes survive.
pub fn decimate_min_max(pts: &[(f64, f64)], max_points: usize) -> Vec<(f64, f64)> {
    let max_points = max_points.max(4);
    if pts.len() <= max_points {
        return pts.to_vec();
    }
    let buckets = (max_points - 2) / 2;
    let n = pts.len();
    let mut out = Vec::with_capacity(2 * buckets + 2);
    out.push(pts[0]);
    for b in 0..buckets {
        let lo = 1 + b * (n - 2) / buckets;
        let hi = 1 + (b + 1) * (n - 2) / buckets;
        let Some(chunk) = pts.get(lo..hi).filter(|c| !c.is_empty()) else {
            continue;
        };
        let (mut imin, mut imax) = (0, 0);
        for (i, p) in chunk.iter().enumerate() {
            if p.1 < chunk[imin].1 {
                imin = i;
            }
            if p.1 > chunk[imax].1 {
                imax = i;
            }
        }
        let (a, c) = (imin.min(imax), imin.max(imax));
        out.push(chunk[a]);
        if c != a {
            out.push(chunk[c]);
        }
    }
    out.push(pts[n - 1]);
    out
}

/// Keeps at most about `max_points` of a planar path: a point is kept when it is farther than a
/// tolerance from the last kept one (so jumps and spikes survive), plus the last point.
fn thin_path(pts: &[(f64, f64)], max_points: usize) -> Vec<(f64, f64)> {
    let max_points = max_points.max(4);
    if pts.len() <= max_points {
        return pts.to_vec();
    }
    // Path length / max_points as the tolerance, doubled until the budget holds.
    let length: f64 = pts
        .windows(2)
        .map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
        .sum();
    let mut tol = length / max_points as f64;
    loop {
        let mut out = vec![pts[0]];
        let mut last = pts[0];
        for &p in &pts[1..pts.len() - 1] {
            if (p.0 - last.0).hypot(p.1 - last.1) >= tol {
                out.push(p);
                last = p;
            }
        }
        out.push(pts[pts.len() - 1]);
        if out.len() <= max_points || tol.is_nan() || tol <= 0.0 {
            return out;
        }
        tol *= 1.5;
    }
}

/// Clips a polyline to the rectangle `[x0, x1] × [y0, y1]` (Liang–Barsky per segment); returns
/// the visible pieces.
fn clip_polyline(
    pts: &[(f64, f64)],
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Vec<Vec<(f64, f64)>> {
    let inside = |p: (f64, f64)| p.0 >= x0 && p.0 <= x1 && p.1 >= y0 && p.1 <= y1;
    let mut pieces = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    if pts.len() == 1 && inside(pts[0]) {
        return vec![pts.to_vec()];
    }
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        let mut visible = true;
        for (p, q) in [
            (-dx, a.0 - x0),
            (dx, x1 - a.0),
            (-dy, a.1 - y0),
            (dy, y1 - a.1),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    visible = false;
                    break;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
        if !visible || t0 > t1 {
            if cur.len() > 1 {
                pieces.push(std::mem::take(&mut cur));
            }
            cur.clear();
            continue;
        }
        // Unclipped ends are kept exactly.
        let pa = if t0 > 0.0 {
            (a.0 + t0 * dx, a.1 + t0 * dy)
        } else {
            a
        };
        let pb = if t1 < 1.0 {
            (a.0 + t1 * dx, a.1 + t1 * dy)
        } else {
            b
        };
        if t0 > 0.0 || cur.is_empty() {
            // Entering the box (or starting): a new piece.
            if cur.len() > 1 {
                pieces.push(std::mem::take(&mut cur));
            }
            cur.clear();
            cur.push(pa);
        }
        cur.push(pb);
        if t1 < 1.0 {
            // Leaving the box.
            pieces.push(std::mem::take(&mut cur));
        }
    }
    if cur.len() > 1 {
        pieces.push(cur);
    }
    pieces
}

/// Nice tick positions for an axis, with their common formatting.
#[derive(Clone, Debug, PartialEq)]
struct Ticks {
    values: Vec<f64>,
    /// Decimals of the scaled labels.
    decimals: usize,
    /// Labels show `v / 10^exp`; the axis label says `×10^exp` when `exp != 0`.
    exp: i32,
}

impl Ticks {
    /// At most `max_ticks` ticks at multiples of 1, 2, 2.5 or 5 × 10^k inside `[lo, hi]`.
    fn nice(lo: f64, hi: f64, max_ticks: usize) -> Self {
        let max_ticks = max_ticks.max(2) as i64;
        let span = hi - lo;
        let mag = 10f64.powf((span / max_ticks as f64).log10().floor());
        // Ticks at integer multiples k·step, k in [k0, k1].
        let ks = |step: f64| {
            (
                (lo / step - 1e-9).ceil() as i64,
                (hi / step + 1e-9).floor() as i64,
            )
        };
        let step = [1.0, 2.0, 2.5, 5.0, 10.0, 20.0]
            .into_iter()
            .map(|m| m * mag)
            .find(|&step| {
                let (k0, k1) = ks(step);
                k1 - k0 < max_ticks
            })
            .unwrap_or(20.0 * mag);
        let (k0, k1) = ks(step);
        let values: Vec<f64> = (k0..=k1).map(|k| k as f64 * step).collect();
        // The fewest decimals that show the step exactly (0.25 → 2, 20 → 0, 2.5 → 1).
        let decimals_for = |exp: i32| {
            let scaled_step = step / 10f64.powi(exp);
            (0..12)
                .find(|&d| {
                    let v = scaled_step * 10f64.powi(d);
                    (v - v.round()).abs() < 1e-6 * v.max(1.0)
                })
                .unwrap_or(12) as usize
        };
        // Labels longer than "0.005" or "10000" get a common engineering factor 10^(3k).
        let maxabs = lo.abs().max(hi.abs());
        let mut exp = 0;
        if maxabs > 0.0 && (maxabs >= 1e4 || decimals_for(0) > 3) {
            exp = 3 * (maxabs.log10() / 3.0).floor() as i32;
        }
        Self {
            values,
            decimals: decimals_for(exp),
            exp,
        }
    }

    fn label(&self, v: f64) -> String {
        let s = format!("{:.*}", self.decimals, v / 10f64.powi(self.exp));
        // No "-0.00".
        if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
            s[1..].to_string()
        } else {
            s.replace('-', "−")
        }
    }

    /// The axis description with the common factor, e.g. `z1,x [m]  (×10⁻³)`.
    fn describe(&self, label: &str) -> String {
        if self.exp == 0 {
            label.to_string()
        } else {
            format!("{label}  (×10{})", superscript(self.exp))
        }
    }
}

fn superscript(n: i32) -> String {
    n.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            '9' => '⁹',
            c => c,
        })
        .collect()
}

/// One legend entry: a line sample and its text.
struct LegendEntry {
    label: String,
    style: Style,
}

fn legend_entries(p: &Panel) -> Vec<LegendEntry> {
    let mut out: Vec<LegendEntry> = Vec::new();
    let mut push = |label: &str, style: Style| {
        if !label.is_empty() && !out.iter().any(|e| e.label == label && e.style == style) {
            out.push(LegendEntry {
                label: label.to_string(),
                style,
            });
        }
    };
    for s in &p.series {
        push(&s.label, s.style);
    }
    for (_, l) in &p.hlines {
        push(l, Style::bound());
    }
    if let Some((_, _, l)) = &p.bound_box {
        push(l, Style::bound());
    }
    out
}

/// Draws a line sample of `style` from `a` to `b` (pixels of `area`).
fn draw_sample<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    a: (i32, i32),
    b: (i32, i32),
    style: Style,
) -> Result<()> {
    if style.dashed {
        area.draw(&DashedPathElement::new(vec![a, b], 8, 5, style.shape()))
    } else {
        area.draw(&PathElement::new(vec![a, b], style.shape()))
    }
    .map_err(plot_err)
}

/// Draws one panel (title, legend strip, axes, data) into `area`.
fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &Panel,
    prep: &Prepared,
    target: Target,
) -> Result<()> {
    let (w, _h) = area.dim_in_pixel();
    let legend_font = (FONT, LEGEND_PX).into_font().color(&TEXT);
    let tick_font = (FONT, TICK_PX).into_font().color(&TEXT);

    // Legend rows: entries flow left to right and wrap; each row is centred.
    let entries = legend_entries(p);
    let gap = 22i32;
    let mut rows: Vec<Vec<(usize, i32)>> = Vec::new(); // (entry, width)
    let mut row_w = 0i32;
    for (i, e) in entries.iter().enumerate() {
        let tw = area
            .estimate_text_size(&e.label, &legend_font)
            .map_err(plot_err)?
            .0 as i32;
        let ew = LEGEND_SAMPLE_PX + 6 + tw;
        if rows.is_empty() || (row_w + gap + ew > w as i32 - 10 && row_w > 0) {
            rows.push(Vec::new());
            row_w = 0;
        }
        row_w += if row_w > 0 { gap + ew } else { ew };
        if let Some(r) = rows.last_mut() {
            r.push((i, ew));
        }
    }
    let title_h = if p.title.is_empty() {
        2
    } else {
        PANEL_TITLE_PX + 8
    };
    let head_h = title_h + LEGEND_ROW_PX * rows.len() as u32 + 4;
    let (head, body) = area.split_vertically(head_h);
    if !p.title.is_empty() {
        let pos = (w as i32 / 2, (PANEL_TITLE_PX / 2 + 2) as i32);
        let anchor = (HPos::Center, VPos::Center);
        draw_text(&head, target, &p.title, pos, PANEL_TITLE_PX, anchor, false)?;
    }
    for (r, row) in rows.iter().enumerate() {
        let total: i32 = row.iter().map(|(_, ew)| ew).sum::<i32>() + gap * (row.len() as i32 - 1);
        let mut x = (w as i32 - total) / 2;
        let y = (title_h + LEGEND_ROW_PX * r as u32 + LEGEND_ROW_PX / 2) as i32;
        for &(i, ew) in row {
            let e = &entries[i];
            draw_sample(&head, (x, y), (x + LEGEND_SAMPLE_PX, y), e.style)?;
            let pos = (x + LEGEND_SAMPLE_PX + 6, y);
            let anchor = (HPos::Left, VPos::Center);
            draw_text(&head, target, &e.label, pos, LEGEND_PX, anchor, false)?;
            x += ew + gap;
        }
    }

    // Ranges: padded data ranges (time axes stay tight), then equal scaling if asked for.
    let mut x = match p.x_range {
        Some(r) => r,
        None if p.equal_aspect => pad_range(prep.x, 0.05),
        None => {
            let (lo, hi) = pad_range(prep.x, 0.0);
            (lo, hi)
        }
    };
    let mut y = match p.y_range {
        Some(r) => r,
        None => pad_range(prep.y, 0.06),
    };

    // The plot area depends on the y tick label width, which depends on the y ticks; the first
    // pass uses the unscaled ranges, which is close enough (a few pixels of slack are added).
    let (_, body_h) = body.dim_in_pixel();
    let plot_h_guess = body_h.saturating_sub(X_LABEL_AREA_PX + 10).max(40);
    let yt_guess = Ticks::nice(y.0, y.1, (plot_h_guess / 42).clamp(4, 9) as usize);
    let y_label_w = y_label_area(&body, &yt_guess, &tick_font)?;
    let make = |xr: (f64, f64), yr: (f64, f64), xt: &Ticks, yt: &Ticks| {
        ChartBuilder::on(&body)
            .margin_top(8)
            .margin_right(18)
            .margin_left(4)
            .margin_bottom(4)
            .x_label_area_size(X_LABEL_AREA_PX)
            .y_label_area_size(y_label_w)
            .build_cartesian_2d(
                Axis {
                    lo: xr.0,
                    hi: xr.1,
                    ticks: xt.values.clone(),
                },
                Axis {
                    lo: yr.0,
                    hi: yr.1,
                    ticks: yt.values.clone(),
                },
            )
            .map_err(plot_err)
    };
    let probe = make(x, y, &yt_guess, &yt_guess)?;
    let (pw, ph) = probe.plotting_area().dim_in_pixel();
    drop(probe);
    if p.equal_aspect && p.x_range.is_none() && p.y_range.is_none() && pw > 0 && ph > 0 {
        // Metres per pixel must be equal: widen the axis that has fewer.
        let (sx, sy) = ((x.1 - x.0) / pw as f64, (y.1 - y.0) / ph as f64);
        if sx < sy {
            let half = 0.5 * sy * pw as f64;
            let mid = 0.5 * (x.0 + x.1);
            x = (mid - half, mid + half);
        } else {
            let half = 0.5 * sx * ph as f64;
            let mid = 0.5 * (y.0 + y.1);
            y = (mid - half, mid + half);
        }
    }
    let xt = Ticks::nice(x.0, x.1, (pw / 80).clamp(4, 12) as usize);
    let yt = Ticks::nice(y.0, y.1, (ph / 42).clamp(4, 9) as usize);
    let mut chart = make(x, y, &xt, &yt)?;
    let (pw, ph) = chart.plotting_area().dim_in_pixel();
    let pen = Pen {
        target,
        sx: f64::from(pw.max(1)) / (x.1 - x.0),
        sy: f64::from(ph.max(1)) / (y.1 - y.0),
    };

    // Grid (under the data), then tick marks, tick labels and axis descriptions, drawn here
    // rather than by plotters' mesh so that all text goes through `draw_text`.
    let grid = Style {
        colour: Colour::Rgb(GRID.0, GRID.1, GRID.2),
        dashed: false,
        width: 1,
    };
    for &v in &xt.values {
        draw_line(&mut chart, &pen, &[(v, y.0), (v, y.1)], grid)?;
    }
    for &v in &yt.values {
        draw_line(&mut chart, &pen, &[(x.0, v), (x.1, v)], grid)?;
    }
    let base = body.get_base_pixel();
    let px = |c: (f64, f64)| {
        let b = chart.backend_coord(&c);
        (b.0 - base.0, b.1 - base.1)
    };
    let axis = TEXT.stroke_width(1);
    let (left, bottom) = px((x.0, y.0));
    let (right, top) = px((x.1, y.1));
    for &v in &xt.values {
        let (tx, ty) = px((v, y.0));
        body.draw(&PathElement::new(vec![(tx, ty), (tx, ty + 5)], axis))
            .map_err(plot_err)?;
        let anchor = (HPos::Center, VPos::Top);
        draw_text(
            &body,
            target,
            &xt.label(v),
            (tx, ty + 8),
            TICK_PX,
            anchor,
            false,
        )?;
    }
    for &v in &yt.values {
        let (tx, ty) = px((x.0, v));
        body.draw(&PathElement::new(vec![(tx - 5, ty), (tx, ty)], axis))
            .map_err(plot_err)?;
        let anchor = (HPos::Right, VPos::Center);
        draw_text(
            &body,
            target,
            &yt.label(v),
            (tx - 8, ty),
            TICK_PX,
            anchor,
            false,
        )?;
    }
    let x_desc = xt.describe(&p.x_label);
    let y_desc = yt.describe(&p.y_label);
    let pos = ((left + right) / 2, bottom + 8 + TICK_PX as i32 + 10);
    draw_text(
        &body,
        target,
        &x_desc,
        pos,
        AXIS_DESC_PX,
        (HPos::Center, VPos::Top),
        false,
    )?;
    let pos = (4, (top + bottom) / 2);
    draw_text(
        &body,
        target,
        &y_desc,
        pos,
        AXIS_DESC_PX,
        (HPos::Center, VPos::Top),
        true,
    )?;

    // Data, in order; dashed lines keep their dash phase across points.
    for (s, runs) in p.series.iter().zip(&prep.lines) {
        for run in runs {
            for piece in clip_polyline(run, x, y) {
                draw_line(&mut chart, &pen, &piece, s.style)?;
            }
        }
    }
    // Bounds on top of the data.
    for (v, _) in &p.hlines {
        if *v >= y.0 && *v <= y.1 {
            draw_line(&mut chart, &pen, &[(x.0, *v), (x.1, *v)], Style::bound())?;
        }
    }
    if let Some((kx, ky, _)) = &p.bound_box {
        let boxed = vec![(-kx, -ky), (*kx, -ky), (*kx, *ky), (-kx, *ky), (-kx, -ky)];
        for piece in clip_polyline(&boxed, x, y) {
            draw_line(&mut chart, &pen, &piece, Style::bound())?;
        }
    }
    // A closed frame around the axes.
    chart
        .plotting_area()
        .draw(&Rectangle::new(
            [(x.0, y.1), (x.1, y.0)],
            TEXT.stroke_width(1),
        ))
        .map_err(plot_err)?;
    Ok(())
}

/// A linear f64 axis whose grid lines and labels are exactly the given ticks.
///
/// (plotters' own `with_key_points` wrapper loses the value formatter of `f64` ranges, so the
/// mesh could not be configured; this small coordinate does the same job.)
#[derive(Clone)]
struct Axis {
    lo: f64,
    hi: f64,
    ticks: Vec<f64>,
}

impl Ranged for Axis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let frac = (v - self.lo) / (self.hi - self.lo);
        let len = f64::from(limit.1 - limit.0);
        let px = f64::from(limit.0) + len * frac;
        // Far-away points (clipped lines never produce them) must not overflow i32.
        px.round().clamp(-1e7, 1e7) as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new() // no minor grid
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}

type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<Axis, Axis>>;

/// How data lengths convert to pixels, and which backend is drawn on.
struct Pen {
    target: Target,
    /// Pixels per unit of x and of y.
    sx: f64,
    sy: f64,
}

/// Dash and gap lengths in pixels.
const DASH_PX: f64 = 9.0;
const GAP_PX: f64 = 6.0;

/// Cuts a polyline (data units) into dashes of `DASH_PX` separated by `GAP_PX`, measured in
/// pixels; the dash phase continues across points.
fn dashes(pts: &[(f64, f64)], sx: f64, sy: f64) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut cur = vec![pts[0]];
    let (mut on, mut left) = (true, DASH_PX);
    for w in pts.windows(2) {
        let (mut a, b) = (w[0], w[1]);
        loop {
            let len = ((b.0 - a.0) * sx).hypot((b.1 - a.1) * sy);
            if len <= left {
                left -= len;
                if on {
                    cur.push(b);
                }
                break;
            }
            let t = left / len;
            let m = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
            if on {
                cur.push(m);
                out.push(std::mem::take(&mut cur));
            } else {
                cur = vec![m];
            }
            on = !on;
            left = if on { DASH_PX } else { GAP_PX };
            a = m;
        }
    }
    if on && cur.len() > 1 {
        out.push(cur);
    }
    out
}

/// Draws a polyline in data coordinates.
///
/// Bitmap pitfall: plotters turns a whole path wider than 1 px into one polygon with unlimited
/// miter joins, so a noisy signal (sharp zig-zags) gets long spikes and holes. On bitmaps wide
/// lines are therefore drawn segment by segment (each a small rectangle); vector output keeps
/// whole paths (the SVG renderer joins them properly and the file stays small).
fn draw_line<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    pen: &Pen,
    pts: &[(f64, f64)],
    style: Style,
) -> Result<()> {
    if pts.len() < 2 {
        return Ok(());
    }
    let pieces = if style.dashed {
        dashes(pts, pen.sx, pen.sy)
    } else {
        vec![pts.to_vec()]
    };
    let shape = style.shape();
    let segmented = pen.target == Target::Bitmap && shape.stroke_width > 1;
    for piece in pieces {
        if segmented {
            chart
                .draw_series(
                    piece
                        .windows(2)
                        .map(|w| PathElement::new(vec![w[0], w[1]], shape)),
                )
                .map_err(plot_err)?;
        } else {
            chart
                .draw_series(std::iter::once(PathElement::new(piece, shape)))
                .map_err(plot_err)?;
        }
    }
    Ok(())
}

/// Draws `text` with its anchor point at `pos` (pixels of `area`), in the figure font of `size`
/// px, optionally rotated to read bottom-to-top (y-axis descriptions).
///
/// Bitmap pitfall: plotters 0.3.7 with `ab_glyph` places each glyph at its advance position but
/// drops the glyph's left bearing, so letters with small bearings (`j`, `_`, `[`) look displaced
/// ("ob ject"). On bitmaps the text is therefore laid out here, glyph by glyph, from the embedded
/// font's own metrics ([`FontMetrics`]); vector output keeps whole strings (the SVG viewer lays
/// them out).
fn draw_text<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    target: Target,
    text: &str,
    pos: (i32, i32),
    size: u32,
    (h, v): (HPos, VPos),
    rotated: bool,
) -> Result<()> {
    if text.is_empty() {
        return Ok(());
    }
    let mut font = (FONT, size).into_font();
    if rotated {
        font = font.transform(FontTransform::Rotate270);
    }
    let style = font.color(&TEXT);
    let metrics = font_metrics();
    let (Target::Bitmap, Some(m)) = (target, metrics) else {
        return area
            .draw(&Text::new(text.to_string(), pos, style.pos(Pos::new(h, v))))
            .map_err(plot_err);
    };
    let size = f64::from(size);
    let width: f64 = text.chars().map(|c| m.advance(c, size)).sum();
    let start = match h {
        HPos::Left => 0.0,
        HPos::Center => -0.5 * width,
        HPos::Right => -width,
    };
    let mut pen = start;
    let mut buf = [0u8; 4];
    for c in text.chars() {
        if !c.is_whitespace() {
            let along = (pen.round() + m.left_bearing(c, size).floor()) as i32;
            let at = if rotated {
                (pos.0, pos.1 - along)
            } else {
                (pos.0 + along, pos.1)
            };
            let glyph: &str = c.encode_utf8(&mut buf);
            area.draw(&Text::new(
                glyph.to_string(),
                at,
                style.clone().pos(Pos::new(HPos::Left, v)),
            ))
            .map_err(plot_err)?;
        }
        pen += m.advance(c, size);
    }
    Ok(())
}

/// Horizontal metrics of the embedded font, read from its `cmap`, `hmtx` and `glyf` tables
/// (only what [`draw_text`] needs; scaled as `ab_glyph` scales: px = units · size / (ascent −
/// descent)).
struct FontMetrics {
    /// Ascent − descent in font units.
    height: f64,
    /// Per glyph: advance width and outline x-minimum, font units.
    advance: Vec<u16>,
    x_min: Vec<i16>,
    /// `cmap` format 4 segments: (start, end, id_delta, id_range_offset position or 0).
    segments: Vec<(u16, u16, u16, usize)>,
    /// The font bytes (for glyph ids read through `id_range_offset`).
    data: &'static [u8],
}

/// Width in pixels of `text` set in the embedded font at `size` px (advance widths, no kerning);
/// 0.6 em per character if the font tables cannot be read.
pub fn text_width_px(text: &str, size: f64) -> f64 {
    match font_metrics() {
        Some(m) => text.chars().map(|c| m.advance(c, size)).sum(),
        None => 0.6 * size * text.chars().count() as f64,
    }
}

fn font_metrics() -> Option<&'static FontMetrics> {
    static METRICS: OnceLock<Option<FontMetrics>> = OnceLock::new();
    METRICS
        .get_or_init(|| FontMetrics::parse(FONT_BYTES))
        .as_ref()
}

impl FontMetrics {
    fn parse(data: &'static [u8]) -> Option<Self> {
        let u16_at = |o: usize| -> Option<u16> {
            Some(u16::from_be_bytes([*data.get(o)?, *data.get(o + 1)?]))
        };
        let i16_at = |o: usize| u16_at(o).map(|v| v as i16);
        let u32_at = |o: usize| -> Option<u32> {
            Some(u32::from_be_bytes([
                *data.get(o)?,
                *data.get(o + 1)?,
                *data.get(o + 2)?,
                *data.get(o + 3)?,
            ]))
        };
        let num_tables = usize::from(u16_at(4)?);
        let table = |tag: &[u8; 4]| -> Option<usize> {
            (0..num_tables).find_map(|i| {
                let rec = 12 + 16 * i;
                (data.get(rec..rec + 4)? == tag).then(|| u32_at(rec + 8).map(|o| o as usize))?
            })
        };
        let (head, hhea, maxp) = (table(b"head")?, table(b"hhea")?, table(b"maxp")?);
        let (hmtx, loca, glyf, cmap) = (
            table(b"hmtx")?,
            table(b"loca")?,
            table(b"glyf")?,
            table(b"cmap")?,
        );
        // Ascent and descent as ttf-parser reports them (OS/2 typo metrics if flagged).
        let (mut asc, mut desc) = (i16_at(hhea + 4)?, i16_at(hhea + 6)?);
        if let Some(os2) = table(b"OS/2")
            && u16_at(os2 + 62)? & (1 << 7) != 0
        {
            asc = i16_at(os2 + 68)?;
            desc = i16_at(os2 + 70)?;
        }
        let height = f64::from(asc) - f64::from(desc);
        let num_glyphs = usize::from(u16_at(maxp + 4)?);
        let num_hm = usize::from(u16_at(hhea + 34)?).max(1);
        let long_loca = i16_at(head + 50)? != 0;
        let loca_at = |g: usize| -> Option<usize> {
            if long_loca {
                u32_at(loca + 4 * g).map(|v| v as usize)
            } else {
                u16_at(loca + 2 * g).map(|v| 2 * usize::from(v))
            }
        };
        let mut advance = Vec::with_capacity(num_glyphs);
        let mut x_min = Vec::with_capacity(num_glyphs);
        for g in 0..num_glyphs {
            advance.push(u16_at(hmtx + 4 * g.min(num_hm - 1))?);
            let (a, b) = (loca_at(g)?, loca_at(g + 1)?);
            x_min.push(if b > a { i16_at(glyf + a + 2)? } else { 0 });
        }
        // The Unicode BMP subtable (platform 3 encoding 1, or platform 0), format 4.
        let n_sub = usize::from(u16_at(cmap + 2)?);
        let sub = (0..n_sub).find_map(|i| {
            let rec = cmap + 4 + 8 * i;
            let (platform, encoding) = (u16_at(rec)?, u16_at(rec + 2)?);
            let off = cmap + u32_at(rec + 4)? as usize;
            ((platform == 3 && encoding == 1 || platform == 0) && u16_at(off)? == 4).then_some(off)
        })?;
        let seg_count = usize::from(u16_at(sub + 6)? / 2);
        let ends = sub + 14;
        let starts = ends + 2 * seg_count + 2;
        let deltas = starts + 2 * seg_count;
        let ranges = deltas + 2 * seg_count;
        let mut segments = Vec::with_capacity(seg_count);
        for i in 0..seg_count {
            let range_pos = ranges + 2 * i;
            let range = u16_at(range_pos)?;
            segments.push((
                u16_at(starts + 2 * i)?,
                u16_at(ends + 2 * i)?,
                u16_at(deltas + 2 * i)?,
                if range == 0 {
                    0
                } else {
                    range_pos + usize::from(range)
                },
            ));
        }
        (height > 0.0).then_some(Self {
            height,
            advance,
            x_min,
            segments,
            data,
        })
    }

    /// The glyph id of `c` (0, the missing glyph, if the font lacks it).
    fn glyph(&self, c: char) -> usize {
        let Ok(c) = u16::try_from(u32::from(c)) else {
            return 0;
        };
        let Some(&(start, end, delta, range_at)) = self.segments.iter().find(|s| s.1 >= c) else {
            return 0;
        };
        if c < start || c > end {
            return 0;
        }
        let id = if range_at == 0 {
            c.wrapping_add(delta)
        } else {
            let o = range_at + 2 * usize::from(c - start);
            match (self.data.get(o), self.data.get(o + 1)) {
                (Some(&a), Some(&b)) if u16::from_be_bytes([a, b]) != 0 => {
                    u16::from_be_bytes([a, b]).wrapping_add(delta)
                }
                _ => 0,
            }
        };
        usize::from(id)
    }

    /// Advance width of `c` in pixels at font size `size`.
    fn advance(&self, c: char, size: f64) -> f64 {
        let g = self.glyph(c);
        f64::from(self.advance.get(g).copied().unwrap_or(0)) * size / self.height
    }

    /// Left edge of the outline of `c` relative to the pen, in pixels at font size `size`.
    fn left_bearing(&self, c: char, size: f64) -> f64 {
        let g = self.glyph(c);
        f64::from(self.x_min.get(g).copied().unwrap_or(0)) * size / self.height
    }
}

/// Width of the y label area: the widest tick label, the tick marks and the rotated axis text.
fn y_label_area<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    ticks: &Ticks,
    font: &TextStyle,
) -> Result<u32> {
    let mut widest = 0;
    for &v in &ticks.values {
        let (tw, _) = area
            .estimate_text_size(&ticks.label(v), font)
            .map_err(plot_err)?;
        widest = widest.max(tw);
    }
    // Slack (equal scaling may change the ticks), tick marks and gap, the rotated axis
    // description.
    Ok(widest + 6 + 12 + AXIS_DESC_PX + 6)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_ticks_are_round_and_inside() {
        let t = Ticks::nice(-0.4, 0.4, 6);
        assert_eq!(t.exp, 0);
        assert!(
            t.values
                .iter()
                .all(|v| *v >= -0.4 - 1e-12 && *v <= 0.4 + 1e-12)
        );
        let labels: Vec<String> = t.values.iter().map(|v| t.label(*v)).collect();
        assert!(labels.contains(&"0.0".to_string()), "{labels:?}");
        assert!(labels.contains(&"0.2".to_string()), "{labels:?}");

        let t = Ticks::nice(0.0, 90.0, 10);
        assert_eq!(
            t.values,
            vec![0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0]
        );
        assert_eq!(t.label(30.0), "30");

        let t = Ticks::nice(-2e-4, 3e-4, 6);
        assert_eq!(t.exp, -6);
        assert_eq!(t.describe("z1 [m]"), "z1 [m]  (×10⁻⁶)");
        assert_eq!(t.label(1e-4), "100");

        // 0.002 steps read fine as they are; 0.0025 steps get a factor.
        let t = Ticks::nice(-0.0106, 0.001, 6);
        assert_eq!((t.exp, t.label(-0.004)), (0, "−0.004".to_string()));
        let t = Ticks::nice(-0.0106, 0.001, 5);
        assert_eq!(t.exp, -3);
        assert_eq!(t.label(-0.005), "−5.0");

        let t = Ticks::nice(0.0, 2.5e5, 5);
        assert_eq!(t.exp, 3);
        assert_eq!(t.label(1e5), "100");
    }

    #[test]
    fn decimation_keeps_spikes_and_ends() {
        let mut pts: Vec<(f64, f64)> = (0..100_000).map(|i| (i as f64, 0.0)).collect();
        pts[54_321].1 = 7.0;
        pts[77_777].1 = -3.0;
        let d = decimate_min_max(&pts, MAX_DRAWN_POINTS);
        assert!(d.len() <= MAX_DRAWN_POINTS);
        assert_eq!(d.first(), pts.first());
        assert_eq!(d.last(), pts.last());
        assert!(d.iter().any(|p| p.1 == 7.0));
        assert!(d.iter().any(|p| p.1 == -3.0));
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0), "time order kept");
    }

    #[test]
    fn thinning_keeps_budget() {
        let pts: Vec<(f64, f64)> = (0..50_000)
            .map(|i| {
                let a = i as f64 * 1e-3;
                (a.cos(), a.sin())
            })
            .collect();
        let d = thin_path(&pts, 1000);
        assert!(d.len() <= 1000 && d.len() > 100, "{}", d.len());
    }

    #[test]
    fn clipping_cuts_at_the_box() {
        let pts = [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.5, 0.5)];
        let pieces = clip_polyline(&pts, (-1.0, 1.0), (-1.0, 1.0));
        assert_eq!(pieces.len(), 2);
        assert_eq!(pieces[0], vec![(0.0, 0.0), (1.0, 0.0)]);
        assert_eq!(pieces[1], vec![(1.0, 1.0), (0.5, 0.5)]);
        // Fully inside: unchanged.
        let inside = [(0.0, 0.0), (0.5, 0.5), (0.2, -0.3)];
        assert_eq!(
            clip_polyline(&inside, (-1.0, 1.0), (-1.0, 1.0)),
            vec![inside.to_vec()]
        );
    }

    #[test]
    fn constant_and_empty_data() {
        assert_eq!(pad_range((0.0, 0.0), 0.05), (-1.0, 1.0));
        let (lo, hi) = pad_range((2.0, 2.0), 0.05);
        assert!(lo < 2.0 && hi > 2.0);
        let t: [f64; 0] = [];
        let p = Panel::new("empty", "t [s]", "y").with(Series::new("e", &t, &t, Style::solid(0)));
        assert!(render_rgb("", &[p], 1, (300, 200)).is_err());
        let a = [1.0, 2.0];
        let b = [1.0];
        let p = Panel::new("ragged", "t [s]", "y").with(Series::new("r", &a, &b, Style::solid(0)));
        let e = render_rgb("", &[p], 1, (300, 200))
            .err()
            .map(|e| format!("{e:#}"));
        assert!(e.unwrap_or_default().contains("ragged"));
        assert!(render_rgb("", &[], 1, (300, 200)).is_err());
    }

    #[test]
    fn constant_series_renders() {
        let t = [0.0, 1.0, 2.0];
        let y = [0.0, 0.0, 0.0];
        let p =
            Panel::new("flat", "t [s]", "y [m]").with(Series::new("y", &t, &y, Style::solid(0)));
        let buf = render_rgb("", &[p], 1, (400, 300)).expect("renders");
        assert!(buf.iter().any(|&b| b != 255));
    }
}
