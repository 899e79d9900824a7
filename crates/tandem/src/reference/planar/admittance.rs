//! Admittance trajectory generator: per arm and per Cartesian axis, a force-driven reference
//! offset $e = x_{r,i} - x_{d,i}$,
//!
//! $$M_e \ddot e + C_e \dot e + K_e e = \tilde F, \qquad \tilde F = \mathrm{LPF}(F_i) - F_{ref,i},$$
//!
//! discretised exactly for a zero-order-held input. Data flow of one control tick (SPEC §3,
//! step 3): `(F_i measured, F_ref,i) → (e, ė) → x_r,i = x_d,i + e, ẋ_r,i = ẋ_d,i + ė`.
//!
//! Covers the paper's (15)–(21): the admittance model (15)–(16), its transfer function
//! (17)–(18), the state-space form (19) and its solution (20)–(21), with the SPEC §3.1 errata:
//!
//! - **Virtual mass.** The paper's model is first order, $C_e \dot e + K_e e = F$ (15)–(16).
//!   Fed by the raw grasp force of a rigid grasp it is unstable: the measured force contains the
//!   controller's own wrench, and the first-order model passes that force straight into the
//!   reference *velocity* $\dot x_r = \dot x_d + (F - K_e e)/C_e$, which the tracking law
//!   multiplies by its velocity gain (SPEC §3.1 measured a per-tick loop gain of about 40 for
//!   the NN law and 1400 for PD, at any control rate). tandem adds a virtual mass $M_e$, which
//!   turns that algebraic loop into an integrator. $M_e = 0$ still selects the paper's form,
//!   with an [`AdmittanceWarning::FirstOrder`] at set-up.
//! - **Force filter and expected force.** $\tilde F$ is the measured force through a first-order
//!   low-pass (time constant $\tau_f$, state started at $F_{ref}(0)$, see
//!   [`AdmittanceState::with_filter_at`]) minus the expected force $F_{ref,i}$ (the arm's share
//!   of the nominal object wrench plus the squeeze), so the reference yields only to the
//!   unexpected part of the force.
//! - **Initial state.** The paper's (20)–(21) put the manipulator's initial state $x_{0,i}$
//!   where the admittance state $e(0)$ belongs. Here the state is $(e, \dot e)$ (and the
//!   filter's output), started by the caller, normally at $e(0) = 0$, $\dot e(0) = 0$.
//! - **Exact discretisation.** Instead of evaluating the convolution (20) the generator
//!   advances $(e, \dot e)$ by the exact zero-order-hold map of the linear ODE (no integration
//!   error for a held input, unconditionally stable).
//!
//! # Discretisation
//! With $A = \begin{pmatrix} 0 & 1 \cr -K_e/M_e & -C_e/M_e \end{pmatrix}$,
//! $B = (0, 1/M_e)^T$ and control period $h$:
//! $$x_{k+1} = \Phi x_k + \Gamma \tilde F_k, \qquad \Phi = e^{Ah}, \qquad
//! \Gamma = \int_0^h e^{A\sigma} d\sigma \ B = (I - \Phi)(1/K_e, 0)^T.$$
//! The last identity holds because the held input has the equilibrium $(\tilde F/K_e, 0)$ and
//! $x_{k+1} - x^\ast = \Phi (x_k - x^\ast)$; its second component is $\Phi_{12}/M_e$. $\Phi$ is
//! built in closed form, with $\sigma = C_e/(2M_e)$, $\omega_n^2 = K_e/M_e$ and
//! $q = 4K_eM_e/C_e^2 = 1/\zeta^2$:
//!
//! - under- or critically damped ($q \ge 1$), $\omega_d = \sigma\sqrt{q-1}$:
//!   $S = \sin(\omega_d h)/\omega_d$ (or $h$ when $\omega_d h = 0$), $C = \cos\omega_d h$;
//! - mildly overdamped ($q < 1$, $\beta = \sigma\sqrt{1-q}$, $\beta h \le 1$):
//!   $S = \sinh(\beta h)/\beta$, $C = \cosh\beta h$;
//! - then $\Phi_{12} = e^{-\sigma h} S$, $\Phi_{11} = e^{-\sigma h}(C + \sigma S)$,
//!   $\Phi_{22} = e^{-\sigma h}(C - \sigma S)$, $\Phi_{21} = -\omega_n^2 \Phi_{12}$;
//! - strongly overdamped ($\beta h > 1$, e.g. a tiny $M_e$): from the real eigenvalues
//!   $\lambda_2 = -(\sigma + \beta)$, $\lambda_1 = \omega_n^2/\lambda_2$ (no cancellation),
//!   $\Phi_{12} = (e^{\lambda_1 h} - e^{\lambda_2 h})/(2\beta)$,
//!   $\Phi_{11} = (\lambda_1 e^{\lambda_2 h} - \lambda_2 e^{\lambda_1 h})/(2\beta)$,
//!   $\Phi_{22} = (\lambda_1 e^{\lambda_1 h} - \lambda_2 e^{\lambda_2 h})/(2\beta)$.
//!   This branch never forms $e^{-\sigma h}\sinh\beta h$, which would be $0 \cdot \infty$.
//!
//! The branches agree at their borders (the functions $S$ and $C$ are entire in
//! $(\sigma^2 - \omega_n^2) h^2$), so nearly critical damping needs no special case.
//!
//! For $M_e = 0$ (the paper's form): $e_{k+1} = a e_k + (1-a)\tilde F_k/K_e$,
//! $a = e^{-K_e h/C_e}$ (with $1 - a$ from `expm1`), and $\dot e$ is not a state: after each step
//! it is set to the ODE's value $\dot e_{k+1} = (\tilde F_k - K_e e_{k+1})/C_e$, which is the
//! $M_e \to 0$ limit of the second-order map. Both cases share one update
//! $x_{k+1} = \Phi x_k + \Gamma \tilde F_k$ with, for $M_e = 0$,
//! $\Phi = \begin{pmatrix} a & 0 \cr -K_e a/C_e & 0 \end{pmatrix}$, $\Gamma = ((1-a)/K_e, a/C_e)^T$.
//!
//! The force filter is discretised exactly too, for the measured force held over the step:
//! $y_{k+1} = y_k + (1 - e^{-h/\tau_f})(F_k - y_k)$, and $y_{k+1} = F_k$ when $\tau_f = 0$.
//!
//! Order inside [`Admittance::step`]: filter update with the new measurement, then
//! $\tilde F = y_{k+1} - F_{ref}$ held over the step, then $(e, \dot e)$ advanced exactly.
//!
//! # Parameters per axis
//! Every parameter is a [`Vector2`] (x, y), so the compliance may differ per axis;
//! [`AdmittanceParams::uniform`] applies scalars to both. The two axes are independent.
//!
//! # References
//! 1. The paper, Section III-B "Trajectory Generation", equations (15)–(21).
//! 2. SPEC §3.1 (the second-order generator, the filter, the expected force, the defaults and
//!    why).

