//! `tandem robustness`: on a planar scenario, every fault family of `[faults]` at increasing
//! severity, for PD and the NN law (tuned); then the grasp-slip family on the spatial S6
//! dual-UR5 set-up (compliant true grasps of decreasing stiffness under a controller that
//! assumes welds); a report (`robustness.md`), figures and `results.json`. On a spatial
//! scenario, the compliant-grasp sweep of that scenario ([`grasps`]: stiffness × damping × law,
//! without and with the output filter).
//!
//! Each run is classified:
//! - **inside**: completed, the true pose never left the bounds (`violations = 0`), and the
//!   tracking error after the transient stays below [`TRACK_MM`] (spatial: and the orientation
//!   error below [`TRACK_RAD`]);
//! - **degraded**: completed inside the bounds, but tracked worse than that;
//! - **outside**: completed, but the true pose violated a bound;
//! - **fault**: stopped early with a named fault (drift or a grasp's slip, singular arm,
//!   non-finite value, ...).

pub mod grasps;

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use anyhow::Result;
use serde_json::json;

use nalgebra::{Quaternion, UnitQuaternion, Vector3, Vector6};
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::pd::PdGains;
use tandem::control::spatial::SpatialControllerParams;
use tandem::plant::spatial::GraspModel;
use tandem::reference::spatial::path::Se3Path;

use crate::figures::plot::{self, Panel, Series, Style};
use crate::output::table::num;
use crate::run::planar::{self as runner, Finished, Prepared};
use crate::scenario::ControllerKind;
use crate::scenario::Source;
use crate::scenario::planar::{FaultsConfig, GainPreset, PlanarScenario};

/// Largest tracking error after the transient of a run that stays "inside", mm.
pub const TRACK_MM: f64 = 10.0;

/// Largest orientation error after the transient of a spatial run that stays "inside", rad:
/// [`TRACK_MM`] over the S6 box's half-length (0.2 m, the controller's metric length that makes
/// forces and torques commensurate), 0.05 rad ≈ 2.9°.
pub const TRACK_RAD: f64 = 0.05;

/// A fault family: name, unit of its severity, the levels (mildest first) and how a level is
/// set in `[faults]`.
pub struct Family {
    /// Name.
    pub name: &'static str,
    /// What the level is.
    pub what: &'static str,
    /// Severity levels, mildest first.
    pub levels: &'static [f64],
    /// Sets a level.
    pub set: fn(&mut FaultsConfig, f64),
}

/// The studied families.
pub const FAMILIES: &[Family] = &[
    Family {
        name: "sensor dropout bursts",
        what: "burst length, s (1 burst/s, every reading held)",
        levels: &[0.01, 0.03, 0.1, 0.3, 1.0],
        set: |f, v| {
            f.dropout_rate = 1.0;
            f.dropout_length = v;
        },
    },
    Family {
        name: "force-sensor saturation",
        what: "saturation per component, N",
        levels: &[2.0, 1.0, 0.5, 0.2, 0.05],
        set: |f, v| f.force_limit = Some(v),
    },
    Family {
        name: "force-sensor delay",
        what: "delay, s",
        levels: &[0.01, 0.03, 0.1, 0.3, 1.0],
        set: |f, v| f.force_delay = v,
    },
    Family {
        name: "actuator torque limit",
        what: "saturation, N m",
        levels: &[50.0, 20.0, 10.0, 5.0, 2.0],
        set: |f, v| f.torque_limit = Some(v),
    },
    Family {
        name: "actuator rate limit",
        what: "rate limit, N m/s",
        levels: &[10000.0, 3000.0, 1000.0, 300.0, 100.0],
        set: |f, v| f.torque_rate = Some(v),
    },
    Family {
        name: "payload mismatch",
        what: "true mass and inertia / nominal",
        levels: &[1.25, 1.5, 2.0, 3.0, 5.0],
        set: |f, v| {
            f.payload_mass = v;
            f.payload_inertia = v;
        },
    },
    Family {
        name: "encoder quantisation",
        what: "resolution, rad",
        levels: &[1e-4, 3e-4, 1e-3, 3e-3, 1e-2],
        set: |f, v| f.encoder_resolution = v,
    },
];

/// The compared laws: (kind, preset, label).
const LAWS: [(ControllerKind, Option<GainPreset>, &str); 2] = [
    (ControllerKind::Pd, None, "PD"),
    (ControllerKind::Nn, Some(GainPreset::Tuned), "NN (tuned)"),
];

/// One run of the grid.
pub struct Cell {
    /// Planar `[faults]` family index into [`FAMILIES`], or for the grasp-slip family
    /// ([`Cell::slip`] set) `Some(0)`; `None`: nominal (spatial: welded grasps).
    pub family: Option<usize>,
    /// Level index.
    pub level: usize,
    /// Law index (into the planar laws, or into [`SLIP_LAWS`] for a slip run).
    pub law: usize,
    /// inside / degraded / outside / fault.
    pub class: &'static str,
    /// Details for the table.
    pub detail: String,
    /// Min margin (NaN if none).
    pub margin: f64,
    /// Max tracking error after the transient, mm (NaN if none): planar `‖z1_xy‖`, spatial the
    /// true box position against the path.
    pub track_mm: f64,
    /// The spatial measurements of a grasp-slip run (`None` for a planar run).
    pub slip: Option<SlipInfo>,
}

/// What a grasp-slip run measured besides the margin.
#[derive(Clone, Debug)]
pub struct SlipInfo {
    /// Max orientation error `‖Log(R_dᵀ R)‖` of the true box after the transient, rad (NaN if
    /// the run stopped before it).
    pub track_rad: f64,
    /// Share of the logged rows (every 10 ms) with the switching `Q < 1` (NN; NaN for PD).
    pub q_low: f64,
    /// Smallest `Q` over the run (NN; NaN for PD).
    pub q_min: f64,
    /// Largest slope of the robust term's linear zone that the loop applied,
    /// `max_j (1 − Q) f^U_j² / ϖ` over the logged rows, (N s/m or N m s/rad) (NN; NaN for PD).
    pub robust_slope: f64,
    /// Largest grasp deflection, m and rad.
    pub deflection: (f64, f64),
    /// Plant steps per 1 ms control period.
    pub substeps: usize,
    /// `substeps` over [`slip_substeps`] (1 but for the step-convergence check).
    pub factor: usize,
    /// The robust bound's constant term `a_j` of `f^U_j` (paper (39)), N ×3, N m ×3 (NN).
    pub fu_rest: Option<[f64; 6]>,
    /// The first logged row with `Q < 1` (NN): time, s, and the input `Z_k` farthest out
    /// (`x_hat.*`, `xd_hat.*`, `alpha.*`, `alpha_dot.*`) with its value.
    pub first_exit: Option<(f64, String, f64)>,
}

