//! The per-arm 6-D admittance generator of SPEC-spatial S5 ("Admittance"): the spatial form of
//! SPEC §3.1's second-order generator, on the six components of each arm's tool pose.
//!
//! Data flow of one control tick (SPEC §3, step 3, on six outputs):
//! `(X_WO,d, V_d, V̇_d; X_OGi; F_i measured, F_ref,i) → X_WTi,d → (e_i, ė_i, ë_i) → X_WTi,r`,
//! and the arms' `X_WTi,r` (pose, twist, twist rate) feed [`se3::fit`], which returns the
//! object-level reference.
//!
//! # 1. Desired tool pose: rigid transport through the grasp
//! The weld (SPEC-spatial S3) ties `X_WTi = X_WO X_OGi`. For the desired object sample
//! `(p_d, R_d, [v_d; ω_d], [v̇_d; ω̇_d])` and `r = R_d p_OGi` (world vector from the object
//! origin to the tool origin), exactly ([`tool_from_object`]):
//!
//! $$ p_T = p_d + r,\quad R_T = R_d R_{OG},\quad
//!    v_T = v_d + \omega_d \times r,\quad \omega_T = \omega_d, $$
//! $$ \dot v_T = \dot v_d + \dot\omega_d \times r + \omega_d \times (\omega_d \times r),\quad
//!    \dot\omega_T = \dot\omega_d $$
//!
//! (`ṙ = ω_d × r`). The inverse map is [`se3::fit::candidate`].
//!
//! # 2. The offset and the reference tool pose
//! The reference tool pose is offset from the desired one by `e = [e_p; e_φ] ∈ ℝ⁶`
//! (linear first, as twists), **both in world axes** ([`reference_tool`]):
//!
//! $$ p_r = p_T + e_p,\qquad R_r = \mathrm{Exp}(e_\varphi)\, R_T . $$
//!
//! `e_p` moves the tool origin; `e_φ` turns the tool **about its own origin** by a rotation
//! vector in world axes (applied on the left). Why world axes: the wrench `F̃` that drives `e`
//! is in world axes (SPEC-spatial S1), so with diagonal `M_e, C_e, K_e` the six axes are
//! independent, time-invariant ODEs (in tool axes the same diagonal gains would rotate with the
//! tool and couple the axes through `ω_T`); it is also the planar generator's choice (world x,
//! y). For isotropic rotational gains (the defaults) the two choices agree.
//!
//! **Rates.** With the left Jacobian of SO(3), `d/dt Exp(φ) = [J_l(φ) φ̇]_× Exp(φ)` (Solà et
//! al. \[3\], the left Jacobian; [`crate::geometry::so3`]), differentiating
//! `R_r = Exp(e_φ) R_T` with `Ṙ_T = [ω_T] R_T`:
//!
//! $$ \omega_r = J_l(e_\varphi)\,\dot e_\varphi + \mathrm{Exp}(e_\varphi)\,\omega_T,
//!    \qquad v_r = v_T + \dot e_p, $$
//! $$ \dot\omega_r = \underbrace{\dot J_l\,\dot e_\varphi + J_l\,\ddot e_\varphi}_{w_2} +
//!    (J_l \dot e_\varphi) \times (\mathrm{Exp}(e_\varphi)\,\omega_T) +
//!    \mathrm{Exp}(e_\varphi)\,\dot\omega_T,
//!    \qquad \dot v_r = \dot v_T + \ddot e_p, $$
//!
//! the cross term from `d/dt (Exp(e_φ) ω_T) = [J_l ė_φ] Exp(e_φ) ω_T + Exp(e_φ) ω̇_T`. `J_l ė`
//! and `w_2` come from [`left_jacobian_rates`] (exact power series for `|e_φ| ≤ 2π`, closed
//! forms beyond; `J̇_l` by the chain rule in `u = |e_φ|²`, smooth through `e_φ = 0`).
//!
//! # 3. The generator
//! Per arm and per axis `j = 0…5` (x, y, z, then rotations about world x, y, z):
//!
//! $$ M_{e,j}\,\ddot e_j + C_{e,j}\,\dot e_j + K_{e,j}\,e_j = \tilde F_j,\qquad
//!    \tilde F = \mathrm{LPF}(F_i) - F_{ref,i}, $$
//!
//! exactly SPEC §3.1's model on each of the six components, discretised exactly for the input
//! held over the control period `h` by the planar generator's closed-form zero-order-hold map
//! ([`crate::reference::planar::admittance`], module doc "Discretisation": `x_{k+1} = Φ x_k + Γ F̃_k` on
//! `x = (e, ė)`, the three damping branches, and the `M_e = 0` first-order limit with `ė` set to
//! the ODE's value). The low-pass is the same exact first-order lag,
//! `y_{k+1} = y_k + (1 − e^{−h/τ_f})(F_k − y_k)`, started at `F_ref,i(0)`
//! ([`AdmittanceSe3State::with_filter_at`], SPEC §3.1: the raw wrench at `t = 0` reads a falling
//! object). Order inside [`AdmittanceSe3::step`], as planar: filter update with the new
//! measurement, then `F̃ = y_{k+1} − F_ref` held over the step, then `(e, ė)` advanced.
//! `ë` at the end of the step follows from the ODE with the held `F̃` ([`AdmittanceSe3::e_ddot`]).
//!
//! **Wrench convention** (SPEC-spatial S1). `F_i = [f; τ]` is the wrench **the object exerts on
//! tool `i`**, about the tool-frame origin, in **world axes** — what [`SpatialWorkspace::wrenches`]
//! holds. A wrist sensor reads the same wrench in tool axes ([`SpatialWorkspace::tool_wrench`]);
//! [`wrench_tool_to_world`] rotates it with the tool orientation (use the *measured* `R_WTi`,
//! from the encoders' forward kinematics). A sensor whose origin is not the tool origin needs a
//! shift first ([`crate::geometry::motion::shift_force`]). `F_ref,i` is in the same convention:
//! the arm's share of the nominal object wrench plus the commanded internal wrench (an input).
//!
//! **Sign: the reference yields.** As planar (`e = x_r − x_d`, `F̃ = LPF(F) − F_ref`, the force
//! on the end-effector): push the object along `+x` and it presses on the tools along `+x`, so
//! `F̃_x > 0` and `e_p,x` settles at `+F̃_x/K_e > 0`: the reference moves with the push. A twist
//! about `+z` gives `τ_z > 0` at the tools and `e_φ,z = τ_z/K_e,rot > 0`: the reference turns
//! with it. Through [`se3::fit`] the object reference does the same (tests).
//!
//! # 4. Defaults and why
//! Translation: SPEC §3.1's `M_e = 200` kg, `C_e = 626` N s/m, `K_e = 1000` N/m,
//! `τ_f = 10` ms (ω_n = 2.24 rad/s, ζ = 0.70; a 2 N push on two arms in parallel moves the
//! reference by 1 mm). Rotation: **the translational admittance seen at a lever arm
//! `ℓ = 0.2` m** ([`ROT_LEVER_ARM`], the half-length of the SPEC-spatial S6 box, i.e. the
//! distance from each grasp to the object centre): `M_rot = M_e ℓ² = 8` kg m²,
//! `C_rot = C_e ℓ² = 25.04` N m s/rad, `K_rot = K_e ℓ² = 40` N m/rad, same `τ_f`. Scaling all
//! three by `ℓ²` keeps the **same natural frequency and damping ratio** (`ω_n² = K/M`,
//! `ζ = C/(2√(KM))` are invariant), and a point at distance `ℓ` from the tool sees the
//! translational stiffness (`τ = K ℓ² φ` is a force `K ℓ φ` at arm `ℓ`, which moves that point by
//! `ℓ φ`). SPEC §3.1's stability argument (the virtual mass turns the algebraic force loop into
//! an integrator; its per-tick gain falls as `1/M_e`) suggests keeping the virtual inertia large
//! against the object's: as a rough guide, `8` kg m² against the S6 box's `0.02–0.05` kg m² is a
//! larger ratio (≥ 160) than `200` kg against its `3` kg (67). These rotational values are not
//! yet validated in closed loop (no spatial tracking law at the time of writing); the scenario
//! should confirm them as SPEC §3.1 did for the planar ones. A `0.5` N m unexpected twist turns
//! the tool reference by `0.5/40 = 12.5` mrad (0.72°). Through two S6 grasps and [`se3::fit`],
//! a `0.5` N m twist on the object (minimum-norm share: `0.240` N m and `±0.048` N per arm) turns
//! the object reference by `6.0` mrad: the fit averages the tools' orientations and ignores the
//! lever-arm part of their position offsets (test `object_reference_yields_to_a_push_through_the_fit`).
//!
//! # 5. Numerics and events (never NaN)
//! A measured component that is non-finite (dropout, NaN upstream) or implausible
//! (`|F_j| >` [`MAX_WRENCH`] = 1e6 N or N m, a sensor fault) is not taken in: that axis's filter
//! holds its value, and the step reports it ([`StepFlags::meas_held`]). An expected component
//! that is non-finite or implausible holds the previous step's `F̃` on that axis
//! ([`StepFlags::ref_held`]). An `(e, ė)` update that is not finite (unreachable with the
//! bounded inputs unless the gains are extreme) keeps the previous state
//! ([`StepFlags::state_held`]). So the state stays finite for every input. The reference pose
//! of [`step_arms`] falls back to the desired tool pose if it is not finite
//! ([`ArmsStep::output_held`], unreachable for offsets below about `1e150`). Offsets are meant to be small (mm, degrees); `Exp` is smooth for every
//! `e_φ`, so nothing breaks past `|e_φ| = π`, the rotation only wraps.
//!
//! Fixed-size types only: [`AdmittanceSe3::step`], [`AdmittanceSe3::reference`] and
//! [`step_arms`] do not allocate (test `no_allocation` in `tests/admittance_se3.rs`).
//!
//! # References
//! 1. SPEC-spatial S1 (conventions, the grasp wrench), S3 (welds), S5 "Admittance".
//! 2. SPEC §3.1 (the second-order generator, the filter started at `F_ref`, the expected force,
//!    exact discretisation, defaults and why); the planar generator [`crate::reference::planar::admittance`].
//! 3. J. Solà, J. Deray, D. Atchuthan, *A micro Lie theory for state estimation in robotics*,
//!    2018 (left Jacobian of SO(3), `d/dt Exp(φ) = [J_l φ̇] Exp(φ)`).
//!
//! [`se3::fit`]: crate::reference::spatial::fit()
//! [`se3::fit::candidate`]: crate::reference::spatial::fit::candidate
//! [`SpatialWorkspace::wrenches`]: crate::plant::spatial::SpatialWorkspace::wrenches
//! [`SpatialWorkspace::tool_wrench`]: crate::plant::spatial::SpatialWorkspace::tool_wrench

