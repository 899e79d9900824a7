//! Planar arm parameters (SPEC §1): links (mass, length, centre of mass, inertia), the base
//! and the elbow branch; plain, serialisable data. The validated arm and its kinematics and
//! dynamics, paper (1)–(4), are in [`crate::dynamics::planar`].

use serde::{Deserialize, Serialize};

/// Standard gravity used by the paper, m/s² (acts along −y).
pub const GRAVITY: f64 = 9.8;

/// One rigid link: plain data, validated by [`Arm::new`](crate::dynamics::planar::Arm::new).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkParams {
    /// Mass `m`, kg (> 0).
    pub mass: f64,
    /// Length `l` between the joint axes, m (> 0).
    pub length: f64,
    /// Distance `l_c` of the centre of mass from the proximal joint along the link, m (≥ 0).
    pub com: f64,
    /// Inertia `I` about the centre of mass, kg m² (≥ 0).
    pub inertia: f64,
}

/// Sign of the elbow angle `q_2` chosen by the analytic inverse kinematics of a 2-link arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Elbow {
    /// `q_2 > 0`.
    Positive,
    /// `q_2 < 0`.
    Negative,
}

impl Elbow {
    pub(crate) fn sign(self) -> f64 {
        match self {
            Elbow::Positive => 1.0,
            Elbow::Negative => -1.0,
        }
    }
}

/// Parameters of one planar arm: plain data, validated by [`Arm::new`](crate::dynamics::planar::Arm::new).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArmParams {
    /// Base position `p_WB` in the world, m.
    pub base: [f64; 2],
    /// Base orientation (added to `q_1`), rad.
    #[serde(default)]
    pub base_angle: f64,
    /// Links from the base outwards.
    pub links: Vec<LinkParams>,
    /// Elbow branch for the analytic 2-link inverse kinematics.
    pub elbow: Elbow,
}

impl ArmParams {
    /// The paper's arm (Table I) with `l_c = l/2` (SPEC §2.1), based at `base`.
    pub fn paper(base: [f64; 2], elbow: Elbow) -> Self {
        ArmParams {
            base,
            base_angle: 0.0,
            links: vec![
                LinkParams {
                    mass: 2.0,
                    length: 0.3,
                    com: 0.15,
                    inertia: 0.045,
                },
                LinkParams {
                    mass: 0.85,
                    length: 0.3,
                    com: 0.15,
                    inertia: 0.019,
                },
            ],
            elbow,
        }
    }
}
