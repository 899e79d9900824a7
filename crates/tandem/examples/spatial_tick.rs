//! The spatial controller tick alone, for instruction counting (load-independent profiling), and
//! a full-precision log of a short S6 run, for before/after comparisons of a rewrite:
//!
//! ```sh
//! cargo build --release -p tandem --example spatial_tick
//! valgrind --tool=callgrind --toggle-collect='*SpatialController::tick' \
//!     target/release/examples/spatial_tick ticks nn 2000
//! target/release/examples/spatial_tick log nn 2 > before.tsv
//! ```
//!
//! `ticks LAW N` replays the measurements of 2 s of the dual-UR5 S6 closed loop through a fresh
//! controller, N ticks (cycling; as the criterion bench `spatial_control/*/tick`); with
//! `--toggle-collect` callgrind counts the ticks only, so the total over N is the instructions
//! per tick (`docs/performance.md`). `log LAW SECONDS` runs the S6 loop (1 ms plant step) and
//! prints its whole log, tab-separated, every value in Rust's shortest round-trip form.
//! Laws: `nn` (default), `pd`, `ctc`.
use tandem::control::law::Law;
use tandem::control::law::adaptive::NnGains;
use tandem::control::law::ctc::CtcGains;
use tandem::control::law::pd::PdGains;
use tandem::control::spatial::{SpatialController, SpatialControllerParams, SpatialTickRecord};
use tandem::drive::Measurements;
use tandem::reference::spatial::path::Se3Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map_or("ticks", String::as_str);
    let law = || match args.get(2).map_or("nn", String::as_str) {
        "pd" => Law::Pd(PdGains::<6>::paper()),
        "ctc" => Law::Ctc(CtcGains::<6>::default()),
        _ => Law::Nn(NnGains::dual_ur5()),
    };
    let setup = tandem::presets::dual_ur5();
    if mode == "log" {
        let duration: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(2.0);
        let (sim, _) = tandem::presets::spatial_s6_simulation(
            &setup.params,
            &setup,
            law(),
            duration,
            1e-3,
            1e-6,
        )
        .expect("simulation");
        let (out, _) = sim.run(|_| {});
        let cols = &out.log.columns;
        println!(
            "{}",
            cols.iter()
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>()
                .join("\t")
        );
        for k in 0..out.log.len() {
            let row: Vec<String> = cols.iter().map(|c| format!("{:?}", c.data[k])).collect();
            println!("{}", row.join("\t"));
        }
        eprintln!("fault {:?}; events {:?}", out.fault, out.events);
        return;
    }
    let n: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(2000);
    let (mut sim, _) =
        tandem::presets::spatial_s6_simulation(&setup.params, &setup, law(), 3.0, 1e-3, 1e-6)
            .expect("simulation");
    let nq = sim.plant().n_q();
    let ticks = 2000;
    let mut rec_q = Vec::with_capacity(ticks);
    let mut rec_w = Vec::with_capacity(ticks);
    for k in 0..ticks {
        sim.tick(k).expect("closed-loop tick");
        let y = sim.state();
        rec_q.push((y[..nq].to_vec(), y[nq + 7..2 * nq + 7].to_vec()));
        rec_w.push(sim.last_readings().to_vec());
    }
    let (mut c, _) = SpatialController::new(
        &SpatialControllerParams::spec_s6(law()),
        &setup.params,
        Se3Path::spec_s6(),
        3.0,
        &setup.q_guess,
    )
    .expect("controller");
    c.start(
        0.0,
        &Measurements {
            q: &rec_q[0].0,
            qd: &rec_q[0].1,
            wrenches: &rec_w[0],
        },
    );
    let mut tau = vec![0.0; nq];
    let mut rec = SpatialTickRecord::new(2);
    let mut sum = 0.0;
    for k in 0..n {
        let i = k % ticks;
        let meas = Measurements {
            q: &rec_q[i].0,
            qd: &rec_q[i].1,
            wrenches: &rec_w[i],
        };
        c.tick(
            i as f64 * 1e-3,
            std::hint::black_box(&meas),
            &mut tau,
            &mut rec,
        );
        sum += tau.iter().map(|v| v.abs()).sum::<f64>();
    }
    println!("{n} ticks; Σ|τ| = {sum:.12e}; events {:?}", c.events());
}
