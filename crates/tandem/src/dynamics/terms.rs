//! The plant's fused pass: kinematics (poses, `J`, `J̇ q̇`), `M` (CRBA) and `C q̇ + g` (RNEA at
//! `q̈ = 0`) from one placement stage and one set of world-coordinate inertias.
//!
//! ```text
//! placements → inertias → RNEA(q̈ = 0) [twists V_k] → J, J̇ q̇ → CRBA
//! ```
//!
//! Cost: the stages of [`super::kinematics`], [`super::rnea`] and [`super::crba`] once each,
//! with the poses, inertias and twists shared.

use nalgebra::Vector3;

use super::crba::crba_pass;
use super::kinematics::{inertias, placements, tool_jacobian, tool_jdqd};
use super::rnea::rnea_passes;
use super::{ChainData, check_len};
use crate::model::SpatialArm;

/// The plant's fused pass: [`super::kinematics`] with `qd`, `d.M`, and
/// `d.bias = C q̇ + g` (n, N m or N).
///
/// Reads `q`, `q̇` (n) and `g_W` (world axes, m/s²); writes `d.X_WL`, `d.X_WT`, `d.J`,
/// `d.jdqd`, `d.M`, `d.bias` and the body twists.
pub fn terms(arm: &SpatialArm, q: &[f64], qd: &[f64], g_W: &Vector3<f64>, d: &mut ChainData) {
    check_len(arm, d, "qd", qd);
    placements(arm, q, d);
    inertias(arm, d);
    // The bias goes into d.bias; take it out to lend it as the output slice.
    let mut bias = std::mem::take(&mut d.bias);
    rnea_passes(qd, None, g_W, None, bias.as_mut_slice(), d);
    d.bias = bias;
    tool_jacobian(d);
    tool_jdqd(qd, d);
    crba_pass(d);
}
