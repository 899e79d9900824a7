//! A self-contained animated SVG of a cooperative-manipulation run, to open in a browser.
//!
//! The animation uses SMIL `<animate>` elements (supported by Firefox, Chrome, Safari and Edge;
//! no script, no external file). Each moving element (arm polylines, the object polygon, the
//! desired point, the revealed trail) carries one `<animate>` whose `values` list has one entry
//! per key frame and whose `keyTimes` are the frames' simulation times scaled to `[0, 1]`;
//! `dur` is the simulated duration divided by the playback speed, and the animation loops.
//! Between key frames the browser interpolates linearly.
//!
//! - At most [`AnimOptions::max_frames`] key frames (default 300) are kept, evenly spaced over
//!   the given frames, always including the first and the last.
//! - Arms are polylines base → joints → end-effector with SVG markers (square base, round
//!   joints, dot end-effector), so markers follow the animated points for free.
//! - The object-centre trail (the centroid of the object polygon in every given frame, at full
//!   resolution, thinned to sub-pixel spacing) is revealed progressively with an animated
//!   `stroke-dashoffset`; viewers without SMIL show the first frame with the whole trail.
//! - The time label is one `<text>` per key frame made visible in turn (discrete animation of
//!   `visibility`), plus a progress bar.
//! - The initial attribute values are those of the first frame, so a static viewer shows a
//!   meaningful picture.
//!
//! World coordinates are metres, x right, y up; the SVG is in pixels, y down. Coordinates are
//! written with 0.1 px resolution, which keeps 300 frames of two arms at about 0.1–0.2 MB.
//!
//! The module knows nothing about the simulator: it takes plain point lists. It uses `output`
//! for the atomic write and `plot` for text measurement.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Result, bail};

use crate::files;

/// One instant of the animation.
#[derive(Clone, Debug, Default)]
pub struct Frame {
    /// Simulation time (s); strictly increasing across frames.
    pub t: f64,
    /// Per arm, the joint positions base, joint 2, …, end-effector (m) (world frame). Every
    /// frame must have the same number of arms and of points per arm.
    pub arms: Vec<Vec<[f64; 2]>>,
    /// The object outline (e.g. its 4 corners) (m); same vertex count in every frame. Its
    /// centroid makes the object-centre trail.
    pub object: Vec<[f64; 2]>,
    /// The desired object position x_d(t) (m), drawn as a moving orange ring if given (in every
    /// frame or in none).
    pub desired: Option<[f64; 2]>,
}

/// Everything an animation shows.
#[derive(Clone, Debug, Default)]
pub struct AnimFrames {
    /// The frames, in time order (e.g. one per log sample).
    pub frames: Vec<Frame>,
    /// The desired path as a static dashed polyline (m) (may be empty).
    pub desired_path: Vec<[f64; 2]>,
    /// The output constraint box `|x| < kx, |y| < ky` (m), drawn dashed, if given.
    pub bounds: Option<(f64, f64)>,
}

/// How the animation is rendered.
#[derive(Clone, Debug)]
pub struct AnimOptions {
    /// Playback speed: 1 plays in real time, 10 plays ten times faster. Must be > 0.
    pub speed: f64,
    /// At most this many key frames (at least 2). 300 keeps files small and motion smooth.
    pub max_frames: usize,
    /// Width of the drawing in pixels; the height follows from the scene's aspect ratio.
    pub width_px: u32,
    /// Title shown above the scene (may be empty).
    pub title: String,
}

impl Default for AnimOptions {
    fn default() -> Self {
        Self {
            speed: 1.0,
            max_frames: 300,
            width_px: 800,
            title: String::new(),
        }
    }
}

/// Writes the animation to `path` (atomically; see [`render_animated_svg`]).
pub fn animated_svg(path: &Path, frames: &AnimFrames, opts: &AnimOptions) -> Result<()> {
    let svg = render_animated_svg(frames, opts)?;
    files::write_text_atomic(path, &svg)
}

// Colours: matplotlib tab10, as in the figures.
const BLUE: &str = "#1f77b4";
const ORANGE: &str = "#ff7f0e";
const ARM_COLOURS: [&str; 6] = [
    "#2ca02c", "#9467bd", "#d62728", "#8c564b", "#e377c2", "#17becf",
];
const TEXT: &str = "#191919";

const MARGIN_PX: f64 = 20.0;
const HEADER_PX: f64 = 44.0;
const FOOTER_PX: f64 = 56.0;

