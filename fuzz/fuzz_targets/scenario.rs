//! cargo fuzz target: any bytes as a scenario file. Parsing and validation must never panic
//! or hang; a scenario that validates is run for 50 ms and must log only finite values.
//! The CLI's modules are compiled in directly (the CLI crate is a binary).
#![no_main]

#[allow(dead_code)]
#[path = "../../crates/tandem-cli/src/anim.rs"]
mod anim;
#[allow(dead_code)]
#[path = "../../crates/tandem-cli/src/figures.rs"]
mod figures;
#[allow(dead_code)]
#[path = "../../crates/tandem-cli/src/output.rs"]
mod output;
#[allow(dead_code)]
#[path = "../../crates/tandem-cli/src/plot.rs"]
mod plot;
#[allow(dead_code)]
#[path = "../../crates/tandem-cli/src/replay.rs"]
mod replay;
#[allow(dead_code)]
#[path = "../../crates/tandem-cli/src/runner.rs"]
mod runner;
#[allow(dead_code)]
#[path = "../../crates/tandem-cli/src/scenario.rs"]
mod scenario;
#[allow(dead_code)]
#[path = "../../crates/tandem-cli/src/scene.rs"]
mod scene;
#[allow(dead_code)]
#[path = "../../crates/tandem-cli/src/suggest.rs"]
mod suggest;
#[allow(dead_code)]
#[path = "../../crates/tandem-cli/src/table.rs"]
mod table;

use libfuzzer_sys::fuzz_target;

/// Bad input (as in the CLI's `main.rs`).
#[derive(Debug)]
pub struct BadInput(String);

impl BadInput {
    /// From a message.
    pub fn msg(s: impl Into<String>) -> Self {
        BadInput(s.into())
    }
}

impl std::fmt::Display for BadInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BadInput {}

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
    let Ok(mut sc) = scenario::parse(&src) else {
        return;
    };
    // Every error renders (excerpts, spans) without panicking.
    let o = scenario::Overrides {
        duration: Some(0.05),
        ..scenario::Overrides::default()
    };
    if sc.apply(&o).is_err() {
        return;
    }
    let p = match runner::prepare(sc, &src) {
        Ok(p) => p,
        Err(e) => {
            let _ = e.to_string();
            return;
        }
    };
    let f = runner::execute(p, |_| {});
    for c in &f.outcome.log.columns {
        assert!(
            c.data.iter().all(|v| v.is_finite()),
            "column {} logged a non-finite value",
            c.name
        );
    }
    let _ = runner::summary_json(&f, "fuzz", None);
});