fn classify(f: &Finished) -> (&'static str, String, f64, f64) {
    let s = &f.summary;
    let margin = if s.min_margin.is_finite() {
        s.min_margin
    } else {
        f64::NAN
    };
    let after = s.t_end > s.transient;
    let track = if after {
        s.max_z1_after * 1e3
    } else {
        f64::NAN
    };
    if let Some(fault) = &f.outcome.fault {
        let kind = serde_json::to_value(&fault.kind)
            .ok()
            .and_then(|v| v["kind"].as_str().map(str::to_string))
            .unwrap_or_default();
        return (
            "fault",
            format!("{kind} at {} s", num(fault.t, 3)),
            margin,
            track,
        );
    }
    let class = if s.violations > 0 {
        "outside"
    } else if track <= TRACK_MM {
        "inside"
    } else {
        "degraded"
    };
    let detail = format!(
        "margin {}, err {} mm{}",
        num(margin, 2),
        num(track, 3),
        if s.violations > 0 {
            format!(", {} violating ticks", s.violations)
        } else {
            String::new()
        }
    );
    (class, detail, margin, track)
}

/// One job of the grid.
enum Job {
    /// A planar run: family, level, law and the prepared scenario.
    Planar(Option<usize>, usize, usize, Box<Prepared>),
    /// A grasp-slip run: level (`None`: welds), law and step factor.
    Slip(Option<usize>, usize, usize),
}

/// Run the grid from `base` (duration overridden by the caller) on `threads` threads, and the
/// grasp-slip family ([`slip_run`], [`SLIP_DURATION`] s each, whatever `base`'s duration).
pub fn run_grid(base: &PlanarScenario, src: &Source, threads: usize) -> Result<Vec<Cell>> {
    let mut jobs: Vec<(Option<usize>, usize, usize, PlanarScenario)> = Vec::new();
    for (l, (kind, gains, _)) in LAWS.iter().enumerate() {
        let mut sc = base.clone();
        sc.controller.kind = *kind;
        sc.controller.gains = *gains;
        sc.faults = FaultsConfig::default();
        jobs.push((None, 0, l, sc.clone()));
        for (fi, fam) in FAMILIES.iter().enumerate() {
            for (li, &v) in fam.levels.iter().enumerate() {
                let mut s = sc.clone();
                (fam.set)(&mut s.faults, v);
                jobs.push((Some(fi), li, l, s));
            }
        }
    }
    // Validate everything first: a bad scenario is bad input, before any run. The slip runs
    // (the stiff ones are the longest) go first.
    let mut prepared: Vec<Mutex<Option<Job>>> = slip_jobs()
        .into_iter()
        .map(|(lv, law, f)| Mutex::new(Some(Job::Slip(lv, law, f))))
        .collect();
    for (f, lv, law, sc) in jobs {
        prepared.push(Mutex::new(Some(Job::Planar(
            f,
            lv,
            law,
            Box::new(runner::prepare(sc, src)?),
        ))));
    }
    let next = AtomicUsize::new(0);
    let cells: Mutex<Vec<Cell>> = Mutex::new(Vec::new());
    let failed: Mutex<Option<anyhow::Error>> = Mutex::new(None);
    std::thread::scope(|s| {
        for _ in 0..threads.max(1) {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(slot) = prepared.get(i) else { break };
                    let Some(job) = slot.lock().ok().and_then(|mut g| g.take()) else {
                        continue;
                    };
                    let cell = match job {
                        Job::Planar(family, level, law, p) => {
                            let f = runner::execute(*p, |_| {});
                            let (class, detail, margin, track_mm) = classify(&f);
                            Cell {
                                family,
                                level,
                                law,
                                class,
                                detail,
                                margin,
                                track_mm,
                                slip: None,
                            }
                        }
                        Job::Slip(level, law, f) => match slip_run_with(level, law, f) {
                            Ok(c) => c,
                            Err(e) => {
                                if let Ok(mut f) = failed.lock() {
                                    f.get_or_insert(e);
                                }
                                continue;
                            }
                        },
                    };
                    if let Ok(mut c) = cells.lock() {
                        c.push(cell);
                    }
                }
            });
        }
    });
    if let Some(e) = failed.into_inner().ok().flatten() {
        return Err(e);
    }
    let mut cells = cells.into_inner().unwrap_or_default();
    cells.sort_by_key(|c| {
        (
            c.slip.is_some(),
            c.family.map_or(0, |f| f + 1),
            c.law,
            c.level,
        )
    });
    Ok(cells)
}

// ---------------------------------------------------------------------------------------------
// The grasp-slip family (spatial).

/// Stiffness levels of the compliant true grasps, (translational N/m, rotational N m/rad),
/// stiffest first: half decades from 1e7/1e5 to 1e4/1e2, the rotational stiffness that of the
/// translational one at a 10 cm lever arm, `k_rot = k (0.1 m)²`.
pub const SLIP_LEVELS: [(f64, f64); 6] = [
    (1e7, 1e5),
    (3e6, 3e4),
    (1e6, 1e4),
    (3e5, 3e3),
    (1e5, 1e3),
    (1e4, 1e2),
];

/// Simulated time of a grasp-slip run, s.
pub const SLIP_DURATION: f64 = 4.0;

/// Transient of a grasp-slip run (the 1 cm start offset and the grasps settling), s: the errors
/// are measured after it (as `summary.json` of the spatial presets).
pub const SLIP_TRANSIENT: f64 = 2.0;

