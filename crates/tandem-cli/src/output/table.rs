//! Summary tables: one column per run, as aligned text for the terminal and as Markdown.

use tandem::report::planar::Summary;

/// `v` with `sig` significant digits, plain notation for 1e-3 ≤ |v| < 1e6, else exponent form.
pub fn num(v: f64, sig: usize) -> String {
    if !v.is_finite() {
        // A metric that does not exist (summary.json says why).
        return "—".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e6).contains(&a) {
        return format!("{:.*e}", sig.saturating_sub(1), v);
    }
    let mag = a.log10().floor() as i32;
    let decimals = (sig as i32 - 1 - mag).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn opt_s(v: Option<f64>) -> String {
    v.map_or_else(|| "never".into(), |x| format!("{} s", num(x, 3)))
}

/// The table rows: (metric, one cell per run).
pub fn rows(runs: &[(&str, &Summary)]) -> Vec<(String, Vec<String>)> {
    let mut out: Vec<(String, Vec<String>)> = Vec::new();
    let mut row = |name: &str, f: &dyn Fn(&Summary) -> String| {
        out.push((name.to_string(), runs.iter().map(|(_, s)| f(s)).collect()));
    };
    row("status", &|s| match &s.fault {
        None if s.completed => "completed".into(),
        None => "stopped early".into(),
        Some(f) => {
            // Kind and time only; the full message (with the state) is printed separately.
            let v = serde_json::to_value(f).unwrap_or_default();
            format!(
                "FAULT ({}) at t = {} s",
                v["kind"].as_str().unwrap_or("fault").replace('_', " "),
                num(v["t"].as_f64().unwrap_or(f64::NAN), 4)
            )
        }
    });
    row("simulated time", &|s| format!("{} s", num(s.t_end, 4)));
    row("RMS ‖z1_xy‖, whole run", &|s| {
        if no_rows(s) {
            return "— (no logged rows)".into();
        }
        format!("{} mm", num(s.rms_z1 * 1e3, 3))
    });
    row("max ‖z1_xy‖, whole run", &|s| {
        if no_rows(s) {
            return "—".into();
        }
        format!("{} mm", num(s.max_z1 * 1e3, 3))
    });
    let tr = runs.first().map_or(0.0, |(_, s)| s.transient);
    let after = format!("after {} s", num(tr, 3));
    // Nothing is "after the transient" in a run that ends before it.
    let after_ok = |s: &Summary| s.t_end > s.transient && !no_rows(s);
    row(&format!("RMS ‖z1_xy‖, {after}"), &|s| {
        if !after_ok(s) {
            return "— (run too short)".into();
        }
        format!("{} mm", num(s.rms_z1_after * 1e3, 3))
    });
    row(&format!("max ‖z1_xy‖, {after}"), &|s| {
        if !after_ok(s) {
            return "—".into();
        }
        format!("{} mm", num(s.max_z1_after * 1e3, 3))
    });
    row(&format!("max |z1_θ|, {after}"), &|s| {
        if !after_ok(s) {
            return "—".into();
        }
        format!("{} mrad", num(s.max_z1_theta_after * 1e3, 3))
    });
    // The true pose against the desired path (every driver; z1 is against x_r).
    row(
        &format!("max ‖(x_o − x_d)_xy‖, {after}"),
        &|s| match s.max_path_error_after {
            Some(p) if after_ok(s) => format!("{} mm", num(p * 1e3, 3)),
            _ => "—".into(),
        },
    );
    row(
        &format!("max |θ_o − θ_d|, {after}"),
        &|s| match s.max_path_error_theta_after {
            Some(t) if after_ok(s) => format!("{} mrad", num(t * 1e3, 3)),
            _ => "—".into(),
        },
    );
    row("settling to ‖z1_xy‖ < 1 mm", &|s| {
        opt_s(s.settling_time_1mm)
    });
    row("min constraint margin", &|s| num(s.min_margin, 3));
    row("bound violations (control ticks)", &|s| {
        s.violations.to_string()
    });
    // A replay has no controller: no commanded wrench.
    let replay = |s: &Summary| s.controller == "replay";
    row("RMS / peak wrench ‖τ_xy‖", &|s| {
        if replay(s) || no_rows(s) {
            return "— (replay)".into();
        }
        format!("{} / {} N", num(s.rms_wrench, 3), num(s.peak_wrench, 3))
    });
    row("wrench roughness (RMS Δτ)", &|s| {
        if replay(s) || no_rows(s) {
            return "—".into();
        }
        format!("{} N", num(s.wrench_roughness, 3))
    });
    row("RMS / peak joint torque", &|s| {
        if no_rows(s) {
            return "—".into();
        }
        format!(
            "{} / {} N m",
            num(s.rms_joint_torque, 3),
            num(s.peak_joint_torque, 3)
        )
    });
    let tr = |s: &Summary| {
        crate::output::torque_rate_rows(&crate::output::torque_rate_json(&s.torque_rate))
    };
    if let Some((_, first)) = runs.first() {
        let [(peak, _), (chatter, _)] = tr(first);
        row(&peak, &|s| tr(s)[0].1.clone());
        row(&chatter, &|s| tr(s)[1].1.clone());
    }
    let jl = |s: &Summary| serde_json::json!(s.joint_limits);
    if runs
        .iter()
        .any(|(_, s)| crate::output::joint_limits_acted(&jl(s)))
    {
        row(crate::output::JOINT_LIMITS_ROW, &|s| {
            crate::output::joint_limits_row(&jl(s))
        });
    }
    row("grasp force range", &|s| {
        format!(
            "{} … {} N",
            num(s.grasp_force_range[0], 3),
            num(s.grasp_force_range[1], 3)
        )
    });
    if runs.iter().any(|(_, s)| s.controller == "nn") {
        row("‖Ŵ_j‖ within ±10 % of final from (x, y, θ)", &|s| {
            if s.controller != "nn" {
                return "—".into();
            }
            s.weight_settling_time
                .iter()
                .map(|t| t.map_or_else(|| "never".into(), |x| format!("{} s", num(x, 3))))
                .collect::<Vec<_>>()
                .join(", ")
        });
    }
    row("barrier hits / torque clips (ticks)", &|s| {
        format!("{} / {}", s.events.barrier_hits, s.events.torque_clips)
    });
    row("non-finite / degenerate (ticks)", &|s| {
        format!("{} / {}", s.events.non_finite, s.events.degenerate)
    });
    row("wall time (real-time factor)", &|s| {
        format!(
            "{} s ({}×)",
            num(s.wall_time, 3),
            num(s.real_time_factor, 3)
        )
    });
    out
}

/// A run that logged no row (every log metric is missing): its grasp-force range is empty.
fn no_rows(s: &Summary) -> bool {
    !(s.grasp_force_range[0] <= s.grasp_force_range[1])
}

/// Aligned text.
pub fn text(runs: &[(&str, &Summary)]) -> String {
    let names: Vec<&str> = runs.iter().map(|(n, _)| *n).collect();
    render_text(&names, &rows(runs))
}

/// A Markdown table.
pub fn markdown(runs: &[(&str, &Summary)]) -> String {
    let names: Vec<&str> = runs.iter().map(|(n, _)| *n).collect();
    render_markdown(&names, &rows(runs))
}

/// `rows` (a metric and one cell per run) as aligned text: the metric column, then one column
/// per run, two spaces apart, trailing spaces trimmed; a header line of the run `names` when
/// there are several. The planar and the spatial tables both print through here.
pub fn render_text(names: &[&str], rows: &[(String, Vec<String>)]) -> String {
    let w0 = rows
        .iter()
        .map(|(n, _)| n.chars().count())
        .max()
        .unwrap_or(0);
    let widths: Vec<usize> = (0..names.len())
        .map(|i| {
            rows.iter()
                .map(|(_, c)| c[i].chars().count())
                .chain(std::iter::once(names[i].chars().count()))
                .max()
                .unwrap_or(0)
        })
        .collect();
    let pad = |s: &str, w: usize| format!("{s}{}", " ".repeat(w.saturating_sub(s.chars().count())));
    let mut out = String::new();
    let mut line = |name: &str, cells: &mut dyn Iterator<Item = &str>| {
        out.push_str(&pad(name, w0));
        for (c, w) in cells.zip(&widths) {
            out.push_str("  ");
            out.push_str(&pad(c, *w));
        }
        out.truncate(out.trim_end().len());
        out.push('\n');
    };
    if names.len() > 1 {
        line("", &mut names.iter().copied());
    }
    for (name, cells) in rows {
        line(name, &mut cells.iter().map(String::as_str));
    }
    out
}

/// `rows` (a metric and one cell per run) as a Markdown table under the run `names` (`|`
/// escaped).
pub fn render_markdown(names: &[&str], rows: &[(String, Vec<String>)]) -> String {
    let esc = |s: &str| s.replace('|', "\\|");
    let mut out = String::from("| metric |");
    for name in names {
        out.push_str(&format!(" {} |", esc(name)));
    }
    out.push_str("\n|---|");
    out.push_str(&"---|".repeat(names.len()));
    out.push('\n');
    for (name, cells) in rows {
        out.push_str(&format!("| {} |", esc(name)));
        for c in cells {
            out.push_str(&format!(" {} |", esc(c)));
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::{num, render_markdown, render_text};

    #[test]
    fn tables_align_and_escape() {
        let rows = vec![
            (
                "status".to_string(),
                vec!["ok".to_string(), "FAULT: a|b".to_string()],
            ),
            (
                "RMS".to_string(),
                vec!["1.5 mm".to_string(), "".to_string()],
            ),
        ];
        // Widths: the metric column 6, the runs' columns the longest of name and cells; the
        // header line only with several runs; trailing spaces trimmed.
        assert_eq!(
            render_text(&["NN", "PD"], &rows),
            "        NN      PD\nstatus  ok      FAULT: a|b\nRMS     1.5 mm\n"
        );
        assert_eq!(render_text(&["NN"], &rows[1..]), "RMS  1.5 mm\n");
        assert_eq!(
            render_markdown(&["NN", "P|D"], &rows[..1]),
            "| metric | NN | P\\|D |\n|---|---|---|\n| status | ok | FAULT: a\\|b |\n"
        );
    }

    #[test]
    fn numbers_are_short() {
        assert_eq!(num(0.30397, 3), "0.304");
        assert_eq!(num(12.0, 3), "12");
        assert_eq!(num(1234.6, 3), "1235");
        assert_eq!(num(2.5e-5, 3), "2.50e-5");
        assert_eq!(num(0.0, 3), "0");
    }
}
