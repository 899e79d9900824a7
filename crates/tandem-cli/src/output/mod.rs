//! What a run writes: the summary, the time series, the terminal and Markdown tables
//! ([`table`]), for planar and [`spatial`] runs.

pub mod planar;
pub mod spatial;
pub mod table;

use serde_json::{Value, json};
use tandem::report::TorqueRate;

/// The table row of [`joint_limits_row`].
pub const JOINT_LIMITS_ROW: &str = "rate-limited / effort-clipped ticks by joint";

/// Why `joint_limits` is `null` in `summary.json`: the run had no actuator stage.
pub const NO_ACTUATOR: &str = "no actuator stage: the torques came from a replay or a user's law, not through tandem's limits";

/// The `torque_rate` block of `summary.json`, the same for planar and spatial runs (issue 24):
/// the applied joint torques of **every control tick** (not the logged rows), per joint the peak
/// `|Δτ|/Δt` (N m/s) and its time, and the chattering count: ticks whose torque step reverses the
/// previous step's sign with both steps above `threshold_Nm`, after `ignore_before_s`
/// ([`tandem::sim::torque_rate`]). `chatter_ticks` counts ticks on which any joint chattered;
/// joints are named as the `tau_q*` columns (`q1` first).
pub fn torque_rate_json(tr: &TorqueRate) -> Value {
    let peak = tr.peak();
    json!({
        "peak_Nm_per_s": peak.map(|p| p.1),
        "peak_joint": peak.map(|p| format!("q{}", p.0 + 1)),
        "peak_t_s": peak.map(|p| p.2),
        "chatter_ticks": tr.chatter_ticks,
        "chatter_joint_ticks": tr.chatter_total(),
        "threshold_Nm": tr.threshold,
        "ignore_before_s": tr.ignore_before,
        "ticks": tr.ticks,
        "joints": tr
            .joints
            .iter()
            .enumerate()
            .map(|(j, r)| {
                json!({
                    "joint": format!("q{}", j + 1),
                    "peak_Nm_per_s": r.peak_rate,
                    "peak_t_s": r.peak_t,
                    "chatter": r.chatter,
                    "first_chatter_s": r.first_chatter,
                    "last_chatter_s": r.last_chatter,
                })
            })
            .collect::<Vec<_>>(),
    })
}

/// The table cell of a `joint_limits` block of `summary.json` (issue 24): per joint the ticks
/// the actuator stage's rate limit and effort limit acted on, joints with none left out:
/// `"q2 36, q8 30 / none"` (rate-limited / effort-clipped); `—` without the stage.
pub fn joint_limits_row(v: &Value) -> String {
    let list = |key: &str| {
        let v: Vec<String> = v[key]
            .as_array()
            .map(|a| {
                a.iter()
                    .enumerate()
                    .filter_map(|(j, c)| {
                        c.as_u64()
                            .filter(|c| *c > 0)
                            .map(|c| format!("q{} {c}", j + 1))
                    })
                    .collect()
            })
            .unwrap_or_default();
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(", ")
        }
    };
    if v.is_null() {
        return "—".into();
    }
    format!("{} / {}", list("rate_limited"), list("effort_clipped"))
}

/// Whether the actuator stage's limits acted on any joint of a run (`joint_limits` of
/// `summary.json`): the tables show [`joint_limits_row`] only then.
pub fn joint_limits_acted(v: &Value) -> bool {
    ["rate_limited", "effort_clipped"].iter().any(|k| {
        v[*k]
            .as_array()
            .is_some_and(|a| a.iter().any(|c| c.as_u64().unwrap_or(0) > 0))
    })
}

/// The two table rows of a `torque_rate` block ([`torque_rate_json`]), for the planar and
/// spatial tables alike: `("peak torque rate", "16276 N m/s (q9, 0.022 s)")`, `("chattering
/// ticks (> 0.5 N m reversals)", "46")`.
pub fn torque_rate_rows(v: &Value) -> [(String, String); 2] {
    let num = |x: &Value| x.as_f64().map_or_else(|| "—".into(), |x| table::num(x, 3));
    let peak = match v["peak_Nm_per_s"].as_f64() {
        Some(p) => format!(
            "{} N m/s ({}, {} s)",
            table::num(p, 4),
            v["peak_joint"].as_str().unwrap_or("—"),
            num(&v["peak_t_s"])
        ),
        None => "—".into(),
    };
    [
        ("peak joint torque rate".into(), peak),
        (
            format!(
                "chattering ticks (reversals > {} N m)",
                num(&v["threshold_Nm"])
            ),
            v["chatter_ticks"]
                .as_u64()
                .map_or_else(|| "—".into(), |c| c.to_string()),
        ),
    ]
}
