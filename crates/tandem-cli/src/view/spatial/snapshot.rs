//! Static snapshots of a [`Scene3d`]: three orthographic views (front, side, top) of the start
//! pose (faded) and the end pose (solid), with the object box, the desired and traced object
//! paths, the table line and metre axes, in the house style of [`crate::figures::plot`] (PNG + SVG,
//! each written atomically).
//!
//! Views (world frame, z up): **front** looks along +y (x to the right, z up), **side** looks
//! along −x (y to the right, z up), **top** looks along −z (x to the right, y up).

use std::path::Path;

use anyhow::{Result, bail};

use super::{Scene3d, frame_valid};
use crate::figures::plot::{self, Colour, PALETTE, Panel, Series, Style};

/// One orthographic view: file stem, title, the two world axes shown (index, label).
struct View {
    stem: &'static str,
    title: &'static str,
    h: (usize, &'static str),
    v: (usize, &'static str),
}

const VIEWS: [View; 3] = [
    View {
        stem: "snapshot_front",
        title: "front (looking along +y)",
        h: (0, "x [m]"),
        v: (2, "z [m]"),
    },
    View {
        stem: "snapshot_side",
        title: "side (looking along −x)",
        h: (1, "y [m]"),
        v: (2, "z [m]"),
    },
    View {
        stem: "snapshot_top",
        title: "top (looking along −z)",
        h: (0, "x [m]"),
        v: (1, "y [m]"),
    },
];

/// Palette indices: arms (cycled), box, desired, traced.
const ARM_COLOURS: [usize; 4] = [4, 8, 7, 6];
const BOX_COLOUR: usize = 5;

/// `c` mixed with white (`a` = share of white), for the faded start pose.
fn faded(i: usize, a: f64) -> Colour {
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    let m = |c: u8| (f64::from(c) + (255.0 - f64::from(c)) * a).round() as u8;
    Colour::Rgb(m(r), m(g), m(b))
}

/// Polyline buffers: points separated by NaN (which breaks the line).
#[derive(Default)]
struct Lines {
    x: Vec<f64>,
    y: Vec<f64>,
}

impl Lines {
    fn push_run(&mut self, pts: &[[f64; 3]], h: usize, v: usize) {
        if !self.x.is_empty() {
            self.x.push(f64::NAN);
            self.y.push(f64::NAN);
        }
        for p in pts {
            self.x.push(p[h]);
            self.y.push(p[v]);
        }
    }
}

fn rotate(q: &[f64; 4], v: [f64; 3]) -> [f64; 3] {
    let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
    // v + 2 w (u × v) + 2 u × (u × v), u = (x, y, z).
    let c1 = [
        y * v[2] - z * v[1],
        z * v[0] - x * v[2],
        x * v[1] - y * v[0],
    ];
    let c2 = [
        y * c1[2] - z * c1[1],
        z * c1[0] - x * c1[2],
        x * c1[1] - y * c1[0],
    ];
    [
        v[0] + 2.0 * (w * c1[0] + c2[0]),
        v[1] + 2.0 * (w * c1[1] + c2[1]),
        v[2] + 2.0 * (w * c1[2] + c2[2]),
    ]
}

/// The 12 edges of the box at a pose, as 2-point runs.
fn box_edges(size: &[f64; 3], pose: &([f64; 3], [f64; 4])) -> Vec<[[f64; 3]; 2]> {
    let h = [size[0] / 2.0, size[1] / 2.0, size[2] / 2.0];
    let corner = |i: usize| {
        let l = [
            if i & 1 == 0 { -h[0] } else { h[0] },
            if i & 2 == 0 { -h[1] } else { h[1] },
            if i & 4 == 0 { -h[2] } else { h[2] },
        ];
        let r = rotate(&pose.1, l);
        [r[0] + pose.0[0], r[1] + pose.0[1], r[2] + pose.0[2]]
    };
    let mut e = Vec::with_capacity(12);
    for i in 0..8usize {
        for bit in [1usize, 2, 4] {
            if i & bit == 0 {
                e.push([corner(i), corner(i | bit)]);
            }
        }
    }
    e
}

/// The chain of points drawn for arm `a` at frame `k`: base, joint origins, tool origin.
fn arm_points(scene: &Scene3d, a: usize, k: usize) -> Vec<[f64; 3]> {
    let arm = &scene.arms[a];
    let mut pts = vec![arm.base];
    pts.extend(arm.joints[k].iter().copied());
    pts.push(arm.tool[k].0);
    pts
}

/// A pad's disc outline (16 segments) and its pressing direction, drawn from the face out
/// (3 cm), world frame, as one run; `p`, `q`: the tool frame.
fn pad_outline(pd: &super::PadTrack, p: [f64; 3], q: &[f64; 4]) -> Vec<[f64; 3]> {
    let c = rotate(q, pd.position);
    let c = [c[0] + p[0], c[1] + p[1], c[2] + p[2]];
    let n = rotate(q, pd.normal);
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-12);
    let n = [n[0] / len, n[1] / len, n[2] / len];
    // Two unit tangents: n × (the axis least aligned with n), then n × u.
    let k = (0..3)
        .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
        .unwrap_or(0);
    let mut e = [0.0; 3];
    e[k] = 1.0;
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let u = cross(n, e);
    let ul = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt().max(1e-12);
    let u = [u[0] / ul, u[1] / ul, u[2] / ul];
    let w = cross(n, u);
    let mut pts: Vec<[f64; 3]> = (0..=16)
        .map(|j| {
            let a = std::f64::consts::TAU * f64::from(j) / 16.0;
            let (s, co) = a.sin_cos();
            std::array::from_fn(|i| c[i] + pd.radius * (co * u[i] + s * w[i]))
        })
        .collect();
    // Back to the centre, then out along −n (the finger's side).
    pts.push(c);
    pts.push(std::array::from_fn(|i| c[i] - 0.03 * n[i]));
    pts
}

/// See [`super::write_snapshots`].
pub fn write(scene: &Scene3d, dir: &Path) -> Result<()> {
    let valid: Vec<usize> = (0..scene.times.len())
        .filter(|&k| frame_valid(scene, k))
        .collect();
    let (Some(&k0), Some(&k1)) = (valid.first(), valid.last()) else {
        bail!("the scene has no frame with finite values: nothing to draw");
    };
    let (t0, t1) = (scene.times[k0], scene.times[k1]);
    let frames: Vec<(usize, bool)> = if k0 == k1 {
        vec![(k1, true)]
    } else {
        vec![(k0, false), (k1, true)]
    };
    for view in &VIEWS {
        let (h, v) = (view.h.0, view.v.0);
        // Owned buffers first; the panel borrows them.
        let mut bufs: Vec<(String, Lines, Style)> = Vec::new();
        // Table (z = 0) in the views that show z: a line across the arms' reach.
        if v == 2 {
            let mut lo = f64::INFINITY;
            let mut hi = f64::NEG_INFINITY;
            for a in 0..scene.arms.len() {
                for &(k, _) in &frames {
                    for p in arm_points(scene, a, k) {
                        lo = lo.min(p[h]);
                        hi = hi.max(p[h]);
                    }
                }
            }
            let pad = 0.3;
            let l = Lines {
                x: vec![lo - pad, hi + pad],
                y: vec![0.0, 0.0],
            };
            bufs.push((
                "table z = 0".into(),
                l,
                Style {
                    colour: Colour::Rgb(120, 120, 120),
                    dashed: false,
                    width: 1,
                },
            ));
        }
        if !scene.desired_path.is_empty() {
            let mut l = Lines::default();
            l.push_run(&scene.desired_path, h, v);
            bufs.push(("desired path".into(), l, Style::dashed(1)));
        }
        {
            let traced: Vec<[f64; 3]> = scene.object.poses[..=k1]
                .iter()
                .map(|p| p.0)
                .filter(|p| p.iter().all(|x| x.is_finite()))
                .collect();
            let mut l = Lines::default();
            l.push_run(&traced, h, v);
            bufs.push((
                format!("object path to t = {t1:.2} s"),
                l,
                Style::solid(0).width(1),
            ));
        }
        for &(k, end) in &frames {
            let when = if end {
                format!("t = {:.2} s", scene.times[k])
            } else {
                format!("t = {:.2} s, faded", scene.times[k])
            };
            let mut l = Lines::default();
            for e in box_edges(&scene.object.size, &scene.object.poses[k]) {
                l.push_run(&e, h, v);
            }
            let style = Style {
                colour: if end {
                    Colour::Palette(BOX_COLOUR)
                } else {
                    faded(BOX_COLOUR, 0.6)
                },
                dashed: false,
                width: 2,
            };
            bufs.push((format!("box, {when}"), l, style));
            for a in 0..scene.arms.len() {
                let c = ARM_COLOURS[a % ARM_COLOURS.len()];
                let mut l = Lines::default();
                l.push_run(&arm_points(scene, a, k), h, v);
                let style = Style {
                    colour: if end {
                        Colour::Palette(c)
                    } else {
                        faded(c, 0.6)
                    },
                    dashed: false,
                    width: if end { 4 } else { 3 },
                };
                bufs.push((format!("{}, {when}", scene.arms[a].name), l, style));
            }
        }
        // Tool frames of the end pose: x red, y green, z blue, 8 cm.
        for (axis, rgb, name) in [
            (0usize, (214u8, 39u8, 40u8), "tool x"),
            (1, (44, 160, 44), "tool y"),
            (2, (31, 119, 180), "tool z"),
        ] {
            let mut l = Lines::default();
            for arm in &scene.arms {
                let (p, q) = arm.tool[k1];
                let mut u = [0.0; 3];
                u[axis] = 0.08;
                let d = rotate(&q, u);
                l.push_run(&[p, [p[0] + d[0], p[1] + d[1], p[2] + d[2]]], h, v);
            }
            bufs.push((
                name.into(),
                l,
                Style {
                    colour: Colour::Rgb(rgb.0, rgb.1, rgb.2),
                    dashed: false,
                    width: 2,
                },
            ));
        }
        // Pads of the end pose, grouped by their state then: each an outline of its disc
        // (true size) and its pressing direction (3 cm, out of the face toward the finger).
        for (code, name, rgb) in [
            (0.0, "pads: stick", (0u8, 110u8, 60u8)),
            (1.0, "pads: slip", (255, 127, 14)),
            (2.0, "pads: separated", (214, 39, 40)),
        ] {
            let mut l = Lines::default();
            for pd in &scene.pads {
                let Some(arm) = scene.arms.get(pd.arm) else {
                    continue;
                };
                let state = pd.state.get(k1).copied().unwrap_or(f64::NAN);
                if state != code {
                    continue;
                }
                let (p, q) = arm.tool[k1];
                l.push_run(&pad_outline(pd, p, &q), h, v);
            }
            if !l.x.is_empty() {
                bufs.push((
                    name.into(),
                    l,
                    Style {
                        colour: Colour::Rgb(rgb.0, rgb.1, rgb.2),
                        dashed: false,
                        width: 3,
                    },
                ));
            }
        }
        let mut panel = Panel::new(view.title, view.h.1, view.v.1).equal_aspect();
        for (label, l, style) in &bufs {
            panel = panel.with(Series::new(label.clone(), &l.x, &l.y, *style));
        }
        let title = if k0 == k1 {
            format!("{}: t = {t1:.2} s", scene.title)
        } else {
            format!("{}: t = {t0:.2} s (faded) and {t1:.2} s", scene.title)
        };
        // Size the figure to the data's aspect (the axes are equally scaled), so the view is
        // not padded with empty metres: about 200 px of titles, legend and labels above and
        // below the axes, 100 px beside them.
        let mut ext = [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for (_, l, _) in &bufs {
            for (x, y) in l.x.iter().zip(&l.y) {
                if x.is_finite() && y.is_finite() {
                    ext = [
                        ext[0].min(*x),
                        ext[1].max(*x),
                        ext[2].min(*y),
                        ext[3].max(*y),
                    ];
                }
            }
        }
        let aspect = ((ext[3] - ext[2]) / (ext[1] - ext[0]).max(1e-6)).clamp(0.35, 1.0);
        let legend_rows = bufs.len().div_ceil(4) as f64;
        let height = (150.0 + 21.0 * legend_rows + 800.0 * aspect).round() as u32;
        plot::panels_sized(&dir.join(view.stem), &title, &[panel], 1, (900, height))?;
    }
    Ok(())
}