use std::fmt;

use nalgebra::{Isometry3, Matrix2, UnitQuaternion, Vector2, Vector3, Vector6};

use crate::error::{ModelError, positive};
use crate::geometry::motion::{ang, lin, stack};
use crate::geometry::so3::exp_quat;
use crate::reference::planar::admittance::axis_map;
use crate::reference::spatial::PoseSample;
use crate::reference::spatial::path::{Se3Sample, left_jacobian_rates};

/// Lever arm `ℓ` \[m\] that scales the translational defaults to the rotational ones
/// (`M_rot = M_e ℓ²`, `C_rot = C_e ℓ²`, `K_rot = K_e ℓ²`): the SPEC-spatial S6 grasp-to-centre
/// distance. See the module doc, section 4.
pub const ROT_LEVER_ARM: f64 = 0.2;

/// Plausibility bound on every wrench component, N or N m: a measured or expected component
/// with `|F_j| > 1e6` (or non-finite) is treated as a sensor fault and held (module doc,
/// section 5). Wrist force/torque sensors saturate orders of magnitude below it; it keeps the
/// offsets, and the fit downstream, far from overflow.
pub const MAX_WRENCH: f64 = 1e6;

/// Axis names for messages: linear x, y, z, then rotations about world x, y, z.
pub const AXIS_NAMES: [&str; 6] = ["x", "y", "z", "rx", "ry", "rz"];

