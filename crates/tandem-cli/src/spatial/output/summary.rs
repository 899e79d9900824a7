//! `summary.json` of a spatial run: the metrics of SPEC §5 on six outputs and the SPEC-spatial
//! S5/S7 claims, `null` plus a reason for what this run does not have.

use nalgebra::Vector3;
use serde_json::{Map, Value, json};
use tandem::control::spatial::{AXES, WRENCH_AXES};

use super::{CLAIM_Z1_P, CLAIM_Z1_ROT, Derived, Finished, TRANSIENT, col, six};

/// `(rms, max)` of `v` over the rows with `t ≥ from` (`None` when there is none).
fn rms_max(t: &[f64], v: &[f64], from: f64) -> Option<(f64, f64)> {
    let (mut ss, mut mx, mut n) = (0.0, 0.0f64, 0usize);
    for (tk, x) in t.iter().zip(v) {
        if *tk >= from {
            ss += x * x;
            mx = mx.max(x.abs());
            n += 1;
        }
    }
    (n > 0).then(|| ((ss / n as f64).sqrt(), mx))
}

/// `(min, max)` of `v` (`None` when empty).
fn range(v: impl IntoIterator<Item = f64>) -> Option<(f64, f64)> {
    v.into_iter().fold(None, |a, x| match a {
        None => Some((x, x)),
        Some((lo, hi)) => Some((lo.min(x), hi.max(x))),
    })
}

/// The first logged time after which `v < limit` for the rest of the run (`None`: never).
fn settling(t: &[f64], v: &[f64], limit: f64) -> Option<f64> {
    match v.iter().rposition(|&x| x >= limit) {
        None => t.first().copied(),
        Some(k) if k + 1 < v.len() => Some(t[k + 1]),
        _ => None,
    }
}

/// Norms of the linear and angular halves of six columns, per row.
fn norms(c: &[&[f64]; 6]) -> (Vec<f64>, Vec<f64>) {
    let n = c[0].len();
    (
        (0..n)
            .map(|k| Vector3::new(c[0][k], c[1][k], c[2][k]).norm())
            .collect(),
        (0..n)
            .map(|k| Vector3::new(c[3][k], c[4][k], c[5][k]).norm())
            .collect(),
    )
}

/// Builds the summary object: values go in with [`Sum::put`]; a missing one is written `null`
/// and its reason recorded in `unavailable`.
struct Sum {
    m: Map<String, Value>,
    why: Map<String, Value>,
}

impl Sum {
    fn put(&mut self, key: &str, v: Value) {
        self.m.insert(key.into(), v);
    }
    /// A number, or `null` with `reason` (also when the number is not finite).
    fn num(&mut self, key: &str, v: Option<f64>, reason: &str) {
        match v {
            Some(x) if x.is_finite() => self.put(key, json!(x)),
            Some(_) => self.null(key, "not a finite number"),
            None => self.null(key, reason),
        }
    }
    fn null(&mut self, key: &str, reason: &str) {
        self.m.insert(key.into(), Value::Null);
        self.why.insert(key.into(), json!(reason));
    }
}

