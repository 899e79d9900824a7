//! The summary of a planar run (SPEC §5), computed from its [`Log`]: no I/O here, the CLI
//! writes it (`summary.json`).
//!
//! Inputs: the true pose the plant logs (`x_o.*`), the law's tracking error `z1` where it logs
//! one, the desired path, the scenario's bounds `k_c` and its transient. A driver whose record
//! has no `z1` columns (a user's own [`crate::drive::Drive`]) is measured against the desired
//! path: `z1 = x_o − x_d`, the same definition as the torque replay's.
//!
//! **Path error.** `z1 = x_1 − x_r` is measured against the admittance-shifted reference, so a
//! wrong force-sensor convention (which moves `x_r` with the measured wrench) does not show in
//! it. Every summary made with a path ([`summarize_with_path`]) also gives the distance of the
//! true pose to the **desired** path, `‖(x_o − x_d)_xy‖` (m) and `|θ_o − θ_d|` (rad).

use serde::Serialize;

use crate::drive::ControlEvents;
use crate::reference::planar::path::Path;
use crate::sim::torque_rate::TorqueRate;
use crate::sim::{Fault, Log, Outcome};

/// The summary of one run (`summary.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// Controller name (`nn`, `pd`, `ctc`, `replay`).
    pub controller: String,
    /// Gain preset or a description.
    pub gains: String,
    /// Simulated time reached, s.
    pub t_end: f64,
    /// Whether the run reached its full duration.
    pub completed: bool,
    /// The fault that stopped it, if any.
    pub fault: Option<Fault>,
    /// Start of the "after the transient" window, s.
    pub transient: f64,
    /// RMS of `‖z1_xy‖` (position part) over the whole run, m.
    pub rms_z1: f64,
    /// Max of `‖z1_xy‖` over the whole run, m.
    pub max_z1: f64,
    /// RMS of `‖z1_xy‖` after the transient, m.
    pub rms_z1_after: f64,
    /// Max of `‖z1_xy‖` after the transient, m.
    pub max_z1_after: f64,
    /// Max `|z1_θ|` after the transient, rad.
    pub max_z1_theta_after: f64,
    /// RMS of `‖(x_o − x_d)_xy‖`, the true position to the desired path, over the whole run, m
    /// (`None` without a path or logged rows; the `_after` ones also when no row is after the
    /// transient).
    pub rms_path_error: Option<f64>,
    /// Max of `‖(x_o − x_d)_xy‖` over the whole run, m.
    pub max_path_error: Option<f64>,
    /// RMS of `‖(x_o − x_d)_xy‖` after the transient, m.
    pub rms_path_error_after: Option<f64>,
    /// Max of `‖(x_o − x_d)_xy‖` after the transient, m.
    pub max_path_error_after: Option<f64>,
    /// RMS of `|θ_o − θ_d|` over the whole run, rad.
    pub rms_path_error_theta: Option<f64>,
    /// Max of `|θ_o − θ_d|` over the whole run, rad.
    pub max_path_error_theta: Option<f64>,
    /// RMS of `|θ_o − θ_d|` after the transient, rad.
    pub rms_path_error_theta_after: Option<f64>,
    /// Max of `|θ_o − θ_d|` after the transient, rad.
    pub max_path_error_theta_after: Option<f64>,
    /// First time after which `‖z1_xy‖ < 1 mm` for the rest of the run, s (`null` if never).
    pub settling_time_1mm: Option<f64>,
    /// Smallest constraint margin `1 − max_j |x_1j|/k_cj` of the true pose, over every control
    /// tick (over the logged rows for a replay).
    pub min_margin: f64,
    /// Control ticks ending with the true pose on or outside the bound (logged rows for a
    /// replay).
    pub violations: usize,
    /// RMS of `‖τ‖` (object wrench, force part), N.
    pub rms_wrench: f64,
    /// Peak of `‖τ_xy‖`, N.
    pub peak_wrench: f64,
    /// RMS of the wrench's change between log samples (a vibration measure), N.
    pub wrench_roughness: f64,
    /// RMS over joints and time of the joint torques, N m.
    pub rms_joint_torque: f64,
    /// Peak absolute joint torque, N m.
    pub peak_joint_torque: f64,
    /// Range of the grasp force components `[min, max]`, N.
    pub grasp_force_range: [f64; 2],
    /// Per output, the first time after which `‖Ŵ_j‖` stays within ±10 % of its final value, s.
    pub weight_settling_time: [Option<f64>; 3],
    /// Final weight norms.
    pub final_weight_norms: [f64; 3],
    /// Controller event counters.
    pub events: ControlEvents,
    /// Largest grasp-constraint drift, m.
    pub max_drift: f64,
    /// Wall time of the simulation loop, s.
    pub wall_time: f64,
    /// Simulated seconds per wall second.
    pub real_time_factor: f64,
    /// Torque rate and chattering of the applied joint torques, from every control tick
    /// ([`Outcome::torque_rate`]). Not serialized yet: `summary.json` is unchanged until the CLI
    /// adds its keys.
    #[serde(skip)]
    pub torque_rate: TorqueRate,
    /// Per joint, the ticks the actuator stage's limits acted on ([`Outcome::joint_limits`];
    /// `None` without the stage). Not serialized here: the CLI writes it as `joint_limits`.
    #[serde(skip)]
    pub joint_limits: Option<crate::drive::JointLimitCounts>,
}