/// Grasp deflection at which a compliant grasp has slipped, m and rad (the loop's `max_drift`,
/// the same number for both): 5 cm, or 0.05 rad ≈ 2.9° about any grasp axis. A run that
/// reaches it stops with the named `constraint_drift` fault.
pub const SLIP_DEFLECTION: f64 = 0.05;

/// Effective mass and rotational inertia of the lightest body on a grasp spring, kg and kg m²:
/// a UR5 wrist's tool flange (the values `tests/spatial_plant.rs` resolves the compliant grasp
/// with). They set the damping rule ([`slip_grasp`]) and the plant step ([`slip_substeps`]).
pub const TIP_MASS: f64 = 0.2;
/// See [`TIP_MASS`].
pub const TIP_INERTIA: f64 = 1e-4;

/// The robust-term smoothing `ϖ` once proposed for the spatial NN law under compliant grasps
/// (`docs/robustness.md`); the default keeps the paper's 0.05 and widens it where the control
/// period needs it instead (`smoothing = "sampled"`, `docs/smooth-nn.md`).
pub const PROPOSED_VARPI: f64 = 20.0;

/// A law of the slip family: label, the law, whether the 6-D admittance runs, and whether it
/// runs the whole ladder (otherwise only the diagnostic levels [`SLIP_DIAGNOSTIC_LEVELS`]).
pub struct SlipLaw {
    /// Label.
    pub name: &'static str,
    /// The law.
    pub law: fn() -> Law<6>,
    /// The default 6-D admittance on (off: `x_r = x_d`).
    pub admittance: bool,
    /// The whole ladder (else the diagnostic levels only).
    pub ladder: bool,
}

/// The compared spatial laws: PD as the paper's baseline (no gravity compensation), PD with
/// the model's gravity, the NN law with its S6 gains in the paper's form (SPEC §3.4's `ϖ`,
/// `d1`, `d2`: `NnGains::with_paper_switching`), and that form with `ϖ = 20`; then diagnostics
/// of the paper form's degradation (no admittance; smaller `ϖ`; a wider switching region with
/// the paper's `ϖ`); last the NN law's smooth default (`docs/smooth-nn.md`: the sampled-data
/// boundary layer and `d1 = 2`, `d2 = 3`).
pub const SLIP_LAWS: [SlipLaw; 9] = [
    SlipLaw {
        name: "PD (paper)",
        law: || Law::Pd(PdGains::<6>::paper()),
        admittance: true,
        ladder: true,
    },
    SlipLaw {
        name: "PD + model gravity",
        law: || {
            Law::Pd(PdGains {
                gravity_compensation: true,
                ..PdGains::<6>::paper()
            })
        },
        admittance: true,
        ladder: true,
    },
    SlipLaw {
        name: "NN (paper form)",
        law: || Law::Nn(NnGains::dual_ur5().with_paper_switching()),
        admittance: true,
        ladder: true,
    },
    SlipLaw {
        name: "NN, ϖ = 20",
        law: || {
            Law::Nn(NnGains {
                varpi: PROPOSED_VARPI,
                ..NnGains::dual_ur5().with_paper_switching()
            })
        },
        admittance: true,
        ladder: true,
    },
    SlipLaw {
        name: "NN, no admittance",
        law: || Law::Nn(NnGains::dual_ur5().with_paper_switching()),
        admittance: false,
        ladder: false,
    },
    SlipLaw {
        name: "NN, ϖ = 3",
        law: || {
            Law::Nn(NnGains {
                varpi: 3.0,
                ..NnGains::dual_ur5().with_paper_switching()
            })
        },
        admittance: true,
        ladder: false,
    },
    SlipLaw {
        name: "NN, ϖ = 10",
        law: || {
            Law::Nn(NnGains {
                varpi: 10.0,
                ..NnGains::dual_ur5().with_paper_switching()
            })
        },
        admittance: true,
        ladder: false,
    },
    SlipLaw {
        name: "NN, d1 = 2, d2 = 3 (paper ϖ)",
        law: || {
            Law::Nn(NnGains {
                d1: 2.0,
                d2: 3.0,
                ..NnGains::dual_ur5().with_paper_switching()
            })
        },
        admittance: true,
        ladder: false,
    },
    SlipLaw {
        name: "NN",
        law: || Law::Nn(NnGains::dual_ur5()),
        admittance: true,
        ladder: true,
    },
];

/// Levels the diagnostic laws run at (1e6/1e4 and 1e5/1e3), besides the welds.
pub const SLIP_DIAGNOSTIC_LEVELS: [usize; 2] = [2, 4];

/// Every (level, law, step factor) of the family, the stiffest levels first; and the NN law
/// at 1e6 / 1e4 with half the step (its chatter is chaotic: the report shows how much).
fn slip_jobs() -> Vec<(Option<usize>, usize, usize)> {
    let mut v = Vec::new();
    for lv in 0..SLIP_LEVELS.len() {
        for (l, law) in SLIP_LAWS.iter().enumerate() {
            if law.ladder || SLIP_DIAGNOSTIC_LEVELS.contains(&lv) {
                v.push((Some(lv), l, 1));
            }
        }
    }
    v.insert(0, (Some(2), NN, 2));
    for l in 0..SLIP_LAWS.len() {
        v.push((None, l, 1));
    }
    v
}

/// The compliant grasp of stiffness `(k, k_rot)`, diagonal in the grasp axes. Damping rule:
/// critically damped against the tip ([`TIP_MASS`], [`TIP_INERTIA`]), `d = 2√(k m_tip)`,
/// `d_rot = 2√(k_rot I_tip)`: a fixed damping ratio at every level, 1 on the wrist's mode and
/// `2√(m_tip/m_box) ≈ 0.37` on the 3 kg box's translation against both grasps (0.06–0.1 on its
/// rotations, as a rubber pad), and the fast wrist mode is not made stiffer than the spring.
pub fn slip_grasp(k: f64, k_rot: f64) -> GraspModel {
    let (d, dr) = (
        2.0 * (k * TIP_MASS).sqrt(),
        2.0 * (k_rot * TIP_INERTIA).sqrt(),
    );
    GraspModel::Compliant {
        stiffness: Vector6::new(k, k, k, k_rot, k_rot, k_rot),
        damping: Vector6::new(d, d, d, dr, dr, dr),
    }
}