/// A JSON number or `null` (non-finite).
fn jn(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

/// The content of `summary.json` (SPEC §5 on six outputs and SPEC-spatial S5/S7): metrics with
/// their unit in the key (`_m`, `_rad`, `_s`, `_N`, `_Nm`; no suffix: dimensionless or a count),
/// `null` plus a reason in `unavailable` for a metric this run does not have, and the wall
/// times under `timing` (the only part that differs between two runs of the same scenario).
pub fn summary(scenario: &str, f: &Finished, d: &Derived, output_time: Option<f64>) -> Value {
    let log = &f.outcome.log;
    let o = &f.outcome;
    let t = &d.t;
    let n = log.len();
    let mut s = Sum {
        m: Map::new(),
        why: Map::new(),
    };
    let t_end = t.last().copied();
    let no_rows = "no logged rows";
    let short = format!("the run ends before the transient window (from {TRANSIENT} s)");
    let short = short.as_str();
    s.put("scenario", json!(scenario));
    s.put("label", json!(f.label));
    s.put("controller", json!(f.controller));
    s.put("tandem_version", json!(env!("CARGO_PKG_VERSION")));
    s.put("duration_s", jn(f.duration));
    s.put("t_end_s", jn(o.t_end));
    s.put("rows", json!(n));
    s.put(
        "status",
        json!(if o.fault.is_some() {
            "fault"
        } else {
            "completed"
        }),
    );
    s.put("fault", json!(o.fault.as_ref().map(|e| e.to_string())));
    s.put("warnings", json!(f.warnings));
    s.put(
        "events",
        json!({
            "barrier_hits": o.events.barrier_hits,
            "torque_clips": o.events.torque_clips,
            "non_finite": o.events.non_finite,
            "degenerate": o.events.degenerate,
        }),
    );
    s.put("violation_ticks", json!(o.violation_ticks));
    s.put("regularised", json!(o.regularised));
    s.num(
        "min_margin",
        o.min_margin,
        "the controller defines no output bounds",
    );
    s.put(
        "k_c",
        json!({ "x_m": f.k_c[0], "y_m": f.k_c[1], "z_m": f.k_c[2],
        "rx_rad": f.k_c[3], "ry_rad": f.k_c[4], "rz_rad": f.k_c[5] }),
    );
    s.put("max_drift_m", jn(o.max_drift));
    s.put("max_drift_rad", jn(o.max_drift_rot));
    s.put("transient_s", json!(TRANSIENT));

    // Tracking error z1 = x_1 − x_r.
    let after = |v: &[f64]| rms_max(t, v, TRANSIENT);
    let whole = |v: &[f64]| rms_max(t, v, f64::NEG_INFINITY);
    let have_z1 = d.z1_p.len() == n && n > 0;
    let z1_why = if n == 0 {
        no_rows
    } else {
        "the log has no z1 columns"
    };
    let (zp_w, zp_a, zr_a) = if have_z1 {
        (whole(&d.z1_p), after(&d.z1_p), after(&d.z1_rot))
    } else {
        (None, None, None)
    };
    let why_after = if have_z1 { short } else { z1_why };
    s.num("z1_p_rms_m", zp_w.map(|v| v.0), z1_why);
    s.num("z1_p_max_m", zp_w.map(|v| v.1), z1_why);
    s.num("z1_p_rms_after_2s_m", zp_a.map(|v| v.0), why_after);
    s.num("z1_p_max_after_2s_m", zp_a.map(|v| v.1), why_after);
    s.num("z1_rot_rms_after_2s_rad", zr_a.map(|v| v.0), why_after);
    s.num("z1_rot_max_after_2s_rad", zr_a.map(|v| v.1), why_after);
    let mut per_axis = Map::new();
    if let (Some(z), true) = (six(log, "z1", &AXES), zp_a.is_some()) {
        for (j, a) in AXES.iter().enumerate() {
            let u = if j < 3 { "m" } else { "rad" };
            per_axis.insert(
                format!("{a}_{u}"),
                jn(after(z[j]).map_or(f64::NAN, |v| v.1)),
            );
        }
        s.put("z1_max_abs_after_2s", Value::Object(per_axis));
    } else {
        s.null("z1_max_abs_after_2s", why_after);
    }
    if have_z1 {
        s.num(
            "settling_time_1mm_s",
            settling(t, &d.z1_p, 1e-3),
            "never: ‖z1_p‖ is not below 1 mm for the rest of the run",
        );
    } else {
        s.null("settling_time_1mm_s", z1_why);
    }
    // SPEC-spatial S5 claims.
    let claim = |v: Option<(f64, f64)>, lim: f64, unit: &str| match v {
        Some((_, mx)) if mx.is_finite() => json!({
            format!("max_{unit}"): mx, format!("limit_{unit}"): lim, "pass": mx < lim }),
        _ => json!({ format!("max_{unit}"): null, format!("limit_{unit}"): lim, "pass": false }),
    };
    let (cp, cr) = (
        claim(zp_a, CLAIM_Z1_P, "m"),
        claim(zr_a, CLAIM_Z1_ROT, "rad"),
    );
    let pass = cp["pass"] == json!(true)
        && cr["pass"] == json!(true)
        && o.fault.is_none()
        && o.violation_ticks == 0;
    s.put(
        "s5_claims",
        json!({
            "z1_p_after_2s": cp,
            "z1_rot_after_2s": cr,
            "completed_without_violation": o.fault.is_none() && o.violation_ticks == 0,
            "pass": pass,
        }),
    );

    // Orientation error as an angle.
    let ang = col(log, "angle_error");
    match (ang.len() == n && n > 0).then(|| after(ang)).flatten() {
        Some((r, m)) => {
            s.put("orientation_error_rms_after_2s_rad", jn(r));
            s.put("orientation_error_max_after_2s_rad", jn(m));
        }
        None => {
            let why = if ang.len() == n && n > 0 {
                short
            } else {
                "the log has no angle_error column"
            };
            s.null("orientation_error_rms_after_2s_rad", why);
            s.null("orientation_error_max_after_2s_rad", why);
        }
    }
    s.num(
        "orientation_error_to_desired_max_after_2s_rad",
        (d.angle_to_desired.len() == n)
            .then(|| after(&d.angle_to_desired))
            .flatten()
            .map(|v| v.1),
        if n == 0 { no_rows } else { short },
    );

    // The commanded object wrench.
    match six(log, "tau", &WRENCH_AXES).filter(|_| n > 0) {
        Some(w) => {
            let (fv, tv) = norms(&w);
            let (fr, fm) = whole(&fv).unwrap_or((f64::NAN, f64::NAN));
            let (tr, tm) = whole(&tv).unwrap_or((f64::NAN, f64::NAN));
            s.put("wrench_force_rms_N", jn(fr));
            s.put("wrench_force_peak_N", jn(fm));
            s.put("wrench_torque_rms_Nm", jn(tr));
            s.put("wrench_torque_peak_Nm", jn(tm));
        }
        None => {
            for k in [
                "wrench_force_rms_N",
                "wrench_force_peak_N",
                "wrench_torque_rms_Nm",
                "wrench_torque_peak_Nm",
            ] {
                s.null(
                    k,
                    if n == 0 {
                        no_rows
                    } else {
                        "the log has no commanded wrench (tau.*)"
                    },
                );
            }
        }
    }

    // Joint torques.
    let (mut sq, mut cnt, mut peak, mut peak_at) = (0.0, 0usize, 0.0f64, None);
    for c in &log.columns {
        if let Some(k) = c.name.strip_prefix("tau_q") {
            for v in &c.data {
                sq += v * v;
                cnt += 1;
                if v.abs() > peak || peak_at.is_none() {
                    peak = peak.max(v.abs());
                    peak_at = Some(k.to_string());
                }
            }
        }
    }
    if cnt > 0 {
        s.put("joint_torque_rms_Nm", jn((sq / cnt as f64).sqrt()));
        s.put("joint_torque_peak_Nm", jn(peak));
        s.put(
            "joint_torque_peak_joint",
            json!(peak_at.map(|k| format!("q{k}"))),
        );
    } else {
        for k in [
            "joint_torque_rms_Nm",
            "joint_torque_peak_Nm",
            "joint_torque_peak_joint",
        ] {
            s.null(k, no_rows);
        }
    }

    // Grasp wrenches (true, world axes) and the internal part of the commands, per arm.
    let arms = f.plant.arms().len();
    for (key, group, what) in [
        ("grasp_wrench", "F", "grasp wrench"),
        ("internal_wrench", "w_int", "internal wrench"),
    ] {
        let mut v = Vec::new();
        for i in 1..=arms {
            let Some(w) = six(log, &format!("{group}{i}"), &WRENCH_AXES).filter(|_| n > 0) else {
                continue;
            };
            let (fv, tv) = norms(&w);
            let fr = range(fv.iter().copied()).unwrap_or((f64::NAN, f64::NAN));
            let tr = range(tv.iter().copied()).unwrap_or((f64::NAN, f64::NAN));
            v.push(json!({ "arm": i, "force_range_N": [jn(fr.0), jn(fr.1)],
                "torque_range_Nm": [jn(tr.0), jn(tr.1)] }));
        }
        if v.len() == arms && arms > 0 {
            s.put(key, json!(v));
        } else {
            s.null(
                key,
                &if n == 0 {
                    no_rows.to_string()
                } else {
                    format!("the log has no {what} columns ({group}*)")
                },
            );
        }
    }

    // NN internals.
    if f.nn() {
        let q = col(log, "Q");
        s.num(
            "q_switch_min",
            (q.len() == n && n > 0).then(|| q.iter().fold(f64::INFINITY, |a, &x| a.min(x))),
            no_rows,
        );
        match six(log, "w_norm", &AXES).filter(|_| n > 0) {
            Some(w) => {
                let mut fin = Map::new();
                let mut st = Map::new();
                let mut never = false;
                for (j, a) in AXES.iter().enumerate() {
                    let last = w[j][n - 1];
                    fin.insert(a.to_string(), jn(last));
                    let band = 0.1 * last.abs();
                    let dev: Vec<f64> = w[j].iter().map(|x| (x - last).abs()).collect();
                    let ts = if last == 0.0 {
                        None
                    } else {
                        settling(t, &dev, band + f64::MIN_POSITIVE)
                    };
                    never |= ts.is_none();
                    st.insert(a.to_string(), json!(ts));
                }
                s.put("weight_norm_final", Value::Object(fin));
                s.put("weight_settling_time_s", Value::Object(st));
                if never {
                    s.why.insert(
                        "weight_settling_time_s.*".into(),
                        json!("null: that weight norm never stays within ±10 % of its final value"),
                    );
                }
            }
            None => {
                s.null("weight_norm_final", no_rows);
                s.null("weight_settling_time_s", no_rows);
            }
        }
    } else {
        let why = format!("the {} run has no NN weights or switching", f.controller);
        for k in [
            "q_switch_min",
            "weight_norm_final",
            "weight_settling_time_s",
        ] {
            s.null(k, &why);
        }
    }

    // Closest approach to a joint limit; the smallest σ of each arm's tool Jacobian.
    match &d.closest {
        Some(c) => s.put(
            "closest_joint_limit",
            json!({
                "arm": c.arm, "joint": c.name, "column": format!("q{}", c.index),
                "side": c.side, format!("margin_{}", c.unit): c.margin, "t_s": c.t,
            }),
        ),
        None => s.null(
            "closest_joint_limit",
            if n == 0 {
                no_rows
            } else {
                "no joint has finite position limits"
            },
        ),
    }
    if d.sigma.len() == arms && n > 0 {
        let v: Vec<Value> = d
            .sigma
            .iter()
            .enumerate()
            .map(|(i, sg)| {
                let k = (0..sg.len()).fold(0, |b, k| if sg[k] < sg[b] { k } else { b });
                json!({ "arm": i + 1, "sigma_min": jn(sg[k]), "t_s": t[k] })
            })
            .collect();
        s.put("jacobian_sigma_min", json!(v));
        s.put(
            "jacobian_sigma_min_note",
            json!(
                "smallest singular value of each arm's 6×n tool Jacobian (world axes; linear \
                   rows in m/rad, angular rows dimensionless), over the logged rows"
            ),
        );
    } else {
        s.null(
            "jacobian_sigma_min",
            if n == 0 {
                no_rows
            } else {
                "the log has no joint positions"
            },
        );
    }
    let _ = t_end;

    let Sum { mut m, why } = s;
    m.insert("unavailable".into(), Value::Object(why));
    let mut timing = Map::new();
    timing.insert("wall_time_s".into(), jn(o.wall_time));
    timing.insert(
        "real_time_factor".into(),
        jn(if o.wall_time > 0.0 {
            o.t_end / o.wall_time
        } else {
            f64::NAN
        }),
    );
    if let Some(w) = output_time {
        timing.insert("output_time_s".into(), jn(w));
    }
    m.insert("timing".into(), Value::Object(timing));
    Value::Object(m)
}