/// Admittance parameters per axis, linear first: `[x, y, z, rx, ry, rz]` (world axes). Plain
/// data; validated by [`AdmittanceSe3::new`].
///
/// Units per axis: translational (kg, N s/m, N/m), rotational (kg m², N m s/rad, N m/rad);
/// `tau_f` in s on all six. Defaults: module doc, section 4.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdmittanceSe3Params {
    /// Virtual mass / inertia $M_e$, ≥ 0 (kg ×3, kg m² ×3); 0 selects the first-order model
    /// on that axis (warned).
    pub m_e: Vector6<f64>,
    /// Virtual damping $C_e$, > 0 (N s/m ×3, N m s/rad ×3).
    pub c_e: Vector6<f64>,
    /// Virtual stiffness $K_e$, > 0 (N/m ×3, N m/rad ×3). A constant $\tilde F_j$ settles at
    /// $e_j = \tilde F_j / K_{e,j}$.
    pub k_e: Vector6<f64>,
    /// Wrench low-pass time constant $\tau_f$ \[s\], ≥ 0 per axis; 0 means no filter.
    pub tau_f: Vector6<f64>,
}

impl Default for AdmittanceSe3Params {
    /// SPEC §3.1's translational defaults (200 kg, 626 N s/m, 1000 N/m, 10 ms) and the same
    /// scaled by [`ROT_LEVER_ARM`]² for rotation (8 kg m², 25.04 N m s/rad, 40 N m/rad).
    fn default() -> Self {
        // Written out (0.2² is not exact in binary): [M_e, C_e, K_e] · ROT_LEVER_ARM².
        AdmittanceSe3Params::uniform([200.0, 626.0, 1000.0], [8.0, 25.04, 40.0], 0.01)
    }
}