use std::fmt;

use nalgebra::{Matrix2, Vector2};

use crate::error::{ModelError, non_negative, positive};

/// Admittance parameters per axis (x, y). Plain data; validated by [`Admittance::new`].
///
/// Defaults (SPEC §3.1): $M_e = 200$ kg, $C_e = 626$ N s/m ($\zeta = 0.7$), $K_e = 1000$ N/m,
/// $\tau_f = 0.01$ s on both axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdmittanceParams {
    /// Virtual mass $M_e$ \[kg\], ≥ 0; 0 selects the paper's first-order model (warned).
    pub m_e: Vector2<f64>,
    /// Virtual damping $C_e$ \[N s/m\], > 0.
    pub c_e: Vector2<f64>,
    /// Virtual stiffness $K_e$ \[N/m\], > 0. A constant $\tilde F$ settles at $e = \tilde F/K_e$.
    pub k_e: Vector2<f64>,
    /// Force low-pass time constant $\tau_f$ \[s\], ≥ 0; 0 means no filter.
    pub tau_f: Vector2<f64>,
}

impl Default for AdmittanceParams {
    fn default() -> Self {
        AdmittanceParams::uniform(200.0, 626.0, 1000.0, 0.01)
    }
}

impl AdmittanceParams {
    /// The same scalar parameters on both axes: `m_e` \[kg\], `c_e` \[N s/m\], `k_e` \[N/m\],
    /// `tau_f` \[s\].
    pub fn uniform(m_e: f64, c_e: f64, k_e: f64, tau_f: f64) -> Self {
        AdmittanceParams {
            m_e: Vector2::repeat(m_e),
            c_e: Vector2::repeat(c_e),
            k_e: Vector2::repeat(k_e),
            tau_f: Vector2::repeat(tau_f),
        }
    }

    /// The paper's model as printed, (15)–(16): first order ($M_e = 0$) on the raw force
    /// ($\tau_f = 0$). Unstable in closed loop with a rigid grasp (SPEC §3.1); for ablations.
    pub fn paper_first_order(c_e: f64, k_e: f64) -> Self {
        AdmittanceParams::uniform(0.0, c_e, k_e, 0.0)
    }
}

/// A set-up warning: the parameters are valid but known to be a bad idea.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum AdmittanceWarning {
    /// $M_e = 0$ on this axis: the paper's first-order model, which SPEC §3.1 found unstable
    /// when fed by the grasp force of a rigid grasp. `Display` gives the reason in a sentence.
    FirstOrder {
        /// Axis index (0 = x, 1 = y).
        axis: usize,
        /// The axis's force-filter time constant $\tau_f$ \[s\] (0: raw force).
        tau_f: f64,
    },
}

impl fmt::Display for AdmittanceWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AdmittanceWarning::FirstOrder { axis, tau_f } => {
                let name = if *axis == 0 { "x" } else { "y" };
                write!(
                    f,
                    "admittance.m_e[{axis}] = 0 selects the paper's first-order model C_e ė + K_e e = F̃ on \
                     the {name} axis: fed by the grasp force of a rigid grasp, it passes the controller's own \
                     wrench straight into the reference velocity ẋ_r = ẋ_d + (F̃ − K_e e)/C_e, which the \
                     tracking law multiplies by its velocity gain, and the loop diverges within milliseconds \
                     at any control rate (SPEC §3.1); {}use a virtual mass (default M_e = 200 kg)",
                    if *tau_f == 0.0 {
                        "the force is not filtered either (τ_f = 0); "
                    } else {
                        ""
                    }
                )
            }
        }
    }
}

/// State of one arm's generator: plain data, `Copy`.
///
/// Start it with [`AdmittanceState::with_filter_at`]`(F_ref(0))` (SPEC §3.1: the filter state
/// starts at the expected force, not at the raw force, which at t = 0 reads a falling object).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AdmittanceState {
    /// Reference offset $e = x_{r,i} - x_{d,i}$ \[m\], (x, y).
    pub e: Vector2<f64>,
    /// Its rate $\dot e$ \[m/s\]. For a first-order axis ($M_e = 0$) this is the ODE's value after
    /// the last step, not an independent state.
    pub e_dot: Vector2<f64>,
    /// Low-pass filtered measured force $\mathrm{LPF}(F_i)$ \[N\]: what the force sensor reads,
    /// the force the object exerts on the end-effector (SPEC §1).
    pub f_filt: Vector2<f64>,
}

impl AdmittanceState {
    /// At rest ($e = \dot e = 0$, so $x_r = x_d$) with the filter output at `f_filt0` \[N\],
    /// normally $F_{ref,i}(0)$.
    pub fn with_filter_at(f_filt0: Vector2<f64>) -> Self {
        AdmittanceState {
            e: Vector2::zeros(),
            e_dot: Vector2::zeros(),
            f_filt: f_filt0,
        }
    }
}

/// One arm's admittance generator: validated parameters plus the precomputed exact
/// discretisation for the control period `h`. Immutable after [`Admittance::new`]; the state
/// lives in [`AdmittanceState`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Admittance {
    params: AdmittanceParams,
    h: f64,
    /// Filter gain $1 - e^{-h/\tau_f}$ per axis (1 when $\tau_f = 0$).
    b_f: Vector2<f64>,
    // Φ and Γ per axis, stored by entry so that the step is a few componentwise products.
    phi11: Vector2<f64>,
    phi12: Vector2<f64>,
    phi21: Vector2<f64>,
    phi22: Vector2<f64>,
    g1: Vector2<f64>,
    g2: Vector2<f64>,
    // ë = dd_f F̃ + dd_v ė + dd_e e per axis (see `e_ddot`).
    dd_f: Vector2<f64>,
    dd_v: Vector2<f64>,
    dd_e: Vector2<f64>,
}

