//! cargo fuzz target: any bytes as a scenario file, parsed (`scenario::parse`, which decides
//! planar or spatial as every command does) and, when spatial, validated as `tandem validate`
//! does it (`run::spatial::prepare`: every set-up check, the arms' URDF chains, the start by
//! inverse kinematics, the controller's design), **without** the run: fast enough for 10⁶
//! executions where the `scenario` target (which runs 50 ms of every valid input) is not.
//!
//! Nothing may panic or hang; every error renders (excerpts, spans) and names a line or a
//! field; a scenario that validates renders its `validate` summary's numbers finite.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tandem_cli::run::spatial;
use tandem_cli::scenario::{self, Scenario};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let src = scenario::Source {
        name: "fuzz".into(),
        display: "fuzz.toml".into(),
        text: text.to_string(),
        dir: std::env::temp_dir(),
        file: None,
    };
    let sc = match scenario::parse(&src) {
        Ok(Scenario::Spatial(sc)) => sc,
        // Planar text is the `scenario` target's business.
        Ok(Scenario::Planar(_)) => return,
        Err(e) => {
            let _ = e.to_string();
            return;
        }
    };
    let p = match spatial::prepare(sc, &src) {
        Ok(p) => p,
        Err(e) => {
            let _ = e.to_string();
            return;
        }
    };
    let b = &p.built;
    assert!(
        b.sim.duration.is_finite() && b.sim.control_period > 0.0 && b.sim.log_period > 0.0,
        "validated timing is not finite: {:?}",
        (b.sim.duration, b.sim.control_period, b.sim.log_period)
    );
    if let Some(m) = p.ready.path_inertia {
        assert!(
            m.iter().all(|v| v.is_finite()),
            "path inertia not finite: {m:?}"
        );
    }
});
