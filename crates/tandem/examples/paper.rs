//! The paper scenario with one law, summary printed: `cargo run --release -p tandem --example paper -- [nn|paper|pd|ctc] [seconds]`
//! (`SCHEME=arm` for the per-arm scheme).
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::pd::PdGains;
use tandem::control::planar::ControllerParams;
use tandem::model::disturbance::Disturbance;
use tandem::sim::SimParams;
use tandem::{presets, report};

fn main() {
    let which = std::env::args().nth(1).unwrap_or("nn".into());
    let dur: f64 = std::env::args()
        .nth(2)
        .map(|s| s.parse().unwrap())
        .unwrap_or(10.0);
    let law = match which.as_str() {
        "pd" => Law::Pd(PdGains::<3>::paper()),
        "paper" => Law::Nn(NnGains::paper()),
        "ctc" => Law::Ctc(Default::default()),
        _ => Law::Nn(NnGains::tuned()),
    };
    let cp = ControllerParams {
        scheme: std::env::var("SCHEME")
            .map(|s| {
                if s == "arm" {
                    tandem::control::Scheme::PerArm
                } else {
                    Default::default()
                }
            })
            .unwrap_or_default(),
        ..ControllerParams::paper(law)
    };
    let sp = SimParams {
        duration: dur,
        ..SimParams::paper()
    };
    let (sim, w) = presets::paper_simulation(&cp, sp, Disturbance::paper()).unwrap();
    for w in w {
        println!("warning: {w}");
    }
    let (out, _) = sim.run(|_| {});
    let s = report::planar::summarize(&out, &which, "", [0.35; 3], 5.0, dur);
    println!("{}", serde_json_like(&s));
}
fn serde_json_like(s: &report::planar::Summary) -> String {
    format!("{s:#?}")
}