impl AdmittanceSe3Params {
    /// Translational `(m_e, c_e, k_e)` on x, y, z, rotational `(m_rot, c_rot, k_rot)` on the
    /// three rotation axes, and one `tau_f` \[s\] for all six.
    pub fn uniform(trans: [f64; 3], rot: [f64; 3], tau_f: f64) -> Self {
        let six = |a: f64, b: f64| Vector6::new(a, a, a, b, b, b);
        AdmittanceSe3Params {
            m_e: six(trans[0], rot[0]),
            c_e: six(trans[1], rot[1]),
            k_e: six(trans[2], rot[2]),
            tau_f: Vector6::repeat(tau_f),
        }
    }

    /// Translational `(m_e, c_e, k_e)` and the rotational ones scaled by `lever²` \[m²\]: the
    /// same natural frequency and damping ratio on all six axes (module doc, section 4).
    pub fn scaled(m_e: f64, c_e: f64, k_e: f64, tau_f: f64, lever: f64) -> Self {
        let l2 = lever * lever;
        AdmittanceSe3Params::uniform([m_e, c_e, k_e], [m_e * l2, c_e * l2, k_e * l2], tau_f)
    }
}

/// A set-up warning: the parameters are valid but known to be a bad idea.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum AdmittanceSe3Warning {
    /// $M_e = 0$ on this axis: the paper's first-order model, which SPEC §3.1 found unstable
    /// when fed by the grasp wrench of a rigid grasp. `Display` gives the reason.
    FirstOrder {
        /// Axis index, 0…5 (x, y, z, rx, ry, rz).
        axis: usize,
        /// The axis's filter time constant $\tau_f$ \[s\] (0: raw wrench).
        tau_f: f64,
    },
}

impl fmt::Display for AdmittanceSe3Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AdmittanceSe3Warning::FirstOrder { axis, tau_f } => {
                let name = AXIS_NAMES.get(*axis).copied().unwrap_or("?");
                write!(
                    f,
                    "admittance.m_e[{axis}] = 0 selects the paper's first-order model C_e ė + K_e e = F̃ on \
                     the {name} axis of the 6-D generator: fed by the grasp wrench of a rigid grasp, it \
                     passes the controller's own wrench straight into the reference velocity \
                     ė = (F̃ − K_e e)/C_e, which the tracking law multiplies by its velocity gain, and the \
                     loop diverges within milliseconds at any control rate (SPEC §3.1); {}use a virtual \
                     mass (default 200 kg, 8 kg m² for rotation)",
                    if *tau_f == 0.0 {
                        "the wrench is not filtered either (τ_f = 0); "
                    } else {
                        ""
                    }
                )
            }
        }
    }
}

/// State of one arm's 6-D generator: plain data, `Copy`. All vectors linear first, world axes.
///
/// Start it with [`AdmittanceSe3State::with_filter_at`]`(F_ref,i(0))` (SPEC §3.1).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AdmittanceSe3State {
    /// Offset $e = [e_p; e_\varphi]$ of the reference tool pose from the desired one (m, rad).
    pub e: Vector6<f64>,
    /// Its rate $\dot e$ (m/s, rad/s). On a first-order axis ($M_e = 0$) the ODE's value after
    /// the last step, not an independent state.
    pub e_dot: Vector6<f64>,
    /// Low-pass filtered measured wrench $\mathrm{LPF}(F_i)$ (N, N m): the object on the tool,
    /// about the tool origin, world axes.
    pub f_filt: Vector6<f64>,
    /// The unexpected wrench $\tilde F$ held over the last step (N, N m).
    pub f_tilde: Vector6<f64>,
}