/// Checks the frames; returns (arm point counts, object vertex count, has desired points).
fn validate(a: &AnimFrames, opts: &AnimOptions) -> Result<(Vec<usize>, usize, bool)> {
    let Some(first) = a.frames.first() else {
        bail!("the animation has no frames");
    };
    if !(opts.speed.is_finite() && opts.speed > 0.0) {
        bail!(
            "playback speed must be a positive number, got {}",
            opts.speed
        );
    }
    if opts.width_px < 100 {
        bail!(
            "animation width must be at least 100 px, got {}",
            opts.width_px
        );
    }
    let arm_shape: Vec<usize> = first.arms.iter().map(|a| a.len()).collect();
    if arm_shape.iter().any(|&n| n < 2) {
        bail!("every arm needs at least 2 points (base and end-effector)");
    }
    let n_obj = first.object.len();
    let has_desired = first.desired.is_some();
    let finite = |p: &[f64; 2]| p[0].is_finite() && p[1].is_finite();
    let mut prev_t = f64::NEG_INFINITY;
    for (k, f) in a.frames.iter().enumerate() {
        if !f.t.is_finite() || f.t <= prev_t {
            bail!(
                "frame {k}: time {} is not finite or not after the previous frame ({prev_t})",
                f.t
            );
        }
        prev_t = f.t;
        let shape: Vec<usize> = f.arms.iter().map(|a| a.len()).collect();
        if shape != arm_shape {
            bail!(
                "frame {k} (t = {}): arm point counts {shape:?} differ from frame 0's {arm_shape:?}",
                f.t
            );
        }
        if f.object.len() != n_obj {
            bail!(
                "frame {k} (t = {}): object has {} vertices, frame 0 has {n_obj}",
                f.t,
                f.object.len()
            );
        }
        if f.desired.is_some() != has_desired {
            bail!(
                "frame {k} (t = {}): the desired point must be given in every frame or in none",
                f.t
            );
        }
        let all_finite = f.arms.iter().flatten().all(finite)
            && f.object.iter().all(finite)
            && f.desired.as_ref().is_none_or(finite);
        if !all_finite {
            bail!("frame {k} (t = {}): a position is not finite", f.t);
        }
    }
    if a.desired_path.iter().any(|p| !finite(p)) {
        bail!("the desired path has a non-finite point");
    }
    if let Some((kx, ky)) = a.bounds
        && !(kx.is_finite() && ky.is_finite() && kx > 0.0 && ky > 0.0)
    {
        bail!("bounds ({kx}, {ky}) must be positive");
    }
    Ok((arm_shape, n_obj, has_desired))
}

/// Indices of at most `max` frames, evenly spread, including the first and the last.
fn key_indices(n: usize, max: usize) -> Vec<usize> {
    let max = max.max(2);
    if n <= max {
        return (0..n).collect();
    }
    let mut out: Vec<usize> = (0..max)
        .map(|k| ((k as f64) * (n - 1) as f64 / (max - 1) as f64).round() as usize)
        .collect();
    out.dedup();
    out
}

fn centroid(pts: &[[f64; 2]]) -> Option<[f64; 2]> {
    if pts.is_empty() {
        return None;
    }
    let n = pts.len() as f64;
    let (sx, sy) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), p| (a + p[0], b + p[1]));
    Some([sx / n, sy / n])
}

/// World (m, y up) → SVG (px, y down).
struct View {
    x0: f64,
    y1: f64,
    /// Pixels per metre.
    scale: f64,
    /// Pixel position of x0 and of y1.
    left: f64,
    top: f64,
}

impl View {
    fn px(&self, p: [f64; 2]) -> (f64, f64) {
        (
            self.left + (p[0] - self.x0) * self.scale,
            self.top + (self.y1 - p[1]) * self.scale,
        )
    }
}

/// A number with at most one decimal, without a trailing ".0".
fn n1(v: f64) -> String {
    let s = format!("{:.1}", v);
    let s = s.strip_suffix(".0").map(str::to_string).unwrap_or(s);
    if s == "-0" { String::from("0") } else { s }
}

fn points_attr(view: &View, pts: &[[f64; 2]]) -> String {
    let mut s = String::with_capacity(12 * pts.len());
    for (i, p) in pts.iter().enumerate() {
        let (x, y) = view.px(*p);
        if i > 0 {
            s.push(' ');
        }
        let _ = write!(s, "{},{}", n1(x), n1(y));
    }
    s
}