/// Plant steps per 1 ms control period for grasps of stiffness `(k, k_rot)`: the fastest
/// spring mode is the tip's, `ω = max(√(k/m_tip), √(k_rot/I_tip))`, and RK4 resolves a
/// critically damped mode to 4 digits with `h ω ≤ 1` (checked by halving the step: the
/// non-chattering runs' errors agree to 4 digits, `docs/robustness.md`); `n = ⌈ω · 1 ms⌉`.
pub fn slip_substeps(k: f64, k_rot: f64) -> usize {
    let w = (k / TIP_MASS).sqrt().max((k_rot / TIP_INERTIA).sqrt());
    (w * 1e-3).ceil().max(1.0) as usize
}

/// One grasp-slip run: the S6 dual-UR5 closed loop (`presets::spatial_s6_simulation_with`),
/// the controller assuming welds, the true grasps compliant at `SLIP_LEVELS[level]` (`None`:
/// welded), law `SLIP_LAWS[law]`, [`SLIP_DURATION`] s; classified as the planar runs with the
/// true box pose against the path as the tracking error.
pub fn slip_run(level: Option<usize>, law: usize) -> Result<Cell> {
    slip_run_with(level, law, 1)
}

/// [`slip_run`] with `factor` times [`slip_substeps`] plant steps per control period (the
/// step-convergence check).
pub fn slip_run_with(level: Option<usize>, law: usize, factor: usize) -> Result<Cell> {
    let l = &SLIP_LAWS[law];
    let setup = tandem::presets::dual_ur5();
    let mut truth = setup.params.clone();
    let mut substeps = 1;
    if let Some(lv) = level {
        let (k, kr) = SLIP_LEVELS[lv];
        truth.grasp_model = slip_grasp(k, kr);
        substeps = slip_substeps(k, kr);
    }
    substeps *= factor.max(1);
    let spatial_law = (l.law)();
    let varpi = match &spatial_law {
        Law::Nn(g) => g.varpi,
        _ => f64::NAN,
    };
    let mut p = SpatialControllerParams::spec_s6(spatial_law);
    if !l.admittance {
        p.admittance = None;
    }
    let (sim, _warnings) = tandem::presets::spatial_s6_simulation_with(
        &truth,
        &setup,
        &p,
        SLIP_DURATION,
        1e-3 / substeps as f64,
        SLIP_DEFLECTION,
    )?;
    let fu = sim.driver().adaptive().map(|a| a.fu().clone());
    let (out, _) = sim.run(|_| {});
    let log = &out.log;
    let col = |n: &str| log.get(n).unwrap_or(&[]);
    let v6 = |g: &str, k: usize| {
        Vector6::from_fn(|j, _| {
            col(&format!("{g}.{}", ["x", "y", "z", "rx", "ry", "rz"][j]))
                .get(k)
                .copied()
                .unwrap_or(f64::NAN)
        })
    };
    let t = col("t");
    let path = Se3Path::spec_s6();
    let (mut ep, mut er) = (f64::NAN, f64::NAN);
    let (mut q_min, mut q_low, mut slope) = (f64::NAN, 0usize, f64::NAN);
    let mut first_exit: Option<(f64, String, f64)> = None;
    for (k, &tk) in t.iter().enumerate() {
        if tk >= SLIP_TRANSIENT {
            let d = path.sample(tk);
            let c = |n: &str| col(n).get(k).copied().unwrap_or(f64::NAN);
            let pos = Vector3::new(c("x_o.x"), c("x_o.y"), c("x_o.z"));
            let q = UnitQuaternion::from_quaternion(Quaternion::new(
                c("x_o.qw"),
                c("x_o.qx"),
                c("x_o.qy"),
                c("x_o.qz"),
            ));
            ep = (pos - d.p).norm().max(if ep.is_nan() { 0.0 } else { ep });
            er = (d.r.inverse() * q)
                .scaled_axis()
                .norm()
                .max(if er.is_nan() { 0.0 } else { er });
        }
        if let Some(fu) = &fu {
            let qk = col("Q").get(k).copied().unwrap_or(f64::NAN);
            q_min = q_min.min(qk);
            if qk < 1.0 {
                q_low += 1;
                if first_exit.is_none() {
                    let mut worst = (String::new(), 0.0f64);
                    for g in ["x_hat", "xd_hat", "alpha", "alpha_dot"] {
                        for (j, a) in ["x", "y", "z", "rx", "ry", "rz"].iter().enumerate() {
                            let v = v6(g, k)[j];
                            if v.abs() > worst.1.abs() {
                                worst = (format!("{g}.{a}"), v);
                            }
                        }
                    }
                    first_exit = Some((tk, worst.0, worst.1));
                }
            }
            // f^U_j(‖x2‖, ‖α‖, ‖α̇‖) of the tick, SPEC §3.4 / paper (39).
            let (x2, a, ad) = (v6("xd_hat", k), v6("alpha", k), v6("alpha_dot", k));
            for j in 0..6 {
                let f = fu.eval(j, x2.norm(), a.norm(), ad.norm());
                slope = slope.max((1.0 - qk) * f * f / varpi);
            }
        }
    }
    let q_low = if fu.is_some() && !t.is_empty() {
        q_low as f64 / t.len() as f64
    } else {
        f64::NAN
    };
    let margin = out.min_margin.unwrap_or(f64::NAN);
    let info = SlipInfo {
        track_rad: er,
        q_low,
        q_min,
        robust_slope: slope,
        deflection: (out.max_drift, out.max_drift_rot),
        substeps,
        factor: factor.max(1),
        fu_rest: fu.as_ref().map(|f| std::array::from_fn(|j| f.a[j])),
        first_exit,
    };
    let track_mm = ep * 1e3;
    let nn = if fu.is_some() {
        format!(", Q < 1 in {} %", num(100.0 * q_low, 2))
    } else {
        String::new()
    };
    let (class, detail) = if let Some(f) = &out.fault {
        let kind = serde_json::to_value(&f.kind)
            .ok()
            .and_then(|v| v["kind"].as_str().map(str::to_string))
            .unwrap_or_default();
        (
            "fault",
            format!(
                "{kind} at {} s: deflection {} mm, {} rad",
                num(f.t, 3),
                num(out.max_drift * 1e3, 2),
                num(out.max_drift_rot, 2)
            ),
        )
    } else {
        let class = if out.violation_ticks > 0 {
            "outside"
        } else if track_mm <= TRACK_MM && er <= TRACK_RAD {
            "inside"
        } else {
            "degraded"
        };
        (
            class,
            format!(
                "margin {}, err {} mm, {} rad{}{}",
                num(margin, 2),
                num(track_mm, 3),
                num(er, 2),
                nn,
                if out.violation_ticks > 0 {
                    format!(", {} violating ticks", out.violation_ticks)
                } else {
                    String::new()
                }
            ),
        )
    };
    Ok(Cell {
        family: level.map(|_| 0),
        level: level.unwrap_or(0),
        law,
        class,
        detail,
        margin,
        track_mm,
        slip: Some(info),
    })
}