impl Admittance {
    /// Validate `params` and precompute the exact zero-order-hold discretisation for the control
    /// period `h` \[s\].
    ///
    /// Errors name the field: `admittance.c_e[i]` and `admittance.k_e[i]` must be finite and
    /// positive, `admittance.m_e[i]` and `admittance.tau_f[i]` finite and non-negative, `h`
    /// finite and positive.
    /// Returns the generator and the set-up warnings (one [`AdmittanceWarning::FirstOrder`] per
    /// axis with $M_e = 0$); the caller reports them.
    pub fn new(
        params: &AdmittanceParams,
        h: f64,
    ) -> Result<(Admittance, Vec<AdmittanceWarning>), ModelError> {
        positive("h", h)?;
        let mut warnings = Vec::new();
        let mut adm = Admittance {
            params: *params,
            h,
            b_f: Vector2::zeros(),
            phi11: Vector2::zeros(),
            phi12: Vector2::zeros(),
            phi21: Vector2::zeros(),
            phi22: Vector2::zeros(),
            g1: Vector2::zeros(),
            g2: Vector2::zeros(),
            dd_f: Vector2::zeros(),
            dd_v: Vector2::zeros(),
            dd_e: Vector2::zeros(),
        };
        for i in 0..2 {
            let a = axis_map(
                i,
                params.m_e[i],
                params.c_e[i],
                params.k_e[i],
                params.tau_f[i],
                h,
            )?;
            if a.first_order {
                warnings.push(AdmittanceWarning::FirstOrder {
                    axis: i,
                    tau_f: a.tau_f,
                });
            }
            adm.b_f[i] = a.b_f;
            adm.phi11[i] = a.phi[(0, 0)];
            adm.phi12[i] = a.phi[(0, 1)];
            adm.phi21[i] = a.phi[(1, 0)];
            adm.phi22[i] = a.phi[(1, 1)];
            adm.g1[i] = a.gamma[0];
            adm.g2[i] = a.gamma[1];
            (adm.dd_f[i], adm.dd_v[i], adm.dd_e[i]) = a.dd;
        }
        Ok((adm, warnings))
    }

    /// The validated parameters.
    pub fn params(&self) -> &AdmittanceParams {
        &self.params
    }

    /// Control period h \[s\] the discretisation was built for.
    pub fn h(&self) -> f64 {
        self.h
    }

    /// Whether `axis` (0 = x, 1 = y) runs the paper's first-order model ($M_e = 0$).
    pub fn is_first_order(&self, axis: usize) -> bool {
        self.params.m_e[axis] == 0.0
    }

    /// State transition $\Phi$ of `axis` (0 = x, 1 = y) acting on $(e, \dot e)$. Panics if
    /// `axis > 1`.
    pub fn phi(&self, axis: usize) -> Matrix2<f64> {
        Matrix2::new(
            self.phi11[axis],
            self.phi12[axis],
            self.phi21[axis],
            self.phi22[axis],
        )
    }

    /// Input vector $\Gamma$ of `axis` (0 = x, 1 = y): $(e, \dot e)$ per newton of held
    /// $\tilde F$ [m/N, m/(N s)]. Panics if `axis > 1`.
    pub fn gamma(&self, axis: usize) -> Vector2<f64> {
        Vector2::new(self.g1[axis], self.g2[axis])
    }

    /// Force-filter gain $1 - e^{-h/\tau_f}$ per axis (1 for no filter).
    pub fn filter_gain(&self) -> Vector2<f64> {
        self.b_f
    }

    /// One control tick: `(f_meas, f_ref) → (f_filt, e, ė)`. No allocation.
    ///
    /// `f_meas` \[N\] is the force sensor reading (the force the object exerts on the
    /// end-effector, SPEC §1) held over the step; `f_ref` \[N\] the expected force
    /// $F_{ref,i}$, which must be finite. Order: filter update with `f_meas`, then
    /// $\tilde F = $ `f_filt − f_ref` held over the step, then $(e, \dot e)$ advanced exactly.
    ///
    /// A non-finite component of `f_meas` (sensor dropout, a NaN upstream) is not taken in: that
    /// axis's filter holds its value, the step proceeds, and the function returns `false` so
    /// the caller can record the event. Returns `true` otherwise.
    #[inline]
    pub fn step(
        &self,
        state: &mut AdmittanceState,
        f_meas: Vector2<f64>,
        f_ref: Vector2<f64>,
    ) -> bool {
        // Filter: y ← y + b (F − y), exact for F held over the step; non-finite F holds y.
        let mut ok = true;
        for i in 0..2 {
            if f_meas[i].is_finite() {
                state.f_filt[i] += self.b_f[i] * (f_meas[i] - state.f_filt[i]);
            } else {
                ok = false;
            }
        }
        // Unexpected force, held over the step.
        let f = state.f_filt - f_ref;
        // (e, ė) ← Φ (e, ė) + Γ F̃, per axis.
        let (e, ed) = (state.e, state.e_dot);
        state.e = self.phi11.component_mul(&e)
            + self.phi12.component_mul(&ed)
            + self.g1.component_mul(&f);
        state.e_dot = self.phi21.component_mul(&e)
            + self.phi22.component_mul(&ed)
            + self.g2.component_mul(&f);
        ok
    }

    /// The unexpected force $\tilde F = $ `f_filt − f_ref` \[N\] at `state`.
    #[inline]
    pub fn f_tilde(&self, state: &AdmittanceState, f_ref: Vector2<f64>) -> Vector2<f64> {
        state.f_filt - f_ref
    }