impl AdmittanceSe3State {
    /// At rest ($e = \dot e = 0$, so the reference is the desired tool pose) with the filter
    /// output at `f_filt0` (N, N m), normally $F_{ref,i}(0)$; $\tilde F = 0$.
    pub fn with_filter_at(f_filt0: Vector6<f64>) -> Self {
        AdmittanceSe3State {
            e: Vector6::zeros(),
            e_dot: Vector6::zeros(),
            f_filt: f_filt0,
            f_tilde: Vector6::zeros(),
        }
    }
}

/// What one [`AdmittanceSe3::step`] did not take in: bit `j` of each mask is axis `j`
/// (x, y, z, rx, ry, rz). All zero on a normal step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepFlags {
    /// Axes whose measured wrench was non-finite or beyond [`MAX_WRENCH`]: the filter held.
    pub meas_held: u8,
    /// Axes whose $F_{ref}$ was non-finite or beyond [`MAX_WRENCH`]: the previous
    /// $\tilde F$ was held.
    pub ref_held: u8,
    /// Axes whose $(e, \dot e)$ update was not finite: the previous state was kept.
    pub state_held: u8,
}

impl StepFlags {
    /// No event on any axis.
    pub fn is_clean(&self) -> bool {
        self.meas_held == 0 && self.ref_held == 0 && self.state_held == 0
    }

    /// Bitwise union of two reports.
    pub fn union(self, other: StepFlags) -> StepFlags {
        StepFlags {
            meas_held: self.meas_held | other.meas_held,
            ref_held: self.ref_held | other.ref_held,
            state_held: self.state_held | other.state_held,
        }
    }
}

/// One arm's 6-D admittance generator: validated parameters and the precomputed exact
/// discretisation for the control period `h`. Immutable after [`AdmittanceSe3::new`]; the state
/// lives in [`AdmittanceSe3State`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdmittanceSe3 {
    params: AdmittanceSe3Params,
    h: f64,
    /// Filter gain $1 - e^{-h/\tau_f}$ per axis (1 when $\tau_f = 0$).
    b_f: Vector6<f64>,
    // Φ and Γ per axis, by entry.
    phi11: Vector6<f64>,
    phi12: Vector6<f64>,
    phi21: Vector6<f64>,
    phi22: Vector6<f64>,
    g1: Vector6<f64>,
    g2: Vector6<f64>,
    // ë = dd_f F̃ + dd_v ė + dd_e e per axis.
    dd_f: Vector6<f64>,
    dd_v: Vector6<f64>,
    dd_e: Vector6<f64>,
}

impl AdmittanceSe3 {
    /// Validate `params` and precompute the exact zero-order-hold discretisation for the control
    /// period `h` \[s\] (the planar per-axis maps, [`crate::reference::planar::admittance`]).
    ///
    /// Errors name the field: `admittance.c_e[j]` and `admittance.k_e[j]` must be finite and
    /// positive, `admittance.m_e[j]` and `admittance.tau_f[j]` finite and non-negative
    /// (`j = 0…5`), `h` finite and positive. Returns the generator and the set-up warnings (one
    /// [`AdmittanceSe3Warning::FirstOrder`] per axis with $M_e = 0$); the caller reports them.
    pub fn new(
        params: &AdmittanceSe3Params,
        h: f64,
    ) -> Result<(AdmittanceSe3, Vec<AdmittanceSe3Warning>), ModelError> {
        positive("h", h)?;
        let z = Vector6::zeros();
        let mut adm = AdmittanceSe3 {
            params: *params,
            h,
            b_f: z,
            phi11: z,
            phi12: z,
            phi21: z,
            phi22: z,
            g1: z,
            g2: z,
            dd_f: z,
            dd_v: z,
            dd_e: z,
        };
        let mut warnings = Vec::new();
        for j in 0..6 {
            let a = axis_map(
                j,
                params.m_e[j],
                params.c_e[j],
                params.k_e[j],
                params.tau_f[j],
                h,
            )?;
            if a.first_order {
                warnings.push(AdmittanceSe3Warning::FirstOrder {
                    axis: j,
                    tau_f: a.tau_f,
                });
            }
            adm.b_f[j] = a.b_f;
            adm.phi11[j] = a.phi[(0, 0)];
            adm.phi12[j] = a.phi[(0, 1)];
            adm.phi21[j] = a.phi[(1, 0)];
            adm.phi22[j] = a.phi[(1, 1)];
            adm.g1[j] = a.gamma[0];
            adm.g2[j] = a.gamma[1];
            (adm.dd_f[j], adm.dd_v[j], adm.dd_e[j]) = a.dd;
        }
        Ok((adm, warnings))
    }

