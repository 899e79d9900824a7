//! Joint-space inertia by the composite-rigid-body algorithm (Featherstone 2008, Table 6.2 and
//! §6.2, in world axes about the base origin).
//!
//! ```text
//! 𝕀ᶜ_k = Σ_{b ≥ k} 𝕀_b                      (suffix sums: 10 additions per body)
//! F_k  = 𝕀ᶜ_k S_k,   M_ik = M_ki = S_i · F_k   for i ≤ k
//! ```
//!
//! In world coordinates the composite inertias need no change of frame, and each entry of `M`
//! is one 6-vector dot product. Cost: the shared placement and inertia stages, then about 30
//! flops per body and 11 per entry of the upper triangle.

use super::ChainData;
use super::kinematics::{inertias, placements};
use crate::model::SpatialArm;
use crate::spatial::SpatialInertia;

/// The CRBA pass on placed bodies (after `placements` and `inertias`): writes `d.M` and the
/// composite inertias `d.Ic`.
#[inline]
pub(super) fn crba_pass(d: &mut ChainData) {
    let n = d.S.len();
    let mut ic = SpatialInertia::zero();
    for k in (0..n).rev() {
        ic += d.I_W[k];
        d.Ic[k] = ic;
        let f = ic.apply(&d.S[k]);
        for i in 0..=k {
            let m = d.S[i].dot(&f);
            d.M[(i, k)] = m;
            d.M[(k, i)] = m;
        }
    }
}

/// Joint-space inertia `M(q)` (n × n, kg m² / kg / kg m) by the composite-rigid-body algorithm
/// (Featherstone 2008, Table 6.2, world coordinates). Reads `q`; writes `d.M` (both triangles)
/// and the poses `d.X_WL`, `d.X_WT`.
pub fn crba(arm: &SpatialArm, q: &[f64], d: &mut ChainData) {
    placements(arm, q, d);
    inertias(arm, d);
    crba_pass(d);
}