/// Escapes text for XML content and attribute values.
fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A nice scale-bar length (1, 2 or 5 × 10^k m) near `target` metres.
fn nice_length(target: f64) -> f64 {
    let mag = 10f64.powf(target.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * mag)
        .find(|&l| l <= target)
        .unwrap_or(mag)
}

/// Renders the animation as an SVG document (see the module docs).
pub fn render_animated_svg(a: &AnimFrames, opts: &AnimOptions) -> Result<String> {
    let (arm_shape, n_obj, has_desired) = validate(a, opts)?;
    let frames = &a.frames;
    let keys = key_indices(frames.len(), opts.max_frames);
    let t0 = frames[0].t;
    let t_end = frames[frames.len() - 1].t;
    let span = t_end - t0;
    let animated = keys.len() >= 2 && span > 0.0;

    // Scene extent: everything that is ever drawn.
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let mut grow = |p: &[f64; 2]| {
        for d in 0..2 {
            lo[d] = lo[d].min(p[d]);
            hi[d] = hi[d].max(p[d]);
        }
    };
    for f in frames {
        f.arms.iter().flatten().for_each(&mut grow);
        f.object.iter().for_each(&mut grow);
        if let Some(d) = &f.desired {
            grow(d);
        }
    }
    a.desired_path.iter().for_each(&mut grow);
    if let Some((kx, ky)) = a.bounds {
        grow(&[-kx, -ky]);
        grow(&[kx, ky]);
    }
    if !(lo[0].is_finite() && lo[1].is_finite()) {
        bail!("the animation has nothing to draw (no arm, object or path points)");
    }
    let size = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-6);
    let pad = 0.06 * size;
    let (x0, x1, y0, y1) = (lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad);
    let centres: Vec<[f64; 2]> = frames.iter().filter_map(|f| centroid(&f.object)).collect();
    let has_trail = centres.len() == frames.len() && centres.len() >= 2;
    let width = f64::from(opts.width_px);
    // Fit the width; a very tall scene is limited to 1.25 × the width, centred.
    let scale = ((width - 2.0 * MARGIN_PX) / (x1 - x0)).min(1.25 * width / (y1 - y0));
    let scene_h = (y1 - y0) * scale;
    let left = 0.5 * (width - (x1 - x0) * scale);
    // Legend: (sample kind, colour, label); kinds: line, dashed line, thick line, ring.
    let mut items: Vec<(&str, &str, String)> = Vec::new();
    if a.desired_path.len() >= 2 {
        items.push(("dashed", ORANGE, "desired path".into()));
    }
    if has_trail {
        items.push(("line", BLUE, "object centre".into()));
    }
    if has_desired {
        items.push(("ring", ORANGE, "desired x_d(t)".into()));
    }
    if a.bounds.is_some() {
        items.push(("dashed", "black", "bounds ±k_c".into()));
    }
    for arm in 0..arm_shape.len() {
        items.push((
            "arm",
            ARM_COLOURS[arm % ARM_COLOURS.len()],
            format!("arm {}", arm + 1),
        ));
    }
    // Lay the legend out in rows that fit the width (text measured with the embedded DejaVu Sans,
    // which the SVG names first).
    let item_w = |label: &str| 30.0 + crate::figures::plot::text_width_px(label, 13.0);
    let mut legend_rows = 1usize;
    let mut x = MARGIN_PX;
    let mut legend_pos = Vec::with_capacity(items.len());
    for (_, _, label) in &items {
        if x > MARGIN_PX && x + item_w(label) > width - MARGIN_PX {
            legend_rows += 1;
            x = MARGIN_PX;
        }
        legend_pos.push((x, legend_rows - 1));
        x += item_w(label) + 22.0;
    }
    let height = HEADER_PX + scene_h + FOOTER_PX + 22.0 * (legend_rows - 1) as f64;
    let view = View {
        x0,
        y1,
        scale,
        left,
        top: HEADER_PX,
    };

    let dur = format!("{:.3}s", span / opts.speed);
    let key_times: String = keys
        .iter()
        .enumerate()
        .map(|(j, &i)| {
            if j == 0 {
                String::from("0")
            } else if j + 1 == keys.len() {
                String::from("1")
            } else {
                format!("{:.5}", (frames[i].t - t0) / span)
            }
        })
        .collect::<Vec<_>>()
        .join(";");
    let animate = |attr: &str, values: &str| -> String {
        if animated {
            format!(
                "<animate attributeName=\"{attr}\" dur=\"{dur}\" repeatCount=\"indefinite\" \
                 calcMode=\"linear\" keyTimes=\"{key_times}\" values=\"{values}\"/>"
            )
        } else {
            String::new()
        }
    };

    let mut svg = String::with_capacity(256 * 1024);
    let (w, h) = (n1(width), n1(height));
    let _ = writeln!(svg, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="DejaVu Sans, Verdana, sans-serif" font-size="14">"#
    );
    let _ = writeln!(svg, "<title>{}</title>", xml_escape(&opts.title));
    let _ = writeln!(
        svg,
        "<desc>tandem animation: {} key frames of {}, simulated {:.3} s, played at {}x speed ({dur}, looping).</desc>",
        keys.len(),
        frames.len(),
        span,
        opts.speed
    );
    let _ = writeln!(
        svg,
        r##"<defs>
<marker id="base" viewBox="-6 -6 12 12" markerWidth="12" markerHeight="12" markerUnits="userSpaceOnUse"><rect x="-5" y="-5" width="10" height="10" fill="#444" stroke="{TEXT}" stroke-width="1"/></marker>
<marker id="joint" viewBox="-6 -6 12 12" markerWidth="12" markerHeight="12" markerUnits="userSpaceOnUse"><circle r="4.5" fill="white" stroke="{TEXT}" stroke-width="1.5"/></marker>
<marker id="ee" viewBox="-4 -4 8 8" markerWidth="8" markerHeight="8" markerUnits="userSpaceOnUse"><circle r="3" fill="{TEXT}"/></marker>
</defs>
<rect width="100%" height="100%" fill="white"/>"##
    );
    if !opts.title.is_empty() {
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="26" text-anchor="middle" font-size="18" fill="{TEXT}">{}</text>"#,
            n1(width / 2.0),
            xml_escape(&opts.title)
        );
    }

    // Static background: axes through the origin (if visible), bounds, desired path.
    let (ox, oy) = view.px([0.0, 0.0]);
    let (sx0, sy0) = view.px([x0, y1]);
    let (sx1, sy1) = view.px([x1, y0]);
    let _ = writeln!(
        svg,
        r##"<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#bbb" stroke-width="1"/>"##,
        n1(sx0),
        n1(sy0),
        n1(sx1 - sx0),
        n1(sy1 - sy0)
    );
    if (x0..=x1).contains(&0.0) {
        let _ = writeln!(
            svg,
            r##"<line x1="{0}" y1="{1}" x2="{0}" y2="{2}" stroke="#e2e2e2" stroke-width="1"/>"##,
            n1(ox),
            n1(sy0),
            n1(sy1)
        );
    }
    if (y0..=y1).contains(&0.0) {
        let _ = writeln!(
            svg,
            r##"<line x1="{1}" y1="{0}" x2="{2}" y2="{0}" stroke="#e2e2e2" stroke-width="1"/>"##,
            n1(oy),
            n1(sx0),
            n1(sx1)
        );
    }
    if let Some((kx, ky)) = a.bounds {
        let (bx0, by0) = view.px([-kx, ky]);
        let (bx1, by1) = view.px([kx, -ky]);
        let _ = writeln!(
            svg,
            r#"<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="black" stroke-width="1.5" stroke-dasharray="8 5"/>"#,
            n1(bx0),
            n1(by0),
            n1(bx1 - bx0),
            n1(by1 - by0)
        );
    }
    // The object-centre trail, revealed as time runs (dash of the full length, offset shrinking).
    if has_trail {
        let (trail, kept) = thin(&view, &centres, &keys);
        // Cumulative pixel length at each kept point.
        let mut cum = Vec::with_capacity(trail.len());
        let mut acc = 0.0;
        for (j, p) in trail.iter().enumerate() {
            if j > 0 {
                let (a, b) = (view.px(trail[j - 1]), view.px(*p));
                acc += (b.0 - a.0).hypot(b.1 - a.1);
            }
            cum.push(acc);
        }
        let total = acc + 1.0;
        let offsets: Vec<String> = keys
            .iter()
            .map(|&i| {
                // Key frames are always kept, so the lookup is exact.
                let j = kept.partition_point(|&k| k <= i).saturating_sub(1);
                n1(total - cum.get(j).copied().unwrap_or(0.0))
            })
            .collect();
        let _ = writeln!(
            svg,
            r#"<polyline points="{}" fill="none" stroke="{BLUE}" stroke-width="2" stroke-linejoin="round" stroke-dasharray="{t} {t}" stroke-dashoffset="0">{}</polyline>"#,
            points_attr(&view, &trail),
            animate("stroke-dashoffset", &offsets.join(";")),
            t = n1(total),
        );
    }

    if a.desired_path.len() >= 2 {
        let _ = writeln!(
            svg,
            r#"<polyline points="{}" fill="none" stroke="{ORANGE}" stroke-width="2" stroke-dasharray="8 5"/>"#,
            points_attr(&view, &thin(&view, &a.desired_path, &[]).0)
        );
    }

    // The object (under the arms, which hold it).
    if n_obj >= 2 {
        let values: Vec<String> = keys
            .iter()
            .map(|&i| points_attr(&view, &frames[i].object))
            .collect();
        let _ = writeln!(
            svg,
            r##"<polygon points="{}" fill="#9a9a9a" fill-opacity="0.55" stroke="{TEXT}" stroke-width="1.5" stroke-linejoin="round">{}</polygon>"##,
            values[0],
            animate("points", &values.join(";"))
        );
    }
    // The desired point.
    if has_desired {
        let pos: Vec<(f64, f64)> = keys
            .iter()
            .map(|&i| view.px(frames[i].desired.unwrap_or([0.0, 0.0])))
            .collect();
        let cx: Vec<String> = pos.iter().map(|p| n1(p.0)).collect();
        let cy: Vec<String> = pos.iter().map(|p| n1(p.1)).collect();
        let _ = writeln!(
            svg,
            r#"<circle cx="{}" cy="{}" r="6" fill="none" stroke="{ORANGE}" stroke-width="2.5">{}{}</circle>"#,
            cx[0],
            cy[0],
            animate("cx", &cx.join(";")),
            animate("cy", &cy.join(";"))
        );
    }
    // The arms.
    for (arm, _) in arm_shape.iter().enumerate() {
        let values: Vec<String> = keys
            .iter()
            .map(|&i| points_attr(&view, &frames[i].arms[arm]))
            .collect();
        let colour = ARM_COLOURS[arm % ARM_COLOURS.len()];
        let _ = writeln!(
            svg,
            r#"<polyline points="{}" fill="none" stroke="{colour}" stroke-width="7" stroke-opacity="0.85" stroke-linecap="round" stroke-linejoin="round" marker-start="url(#base)" marker-mid="url(#joint)" marker-end="url(#ee)">{}</polyline>"#,
            values[0],
            animate("points", &values.join(";"))
        );
    }

    // Footer: time label, progress bar, legend, scale bar.
    let foot = HEADER_PX + scene_h;
    let ty = foot + 22.0;
    if animated {
        for (j, &i) in keys.iter().enumerate() {
            let kt = |jj: usize| -> String {
                if jj + 1 == keys.len() {
                    String::from("1")
                } else {
                    format!("{:.5}", (frames[keys[jj]].t - t0) / span)
                }
            };
            let (values, times) = if j == 0 {
                ("visible;hidden".to_string(), format!("0;{}", kt(1)))
            } else if j + 1 == keys.len() {
                ("hidden;visible".to_string(), format!("0;{}", kt(j)))
            } else {
                (
                    "hidden;visible;hidden".to_string(),
                    format!("0;{};{}", kt(j), kt(j + 1)),
                )
            };
            let _ = writeln!(
                svg,
                r#"<text x="{}" y="{}" fill="{TEXT}" visibility="{}">t = {:.2} s<animate attributeName="visibility" dur="{dur}" repeatCount="indefinite" calcMode="discrete" keyTimes="{times}" values="{values}"/></text>"#,
                n1(MARGIN_PX),
                n1(ty),
                if j == 0 { "visible" } else { "hidden" },
                frames[i].t
            );
        }
        let bar_w = 120.0;
        let _ = writeln!(
            svg,
            r##"<rect x="{0}" y="{1}" width="{2}" height="4" fill="#e6e6e6"/><rect x="{0}" y="{1}" width="0" height="4" fill="{BLUE}"><animate attributeName="width" dur="{dur}" repeatCount="indefinite" values="0;{2}"/></rect>"##,
            n1(MARGIN_PX + 110.0),
            n1(ty - 9.0),
            n1(bar_w)
        );
    } else {
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{}" fill="{TEXT}">t = {:.2} s</text>"#,
            n1(MARGIN_PX),
            n1(ty),
            t0
        );
    }
    for ((kind, colour, label), (lx, row)) in items.into_iter().zip(legend_pos) {
        let ly = foot + 46.0 + 22.0 * row as f64;
        let (x0, x1, y) = (n1(lx), n1(lx + 24.0), n1(ly));
        let _ = match kind {
            "ring" => write!(
                svg,
                r#"<circle cx="{}" cy="{y}" r="5" fill="none" stroke="{colour}" stroke-width="2"/>"#,
                n1(lx + 12.0)
            ),
            "dashed" => write!(
                svg,
                r#"<line x1="{x0}" y1="{y}" x2="{x1}" y2="{y}" stroke="{colour}" stroke-width="2" stroke-dasharray="6 4"/>"#
            ),
            "arm" => write!(
                svg,
                r#"<line x1="{x0}" y1="{y}" x2="{x1}" y2="{y}" stroke="{colour}" stroke-width="6" stroke-linecap="round"/>"#
            ),
            _ => write!(
                svg,
                r#"<line x1="{x0}" y1="{y}" x2="{x1}" y2="{y}" stroke="{colour}" stroke-width="2"/>"#
            ),
        };
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{}" fill="{TEXT}" font-size="13">{}</text>"#,
            n1(lx + 30.0),
            n1(ly + 4.5),
            xml_escape(&label)
        );
    }
    // Scale bar, bottom right.
    let len_m = nice_length(0.2 * (x1 - x0));
    let len_px = len_m * scale;
    let bx1 = width - MARGIN_PX;
    let bx0 = bx1 - len_px;
    let _ = writeln!(
        svg,
        r#"<path d="M{0},{2}v5H{1}v-5" fill="none" stroke="{TEXT}" stroke-width="1.5"/><text x="{3}" y="{4}" text-anchor="middle" fill="{TEXT}" font-size="13">{5} m</text>"#,
        n1(bx0),
        n1(bx1),
        n1(ty - 9.0),
        n1(0.5 * (bx0 + bx1)),
        n1(ty + 14.0),
        len_m
    );
    svg.push_str("</svg>\n");
    Ok(svg)
}

