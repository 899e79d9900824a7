//! cargo fuzz target: any bytes as a scenario file, planar or spatial (`scenario::parse`
//! decides, as every command does). Parsing and validation must never panic or hang; a scenario
//! that validates is run for 50 ms and must log only finite values, and its summary renders.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tandem_cli::output::{planar as planar_output, spatial as spatial_output};
use tandem_cli::run::{planar, spatial};
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
    let mut sc = match scenario::parse(&src) {
        Ok(sc) => sc,
        Err(e) => {
            // Every error renders (excerpts, spans) without panicking.
            let _ = e.to_string();
            return;
        }
    };
    let o = scenario::Overrides {
        duration: Some(0.05),
        ..scenario::Overrides::default()
    };
    if sc.apply(&o).is_err() {
        return;
    }
    let log = match sc {
        Scenario::Planar(sc) => {
            let Ok(p) = planar::prepare(sc, &src).map_err(|e| e.to_string()) else {
                return;
            };
            let f = planar::execute(p, |_| {});
            let _ = planar_output::summary_json(&f, "fuzz", None);
            f.outcome.log
        }
        Scenario::Spatial(sc) => {
            let Ok(p) = spatial::prepare(sc, &src).map_err(|e| e.to_string()) else {
                return;
            };
            let Ok(f) = spatial::execute(p, |_| {}) else {
                return;
            };
            let d = spatial_output::Derived::new(&f);
            let _ = spatial_output::summary("fuzz", &f, &d, None);
            f.outcome.log
        }
    };
    for c in &log.columns {
        assert!(
            c.data.iter().all(|v| v.is_finite()),
            "column {} logged a non-finite value",
            c.name
        );
    }
});
