//! cargo fuzz target: any bytes as URDF text (lossily as UTF-8) → `Urdf::parse` → a chain
//! from each root link to each leaf link (as a scenario's `base_link`/`tool_link` would name
//! them, through `Urdf::chain`, which `load_chain` calls) → one kinematics and dynamics
//! evaluation at the middle of the joint limits (0 where a joint is unlimited).
//!
//! Nothing may panic or hang. Every parse error points at a line of the text. A chain the
//! loader accepts is data a simulation will use: its kinematics, mass matrix, bias forces and
//! accelerations must be finite, and its mass matrix must factor (a non-finite value there means
//! the loader should have reported an error naming the element and its line).
#![no_main]

use libfuzzer_sys::fuzz_target;
use tandem::dynamics::spatial::{ChainData, aba, terms};
use tandem::model::spatial::SpatialArm;
use tandem::model::spatial::urdf::Urdf;
use tandem::nalgebra::{Isometry3, Vector3};
use tandem_cli::scenario::MAX_LINKS;

/// Chains tried per input: roots × leaves can be large; a scenario names one pair per arm.
const MAX_ROOTS: usize = 2;
const MAX_LEAVES: usize = 6;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let urdf = match Urdf::parse(&text) {
        Ok(u) => u,
        Err(e) => {
            let msg = e.to_string();
            let lines = 1 + text.matches('\n').count() as u32;
            let line = e
                .line()
                .unwrap_or_else(|| panic!("a parse error without a line: {msg}"));
            assert!(
                (1..=lines).contains(&line),
                "line {line} outside the text's {lines} lines: {msg}"
            );
            return;
        }
    };
    let roots: Vec<String> = urdf
        .root_links()
        .take(MAX_ROOTS)
        .map(String::from)
        .collect();
    let leaves: Vec<String> = urdf
        .leaf_links()
        .take(MAX_LEAVES)
        .map(String::from)
        .collect();
    for base in &roots {
        for tool in &leaves {
            let Ok((chain, _warnings)) = urdf.chain(base, tool).map_err(|e| e.to_string()) else {
                continue;
            };
            // A scenario refuses a longer chain before building anything from it.
            if chain.dof() > MAX_LINKS {
                continue;
            }
            evaluate(SpatialArm {
                chain,
                base: Isometry3::identity(),
            });
        }
    }
});

/// Kinematics, `M`, `C q̇ + g` and `q̈` (ABA) at mid-limit with a small velocity.
fn evaluate(arm: SpatialArm) {
    let q: Vec<f64> = arm
        .chain
        .joints
        .iter()
        .map(|j| {
            let (lo, hi) = (j.limits.lower, j.limits.upper);
            if lo.is_finite() && hi.is_finite() {
                0.5 * lo + 0.5 * hi
            } else {
                0.0
            }
        })
        .collect();
    let n = q.len();
    let qd = vec![0.1; n];
    let tau = vec![0.0; n];
    let mut qdd = vec![0.0; n];
    let g = Vector3::new(0.0, 0.0, -9.81);
    let mut d = ChainData::new(&arm);
    terms(&arm, &q, &qd, &g, &mut d);
    let name = format!("{} → {}", arm.chain.base_link, arm.chain.tool_link);
    for x in &d.X_WL {
        assert!(
            finite(x.translation.vector.iter().chain(x.rotation.coords.iter())),
            "{name}: non-finite body pose"
        );
    }
    assert!(finite(d.J.iter()), "{name}: non-finite Jacobian");
    assert!(finite(d.M.iter()), "{name}: non-finite M");
    assert!(finite(d.bias.iter()), "{name}: non-finite C q̇ + g");
    aba(&arm, &q, &qd, &tau, &g, None, &mut qdd, &mut d);
    assert!(finite(qdd.iter()), "{name}: non-finite q̈: {qdd:?}");
}

fn finite<'a>(v: impl IntoIterator<Item = &'a f64>) -> bool {
    v.into_iter().all(|x| x.is_finite())
}