    /// The offset's acceleration $\ddot e$ \[m/s²\] at `state`, with $\tilde F = $
    /// `state.f_filt − f_ref` (the force held over the step just taken), for
    /// $\ddot x_{r,i} = \ddot x_{d,i} + \ddot e$.
    ///
    /// - $M_e > 0$: $\ddot e = (\tilde F - C_e \dot e - K_e e)/M_e$.
    /// - $M_e = 0$: $\dot e$ is not a state; from the ODE, $\dot e = (\tilde F - K_e e)/C_e$
    ///   and, with $\tilde F$ held, $\ddot e = -K_e \dot e / C_e = -K_e(\tilde F - K_e e)/C_e^2$.
    ///   (`state.e_dot` is ignored.)
    ///
    /// For a very small $M_e$ the second-order formula is ill-conditioned (its three terms are
    /// $O(|\tilde F|)$ and cancel to $O(M_e |\ddot e|)$): rounding leaves about
    /// $\varepsilon |\tilde F| / M_e$. Use $M_e = 0$ rather than a token mass.
    #[inline]
    pub fn e_ddot(&self, state: &AdmittanceState, f_ref: Vector2<f64>) -> Vector2<f64> {
        let f = state.f_filt - f_ref;
        self.dd_f.component_mul(&f)
            + self.dd_v.component_mul(&state.e_dot)
            + self.dd_e.component_mul(&state.e)
    }

    /// Static offset $\tilde F / K_e$ \[m\] a constant unexpected force `f_tilde` \[N\] settles to.
    pub fn static_offset(&self, f_tilde: Vector2<f64>) -> Vector2<f64> {
        f_tilde.component_div(&self.params.k_e)
    }
}

/// Exact ZOH discretisation of $M\ddot e + C\dot e + K e = u$ (M, C, K > 0) for step h:
/// returns $(\Phi, \Gamma)$ on the state $(e, \dot e)$. Closed form; see the module docs.
/// One axis's validated parameters and exact discretisation, shared by the planar and the 6-D
/// generator ([`crate::reference::spatial::admittance`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct AxisMap {
    /// Filter gain `1 − e^{−h/τ_f}` (1 when `τ_f = 0`).
    pub b_f: f64,
    /// `Φ` of the axis.
    pub phi: Matrix2<f64>,
    /// `Γ` of the axis.
    pub gamma: Vector2<f64>,
    /// `(dd_f, dd_v, dd_e)`: `ë = dd_f F̃ + dd_v ė + dd_e e`.
    pub dd: (f64, f64, f64),
    /// `M_e = 0` (the paper's first-order form).
    pub first_order: bool,
    /// The axis's `τ_f`.
    pub tau_f: f64,
}

/// Validate axis `j`'s `(M_e, C_e, K_e, τ_f)` (errors name `admittance.{m_e,c_e,k_e,tau_f}[j]`)
/// and build its exact zero-order-hold map for the period `h`.
pub(crate) fn axis_map(
    j: usize,
    m_e: f64,
    c_e: f64,
    k_e: f64,
    tau_f: f64,
    h: f64,
) -> Result<AxisMap, ModelError> {
    let m = non_negative(&format!("admittance.m_e[{j}]"), m_e)?;
    let c = positive(&format!("admittance.c_e[{j}]"), c_e)?;
    let k = positive(&format!("admittance.k_e[{j}]"), k_e)?;
    let tau = non_negative(&format!("admittance.tau_f[{j}]"), tau_f)?;
    let b_f = if tau == 0.0 {
        1.0
    } else {
        -(-h / tau).exp_m1()
    };
    let (phi, gamma) = if m == 0.0 {
        zoh_first_order(c, k, h)
    } else {
        zoh_second_order(m, c, k, h)
    };
    if !(phi.iter().all(|x| x.is_finite()) && gamma.iter().all(|x| x.is_finite())) {
        return Err(ModelError::invalid(
            format!("admittance.m_e[{j}]"),
            m,
            format!("exact discretisation overflows with c_e = {c}, k_e = {k}, h = {h}"),
        ));
    }
    // ë coefficients: (F̃ − C ė − K e)/M, or −K(F̃ − K e)/C² for the first-order form.
    let dd = if m > 0.0 {
        (1.0 / m, -c / m, -k / m)
    } else {
        (-k / (c * c), 0.0, (k / c) * (k / c))
    };
    Ok(AxisMap {
        b_f,
        phi,
        gamma,
        dd,
        first_order: m == 0.0,
        tau_f: tau,
    })
}

fn zoh_second_order(m: f64, c: f64, k: f64, h: f64) -> (Matrix2<f64>, Vector2<f64>) {
    let sigma = c / (2.0 * m);
    let wn2 = k / m;
    // q = ω_n²/σ² = 1/ζ², formed without squaring σ (no overflow for tiny m).
    let q = 4.0 * k * m / (c * c);
    // Φ from S (the kernel's integral) and C (its derivative): entire in (σ² − ω_n²)h².
    let from_kernel = |s: f64, cn: f64| {
        let ex = (-sigma * h).exp();
        (ex * (cn + sigma * s), ex * s, ex * (cn - sigma * s))
    };
    let (phi11, phi12, phi22) = if q >= 1.0 {
        // Under- or critically damped.
        let wd = sigma * (q - 1.0).sqrt();
        let x = wd * h;
        from_kernel(if x == 0.0 { h } else { x.sin() / wd }, x.cos())
    } else {
        let beta = sigma * (1.0 - q).sqrt();
        let x = beta * h;
        if x <= 1.0 {
            // Mildly overdamped: e^{−σh} sinh(βh) stays finite.
            from_kernel(if x == 0.0 { h } else { x.sinh() / beta }, x.cosh())
        } else {
            // Strongly overdamped: real eigenvalues, λ2 fast, λ1 slow; λ1 = ω_n²/λ2 avoids the
            // cancellation in −σ + β.
            let l2 = -(sigma + beta);
            let l1 = wn2 / l2;
            let (e1, e2) = ((l1 * h).exp(), (l2 * h).exp());
            let inv = 1.0 / (2.0 * beta); // 1/(λ1 − λ2)
            (
                (l1 * e2 - l2 * e1) * inv,
                (e1 - e2) * inv,
                (l1 * e1 - l2 * e2) * inv,
            )
        }
    };
    let phi21 = -wn2 * phi12;
    // Γ = (I − Φ)(1/K, 0)ᵀ; the second entry equals Φ12/M exactly in exact arithmetic. 1 − Φ11
    // is exact in floating point for Φ11 ≥ ½ (Sterbenz), so Γ1 F̃ carries an absolute error of
    // about ε|F̃/K| per step: the same size as the rounding of the state itself.
    let gamma = Vector2::new((1.0 - phi11) / k, phi12 / m);
    (Matrix2::new(phi11, phi12, phi21, phi22), gamma)
}