    /// The validated parameters.
    pub fn params(&self) -> &AdmittanceSe3Params {
        &self.params
    }

    /// Control period `h` \[s\] the discretisation was built for.
    pub fn h(&self) -> f64 {
        self.h
    }

    /// Whether axis `j` (0…5) runs the first-order model ($M_e = 0$). Panics if `j > 5`.
    pub fn is_first_order(&self, j: usize) -> bool {
        self.params.m_e[j] == 0.0
    }

    /// State transition $\Phi$ of axis `j` (0…5) on $(e_j, \dot e_j)$. Panics if `j > 5`.
    pub fn phi(&self, j: usize) -> Matrix2<f64> {
        Matrix2::new(self.phi11[j], self.phi12[j], self.phi21[j], self.phi22[j])
    }

    /// Input vector $\Gamma$ of axis `j` (0…5): $(e_j, \dot e_j)$ per unit of held
    /// $\tilde F_j$. Panics if `j > 5`.
    pub fn gamma(&self, j: usize) -> Vector2<f64> {
        Vector2::new(self.g1[j], self.g2[j])
    }

    /// Filter gain $1 - e^{-h/\tau_f}$ per axis (1 for no filter).
    pub fn filter_gain(&self) -> Vector6<f64> {
        self.b_f
    }

    /// One control tick: `(F_i, F_ref,i) → (LPF(F_i), F̃, e, ė)`. No allocation, never NaN.
    ///
    /// `f_meas` (N, N m) is the measured grasp wrench (the object on the tool, about the tool
    /// origin, **world axes**; convert a wrist-sensor reading with [`wrench_tool_to_world`]),
    /// held over the step; `f_ref` the expected wrench $F_{ref,i}$ in the same convention.
    /// Order: filter update, $\tilde F$ = `f_filt − f_ref` held over the step, $(e, \dot e)$
    /// advanced exactly. Non-finite inputs are held per axis and reported (module doc,
    /// section 5).
    #[inline]
    pub fn step(
        &self,
        state: &mut AdmittanceSe3State,
        f_meas: &Vector6<f64>,
        f_ref: &Vector6<f64>,
    ) -> StepFlags {
        let mut flags = StepFlags::default();
        for j in 0..6 {
            let bit = 1u8 << j;
            // Filter: y ← y + b (F − y), exact for F held over the step.
            // A reading beyond MAX_WRENCH (or NaN, ±∞) is a sensor fault: held.
            if f_meas[j].abs() <= MAX_WRENCH {
                state.f_filt[j] = if self.b_f[j] == 1.0 {
                    f_meas[j]
                } else {
                    state.f_filt[j] + self.b_f[j] * (f_meas[j] - state.f_filt[j])
                };
            } else {
                flags.meas_held |= bit;
            }
            // Unexpected wrench held over the step (the previous one if F_ref is implausible).
            let ft = if f_ref[j].abs() <= MAX_WRENCH {
                state.f_filt[j] - f_ref[j]
            } else {
                flags.ref_held |= bit;
                state.f_tilde[j]
            };
            // (e, ė) ← Φ (e, ė) + Γ F̃.
            let (e, ed) = (state.e[j], state.e_dot[j]);
            let e1 = self.phi11[j] * e + self.phi12[j] * ed + self.g1[j] * ft;
            let ed1 = self.phi21[j] * e + self.phi22[j] * ed + self.g2[j] * ft;
            if e1.is_finite() && ed1.is_finite() {
                state.e[j] = e1;
                state.e_dot[j] = ed1;
                state.f_tilde[j] = ft;
            } else {
                flags.state_held |= bit;
            }
        }
        flags
    }

    /// The offset's acceleration $\ddot e$ (m/s², rad/s²) at `state`, from the ODE with the
    /// $\tilde F$ held over the step just taken (`state.f_tilde`):
    /// $(\tilde F - C_e\dot e - K_e e)/M_e$, or $-K_e(\tilde F - K_e e)/C_e^2$ on a first-order
    /// axis (as planar, [`crate::reference::planar::admittance::Admittance::e_ddot`]). A component that overflows
    /// is returned as 0.
    #[inline]
    pub fn e_ddot(&self, state: &AdmittanceSe3State) -> Vector6<f64> {
        let a = self.dd_f.component_mul(&state.f_tilde)
            + self.dd_v.component_mul(&state.e_dot)
            + self.dd_e.component_mul(&state.e);
        a.map(|x| if x.is_finite() { x } else { 0.0 })
    }

