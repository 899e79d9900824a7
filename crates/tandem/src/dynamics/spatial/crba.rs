//! Joint-space inertia by the composite-rigid-body algorithm (Featherstone 2008, Table 6.2 and
//! §6.2, in world axes about the base origin).
//!
//! ```text
//! 𝕀ᶜ_k = Σ_{b ≥ k} 𝕀_b                      (suffix sums: 10 additions per body)
//! F_k  = 𝕀ᶜ_k S_k,   M_ik = M_ki = S_i · F_k   for i ≤ k
//! ```
//!
//! In one fixed coordinate system the composite inertias need no change of frame, and each entry of `M`
//! is one 6-vector dot product. Cost: the shared placement and inertia stages, then about 30
//! flops per body and 11 per entry of the upper triangle.

use super::ChainData;
use super::kinematics::placements_and_inertias;
use crate::geometry::SpatialInertia;
use crate::model::spatial::SpatialArm;

/// The CRBA pass on placed bodies (after `placements` and `inertias`): writes `d.M`.
#[inline]
pub(super) fn crba_pass(d: &mut ChainData) {
    let n = d.S.len();
    let (s, iw) = (&d.S[..n], &d.I_W[..n]);
    let m = &mut d.M.as_mut_slice()[..n * n];
    let mut ic = SpatialInertia::zero();
    // Upper triangle column by column (column k holds M_ik, i ≤ k; column-major), then the
    // mirror.
    for k in (0..n).rev() {
        ic += iw[k];
        let f = ic.apply(&s[k]);
        for (mik, si) in m[k * n..k * n + k + 1].iter_mut().zip(s) {
            *mik = si.dot(&f);
        }
    }
    for k in 0..n {
        for i in 0..k {
            m[i * n + k] = m[k * n + i];
        }
    }
}

/// Joint-space inertia `M(q)` (n × n, kg m² / kg / kg m) by the composite-rigid-body algorithm
/// (Featherstone 2008, Table 6.2, world axes about the base origin). Reads `q`; writes `d.M` (both triangles)
/// and the poses `d.X_WL`, `d.X_WT`.
pub fn crba(arm: &SpatialArm, q: &[f64], d: &mut ChainData) {
    placements_and_inertias(arm, q, d);
    crba_pass(d);
}