/// The report, the figure and `results.json` into `dir`.
pub fn write(
    dir: &std::path::Path,
    cells: &[Cell],
    base: &PlanarScenario,
    cmd: &str,
) -> Result<()> {
    let find = |f: Option<usize>, lv: usize, law: usize| {
        cells
            .iter()
            .find(|c| c.slip.is_none() && c.family == f && c.level == lv && c.law == law)
    };
    let find_slip_f = |lv: Option<usize>, law: usize, f: usize| {
        cells.iter().find(|c| {
            c.slip.as_ref().is_some_and(|i| i.factor == f)
                && c.family == lv.map(|_| 0)
                && c.level == lv.unwrap_or(0)
                && c.law == law
        })
    };
    let find_slip = |lv: Option<usize>, law: usize| find_slip_f(lv, law, 1);
    let halved = find_slip_f(Some(2), NN, 2);
    let mut md = String::from("# Robustness to injected faults\n\n");
    md.push_str(&format!(
        "Generated by `{cmd}` (tandem {}): the paper scenario, {} s per run, seed {}, for PD and \
         the NN law (tuned gains). Each fault family of the scenario's `[faults]` section runs at \
         five increasing severities; everything else is nominal. A run is **inside** when it \
         completes, the true pose never leaves the bounds `|x_1j| < k_cj`, and `‖z1_xy‖` stays \
         below {TRACK_MM} mm after the {} s transient; **degraded** when it completes inside the \
         bounds but tracks worse; **outside** when it completes but the true pose violated a \
         bound; **fault** when it stops with a named fault. Every run either completes or stops \
         with a named fault. The last section runs the grasp-slip family on the spatial S6 \
         set-up.\n\n",
        env!("CARGO_PKG_VERSION"),
        num(base.run.duration, 4),
        base.run.seed,
        num(base.metrics.transient, 3),
    ));
    md.push_str(
        "Reproduce this page (about 15 s of CPU time, 113 runs):\n\n```sh\ncargo run --release -p tandem-cli -- robustness \
         --out out/robustness --force && cp out/robustness/robustness.md docs/ && \
         cp out/robustness/figures/robustness*.png docs/figures/\n```\n\n\
         The knobs are the scenario's `[faults]` section (see `crates/tandem-cli/README.md`); \
         `results.json` next to the report holds every run.\n\n",
    );
    md.push_str("## Nominal\n\n| law | result |\n|---|---|\n");
    for (l, (_, _, name)) in LAWS.iter().enumerate() {
        if let Some(c) = find(None, 0, l) {
            md.push_str(&format!("| {name} | **{}** ({}) |\n", c.class, c.detail));
        }
    }
    md.push_str(
        "\n![Minimum constraint margin per family](figures/robustness.png)\n\n\
         ![Tracking error per family](figures/robustness_error.png)\n\n\
         The figures plot, per family and severity level (1 = mildest), the minimum constraint \
         margin `1 − max_j |x_1j|/k_cj` over the run (below 0: the bound was violated) and the \
         largest `‖z1_xy‖` after the transient (clipped at the top of the axis); a run that \
         faulted ends its law's line. The tables below give every run.\n\n",
    );
    for (fi, fam) in FAMILIES.iter().enumerate() {
        md.push_str(&format!("## {} ({})\n\n| level |", fam.name, fam.what));
        for (_, _, name) in LAWS {
            md.push_str(&format!(" {name} |"));
        }
        md.push_str("\n|---|");
        for _ in LAWS {
            md.push_str("---|");
        }
        md.push('\n');
        for (li, v) in fam.levels.iter().enumerate() {
            md.push_str(&format!("| {} |", num(*v, 3)));
            for l in 0..LAWS.len() {
                match find(Some(fi), li, l) {
                    Some(c) => md.push_str(&format!(" **{}** ({}) |", c.class, c.detail)),
                    None => md.push_str(" — |"),
                }
            }
            md.push('\n');
        }
        md.push('\n');
    }
    slip_section(&mut md, &find_slip, halved);
    crate::files::write_text_atomic(&dir.join("robustness.md"), &md)?;

    // Figures: one panel per family, the metric against the level, one series per law; a
    // faulted run ends its law's line.
    std::fs::create_dir_all(dir.join("figures"))?;
    let xs: Vec<f64> = (1..=5).map(f64::from).collect();
    type Metric = fn(&Cell) -> f64;
    /// (file stem, title, y label, metric, y range, reference line and its label).
    type Fig<'a> = (&'a str, &'a str, &'a str, Metric, (f64, f64), f64, &'a str);
    let figs: [Fig; 2] = [
        (
            "robustness",
            "Robustness: minimum constraint margin per fault family and severity",
            "min margin",
            |c| c.margin,
            (-0.5, 1.0),
            0.0,
            "bound",
        ),
        (
            "robustness_error",
            "Robustness: max tracking error ‖z1_xy‖ after the transient",
            "max ‖z1_xy‖ after transient [mm]",
            |c| c.track_mm,
            (0.0, 2.0 * TRACK_MM),
            TRACK_MM,
            "inside limit",
        ),
    ];
    for (stem, title, y_label, metric, (lo, hi), line, line_label) in figs {
        let ys: Vec<Vec<Vec<f64>>> = (0..FAMILIES.len())
            .map(|fi| {
                (0..LAWS.len())
                    .map(|l| {
                        (0..FAMILIES[fi].levels.len())
                            .map_while(|lv| {
                                find(Some(fi), lv, l)
                                    .filter(|c| c.class != "fault" && metric(c).is_finite())
                                    .map(|c| metric(c).clamp(lo, hi))
                            })
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let mut panels = Vec::new();
        for (fi, fam) in FAMILIES.iter().enumerate() {
            let mut p = Panel::new(fam.name, format!("level (1..5: {})", fam.what), y_label)
                .hline(line, line_label)
                .x_range(0.5, 5.5)
                .y_range(lo, hi);
            for (l, (_, _, name)) in LAWS.iter().enumerate() {
                let y = &ys[fi][l];
                p = p.with(Series::new(*name, &xs[..y.len()], y, Style::solid(l)));
            }
            panels.push(p);
        }
        plot::panels(&dir.join("figures").join(stem), title, &panels, 2)?;
    }
    slip_figure(&dir.join("figures").join("robustness_slip"), &find_slip)?;
    let rows: Vec<serde_json::Value> = cells
        .iter()
        .map(|c| {
            if let Some(i) = &c.slip {
                let lv = (c.family.is_some()).then(|| SLIP_LEVELS[c.level]);
                return json!({
                    "family": c.family.map(|_| "grasp slip"),
                    "level": lv.map(|(k, kr)| json!({"stiffness": k, "stiffness_rot": kr})),
                    "law": SLIP_LAWS[c.law].name,
                    "class": c.class,
                    "detail": c.detail,
                    "min_margin": c.margin.is_finite().then_some(c.margin),
                    "max_position_error_after_mm": c.track_mm.is_finite().then_some(c.track_mm),
                    "max_orientation_error_after_rad": i.track_rad.is_finite().then_some(i.track_rad),
                    "q_below_1_share": i.q_low.is_finite().then_some(i.q_low),
                    "q_min": i.q_min.is_finite().then_some(i.q_min),
                    "max_robust_slope": i.robust_slope.is_finite().then_some(i.robust_slope),
                    "max_deflection_m": i.deflection.0,
                    "max_deflection_rad": i.deflection.1,
                    "plant_substeps": i.substeps,
                });
            }
            json!({
                "family": c.family.map(|f| FAMILIES[f].name),
                "level": c.family.map(|f| FAMILIES[f].levels[c.level]),
                "law": LAWS[c.law].2,
                "class": c.class,
                "detail": c.detail,
                "min_margin": c.margin.is_finite().then_some(c.margin),
                "max_z1_after_mm": c.track_mm.is_finite().then_some(c.track_mm),
            })
        })
        .collect();
    crate::files::write_json_atomic(&dir.join("results.json"), &json!({ "runs": rows }))?;
    Ok(())
}

/// Type of the slip-cell lookup: (level, `None` = welds; law).
type FindSlip<'a> = dyn Fn(Option<usize>, usize) -> Option<&'a Cell> + 'a;

/// Index of the NN law in the paper's form and of that form with `ϖ = 20` in [`SLIP_LAWS`].
const NN: usize = 2;
const NN_PROPOSED: usize = 3;

fn level_label(lv: usize) -> String {
    let (k, kr) = SLIP_LEVELS[lv];
    format!("{k:e} / {kr:e}")
}

/// The grasp-slip section of the report.
fn slip_section<'a>(md: &mut String, find: &FindSlip<'a>, halved: Option<&Cell>) {
    let detail = |lv: Option<usize>, law: usize| {
        find(lv, law).map_or("—".to_string(), |c| {
            format!("**{}** ({})", c.class, c.detail)
        })
    };
    let info = |lv: Option<usize>, law: usize| find(lv, law).and_then(|c| c.slip.clone());
    md.push_str(&format!(
        "## Grasp slip (spatial S6, dual UR5: compliant true grasps, stiffness N/m / N m/rad)\n\n\
         The SPEC-spatial S6 closed loop (`presets::spatial_s6_simulation_with`: the S6 circle \
         with its pitch oscillation, the S6 disturbance, a start 1 cm inside the circle, 1 kHz \
         control, the default 6-D admittance) with a controller that assumes welded grasps, on \
         a true plant whose grasps are 6-D spring–dampers (`plant::spatial::GraspModel::\
         Compliant`, diagonal in the grasp axes) of decreasing stiffness, {} s per run (this \
         family ignores `--duration`). Damping rule: critically damped against the lightest \
         body on the spring, a UR5 wrist's flange ({TIP_MASS} kg, {TIP_INERTIA} kg m²): \
         `d = 2√(k·{TIP_MASS})`, `d_rot = 2√(k_rot·{TIP_INERTIA})`, a fixed damping ratio at \
         every level (1 on the wrist's mode, 0.37 on the 3 kg box's translation against both \
         grasps, 0.06–0.1 on its rotations against the rotational springs alone). Plant step: the fastest mode is the wrist's on the spring, \
         `ω = max(√(k/m_tip), √(k_rot/I_tip))`, and the step is 1 ms/n with `n = ⌈ω·1 ms⌉` \
         (`h ω ≤ 1`). Halving the step (`slip_run_with(.., 2)`, the ignored test \
         `slip_family_converges_in_the_step`) leaves the runs that neither chatter nor wobble \
         unchanged to 6 digits (the PD laws from 1e7 to 1e6, the NN law at 1e7, the NN law \
         with `ϖ = 20` at every level that completes); the runs that oscillate (the NN law's \
         chatter, the PD laws' rotational wobble from 3e5 / 3e3, the runs that leave the \
         bounds) move by up to 20 % in their errors, and one class changes (the NN law's at \
         1e6 / 1e4, run both ways below). Classes as above on six outputs: the margin is `1 − max_j |x_1j|/k_cj` over \
         the three positions (`k_c` = 0.167, 0.167, 0.1 m) and three chart rotations (0.29 rad \
         each) of the true box, every tick; the errors are the true box pose against the path \
         after {} s (position ≤ {TRACK_MM} mm and orientation `‖Log(R_dᵀR)‖` ≤ {TRACK_RAD} rad \
         for **inside**). A grasp that deflects more than {SLIP_DEFLECTION} m or \
         {SLIP_DEFLECTION} rad has slipped: the run stops with the named `constraint_drift` \
         fault. For the NN law the table also gives the share of the run with the switching \
         `Q < 1` (paper (37)–(38)).\n\n",
        num(SLIP_DURATION, 3),
        num(SLIP_TRANSIENT, 3),
    ));
    let ladder: Vec<usize> = (0..SLIP_LAWS.len())
        .filter(|&l| SLIP_LAWS[l].ladder)
        .collect();
    md.push_str("| stiffness (steps/ms) |");
    for &l in &ladder {
        md.push_str(&format!(" {} |", SLIP_LAWS[l].name));
    }
    md.push_str("\n|---|");
    for _ in &ladder {
        md.push_str("---|");
    }
    md.push_str("\n| welds (1) |");
    for &l in &ladder {
        md.push_str(&format!(" {} |", detail(None, l)));
    }
    md.push('\n');
    for lv in 0..SLIP_LEVELS.len() {
        let (k, kr) = SLIP_LEVELS[lv];
        md.push_str(&format!(
            "| {} ({}) |",
            level_label(lv),
            slip_substeps(k, kr)
        ));
        for &l in &ladder {
            md.push_str(&format!(" {} |", detail(Some(lv), l)));
        }
        md.push('\n');
    }
    md.push_str(
        "\n![Grasp slip: margin and errors per stiffness](figures/robustness_slip.png)\n\n",
    );

    // Why the NN law degrades: numbers from the runs above.
    let pct = |i: &Option<SlipInfo>| i.as_ref().map_or("—".into(), |i| num(100.0 * i.q_low, 2));
    let qmin = |i: &Option<SlipInfo>| i.as_ref().map_or("—".into(), |i| num(i.q_min, 2));
    let slope = |i: &Option<SlipInfo>| i.as_ref().map_or("—".into(), |i| num(i.robust_slope, 2));
    let (weld, mid) = (info(None, NN), info(Some(2), NN));
    let fu_rest = weld
        .as_ref()
        .and_then(|i| i.fu_rest)
        .map_or("—".into(), |a| {
            format!(
                "{}, {}, {} N and {}, {}, {} N m",
                num(a[0], 2),
                num(a[1], 2),
                num(a[2], 2),
                num(a[3], 2),
                num(a[4], 2),
                num(a[5], 2)
            )
        });
    let exit = weld
        .as_ref()
        .and_then(|i| i.first_exit.clone())
        .map_or("—".into(), |(t, name, v)| {
            format!("at {} s `{name}` = {}", num(t, 2), num(v, 3))
        });
    let low_ms = weld
        .as_ref()
        .map_or("—".into(), |i| num(i.q_low * SLIP_DURATION * 1e3, 2));
    md.push_str(&format!(
        "### Why the NN law in the paper's form degrades under compliance\n\n\
         The NN law blends the network and the robust term with the switching `Q = Π_k m_k(Z_k)` \
         (paper (37)–(38)) over the 24 inputs `Z = [x_1, x_2, α, α̇]`, `m_k = 1` for \
         `|Z_k| ≤ d1 = 1` and 0 beyond `d2 = 1.5`, and the robust term `−f^U tanh(f^U z_2/ϖ)` \
         (SPEC §3.4, `ϖ = 0.05`) is, in its linear zone, a feedback on `z_2` of slope \
         `f^U²/ϖ`; `f^U = a + b‖x_2‖‖α‖ + c‖α̇‖` (paper (39); on S6 `a` = {fu_rest}). The \
         'robust slope' below is `max_j (1 − Q) f^U_j²/ϖ` over the logged rows (every 10 ms).\n\n\
         - **With welds the robust term already acts, harmlessly.** The 1 cm start offset \
         takes `Z` out of `Ω` (first row with `Q < 1`: {exit}): `Q` dips to {} for about {low_ms} \
         ms ({} % of the run), and the robust slope reaches {} — far above what a 1 kHz loop can \
         apply (a velocity feedback of slope `g` on an inertia `𝓜` sampled every `h` is stable \
         only for `g h/𝓜 < 2`: 2.2e4 N s/m on the welded box's 11 kg) — but there the tanh is \
         saturated, a push of at most `(1 − Q) f^U` on the box's chart inertia (11–18 kg, \
         0.02–0.76 kg m²), and `Q` returns to 1.\n\
         - **With compliant grasps the same push lands on the wrists.** Between the arms and \
         the box there are now springs, and the robust term's sign flips excite the wrists' \
         modes (0.2 kg, 1e-4 kg m²: `g h/𝓜 < 2` means 400 N s/m, 0.2 N m s/rad). The ringing \
         is what the controller measures (joint encoders through the welded model): `x_2` and \
         `α̇` stay out of `Ω`, `Q` drops to 0, `f^U` grows with `‖x_2‖‖α‖`, and the robust term \
         chatters at the tick rate through the springs. At {}: Q < 1 in {} % of the run, \
         robust slope up to {}, and the box's orientation error reaches tenths of a radian: {}. \
         The chatter is chaotic: with half the plant step the same run is {}.\n\
         - **Not the admittance** (which feeds the measured wrist wrenches back into `x_r`): \
         without it, at the same two levels: {}; {}.\n\
         - **It is the robust term's slope.** Raising `ϖ` lowers it: `ϖ = 3`: {} / {}; \
         `ϖ = 10`: {} / {}; `ϖ = {}` (the ladder's last column): inside down to 1e5 / 1e3, \
         where both PD laws leave the bounds or slip. With welds `ϖ = {}` changes nothing \
         measurable ({} against {}): `ϖ` enters the paper's ultimate bound through \
         `0.2785 ϖ` only while `Q < 1`, which on S6 with welds is the start.\n\
         - **Or keep `Q = 1`:** a switching region wide enough for the start transient \
         (`d1 = 2`, `d2 = 3`; the RBF centres ±1 with `ϑ² = 50` still cover it): {} / {}; \
         with welds {}.\n\n\
         Applied as the spatial default (`docs/smooth-nn.md`; the ladder's column **NN**): \
         `d1 = 2`, `d2 = 3`, so that the nominal trajectory's `Z` stays inside `Ω`, and the \
         robust term's boundary layer widened to what the control period resolves \
         (`smoothing = \"sampled\"`, `ϖ_j = max(ϖ, f_jᵁ² h/(β M_j))`), so that it is never a \
         high-gain sampled feedback when `Q` does drop. Both are the paper's own design \
         constants, neither touches the planar law, and both leave the welded S6 run as it was \
         (`z1` within 0.3 %). The soft \
         end of the ladder (1e4 / 1e2) slips under every law within half a second, in the start \
         transient: a 100 N m/rad grasp turns 0.05 rad under 5 N m.\n\n",
        qmin(&weld),
        pct(&weld),
        slope(&weld),
        level_label(2),
        pct(&mid),
        slope(&mid),
        detail(Some(2), NN),
        halved.map_or("—".to_string(), |c| format!(
            "**{}** ({})",
            c.class, c.detail
        )),
        detail(Some(2), 4),
        detail(Some(4), 4),
        detail(Some(2), 5),
        detail(Some(4), 5),
        detail(Some(2), 6),
        detail(Some(4), 6),
        num(PROPOSED_VARPI, 2),
        num(PROPOSED_VARPI, 2),
        detail(None, NN_PROPOSED),
        detail(None, NN),
        detail(Some(2), 7),
        detail(Some(4), 7),
        detail(None, 7),
    ));
    md.push_str("Diagnostics (NN law variants at two levels):\n\n| law | welds |");
    for lv in SLIP_DIAGNOSTIC_LEVELS {
        md.push_str(&format!(" {} |", level_label(lv)));
    }
    md.push_str("\n|---|---|");
    for _ in SLIP_DIAGNOSTIC_LEVELS {
        md.push_str("---|");
    }
    md.push('\n');
    for (l, law) in SLIP_LAWS.iter().enumerate() {
        if law.ladder && l != NN {
            continue;
        }
        md.push_str(&format!("| {} | {} |", law.name, detail(None, l)));
        for lv in SLIP_DIAGNOSTIC_LEVELS {
            let i = info(Some(lv), l);
            md.push_str(&format!(
                " {} (Q min {}, robust slope {}) |",
                detail(Some(lv), l),
                qmin(&i),
                slope(&i)
            ));
        }
        md.push('\n');
    }
    md.push('\n');
}

/// The grasp-slip figure: margin, position and orientation errors and the share of `Q < 1`
/// against the level, one line per ladder law; a faulted run ends its law's line.
fn slip_figure<'a>(stem: &std::path::Path, find: &FindSlip<'a>) -> Result<()> {
    let xs: Vec<f64> = (1..=SLIP_LEVELS.len()).map(|k| k as f64).collect();
    type Metric = fn(&Cell) -> f64;
    /// (title, y label, metric, y range, reference line and its label).
    type Fig<'a> = (&'a str, &'a str, Metric, (f64, f64), f64, &'a str);
    let metrics: [Fig; 4] = [
        (
            "min margin (six bounds)",
            "min margin",
            |c| c.margin,
            (-0.5, 1.0),
            0.0,
            "bound",
        ),
        (
            "position error after 2 s",
            "max ‖p − p_d‖ [mm]",
            |c| c.track_mm,
            (0.0, 2.0 * TRACK_MM),
            TRACK_MM,
            "inside limit",
        ),
        (
            "orientation error after 2 s",
            "max ‖Log(R_dᵀR)‖ [rad]",
            |c| c.slip.as_ref().map_or(f64::NAN, |i| i.track_rad),
            (0.0, 2.0 * TRACK_RAD),
            TRACK_RAD,
            "inside limit",
        ),
        (
            "NN switching: share of the run with Q < 1",
            "share",
            |c| c.slip.as_ref().map_or(f64::NAN, |i| i.q_low),
            (0.0, 1.0),
            0.0,
            "",
        ),
    ];
    let labels: Vec<String> = (0..SLIP_LEVELS.len()).map(level_label).collect();
    let x_label = format!("level (1..{}: {})", labels.len(), labels.join(", "));
    let ys: Vec<Vec<Vec<f64>>> = metrics
        .iter()
        .map(|(_, _, m, (lo, hi), _, _)| {
            (0..SLIP_LAWS.len())
                .map(|l| {
                    (0..SLIP_LEVELS.len())
                        .map_while(|lv| {
                            find(Some(lv), l)
                                .filter(|c| c.class != "fault" && m(c).is_finite())
                                .map(|c| m(c).clamp(*lo, *hi))
                        })
                        .collect()
                })
                .collect()
        })
        .collect();
    let mut panels = Vec::new();
    for (mi, (title, y_label, _, (lo, hi), line, line_label)) in metrics.iter().enumerate() {
        let mut p = Panel::new(*title, x_label.clone(), *y_label)
            .x_range(0.5, SLIP_LEVELS.len() as f64 + 0.5)
            .y_range(*lo, *hi);
        if !line_label.is_empty() {
            p = p.hline(*line, *line_label);
        }
        for (l, law) in SLIP_LAWS.iter().enumerate() {
            if !law.ladder || ys[mi][l].is_empty() {
                continue;
            }
            let y = &ys[mi][l];
            p = p.with(Series::new(law.name, &xs[..y.len()], y, Style::solid(l)));
        }
        panels.push(p);
    }
    plot::panels(
        stem,
        "Grasp slip: S6 dual UR5, compliant true grasps, controller assuming welds",
        &panels,
        2,
    )
}