    /// Static offset $\tilde F / K_e$ (m, rad) a constant unexpected wrench `f_tilde` settles to.
    pub fn static_offset(&self, f_tilde: &Vector6<f64>) -> Vector6<f64> {
        f_tilde.component_div(&self.params.k_e)
    }

    /// Arm `i`'s reference tool pose sample at `state`, offset from its desired tool sample
    /// `tool_d` ([`tool_from_object`]): [`reference_tool`] with $(e, \dot e, \ddot e)$ of the
    /// state. `(X_WT,d, V, V̇; e, ė, ë) → (X_WT,r, V_r, V̇_r)`.
    #[inline]
    pub fn reference(&self, state: &AdmittanceSe3State, tool_d: &PoseSample) -> PoseSample {
        reference_tool(tool_d, &state.e, &state.e_dot, &self.e_ddot(state))
    }
}

/// A desired [`Se3Sample`] (from [`crate::reference::spatial::path`]) as a [`PoseSample`]: pose,
/// twist `[v; ω]` and twist rate `[v̇; ω̇]`, world axes (jerk and `ω̈` dropped).
#[inline]
pub fn pose_sample(s: &Se3Sample) -> PoseSample {
    PoseSample {
        p: s.p,
        q: s.r,
        twist: stack(&s.v, &s.w),
        twist_dot: stack(&s.a, &s.wd),
    }
}

/// The tool pose, twist and twist rate of a weld `X_OG` on a moving object, by rigid transport
/// (module doc, section 1): `X_WT = X_WO X_OG`, `ω_T = ω_O`, `v_T = v_O + ω × r`,
/// `ω̇_T = ω̇_O`, `v̇_T = v̇_O + ω̇ × r + ω × (ω × r)`, `r = R_WO p_OG`. Exact; no allocation.
#[inline]
pub fn tool_from_object(object: &PoseSample, x_og: &Isometry3<f64>) -> PoseSample {
    let r = object.q * x_og.translation.vector;
    let (w, wd) = (object.w(), object.w_dot());
    PoseSample {
        p: object.p + r,
        q: object.q * x_og.rotation,
        twist: stack(&(object.v() + w.cross(&r)), &w),
        twist_dot: stack(
            &(object.v_dot() + wd.cross(&r) + w.cross(&w.cross(&r))),
            &wd,
        ),
    }
}

/// [`tool_from_object`] from a desired path sample ([`Se3Sample`]).
#[inline]
pub fn tool_from_object_se3(object: &Se3Sample, x_og: &Isometry3<f64>) -> PoseSample {
    tool_from_object(&pose_sample(object), x_og)
}

/// The reference tool pose offset from the desired `tool_d` by `e = [e_p; e_φ]` with rates
/// `e_dot`, `e_ddot` (world axes; module doc, section 2):
/// `p_r = p_d + e_p`, `R_r = Exp(e_φ) R_d`, `v_r = v_d + ė_p`, `v̇_r = v̇_d + ë_p`,
/// `ω_r = J_l(e_φ) ė_φ + Exp(e_φ) ω_d`,
/// `ω̇_r = J̇_l ė_φ + J_l ë_φ + (J_l ė_φ) × (Exp(e_φ) ω_d) + Exp(e_φ) ω̇_d`. Exact; no allocation.
#[inline]
pub fn reference_tool(
    tool_d: &PoseSample,
    e: &Vector6<f64>,
    e_dot: &Vector6<f64>,
    e_ddot: &Vector6<f64>,
) -> PoseSample {
    let (phi, phi_d, phi_dd) = (ang(e), ang(e_dot), ang(e_ddot));
    let q_e = exp_quat(&phi);
    // [J_l ė, d/dt (J_l ė)] along e_φ(t).
    let [w1, w2, _] = left_jacobian_rates(&phi, &phi_d, &phi_dd, &Vector3::zeros());
    let w_rot = q_e * tool_d.w();
    let w = w1 + w_rot;
    let w_dot = w2 + w1.cross(&w_rot) + q_e * tool_d.w_dot();
    PoseSample {
        p: tool_d.p + lin(e),
        q: q_e * tool_d.q,
        twist: stack(&(tool_d.v() + lin(e_dot)), &w),
        twist_dot: stack(&(tool_d.v_dot() + lin(e_ddot)), &w_dot),
    }
}

