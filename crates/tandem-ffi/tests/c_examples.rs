//! The C and C++ examples (`examples/c/loop.c`, `examples/cpp/loop.cpp`) compiled with the
//! system's `cc` and `c++` against this crate's static and shared library, run, and their
//! printed torques (`%.17g`) and `z1` compared bit for bit with the Rust `Standalone` tick on
//! the same inputs. Without a C compiler the test says "skipped: no C compiler" and passes
//! (`.ci/run` installs build-essential, so CI runs it).

use std::path::{Path, PathBuf};
use std::process::Command;

use tandem_cli::scenario::standalone::{self, Standalone};
use tandem_cli::scenario::{self, ControllerChoice, EMBEDDED, Scenario};

/// Whether `tool --version` runs.
fn have(tool: &str) -> bool {
    Command::new(tool)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The folder holding `libtandem_ffi.a` and `.so`: cargo builds them, with this test, into the
/// folder of the test binary (`target/<profile>/deps`); `target/<profile>` after a
/// `cargo build`.
fn lib_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    for d in exe.ancestors().skip(1).take(2) {
        if d.join("libtandem_ffi.a").is_file() {
            return d.to_path_buf();
        }
    }
    panic!(
        "libtandem_ffi.a is neither beside {} nor in its parent folder",
        exe.display()
    );
}

fn run(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// The words after `key` on each line that starts with it.
fn lines<'a>(out: &'a str, key: &'a str) -> impl Iterator<Item = Vec<&'a str>> + 'a {
    out.lines()
        .filter_map(move |l| l.strip_prefix(key).map(|r| r.split_whitespace().collect()))
}

fn bits(words: &[&str]) -> Vec<u64> {
    words
        .iter()
        .map(|w| w.parse::<f64>().unwrap().to_bits())
        .collect()
}

/// The dual-UR5 NN controller in Rust, started and ticked `n` times on its start state held,
/// as the examples do: each tick's torques and the last z1.
fn reference(n: usize) -> (Vec<Vec<u64>>, Vec<u64>) {
    let e = EMBEDDED.iter().find(|e| e.name == "dual-ur5").unwrap();
    let src = scenario::embedded_source(e);
    let Scenario::Spatial(sc) = scenario::parse(&src).unwrap() else {
        unreachable!()
    };
    let mut s: Standalone = standalone::spatial(&sc, &src, Some(ControllerChoice::Nn)).unwrap();
    let (q, qd, w) = (
        s.start.q.clone(),
        s.start.qd.clone(),
        s.start.wrenches.clone(),
    );
    let dt = s.control_period;
    let mut tau = vec![0.0; s.n_q];
    s.try_start(0.0, &q, &qd, &w).unwrap();
    let mut taus = Vec::new();
    for k in 0..n {
        s.try_tick(k as f64 * dt, &q, &qd, &w, &mut tau).unwrap();
        taus.push(tau.iter().map(|v| v.to_bits()).collect());
    }
    let z1 = s
        .record_vectors()
        .iter()
        .find(|(k, _)| *k == "z1")
        .unwrap()
        .1;
    (taus, z1.iter().map(|v| v.to_bits()).collect())
}

#[test]
fn c_and_cpp_examples_match_the_rust_tick_bit_for_bit() {
    if !have("cc") {
        // .ci/run installs the compilers and sets TANDEM_REQUIRE_CC: there, a missing one fails.
        assert!(
            std::env::var_os("TANDEM_REQUIRE_CC").is_none(),
            "TANDEM_REQUIRE_CC is set but there is no `cc`"
        );
        println!("skipped: no C compiler");
        return;
    }
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let include = crate_dir.join("include");
    let lib = lib_dir();
    let out = Path::new(env!("CARGO_TARGET_TMPDIR"));
    let (taus, z1) = reference(1000);

    // C, linked statically.
    let exe_c = out.join("tandem_loop_c");
    run(Command::new("cc")
        .args(["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-I"])
        .arg(&include)
        .arg(crate_dir.join("examples/c/loop.c"))
        .arg(lib.join("libtandem_ffi.a"))
        .args([
            "-lpthread",
            "-ldl",
            "-lm",
            "-lrt",
            "-lutil",
            "-lgcc_s",
            "-lc",
            "-o",
        ])
        .arg(&exe_c));
    let text = run(Command::new(&exe_c).args(["dual-ur5", "nn", "1000"]));
    let got: Vec<Vec<&str>> = lines(&text, "tau ").collect();
    assert_eq!(got.len(), 1000, "{text}");
    for (k, words) in got.iter().enumerate() {
        assert_eq!(words[0], k.to_string());
        assert_eq!(bits(&words[1..]), taus[k], "C tick {k}");
    }
    let z: Vec<Vec<&str>> = lines(&text, "z1 ").collect();
    assert_eq!(bits(&z[0]), z1, "C z1");
    assert!(
        text.contains("refused: TANDEM_ERR_NON_FINITE: q[1] = NaN: every value must be finite"),
        "{text}"
    );
    assert!(text.contains("next tick: ok"), "{text}");

    // C++, linked against the shared library, 1000 ticks paced at 1 kHz.
    if !have("c++") {
        assert!(
            std::env::var_os("TANDEM_REQUIRE_CC").is_none(),
            "TANDEM_REQUIRE_CC is set but there is no `c++`"
        );
        println!("skipped the C++ example: no C++ compiler");
        return;
    }
    let exe_cpp = out.join("tandem_loop_cpp");
    run(Command::new("c++")
        .args(["-std=c++17", "-O2", "-Wall", "-Wextra", "-Werror", "-I"])
        .arg(&include)
        .arg(crate_dir.join("examples/cpp/loop.cpp"))
        .arg("-L")
        .arg(&lib)
        .arg("-ltandem_ffi")
        .arg(format!("-Wl,-rpath,{}", lib.display()))
        .arg("-o")
        .arg(&exe_cpp));
    let text = run(&mut Command::new(&exe_cpp));
    let got: Vec<Vec<&str>> = lines(&text, "tau ").collect();
    assert_eq!(got.len(), 11, "{text}");
    for words in &got {
        let k: usize = words[0].parse().unwrap();
        assert_eq!(bits(&words[1..]), taus[k], "C++ tick {k}");
    }
    let z: Vec<Vec<&str>> = lines(&text, "z1 ").collect();
    assert_eq!(bits(&z[0]), z1, "C++ z1");
    assert!(
        text.contains("caught: tandem_tick: TANDEM_ERR_TIME: t = 0: time went back"),
        "{text}"
    );
    assert!(text.contains("next tick: ok"), "{text}");
}
