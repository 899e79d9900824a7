//! `summary.json` of a spatial run: the library's summary ([`tandem::report::spatial`]: the
//! metrics of SPEC §5 on six outputs and the SPEC-spatial S5/S7 claims) as JSON, `null` plus a
//! reason for what this run does not have.

use serde_json::{Map, Value, json};
use tandem::control::spatial::AXES;
use tandem::report::spatial::{ArmWrenchRange, RmsMax, SpatialSummary};

use super::{Derived, Finished, TRANSIENT};

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
    let r = tandem::report::spatial::summarize(f, d);
    summary_json(scenario, f, &r, output_time)
}

/// `summary.json` from the library's summary `r` of `f`.
pub fn summary_json(
    scenario: &str,
    f: &Finished,
    r: &SpatialSummary,
    output_time: Option<f64>,
) -> Value {
    let o = &f.outcome;
    let n = r.rows;
    let mut s = Sum {
        m: Map::new(),
        why: Map::new(),
    };
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
            "rate_limited": o.events.rate_limited,
            "filtered": o.events.filtered,
            "non_finite": o.events.non_finite,
            "degenerate": o.events.degenerate,
        }),
    );
    // Per joint (all arms in joint order), the ticks each limit of the actuator stage acted on.
    match &o.joint_limits {
        Some(c) => s.put("joint_limits", json!(c)),
        None => s.null("joint_limits", crate::output::NO_ACTUATOR),
    }
    s.put("violation_ticks", json!(r.violations));
    s.put(
        "torque_rate",
        crate::output::torque_rate_json(&r.torque_rate),
    );
    s.put("regularised", json!(o.regularised));
    match &f.contacts {
        Some(c) => {
            let mut v = contacts_json(c);
            v["distribution"] = match &f.friction {
                Some(st) => json!({
                    "mode": "friction",
                    "ticks": st.solves,
                    "fallbacks": st.fallbacks,
                    "unconverged": st.unconverged,
                    "first_fallback_t_s": st.first_fallback_t,
                    "mean_iterations": if st.solves > 0 { json!(st.iterations as f64 / st.solves as f64) } else { Value::Null },
                    "max_iterations": st.max_iterations,
                    "min_planned_margin_N": jn(st.min_margin),
                    "effort_limited_ticks": st.torque_limited,
                    "effort_unmet_ticks": st.torque_unmet,
                    "first_effort_unmet_t_s": st.first_torque_unmet_t,
                }),
                None => json!({ "mode": "weld" }),
            };
            s.put("contacts", v)
        }
        None => s.null(
            "contacts",
            "the grasps are welds or springs (plant.contact_grasps gives pads held by friction, or with gauge_only = true pads that gauge them)",
        ),
    }
    s.num(
        "min_margin",
        r.min_margin,
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
    let z1_why = if n == 0 {
        no_rows
    } else {
        "the log has no z1 columns (see path_error_*: the true pose to the desired path)"
    };
    let why_after = if r.has_z1 { short } else { z1_why };
    let rms = |v: Option<RmsMax>| v.map(|v| v.rms);
    let max = |v: Option<RmsMax>| v.map(|v| v.max);
    s.num("z1_p_rms_m", rms(r.z1_p), z1_why);
    s.num("z1_p_max_m", max(r.z1_p), z1_why);
    s.num("z1_p_rms_after_2s_m", rms(r.z1_p_after), why_after);
    s.num("z1_p_max_after_2s_m", max(r.z1_p_after), why_after);
    s.num("z1_rot_rms_after_2s_rad", rms(r.z1_rot_after), why_after);
    s.num("z1_rot_max_after_2s_rad", max(r.z1_rot_after), why_after);
    if let Some(z) = r.z1_max_abs_after {
        let mut per_axis = Map::new();
        for (j, a) in AXES.iter().enumerate() {
            let u = if j < 3 { "m" } else { "rad" };
            per_axis.insert(format!("{a}_{u}"), jn(z[j]));
        }
        s.put("z1_max_abs_after_2s", Value::Object(per_axis));
    } else {
        s.null("z1_max_abs_after_2s", why_after);
    }
    if r.has_z1 {
        s.num(
            "settling_time_1mm_s",
            r.settling_time_1mm,
            "never: ‖z1_p‖ is not below 1 mm for the rest of the run",
        );
    } else {
        s.null("settling_time_1mm_s", z1_why);
    }
    // SPEC-spatial S5 claims.
    let claim = |c: &tandem::report::spatial::Claim, unit: &str| json!({ format!("max_{unit}"): c.max, format!("limit_{unit}"): c.limit, "pass": c.pass });
    s.put(
        "s5_claims",
        json!({
            "z1_p_after_2s": claim(&r.s5.z1_p_after, "m"),
            "z1_rot_after_2s": claim(&r.s5.z1_rot_after, "rad"),
            "completed_without_violation": r.s5.completed_without_violation,
            "pass": r.s5.pass,
        }),
    );

    // Orientation error as an angle.
    match r.orientation_error_after {
        Some(v) => {
            s.put("orientation_error_rms_after_2s_rad", jn(v.rms));
            s.put("orientation_error_max_after_2s_rad", jn(v.max));
        }
        None => {
            let why = if r.has_angle_error {
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
        r.orientation_error_to_desired_max_after,
        if n == 0 { no_rows } else { short },
    );

    // The true pose against the desired path (every driver).
    let pe_why = if n == 0 {
        no_rows
    } else if r.path_error_p.is_none() {
        "the log has no object pose (x_o.*)"
    } else {
        short
    };
    s.num("path_error_p_rms_m", rms(r.path_error_p), pe_why);
    s.num("path_error_p_max_m", max(r.path_error_p), pe_why);
    s.num(
        "path_error_p_rms_after_2s_m",
        rms(r.path_error_p_after),
        pe_why,
    );
    s.num(
        "path_error_p_max_after_2s_m",
        max(r.path_error_p_after),
        pe_why,
    );
    s.num("path_error_rot_rms_rad", rms(r.path_error_rot), pe_why);
    s.num("path_error_rot_max_rad", max(r.path_error_rot), pe_why);
    s.num(
        "path_error_rot_rms_after_2s_rad",
        rms(r.path_error_rot_after),
        pe_why,
    );
    s.num(
        "path_error_rot_max_after_2s_rad",
        max(r.path_error_rot_after),
        pe_why,
    );

    // The commanded object wrench.
    match r.wrench {
        Some(w) => {
            s.put("wrench_force_rms_N", jn(w.force_rms));
            s.put("wrench_force_peak_N", jn(w.force_peak));
            s.put("wrench_torque_rms_Nm", jn(w.torque_rms));
            s.put("wrench_torque_peak_Nm", jn(w.torque_peak));
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
    if let Some(j) = &r.joint_torque {
        s.put("joint_torque_rms_Nm", jn(j.rms));
        s.put("joint_torque_peak_Nm", jn(j.peak));
        s.put("joint_torque_peak_joint", json!(j.peak_joint));
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
    for (key, group, what, v) in [
        ("grasp_wrench", "F", "grasp wrench", &r.grasp_wrench),
        (
            "internal_wrench",
            "w_int",
            "internal wrench",
            &r.internal_wrench,
        ),
    ] {
        match v {
            Some(v) => {
                let v: Vec<Value> = v
                    .iter()
                    .map(|a: &ArmWrenchRange| {
                        json!({ "arm": a.arm, "force_range_N": [jn(a.force[0]), jn(a.force[1])],
                            "torque_range_Nm": [jn(a.torque[0]), jn(a.torque[1])] })
                    })
                    .collect();
                s.put(key, json!(v));
            }
            None => s.null(
                key,
                &if n == 0 {
                    no_rows.to_string()
                } else {
                    format!("the log has no {what} columns ({group}*)")
                },
            ),
        }
    }

    // NN internals.
    if f.nn() {
        s.num("q_switch_min", r.q_switch_min, no_rows);
        match (r.weight_norm_final, r.weight_settling_time) {
            (Some(w), Some(ts)) => {
                let mut fin = Map::new();
                let mut st = Map::new();
                for (j, a) in AXES.iter().enumerate() {
                    fin.insert(a.to_string(), jn(w[j]));
                    st.insert(a.to_string(), json!(ts[j]));
                }
                s.put("weight_norm_final", Value::Object(fin));
                s.put("weight_settling_time_s", Value::Object(st));
                if ts.iter().any(|x| x.is_none()) {
                    s.why.insert(
                        "weight_settling_time_s.*".into(),
                        json!("null: that weight norm never stays within ±10 % of its final value"),
                    );
                }
            }
            _ => {
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
    match &r.closest_joint_limit {
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
    if let Some(v) = &r.jacobian_sigma_min {
        let v: Vec<Value> = v
            .iter()
            .map(|g| json!({ "arm": g.arm, "sigma_min": jn(g.sigma_min), "t_s": g.t }))
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

/// Most contact events `summary.json` lists (all are counted).
pub const LISTED_CONTACT_EVENTS: usize = 100;

fn status_name(s: tandem::plant::spatial::PadStatus) -> &'static str {
    use tandem::plant::spatial::PadStatus;
    match s {
        PadStatus::Stick => "stick",
        PadStatus::Slip => "slip",
        PadStatus::Separated => "separated",
    }
}

/// The contact grasps' record: slip per grasp, per pad the smallest cone margins and when, the
/// final status, and the status changes (slip onset and end, separation) with their times.
fn contacts_json(c: &tandem::plant::spatial::ContactLog) -> Value {
    let mut pads = Vec::new();
    for (k, (i, j)) in c.pads.iter().enumerate() {
        let r = &c.readings[k];
        let (m, t) = c.min_margin[k];
        let (mt, tt) = c.min_torsion_margin[k];
        let (mc, tc) = c.min_cone_margin[k];
        pads.push(json!({
            "arm": i,
            "pad": j,
            "min_margin_N": jn(m),
            "min_margin_t_s": if m.is_finite() { json!(t) } else { Value::Null },
            "min_torsion_margin_Nm": jn(mt),
            "min_torsion_margin_t_s": if mt.is_finite() { json!(tt) } else { Value::Null },
            "min_cone_margin_N": jn(mc),
            "min_cone_margin_t_s": if mc.is_finite() { json!(tc) } else { Value::Null },
            "final_status": status_name(r.status),
            "final_normal_N": jn(r.normal),
        }));
    }
    let events: Vec<Value> = c
        .events
        .iter()
        .take(LISTED_CONTACT_EVENTS)
        .map(|e| {
            json!({
                "t_s": e.t, "arm": e.grasp, "pad": e.pad,
                "from": status_name(e.from), "to": status_name(e.to),
            })
        })
        .collect();
    use tandem::plant::spatial::PadStatus;
    let mut v = if c.gauged {
        // Welds or springs gauged by pads: nothing slips; a pad out of its cone (or with no
        // pressure left) says the grasp needs more friction or grip than the pads give.
        let onset = c
            .events
            .iter()
            .find(|e| e.to != PadStatus::Stick)
            .map(|e| e.t);
        json!({
            "held_by": "gauge",
            "would_slip": onset.is_some(),
            "first_would_slip_t_s": onset,
        })
    } else {
        let onset = c
            .events
            .iter()
            .find(|e| e.to == PadStatus::Slip)
            .map(|e| e.t);
        json!({
            "held_by": "friction",
            "slipped": c.slip_distance.iter().any(|d| *d > 0.0) || c.slip_angle.iter().any(|d| *d > 0.0),
            "first_slip_t_s": onset,
            "slip_distance_m": c.slip_distance.iter().map(|v| jn(*v)).collect::<Vec<_>>(),
            "slip_angle_rad": c.slip_angle.iter().map(|v| jn(*v)).collect::<Vec<_>>(),
        })
    };
    v["pads"] = json!(pads);
    v["events_total"] = json!(c.events.len() as u64 + c.dropped);
    v["events"] = json!(events);
    v
}