/// A wrist-sensor reading `f_tool = [f; τ]` in tool axes (about the tool origin) in world axes:
/// `[R_WT f; R_WT τ]`, with `q_wt` the tool orientation (the measured one). The inverse of
/// [`crate::plant::spatial::SpatialWorkspace::tool_wrench`]. A non-finite component spreads to
/// its three world components (then held by [`AdmittanceSe3::step`]).
#[inline]
pub fn wrench_tool_to_world(q_wt: &UnitQuaternion<f64>, f_tool: &Vector6<f64>) -> Vector6<f64> {
    stack(&(q_wt * lin(f_tool)), &(q_wt * ang(f_tool)))
}

/// What [`step_arms`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ArmsStep {
    /// Arms processed: the shortest of the slices' lengths.
    pub n: usize,
    /// Union of the arms' [`StepFlags`].
    pub flags: StepFlags,
    /// Bit `i`: arm `i` (`i < 64`) had an event (a flag, or its output held).
    pub arms_with_events: u64,
    /// Bit `i`: arm `i`'s reference was not finite and the desired tool pose was output
    /// instead (`i < 64`).
    pub output_held: u64,
}

impl ArmsStep {
    /// No event on any arm.
    pub fn is_clean(&self) -> bool {
        self.arms_with_events == 0
    }
}

/// One tick of every arm's generator, ready for [`se3::fit`]: for arm `i`,
/// `X_WTi,d = X_WO,d X_OGi` ([`tool_from_object`]), the generator stepped with the measured
/// wrench `f_meas[i]` and the expected wrench `f_ref[i]` (both the object on tool `i`, about its
/// origin, world axes), and `out[i]` = the reference tool pose, twist and twist rate
/// ([`AdmittanceSe3::reference`]).
///
/// `gens[i]` is arm `i`'s generator (arms may have different parameters). Processes
/// `n = min` of the slices' lengths (reported); no allocation, never NaN for a finite
/// `object_d` (a non-finite reference falls back to the desired tool pose, reported).
///
/// [`se3::fit`]: crate::reference::spatial::fit()
#[allow(clippy::too_many_arguments)]
pub fn step_arms(
    gens: &[AdmittanceSe3],
    states: &mut [AdmittanceSe3State],
    object_d: &PoseSample,
    x_og: &[Isometry3<f64>],
    f_meas: &[Vector6<f64>],
    f_ref: &[Vector6<f64>],
    out: &mut [PoseSample],
) -> ArmsStep {
    let n = gens
        .len()
        .min(states.len())
        .min(x_og.len())
        .min(f_meas.len())
        .min(f_ref.len())
        .min(out.len());
    let mut rep = ArmsStep {
        n,
        ..ArmsStep::default()
    };
    for i in 0..n {
        let tool_d = tool_from_object(object_d, &x_og[i]);
        let flags = gens[i].step(&mut states[i], &f_meas[i], &f_ref[i]);
        let r = gens[i].reference(&states[i], &tool_d);
        let bit = if i < 64 { 1u64 << i } else { 0 };
        out[i] = if is_finite(&r) {
            r
        } else {
            rep.output_held |= bit;
            tool_d
        };
        if !flags.is_clean() {
            rep.arms_with_events |= bit;
        }
        rep.flags = rep.flags.union(flags);
    }
    rep.arms_with_events |= rep.output_held;
    rep
}

/// Every component of a pose sample is finite.
#[inline]
fn is_finite(s: &PoseSample) -> bool {
    s.p.iter()
        .chain(s.q.coords.iter())
        .chain(s.twist.iter())
        .chain(s.twist_dot.iter())
        .all(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_share_natural_frequency_and_damping() {
        let p = AdmittanceSe3Params::default();
        for j in 0..6 {
            let wn = (p.k_e[j] / p.m_e[j]).sqrt();
            let zeta = p.c_e[j] / (2.0 * (p.k_e[j] * p.m_e[j]).sqrt());
            assert!((wn - 5f64.sqrt()).abs() < 1e-14, "axis {j}: ω_n {wn}");
            assert!((zeta - 0.7).abs() < 1e-3, "axis {j}: ζ {zeta}");
        }
        let s = AdmittanceSe3Params::scaled(200.0, 626.0, 1000.0, 0.01, ROT_LEVER_ARM);
        assert!((s.m_e - p.m_e).amax() < 1e-12 && (s.k_e - p.k_e).amax() < 1e-12);
        assert!((s.c_e - p.c_e).amax() < 1e-12 && s.tau_f == p.tau_f);
    }
}