fn col<'a>(log: &'a Log, name: &str) -> &'a [f64] {
    log.get(name).unwrap_or(&[])
}

/// Compute the summary of a run without its desired path (no path-error metrics; the log must
/// have `z1` columns for the tracking metrics, else they are NaN); `k_c` the output bounds,
/// `transient` the start of the steady-state window (s).
pub fn summarize(
    out: &Outcome,
    controller: &str,
    gains: &str,
    k_c: [f64; 3],
    transient: f64,
    duration: f64,
) -> Summary {
    summarize_inner(out, None, controller, gains, k_c, transient, duration)
}

/// Compute the summary of a run against its desired `path`: everything [`summarize`] gives, the
/// distance of the true pose to the path (`*_path_error*`), and, for a driver that logs no
/// `z1` (a user's own `Drive`), the tracking metrics from `z1 = x_o − x_d`.
pub fn summarize_with_path(
    out: &Outcome,
    path: &Path,
    controller: &str,
    gains: &str,
    k_c: [f64; 3],
    transient: f64,
    duration: f64,
) -> Summary {
    summarize_inner(out, Some(path), controller, gains, k_c, transient, duration)
}

/// `(x_o − x_d)` per logged row, three columns (empty without the pose columns).
fn to_path(log: &Log, t: &[f64], path: &Path) -> [Vec<f64>; 3] {
    let n = t.len();
    let xo = [col(log, "x_o.x"), col(log, "x_o.y"), col(log, "x_o.theta")];
    if xo.iter().any(|c| c.len() != n) {
        return [Vec::new(), Vec::new(), Vec::new()];
    }
    let mut e = [
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    ];
    for (k, &tk) in t.iter().enumerate() {
        let p = path.sample(tk).p;
        for j in 0..3 {
            e[j].push(xo[j][k] - p[j]);
        }
    }
    e
}