/// Exact ZOH discretisation of the first-order $C\dot e + K e = u$, written on $(e, \dot e)$ with
/// $\dot e_{k+1}$ set to the ODE's value: see the module docs.
fn zoh_first_order(c: f64, k: f64, h: f64) -> (Matrix2<f64>, Vector2<f64>) {
    let x = -k * h / c;
    let a = x.exp();
    let one_minus_a = -x.exp_m1();
    (
        Matrix2::new(a, 0.0, -k * a / c, 0.0),
        Vector2::new(one_minus_a / k, a / c),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Complex, Matrix3};
    use proptest::prelude::*;

    const H: f64 = 1e-3;

    fn build(p: &AdmittanceParams, h: f64) -> Admittance {
        Admittance::new(p, h).unwrap().0
    }

    /// Reference: $\Phi$ and $\Gamma$ from nalgebra's Padé matrix exponential of the augmented
    /// matrix $\begin{pmatrix} A & B \cr 0 & 0 \end{pmatrix} h$ (an independent algorithm).
    fn expm_reference(m: f64, c: f64, k: f64, h: f64) -> (Matrix2<f64>, Vector2<f64>) {
        #[rustfmt::skip]
        let aug = Matrix3::new(
            0.0, 1.0, 0.0,
            -k / m, -c / m, 1.0 / m,
            0.0, 0.0, 0.0,
        ) * h;
        let e = aug.exp();
        (
            e.fixed_view::<2, 2>(0, 0).into_owned(),
            Vector2::new(e[(0, 2)], e[(1, 2)]),
        )
    }

    /// Analytic solution of $M\ddot e + C\dot e + Ke = F$ (constant F) from $(e_0, v_0)$ at
    /// time t, written independently of the implementation: characteristic roots (stable
    /// quadratic formula) in complex arithmetic, the repeated-root form when $C^2 = 4KM$
    /// exactly, and $e = F/K + (e_0 - F/K)e^{-Kt/C}$ for M = 0.
    fn analytic(m: f64, c: f64, k: f64, f: f64, e0: f64, v0: f64, t: f64) -> (f64, f64) {
        let y0 = e0 - f / k;
        if m == 0.0 {
            let d = (-k * t / c).exp();
            return (f / k + y0 * d, -k / c * y0 * d);
        }
        let disc = c * c - 4.0 * k * m;
        if disc == 0.0 {
            let s = c / (2.0 * m);
            let b = v0 + s * y0;
            let ex = (-s * t).exp();
            return (f / k + (y0 + b * t) * ex, (b - s * (y0 + b * t)) * ex);
        }
        // q = −(c + sqrt(disc))/2; roots q/m and k/q.
        let sq = Complex::new(disc, 0.0).sqrt();
        let q = (sq + c) * -0.5;
        let (r1, r2) = (Complex::new(k, 0.0) / q, q / m);
        let c1 = (Complex::new(v0, 0.0) - r2 * y0) / (r1 - r2);
        let c2 = Complex::new(y0, 0.0) - c1;
        let (x1, x2) = ((r1 * t).exp(), (r2 * t).exp());
        (
            (c1 * x1 + c2 * x2).re + f / k,
            (c1 * r1 * x1 + c2 * r2 * x2).re,
        )
    }

    /// Parameter sets (M, C, K) covering every branch of the closed form.
    fn cases() -> Vec<(&'static str, f64, f64, f64)> {
        vec![
            ("underdamped (defaults, ζ = 0.7)", 200.0, 626.0, 1000.0),
            ("lightly damped (ζ = 0.05)", 10.0, 10.0, 1000.0),
            ("critically damped (C² = 4KM exactly)", 100.0, 400.0, 400.0),
            ("overdamped, βh ≤ 1 (sinh branch)", 10.0, 626.0, 1000.0),
            (
                "strongly overdamped, βh > 1 (eigenvalue branch)",
                1e-3,
                626.0,
                1000.0,
            ),
        ]
    }

    #[test]
    fn discretisation_matches_matrix_exponential() {
        // Moderate stiffness (‖A h‖ ≤ 10) so the Padé reference is itself accurate to ~1e-15.
        let mut sets = cases();
        sets.pop();
        sets.push(("eigenvalue branch, moderate stiffness", 1.0, 100.0, 100.0)); // βh = 4.9 at h = 0.1
        sets.push(("ζ = 1 − 1e-9", 100.0, 400.0 * (1.0 - 1e-9), 400.0));
        sets.push(("ζ = 1 + 1e-9", 100.0, 400.0 * (1.0 + 1e-9), 400.0));
        for (name, m, c, k) in sets {
            for h in [1e-3, 0.1] {
                let adm = build(&AdmittanceParams::uniform(m, c, k, 0.0), h);
                let (phi_ref, gamma_ref) = expm_reference(m, c, k, h);
                // Entry scales: Φ11, Φ22 ~ 1, Φ12 ~ h, Φ21 ~ ω_n² h, Γ1 ≤ 2/K, Γ2 ~ h/M.
                let scale = Matrix2::new(1.0, h, k / m * h, 1.0);
                let err = (adm.phi(0) - phi_ref).component_div(&scale).amax();
                assert!(err < 1e-13, "{name}, h = {h}: Φ error {err:e}");
                let gscale = Vector2::new(1.0 / k, h / m);
                let gerr = (adm.gamma(0) - gamma_ref).component_div(&gscale).amax();
                assert!(gerr < 1e-13, "{name}, h = {h}: Γ error {gerr:e}");
            }
        }
    }

    /// Run N steps of a step input F̃ = f (no filter) from (e0, v0) and compare every tick with
    /// the analytic solution.
    ///
    /// Tolerance 1e-12 relative to the scale of e (max(|F/K|, |e0|)) and of ė (its max over the
    /// run, at least ω_n·scale_e): the discrete map is exact, so the error is rounding only.
    /// Each step adds a few ε·scale, damped by Φ, and the ~1 ulp bias in Φ's entries grows as
    /// N ε e^{λ N h}, at most ε/(e |λ| h) ≈ 5e-14 for the slowest pole here (|λ| ≥ 1.56 s⁻¹,
    /// h = 1 ms): 1e-12 leaves a margin of about 20.
    fn check_step_response(m: f64, c: f64, k: f64, name: &str) {
        let (f, e0, v0) = (10.0, 0.002, -0.01);
        let adm = build(&AdmittanceParams::uniform(m, c, k, 0.0), H);
        let f_ref = Vector2::new(1.5, -2.0);
        let mut st = AdmittanceState {
            e: Vector2::repeat(e0),
            e_dot: Vector2::repeat(v0),
            f_filt: f_ref,
        };
        let f_meas = f_ref + Vector2::repeat(f);
        let n = 3000;
        let mut traj = Vec::with_capacity(n);
        for step in 1..=n {
            adm.step(&mut st, f_meas, f_ref);
            traj.push((step as f64 * H, st));
        }
        let scale_e = (f / k).abs().max(e0.abs());
        let mut scale_v = if m > 0.0 {
            (k / m).sqrt() * scale_e
        } else {
            0.0
        };
        for (t, _) in &traj {
            scale_v = scale_v.max(analytic(m, c, k, f, e0, v0, *t).1.abs());
        }
        for (t, s) in &traj {
            let (e, v) = analytic(m, c, k, f, e0, v0, *t);
            for i in 0..2 {
                assert!(
                    (s.e[i] - e).abs() <= 1e-12 * scale_e,
                    "{name}: e at t = {t}: {} vs {e}",
                    s.e[i]
                );
                assert!(
                    (s.e_dot[i] - v).abs() <= 1e-12 * scale_v,
                    "{name}: ė at t = {t}: {} vs {v}",
                    s.e_dot[i]
                );
            }
        }
    }

    #[test]
    fn step_response_matches_analytic_second_order() {
        for (name, m, c, k) in cases() {
            check_step_response(m, c, k, name);
        }
    }

    #[test]
    fn step_response_matches_analytic_first_order() {
        check_step_response(0.0, 626.0, 1000.0, "first order (M_e = 0)");
    }

    /// Continuous response to F̃(t) = A sin Ωt from rest, e and ė, via the complex particular
    /// solution plus the homogeneous solution that cancels its initial values.
    fn sinusoid_continuous(m: f64, c: f64, k: f64, amp: f64, w: f64, t: f64) -> (f64, f64) {
        let y = Complex::new(amp, 0.0) / Complex::new(k - m * w * w, c * w);
        let yp = |t: f64| {
            let z = y * Complex::new(0.0, w * t).exp();
            (z.im, (z * Complex::new(0.0, w)).im)
        };
        let (p0, pd0) = yp(0.0);
        let (p, pd) = yp(t);
        let (hx, hv) = analytic(m, c, k, 0.0, -p0, -pd0, t);
        (p + hx, pd + hv)
    }

    /// Sampled-and-held sinusoid against the continuous response.
    ///
    /// The held input differs from the continuous one by |u_h − u| ≤ max|u̇| h = AΩh, so by
    /// convolution |e_disc − e_cont| ≤ ‖g‖₁ AΩh and |ė_disc − ė_cont| ≤ ‖ġ‖₁ AΩh, with g the
    /// impulse response from F̃ to e. Underdamped: |g| ≤ e^{−σt}/(M ω_d) and
    /// |ġ| ≤ e^{−σt} ω_n/(M ω_d), so ‖g‖₁ ≤ 1/(M ω_d σ), ‖ġ‖₁ ≤ ω_n/(M ω_d σ). First order:
    /// ‖g‖₁ = 1/K, and ė_disc also sees the held input directly, adding AΩh/C. The observed
    /// error must also exceed a twentieth of the bound (observed: 0.13 for M = 200, 0.25 for M = 0) (the O(h) effect of the hold is real: about
    /// an h/2 delay), and halving h must halve it.
    #[test]
    fn sinusoid_matches_continuous_within_zoh_bound() {
        let (amp, w) = (10.0, 3.0);
        for (m, c, k) in [(200.0_f64, 626.0_f64, 1000.0_f64), (0.0, 626.0, 1000.0)] {
            let (bound_e, bound_v) = if m > 0.0 {
                let sigma = c / (2.0 * m);
                let wn = (k / m).sqrt();
                let wd = (wn * wn - sigma * sigma).sqrt();
                (1.0 / (m * wd * sigma), wn / (m * wd * sigma))
            } else {
                (1.0 / k, 2.0 / c)
            };
            let mut max_err = [0.0_f64; 2];
            for (run, h) in [H, H / 2.0].into_iter().enumerate() {
                let adm = build(&AdmittanceParams::uniform(m, c, k, 0.0), h);
                let mut st = AdmittanceState::default();
                let (mut err_e, mut err_v) = (0.0_f64, 0.0_f64);
                let n = (4.0 / h).round() as usize;
                for step in 0..n {
                    let t = step as f64 * h;
                    adm.step(
                        &mut st,
                        Vector2::repeat(amp * (w * t).sin()),
                        Vector2::zeros(),
                    );
                    let (e, v) = sinusoid_continuous(m, c, k, amp, w, t + h);
                    err_e = err_e.max((st.e.x - e).abs());
                    err_v = err_v.max((st.e_dot.x - v).abs());
                }
                assert!(
                    err_e <= bound_e * amp * w * h,
                    "M = {m}, h = {h}: e error {err_e:e}"
                );
                assert!(
                    err_v <= bound_v * amp * w * h,
                    "M = {m}, h = {h}: ė error {err_v:e}"
                );
                assert!(
                    err_e >= 0.05 * bound_e * amp * w * h,
                    "M = {m}: e error suspiciously small"
                );
                max_err[run] = err_e;
            }
            let ratio = max_err[0] / max_err[1];
            assert!(
                (1.8..2.2).contains(&ratio),
                "M = {m}: error ratio for h/2 is {ratio}"
            );
        }
    }

    /// $M_e = 10^{-6}$ against $M_e = 0$. The second-order model's slow pole is
    /// $-K/C \ (1 + KM/C^2 + \dots)$ and its offset lags the first-order one by about
    /// $(M/C)\dot e$, both relative corrections of order $KM/C^2 \approx 2.6\cdot 10^{-9}$; the fast
    /// pole $-C/M$ is dead after one tick ($e^{-Ch/M} = 0$). Tolerance $10 KM/C^2$ relative.
    #[test]
    fn small_mass_approaches_first_order() {
        let (c, k, m) = (626.0, 1000.0, 1e-6);
        let (a1, _) = Admittance::new(&AdmittanceParams::uniform(m, c, k, 0.0), H).unwrap();
        let (a0, _) = Admittance::new(&AdmittanceParams::uniform(0.0, c, k, 0.0), H).unwrap();
        let f = Vector2::new(10.0, -4.0);
        let mut s1 = AdmittanceState {
            e: Vector2::new(0.003, 0.0),
            ..Default::default()
        };
        let mut s0 = s1;
        let rel = 10.0 * k * m / (c * c);
        let (scale_e, scale_v) = (0.01, 0.01 * k / c);
        for _ in 0..3000 {
            a1.step(&mut s1, f, Vector2::zeros());
            a0.step(&mut s0, f, Vector2::zeros());
            assert!(
                (s1.e - s0.e).amax() <= rel * scale_e,
                "{} vs {}",
                s1.e,
                s0.e
            );
            assert!(
                (s1.e_dot - s0.e_dot).amax() <= rel * scale_v,
                "{} vs {}",
                s1.e_dot,
                s0.e_dot
            );
        }
    }

    /// The accelerations agree as well (first order: ë = −K ė/C), up to the conditioning of
    /// ë = (F̃ − C ė − K e)/M for a tiny M: its three terms are O(|F̃|) and cancel to O(M |ë|), so
    /// rounding leaves about ε (|F̃| + C|ė| + K|e|)/M ≈ 7e-9 m/s² absolute here (4ε allowed),
    /// on top of the model difference 10 K M/C² relative.
    #[test]
    fn small_mass_acceleration_approaches_first_order() {
        let (c, k, m) = (626.0, 1000.0, 1e-6);
        let (a1, _) = Admittance::new(&AdmittanceParams::uniform(m, c, k, 0.0), H).unwrap();
        let (a0, _) = Admittance::new(&AdmittanceParams::uniform(0.0, c, k, 0.0), H).unwrap();
        let f = Vector2::new(10.0, -4.0);
        let mut s1 = AdmittanceState {
            e: Vector2::new(0.003, 0.0),
            ..Default::default()
        };
        let mut s0 = s1;
        for step in 1..=3000 {
            a1.step(&mut s1, f, Vector2::zeros());
            a0.step(&mut s0, f, Vector2::zeros());
            if step % 100 == 0 {
                let (d1, d0) = (
                    a1.e_ddot(&s1, Vector2::zeros()),
                    a0.e_ddot(&s0, Vector2::zeros()),
                );
                for i in 0..2 {
                    let terms = f[i].abs() + c * s1.e_dot[i].abs() + k * s1.e[i].abs();
                    let tol = 4.0 * f64::EPSILON * terms / m + 10.0 * k * m / (c * c) * d0[i].abs();
                    assert!(
                        (d1[i] - d0[i]).abs() <= tol,
                        "step {step}: {d1} vs {d0} (tol {tol:e})"
                    );
                }
            }
        }
    }

    /// Constant F̃ settles at F̃/K_e. With two arms in parallel an external push P splits in two,
    /// each arm sees P/2 and the reference complies by P/(2 K_e) (SPEC §3.1: 1 mm for 2 N).
    ///
    /// After 60 s the transient is e^{−σ t} ≈ 1e-41; what is left is the rounding of the fixed
    /// point, about ε·M/(C h) ≈ 1.4e-13 relative (the map contracts ė by 2σh per tick and e by
    /// ω_n² h²/2): tolerance 1e-12 relative.
    #[test]
    fn static_gain_two_arm_push() {
        let p = AdmittanceParams::default();
        let (adm, warnings) = Admittance::new(&p, H).unwrap();
        assert!(warnings.is_empty());
        let push = Vector2::new(2.0, -2.0);
        // Each arm's expected force (its share of the nominal wrench plus squeeze).
        let f_ref = [Vector2::new(5.0, 4.9), Vector2::new(-5.0, 4.9)];
        let mut st = f_ref.map(AdmittanceState::with_filter_at);
        // 2 s push: e at the release, the SPEC's "1.05 mm" (ζ = 0.7 overshoots by 4.6 %).
        for _ in 0..2000 {
            for i in 0..2 {
                adm.step(&mut st[i], f_ref[i] + push / 2.0, f_ref[i]);
            }
        }
        for s in &st {
            assert!(
                (s.e.x - 1.05e-3).abs() < 0.01e-3 && (s.e.y + 1.05e-3).abs() < 0.01e-3,
                "{}",
                s.e
            );
        }
        for _ in 2000..60_000 {
            for i in 0..2 {
                adm.step(&mut st[i], f_ref[i] + push / 2.0, f_ref[i]);
            }
        }
        let want = adm.static_offset(push / 2.0);
        assert_eq!(want, Vector2::new(1e-3, -1e-3));
        for s in &st {
            assert!((s.e - want).amax() < 1e-12 * 1e-3, "{} vs {want}", s.e);
            assert!(s.e_dot.amax() < 1e-15);
        }
        // Release: back to the path (SPEC: within 4 µm in closed loop; the generator alone
        // returns to rounding).
        for _ in 0..60_000 {
            for i in 0..2 {
                adm.step(&mut st[i], f_ref[i], f_ref[i]);
            }
        }
        for s in &st {
            assert!(s.e.amax() < 1e-15);
        }
    }

    #[test]
    fn filter_is_exact_first_order_lag() {
        let tau = 0.01;
        let adm = build(&AdmittanceParams::uniform(200.0, 626.0, 1000.0, tau), H);
        let (f0, f1) = (Vector2::new(3.0, -1.0), Vector2::new(-2.0, 5.0));
        let mut st = AdmittanceState::with_filter_at(f0);
        for k in 1..=100 {
            adm.step(&mut st, f1, Vector2::zeros());
            let want = f1 + (f0 - f1) * (-(k as f64) * H / tau).exp();
            // Rounding only: ~k ulps of |f| ≤ 5 at most.
            assert!(
                (st.f_filt - want).amax() < 1e-13,
                "k = {k}: {} vs {want}",
                st.f_filt
            );
        }
        // τ_f = 0: no filter.
        let adm = build(&AdmittanceParams::uniform(200.0, 626.0, 1000.0, 0.0), H);
        let mut st = AdmittanceState::with_filter_at(f0);
        adm.step(&mut st, f1, Vector2::zeros());
        assert_eq!(st.f_filt, f1);
    }

    #[test]
    fn e_ddot_matches_finite_differences_of_e_dot() {
        // Central difference of ė along the exact trajectory (constant F̃, so e is smooth):
        // error ≤ h²/6 max|e⁗| + rounding 4ε max|ė|/h. e⁗ from the ODE at the middle point
        // (second order: e‴ = −(C ë + K ė)/M, e⁗ = −(C e‴ + K ë)/M; first order: e⁗ = (K/C)² ë),
        // times 2 for its variation over the ±h stencil (e^{|λ| h} ≤ 1.07 for these poles).
        for (m, c, k) in [
            (200.0, 626.0, 1000.0),
            (0.0, 626.0, 1000.0),
            (10.0, 626.0, 1000.0),
        ] {
            let adm = build(&AdmittanceParams::uniform(m, c, k, 0.0), H);
            let f = Vector2::new(10.0, -3.0);
            let mut st = AdmittanceState::default();
            let mut hist = Vec::new();
            for _ in 0..500 {
                adm.step(&mut st, f, Vector2::zeros());
                hist.push(st);
            }
            let v_max = hist.iter().map(|s| s.e_dot.amax()).fold(0.0, f64::max);
            for w in hist.windows(3) {
                let fd = (w[2].e_dot - w[0].e_dot) / (2.0 * H);
                let acc = adm.e_ddot(&w[1], Vector2::zeros());
                let d4 = if m > 0.0 {
                    let d3 = -(acc * c + w[1].e_dot * k) / m;
                    (d3 * c + acc * k).amax() / m
                } else {
                    (k / c).powi(2) * acc.amax()
                };
                let tol = 2.0 * H * H / 6.0 * d4 + 4.0 * f64::EPSILON * v_max / H;
                assert!(
                    (fd - acc).amax() <= tol,
                    "M = {m}: fd {fd} vs {acc} (tol {tol:e})"
                );
            }
        }
    }

    #[test]
    fn validation_names_the_field_and_first_order_warns() {
        let name = |p: AdmittanceParams, h: f64| match Admittance::new(&p, h).unwrap_err() {
            ModelError::Invalid { param, .. } => param,
            other => panic!("unexpected {other:?}"),
        };
        let d = AdmittanceParams::default();
        assert_eq!(
            name(
                AdmittanceParams {
                    c_e: Vector2::new(0.0, 1.0),
                    ..d
                },
                H
            ),
            "admittance.c_e[0]"
        );
        assert_eq!(
            name(
                AdmittanceParams {
                    k_e: Vector2::new(1.0, -1.0),
                    ..d
                },
                H
            ),
            "admittance.k_e[1]"
        );
        assert_eq!(
            name(
                AdmittanceParams {
                    m_e: Vector2::new(f64::NAN, 1.0),
                    ..d
                },
                H
            ),
            "admittance.m_e[0]"
        );
        assert_eq!(
            name(
                AdmittanceParams {
                    tau_f: Vector2::new(0.0, -0.1),
                    ..d
                },
                H
            ),
            "admittance.tau_f[1]"
        );
        assert_eq!(name(d, 0.0), "h");
        assert_eq!(name(d, f64::INFINITY), "h");

        let p = AdmittanceParams {
            m_e: Vector2::new(200.0, 0.0),
            ..d
        };
        let (adm, w) = Admittance::new(&p, H).unwrap();
        assert_eq!(
            w,
            vec![AdmittanceWarning::FirstOrder {
                axis: 1,
                tau_f: 0.01
            }]
        );
        assert!(!adm.is_first_order(0) && adm.is_first_order(1));
        let msg = w[0].to_string();
        assert!(
            msg.contains("diverges") && msg.contains("SPEC §3.1") && msg.contains("m_e[1]"),
            "{msg}"
        );
        let (_, w) =
            Admittance::new(&AdmittanceParams::paper_first_order(626.0, 1000.0), H).unwrap();
        assert_eq!(w.len(), 2);
        assert!(w[0].to_string().contains("τ_f = 0"));
    }

    #[test]
    fn non_finite_force_is_rejected_and_reported() {
        let (adm, _) = Admittance::new(&AdmittanceParams::default(), H).unwrap();
        let f_ref = Vector2::new(1.0, 2.0);
        let mut st = AdmittanceState::with_filter_at(f_ref);
        assert!(adm.step(&mut st, Vector2::new(3.0, 2.0), f_ref));
        let before = st.f_filt;
        assert!(!adm.step(&mut st, Vector2::new(f64::NAN, 7.0), f_ref));
        assert_eq!(st.f_filt.x, before.x);
        assert!(st.f_filt.y > before.y);
        assert!(st.e.iter().chain(st.e_dot.iter()).all(|x| x.is_finite()));
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(11), ..ProptestConfig::default() })]

        /// Closed form against the Padé exponential over dimensionless ω_n h ∈ [1e-3, 5] and
        /// ζ ∈ [0.05, 20] (so ‖A h‖ ≤ 200), scaled per entry as in
        /// `discretisation_matches_matrix_exponential`; the looser 1e-11 covers the reference's
        /// own error, which grows with ‖A h‖ through its squarings.
        #[test]
        fn closed_form_matches_expm(
            log_m in -2.0f64..3.0, log_wnh in -3.0f64..0.7, log_zeta in -1.3f64..1.3, log_h in -4.0f64..-1.0
        ) {
            let (m, h) = (10f64.powf(log_m), 10f64.powf(log_h));
            let wn = 10f64.powf(log_wnh) / h;
            let zeta = 10f64.powf(log_zeta);
            let k = m * wn * wn;
            let c = 2.0 * zeta * (k * m).sqrt();
            let adm = build(&AdmittanceParams::uniform(m, c, k, 0.0), h);
            let (phi_ref, gamma_ref) = expm_reference(m, c, k, h);
            let scale = Matrix2::new(1.0, h, wn * wn * h, 1.0);
            let err = (adm.phi(1) - phi_ref).component_div(&scale).amax();
            prop_assert!(err < 1e-11, "Φ error {:e}", err);
            let gerr = (adm.gamma(1) - gamma_ref).component_div(&Vector2::new(1.0 / k, h / m)).amax();
            prop_assert!(gerr < 1e-11, "Γ error {:e}", gerr);
        }
    }
}
