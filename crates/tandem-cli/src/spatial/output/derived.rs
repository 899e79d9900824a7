//! Per-row quantities derived from a spatial run's log and the plant's kinematics: the true pose
//! in the output chart, the grasp wrenches in tool axes, the tool Jacobians' smallest singular
//! values and the joints' distances to their limits (computed on the logged rows, with
//! `tandem::dynamics::spatial::kinematics` on the logged joint positions).

use nalgebra::{DMatrix, Quaternion, UnitQuaternion, Vector3};
use tandem::control::spatial::{AXES, WRENCH_AXES};
use tandem::dynamics::spatial::{ChainData, kinematics};
use tandem::model::spatial::JointKind;

use super::{Finished, col, six};

/// Per-row quantities derived from the log and the plant's kinematics.
pub struct Derived {
    /// Times of the logged rows, s.
    pub t: Vec<f64>,
    /// The true object pose in the output chart, `x_1 = (p − c, φ)` (6 columns; empty if the log
    /// has no object pose).
    pub x1: Vec<Vec<f64>>,
    /// `‖z1_p‖`, m (empty if no `z1` columns).
    pub z1_p: Vec<f64>,
    /// `‖z1_φ‖`, rad.
    pub z1_rot: Vec<f64>,
    /// Per arm, the true grasp wrench in tool axes (6 columns each; empty if not computable).
    pub f_tool: Vec<Vec<Vec<f64>>>,
    /// Per arm, the smallest singular value of the tool Jacobian per row.
    pub sigma: Vec<Vec<f64>>,
    /// Per arm, the smallest distance of a joint to its nearest limit per row (rad or m;
    /// infinite when no joint of the arm has a finite limit).
    pub limit_margin: Vec<Vec<f64>>,
    /// Per joint (all arms), `(q − lower)/(upper − lower)`; `None` for a joint without finite
    /// limits.
    pub q_norm: Vec<Option<Vec<f64>>>,
    /// The closest approach to a joint limit over the logged rows.
    pub closest: Option<Closest>,
    /// True orientation error to the desired path, `|Log(R_dᵀ R_o)|`, rad.
    pub angle_to_desired: Vec<f64>,
}

/// The closest approach of a joint to one of its limits.
#[derive(Clone, Debug, PartialEq)]
pub struct Closest {
    /// Arm (1-based).
    pub arm: usize,
    /// Global joint index (1-based, as the `q*` columns).
    pub index: usize,
    /// The joint's name in its chain.
    pub name: String,
    /// Distance to the limit (rad, or m for a prismatic joint).
    pub margin: f64,
    /// `rad` or `m`.
    pub unit: &'static str,
    /// `lower` or `upper`.
    pub side: &'static str,
    /// Time of the row, s.
    pub t: f64,
}

/// The smallest singular value of a 6 × n tool Jacobian (`n ≥ 6`: from the eigenvalues of
/// `J Jᵀ`; `n < 6`: of `Jᵀ J`).
pub fn sigma_min(j: &DMatrix<f64>) -> f64 {
    let g = if j.ncols() >= j.nrows() {
        j * j.transpose()
    } else {
        j.transpose() * j
    };
    g.symmetric_eigenvalues()
        .iter()
        .fold(f64::INFINITY, |a, &v| a.min(v))
        .max(0.0)
        .sqrt()
}

