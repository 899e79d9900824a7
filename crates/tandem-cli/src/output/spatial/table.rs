//! The table of one or more spatial runs' summaries: aligned text for the terminal and Markdown
//! for a comparison's `report.md`.

use serde_json::{Value, json};

use crate::output::table::num;

/// The table rows of one or more runs' summaries: `(metric, one cell per run)`.
pub fn rows(runs: &[(&str, &Value)]) -> Vec<(String, Vec<String>)> {
    let mut out: Vec<(String, Vec<String>)> = Vec::new();
    let mut row = |name: &str, f: &dyn Fn(&Value) -> String| {
        out.push((name.to_string(), runs.iter().map(|(_, s)| f(s)).collect()));
    };
    let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    let mm = |v: &Value| match v.as_f64() {
        Some(x) => format!("{} mm", num(x * 1e3, 3)),
        None => "—".into(),
    };
    let mrad = |v: &Value| match v.as_f64() {
        Some(x) => format!("{} mrad", num(x * 1e3, 3)),
        None => "—".into(),
    };
    let pass = |v: &Value| {
        let missing = v
            .as_object()
            .is_some_and(|m| m.iter().any(|(k, x)| k.starts_with("max") && x.is_null()));
        if v["pass"] == json!(true) {
            "pass"
        } else if missing {
            "run too short"
        } else {
            "FAIL"
        }
    };
    row("status", &|s| match s["fault"].as_str() {
        None => s["status"].as_str().unwrap_or("?").to_string(),
        Some(m) => format!("FAULT: {}", m.chars().take(60).collect::<String>()),
    });
    row("simulated time", &|s| {
        format!("{} s", num(f(&s["t_end_s"]), 4))
    });
    row("RMS ‖z1_p‖, whole run", &|s| mm(&s["z1_p_rms_m"]));
    row("max ‖z1_p‖ after 2 s (S5: < 1 mm)", &|s| {
        let c = &s["s5_claims"]["z1_p_after_2s"];
        format!("{} ({})", mm(&c["max_m"]), pass(c))
    });
    row("max ‖z1_φ‖ after 2 s (S5: < 1 mrad)", &|s| {
        let c = &s["s5_claims"]["z1_rot_after_2s"];
        format!("{} ({})", mrad(&c["max_rad"]), pass(c))
    });
    row(
        "settling to ‖z1_p‖ < 1 mm",
        &|s| match s["settling_time_1mm_s"].as_f64() {
            Some(x) => format!("{} s", num(x, 3)),
            None => "never".into(),
        },
    );
    row("max orientation error after 2 s (to x_r / to x_d)", &|s| {
        let r = &s["orientation_error_max_after_2s_rad"];
        let d = &s["orientation_error_to_desired_max_after_2s_rad"];
        match (r.as_f64(), d.as_f64()) {
            (Some(r), Some(d)) => format!("{} / {} mrad", num(r * 1e3, 3), num(d * 1e3, 3)),
            _ => "—".into(),
        }
    });
    // The true pose against the desired path (every driver; z1 is against x_r).
    row("max ‖p_o − p_d‖ after 2 s", &|s| {
        mm(&s["path_error_p_max_after_2s_m"])
    });
    row("max angle to R_d after 2 s", &|s| {
        mrad(&s["path_error_rot_max_after_2s_rad"])
    });
    row("min constraint margin", &|s| num(f(&s["min_margin"]), 3));
    row("bound violations (control ticks)", &|s| {
        s["violation_ticks"].to_string()
    });
    row("constraint drift", &|s| {
        format!(
            "{} m / {} rad",
            num(f(&s["max_drift_m"]), 2),
            num(f(&s["max_drift_rad"]), 2)
        )
    });
    row("RMS / peak object force ‖f‖", &|s| {
        format!(
            "{} / {} N",
            num(f(&s["wrench_force_rms_N"]), 3),
            num(f(&s["wrench_force_peak_N"]), 3)
        )
    });
    row("RMS / peak joint torque", &|s| {
        format!(
            "{} / {} N m",
            num(f(&s["joint_torque_rms_Nm"]), 3),
            num(f(&s["joint_torque_peak_Nm"]), 3)
        )
    });
    let ranges = |key: &'static str| {
        move |s: &Value| match s[key].as_array() {
            Some(a) => {
                a.iter()
                    .map(|w| {
                        format!(
                            "{}…{}",
                            num(f(&w["force_range_N"][0]), 3),
                            num(f(&w["force_range_N"][1]), 3)
                        )
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
                    + " N"
            }
            None => "—".into(),
        }
    };
    row("grasp force ‖f_i‖ range per arm", &ranges("grasp_wrench"));
    row("internal force range per arm", &ranges("internal_wrench"));
    row("closest joint limit", &|s| {
        let c = &s["closest_joint_limit"];
        if c.is_null() {
            return "—".into();
        }
        let (m, u) = match c.get("margin_rad") {
            Some(m) => (f(m), "rad"),
            None => (f(&c["margin_m"]), "m"),
        };
        format!(
            "{} {u} ({}, arm {}, t = {} s)",
            num(m, 3),
            c["joint"].as_str().unwrap_or("?"),
            c["arm"],
            num(f(&c["t_s"]), 3)
        )
    });
    row(
        "min σ of the tool Jacobians",
        &|s| match s["jacobian_sigma_min"].as_array() {
            Some(a) => a
                .iter()
                .map(|v| num(f(&v["sigma_min"]), 3))
                .collect::<Vec<_>>()
                .join(", "),
            None => "—".into(),
        },
    );
    if runs.iter().any(|(_, s)| s["controller"] == "nn") {
        row("min Q / all ‖Ŵ_j‖ within ±10 % of final from", &|s| {
            if s["controller"] != "nn" {
                return "—".into();
            }
            let last = s["weight_settling_time_s"]
                .as_object()
                .map(|m| {
                    let v: Vec<Option<f64>> = m.values().map(Value::as_f64).collect();
                    if v.iter().any(Option::is_none) {
                        "never".to_string()
                    } else {
                        let x = v.iter().flatten().fold(0.0f64, |a, &b| a.max(b));
                        format!("{} s", num(x, 3))
                    }
                })
                .unwrap_or_else(|| "—".into());
            format!("{} / {last}", num(f(&s["q_switch_min"]), 3))
        });
    }
    let tr = |s: &Value| crate::output::torque_rate_rows(&s["torque_rate"]);
    if let Some((_, first)) = runs.first() {
        let [(peak, _), (chatter, _)] = tr(first);
        row(&peak, &|s| tr(s)[0].1.clone());
        row(&chatter, &|s| tr(s)[1].1.clone());
    }
    if runs
        .iter()
        .any(|(_, s)| crate::output::joint_limits_acted(&s["joint_limits"]))
    {
        row(crate::output::JOINT_LIMITS_ROW, &|s| {
            crate::output::joint_limits_row(&s["joint_limits"])
        });
    }
    if runs.iter().any(|(_, s)| s["contacts"].is_object()) {
        contact_rows(&mut row);
    }
    row("barrier hits / torque clips (ticks)", &|s| {
        format!(
            "{} / {}",
            s["events"]["barrier_hits"], s["events"]["torque_clips"]
        )
    });
    row("wall time (real-time factor)", &|s| {
        format!(
            "{} s ({}×)",
            num(f(&s["timing"]["wall_time_s"]), 3),
            num(f(&s["timing"]["real_time_factor"]), 3)
        )
    });
    out
}

/// The table as aligned text (one column per run; a header line when there are several).
pub fn text(runs: &[(&str, &Value)]) -> String {
    let names: Vec<&str> = runs.iter().map(|(n, _)| *n).collect();
    crate::output::table::render_text(&names, &rows(runs))
}

/// The table in Markdown.
pub fn markdown(runs: &[(&str, &Value)]) -> String {
    let names: Vec<&str> = runs.iter().map(|(n, _)| *n).collect();
    crate::output::table::render_markdown(&names, &rows(runs))
}

/// What adds a row: its name and the cell of one run's summary.
type AddRow<'a> = dyn FnMut(&str, &dyn Fn(&Value) -> String) + 'a;

/// Rows for pads (held by friction, or gauging welds and springs): slip, the tightest cone
/// margin, and what the friction-aware distribution did. "—" for a run without pads.
fn contact_rows(row: &mut AddRow<'_>) {
    row("slip per arm (first at)", &|s| {
        let c = &s["contacts"];
        match c["held_by"].as_str() {
            Some("friction") => {
                let d: Vec<String> = c["slip_distance_m"]
                    .as_array()
                    .map(|a| {
                        a.iter()
                            .map(|v| format!("{} mm", num(v.as_f64().unwrap_or(f64::NAN) * 1e3, 3)))
                            .collect()
                    })
                    .unwrap_or_default();
                match c["first_slip_t_s"].as_f64() {
                    Some(t) => format!("{} ({} s)", d.join(", "), num(t, 4)),
                    None => "none".into(),
                }
            }
            Some("gauge") => match c["first_would_slip_t_s"].as_f64() {
                Some(t) => format!("gauged: pads would slip ({} s)", num(t, 4)),
                None => "gauged: pads would hold".into(),
            },
            _ => "—".into(),
        }
    });
    row("min friction-cone margin (arm, pad, t)", &|s| {
        let pads = s["contacts"]["pads"].as_array();
        let worst = pads.and_then(|p| {
            p.iter()
                .filter_map(|x| Some((x["min_cone_margin_N"].as_f64()?, x)))
                .min_by(|a, b| a.0.total_cmp(&b.0))
        });
        match worst {
            Some((m, x)) => format!(
                "{} N ({}, {}, {} s)",
                num(m, 3),
                x["arm"].as_u64().map_or(0, |v| v + 1),
                x["pad"].as_u64().map_or(0, |v| v + 1),
                num(x["min_cone_margin_t_s"].as_f64().unwrap_or(f64::NAN), 4)
            ),
            None => "—".into(),
        }
    });
    row(
        "friction plan: fallbacks / effort-limited / unmet (ticks)",
        &|s| {
            let d = &s["contacts"]["distribution"];
            if d["mode"] == json!("friction") {
                format!(
                    "{} / {} / {}",
                    d["fallbacks"], d["effort_limited_ticks"], d["effort_unmet_ticks"]
                )
            } else {
                "—".into()
            }
        },
    );
}