fn summarize_inner(
    out: &Outcome,
    path: Option<&Path>,
    controller: &str,
    gains: &str,
    k_c: [f64; 3],
    transient: f64,
    duration: f64,
) -> Summary {
    let log = &out.log;
    let t = col(log, "t");
    let n = t.len();
    // The true pose against the desired path (empty without a path).
    let ep = path.map(|p| to_path(log, t, p));
    let has_z1 = ["z1.x", "z1.y", "z1.theta"]
        .iter()
        .all(|c| col(log, c).len() == n);
    let nan = vec![f64::NAN; n];
    let (zx, zy, zt) = match (&ep, has_z1) {
        (_, true) => (col(log, "z1.x"), col(log, "z1.y"), col(log, "z1.theta")),
        (Some(e), false) if e[0].len() == n => (&e[0][..], &e[1][..], &e[2][..]),
        _ => (&nan[..], &nan[..], &nan[..]),
    };
    let e: Vec<f64> = (0..n).map(|k| zx[k].hypot(zy[k])).collect();
    let rms = |v: &[f64]| {
        if v.is_empty() {
            0.0
        } else {
            (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
        }
    };
    let maxabs = |v: &[f64]| v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let after = t.iter().position(|&x| x >= transient).unwrap_or(n);
    let settling = match e.iter().rposition(|&x| x >= 1e-3) {
        None => Some(t.first().copied().unwrap_or(0.0)),
        Some(k) if k + 1 < n => Some(t[k + 1]),
        _ => None,
    };
    // Margins from the true pose.
    let (xo, yo, to) = (col(log, "x_o.x"), col(log, "x_o.y"), col(log, "x_o.theta"));
    let mut min_margin = f64::INFINITY;
    let mut violations = 0;
    for k in 0..n {
        let m = [xo[k] / k_c[0], yo[k] / k_c[1], to[k] / k_c[2]]
            .iter()
            .fold(f64::INFINITY, |a, r| a.min(1.0 - r.abs()));
        if m <= 0.0 {
            violations += 1;
        }
        min_margin = min_margin.min(m);
    }
    // Distance of the true pose to the desired path.
    let (mut pe, mut pt) = (None, None);
    if let Some(e) = ep.as_ref().filter(|e| e[0].len() == n) {
        pe = Some((0..n).map(|k| e[0][k].hypot(e[1][k])).collect::<Vec<f64>>());
        pt = Some(e[2].iter().map(|x| x.abs()).collect::<Vec<f64>>());
    }
    let stat = |v: &Option<Vec<f64>>, f: &dyn Fn(&[f64]) -> f64, from: usize| {
        v.as_ref().filter(|v| from < v.len()).map(|v| f(&v[from..]))
    };
    // The commanded wrench (NaN, `null` in JSON, for a driver that logs none).
    let (wx, wy) = match (col(log, "tau.x"), col(log, "tau.y")) {
        (x, y) if x.len() == n && y.len() == n => (x, y),
        _ => (&nan[..], &nan[..]),
    };
    let w: Vec<f64> = (0..n).map(|k| wx[k].hypot(wy[k])).collect();
    let dw: Vec<f64> = (1..n)
        .map(|k| (wx[k] - wx[k - 1]).hypot(wy[k] - wy[k - 1]))
        .collect();
    let mut tq_sq = 0.0;
    let mut tq_n = 0usize;
    let mut tq_peak = 0.0f64;
    let mut f_min = f64::INFINITY;
    let mut f_max = f64::NEG_INFINITY;
    for c in &log.columns {
        if c.name.starts_with("tau_q") {
            for v in &c.data {
                tq_sq += v * v;
                tq_n += 1;
                tq_peak = tq_peak.max(v.abs());
            }
        }
        if c.name.starts_with('F') && !c.name.starts_with("F_meas") {
            for v in &c.data {
                f_min = f_min.min(*v);
                f_max = f_max.max(*v);
            }
        }
    }
    let mut w_settle = [None; 3];
    let mut w_final = [0.0; 3];
    for (j, a) in ["x", "y", "theta"].iter().enumerate() {
        let v = col(log, &format!("w_norm.{a}"));
        if let Some(&last) = v.last() {
            w_final[j] = last;
            let band = 0.1 * last.abs();
            w_settle[j] = if last == 0.0 {
                None
            } else {
                match v.iter().rposition(|&x| (x - last).abs() > band) {
                    None => Some(t[0]),
                    Some(k) if k + 1 < n => Some(t[k + 1]),
                    _ => None,
                }
            };
        }
    }
    Summary {
        controller: controller.to_string(),
        gains: gains.to_string(),
        t_end: out.t_end,
        completed: out.fault.is_none() && out.t_end >= duration - 1e-9,
        fault: out.fault.clone(),
        transient,
        rms_z1: rms(&e),
        max_z1: maxabs(&e),
        rms_z1_after: rms(&e[after..]),
        max_z1_after: maxabs(&e[after..]),
        max_z1_theta_after: maxabs(&zt[after.min(zt.len())..]),
        rms_path_error: stat(&pe, &rms, 0),
        max_path_error: stat(&pe, &maxabs, 0),
        rms_path_error_after: stat(&pe, &rms, after),
        max_path_error_after: stat(&pe, &maxabs, after),
        rms_path_error_theta: stat(&pt, &rms, 0),
        max_path_error_theta: stat(&pt, &maxabs, 0),
        rms_path_error_theta_after: stat(&pt, &rms, after),
        max_path_error_theta_after: stat(&pt, &maxabs, after),
        settling_time_1mm: if n == 0 { None } else { settling },
        min_margin: out.min_margin.map_or(min_margin, |m| m.min(min_margin)),
        violations: if out.min_margin.is_some() {
            out.violation_ticks as usize
        } else {
            violations
        },
        rms_wrench: rms(&w),
        peak_wrench: maxabs(&w),
        wrench_roughness: rms(&dw),
        rms_joint_torque: if tq_n > 0 {
            (tq_sq / tq_n as f64).sqrt()
        } else {
            0.0
        },
        peak_joint_torque: tq_peak,
        grasp_force_range: [f_min, f_max],
        weight_settling_time: w_settle,
        final_weight_norms: w_final,
        events: out.events,
        max_drift: out.max_drift,
        wall_time: out.wall_time,
        real_time_factor: if out.wall_time > 0.0 {
            out.t_end / out.wall_time
        } else {
            f64::INFINITY
        },
        torque_rate: out.torque_rate.clone(),
        joint_limits: out.joint_limits.clone(),
    }
}