impl Derived {
    /// Compute everything from `f`'s log (one forward-kinematics pass per arm and logged row).
    pub fn new(f: &Finished) -> Self {
        let log = &f.outcome.log;
        let n = log.len();
        let t = col(log, "t").to_vec();
        let mut d = Derived {
            t,
            x1: Vec::new(),
            z1_p: Vec::new(),
            z1_rot: Vec::new(),
            f_tool: Vec::new(),
            sigma: Vec::new(),
            limit_margin: Vec::new(),
            q_norm: Vec::new(),
            closest: None,
            angle_to_desired: Vec::new(),
        };
        if d.t.len() != n {
            return d;
        }
        let pose: Option<Vec<&[f64]>> = ["x", "y", "z", "qw", "qx", "qy", "qz"]
            .iter()
            .map(|a| log.get(&format!("x_o.{a}")).filter(|c| c.len() == n))
            .collect();
        if let Some(p) = pose {
            let mut x1 = (0..6).map(|_| Vec::with_capacity(n)).collect::<Vec<_>>();
            for k in 0..n {
                let q = UnitQuaternion::from_quaternion(Quaternion::new(
                    p[3][k], p[4][k], p[5][k], p[6][k],
                ));
                let x = f.chart.coords(&Vector3::new(p[0][k], p[1][k], p[2][k]), &q);
                for (c, v) in x1.iter_mut().zip(x.iter()) {
                    c.push(*v);
                }
                let s = f.path.sample(d.t[k]);
                d.angle_to_desired
                    .push(tandem::geometry::so3::log_quat(&(s.r.inverse() * q)).norm());
            }
            d.x1 = x1;
        }
        if let Some(z) = six(log, "z1", &AXES) {
            d.z1_p = (0..n)
                .map(|k| Vector3::new(z[0][k], z[1][k], z[2][k]).norm())
                .collect();
            d.z1_rot = (0..n)
                .map(|k| Vector3::new(z[3][k], z[4][k], z[5][k]).norm())
                .collect();
        }
        // Kinematics per arm and row.
        let arms = f.plant.arms();
        let mut off = 0;
        for (i, arm) in arms.iter().enumerate() {
            let dof = arm.chain.dof();
            let qcols: Vec<&[f64]> = (0..dof)
                .map(|k| col(log, &format!("q{}", off + k + 1)))
                .collect();
            let fw = six(log, &format!("F{}", i + 1), &WRENCH_AXES);
            if qcols.iter().any(|c| c.len() != n) {
                off += dof;
                continue;
            }
            let mut data = ChainData::new(arm);
            let mut qi = vec![0.0; dof];
            let mut ft = (0..6).map(|_| Vec::with_capacity(n)).collect::<Vec<_>>();
            let mut sig = Vec::with_capacity(n);
            for k in 0..n {
                for (v, c) in qi.iter_mut().zip(&qcols) {
                    *v = c[k];
                }
                kinematics(arm, &qi, None, &mut data);
                sig.push(sigma_min(&DMatrix::from_iterator(
                    6,
                    dof,
                    data.J.iter().copied(),
                )));
                if let Some(w) = fw {
                    let r = &data.X_WT.rotation;
                    let fl = r.inverse_transform_vector(&Vector3::new(w[0][k], w[1][k], w[2][k]));
                    let tl = r.inverse_transform_vector(&Vector3::new(w[3][k], w[4][k], w[5][k]));
                    for (c, v) in ft.iter_mut().zip(fl.iter().chain(tl.iter())) {
                        c.push(*v);
                    }
                }
            }
            if fw.is_some() {
                d.f_tool.push(ft);
            }
            d.sigma.push(sig);
            let mut lm = vec![f64::INFINITY; n];
            for (k, j) in arm.chain.joints.iter().enumerate() {
                let (lo, hi) = (j.limits.lower, j.limits.upper);
                let q = qcols[k];
                if !(lo.is_finite() && hi.is_finite() && hi > lo) {
                    d.q_norm.push(None);
                    continue;
                }
                d.q_norm
                    .push(Some(q.iter().map(|v| (v - lo) / (hi - lo)).collect()));
                for (r, v) in q.iter().enumerate() {
                    let (m, side) = if v - lo <= hi - v {
                        (v - lo, "lower")
                    } else {
                        (hi - v, "upper")
                    };
                    lm[r] = lm[r].min(m);
                    if d.closest.as_ref().is_none_or(|c| m < c.margin) {
                        d.closest = Some(Closest {
                            arm: i + 1,
                            index: off + k + 1,
                            name: j.name.clone(),
                            margin: m,
                            unit: if j.kind == JointKind::Prismatic {
                                "m"
                            } else {
                                "rad"
                            },
                            side,
                            t: d.t[r],
                        });
                    }
                }
            }
            d.limit_margin.push(lm);
            off += dof;
        }
        d
    }
}