/// Thins a polyline to points at least 0.75 px apart, always keeping the first and last points
/// and the indices in `keep` (sorted). Returns the points and their original indices.
fn thin(view: &View, pts: &[[f64; 2]], keep: &[usize]) -> (Vec<[f64; 2]>, Vec<usize>) {
    let tol = 0.75 / view.scale;
    let mut out = Vec::new();
    let mut idx = Vec::new();
    let mut next_keep = keep.iter().peekable();
    let mut last: Option<[f64; 2]> = None;
    for (i, p) in pts.iter().enumerate() {
        while next_keep.peek().is_some_and(|&&k| k < i) {
            next_keep.next();
        }
        let forced = i == 0 || i + 1 == pts.len() || next_keep.peek() == Some(&&i);
        let far = last.is_none_or(|l| (p[0] - l[0]).hypot(p[1] - l[1]) >= tol);
        if forced || far {
            out.push(*p);
            idx.push(i);
            last = Some(*p);
        }
    }
    (out, idx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_indices_cover_both_ends() {
        assert_eq!(key_indices(5, 300), vec![0, 1, 2, 3, 4]);
        let k = key_indices(3001, 300);
        assert_eq!(k.len(), 300);
        assert_eq!((k[0], k[299]), (0, 3000));
        assert!(k.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn rejects_inconsistent_frames() {
        let f = |t: f64, n: usize| Frame {
            t,
            arms: vec![vec![[0.0, 0.0]; n]],
            object: vec![[0.0, 0.0]; 4],
            desired: None,
        };
        let opts = AnimOptions::default();
        let bad = AnimFrames {
            frames: vec![f(0.0, 3), f(0.1, 2)],
            ..Default::default()
        };
        assert!(render_animated_svg(&bad, &opts).is_err());
        let bad_t = AnimFrames {
            frames: vec![f(0.0, 3), f(0.0, 3)],
            ..Default::default()
        };
        assert!(render_animated_svg(&bad_t, &opts).is_err());
        assert!(render_animated_svg(&AnimFrames::default(), &opts).is_err());
        let ok = AnimFrames {
            frames: vec![f(0.0, 3), f(0.1, 3)],
            ..Default::default()
        };
        assert!(render_animated_svg(&ok, &opts).is_ok());
        let slow = AnimOptions {
            speed: 0.0,
            ..AnimOptions::default()
        };
        assert!(render_animated_svg(&ok, &slow).is_err());
    }

    #[test]
    fn number_format_is_compact() {
        assert_eq!(n1(12.0), "12");
        assert_eq!(n1(12.345), "12.3");
        assert_eq!(n1(-0.01), "0");
    }
}
