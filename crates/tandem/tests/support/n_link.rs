//! Closed chains of 3- and 4-link arms for the n-link kernel tests: two or three arms of one
//! link count holding the paper's box — two at `(∓0.38, 0)` on its ends (as
//! `presets::redundant_pair`), a third at `(0, −0.4)` on its bottom face's midpoint (as
//! `presets::three_arms`) — with a joint-angle guess for the numerical inverse kinematics
//! at `presets::paper_start`.
#![allow(dead_code)]

use tandem::model::planar::arm::{ArmParams, Elbow, LinkParams};
use tandem::plant::planar::PlantParams;

/// `arms` arms (2 or 3; 2 for 5 links) of `links` links (3, 4 or 5) each, and the stacked IK
/// guess. 3 links: 0.2 m each (masses 1.5, 1.0, 0.5 kg); 4 links: 0.15 m each (1.5, 1.0, 0.7,
/// 0.5 kg); 5 links (no fixed-size kernel: the dynamic-size route): 0.12 m each (1.5, 1.0, 0.7,
/// 0.5, 0.3 kg); centres of mass mid-link. The guesses put each end-effector on its grasp point at the start pose
/// (2-link inverse kinematics for the first two links, the others along a fixed direction).
pub fn chain(arms: usize, links: usize) -> (PlantParams, Vec<f64>) {
    assert!((2..=3).contains(&arms) && (3..=5).contains(&links) && (links, arms) != (5, 3));
    let (len, masses, inertias): (f64, &[f64], &[f64]) = match links {
        3 => (0.2, &[1.5, 1.0, 0.5], &[0.02, 0.01, 0.005]),
        4 => (0.15, &[1.5, 1.0, 0.7, 0.5], &[0.02, 0.01, 0.007, 0.005]),
        _ => (
            0.12,
            &[1.5, 1.0, 0.7, 0.5, 0.3],
            &[0.02, 0.01, 0.007, 0.005, 0.003],
        ),
    };
    let arm = |base: [f64; 2], elbow| ArmParams {
        base,
        base_angle: 0.0,
        links: masses
            .iter()
            .zip(inertias)
            .map(|(&mass, &inertia)| LinkParams {
                mass,
                length: len,
                com: len / 2.0,
                inertia,
            })
            .collect(),
        elbow,
    };
    let mut p = PlantParams::paper();
    p.arms = vec![
        arm([-0.38, 0.0], Elbow::Negative),
        arm([0.38, 0.0], Elbow::Positive),
    ];
    let mut guess: Vec<f64> = match links {
        3 => vec![0.644, -1.287, 0.644, -1.42, 2.84, 1.721],
        4 => vec![0.748, -1.495, 0.748, 0.0, -1.008, 2.017, 2.133, 0.0],
        _ => vec![
            0.841, -1.682, 0.841, 0.0, 0.0, -0.411, 0.822, 2.73, 0.0, 0.0,
        ],
    };
    if arms == 3 {
        p.arms.push(arm([0.0, -0.4], Elbow::Positive));
        p.grasps.push([0.0, -0.025]);
        if links == 3 {
            guess.extend([-0.124, 1.738, -0.042]);
        } else {
            guess.extend([-0.446, 1.644, 0.373, 0.0]);
        }
    }
    (p, guess)
}
