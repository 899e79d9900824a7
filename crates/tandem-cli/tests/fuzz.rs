//! Property-based fuzzing of scenario files (proptest, stable Rust): every embedded scenario,
//! mutated (numbers replaced by extreme values, lines deleted, duplicated or swapped, arrays
//! lengthened, text truncated or garbage inserted), is parsed, validated and run for 50 ms.
//! None of it may panic or hang, and a run never logs a non-finite value nor leaves a `null`
//! in its summary without a reason.
//!
//! The spatial presets get the same treatment (fewer cases: a spatial set-up follows the path by
//! inverse kinematics). Longer runs on nightly: `fuzz/` (cargo fuzz), see `fuzz/README.md`.

use std::time::Instant;

use proptest::prelude::*;
use tandem_cli::run::{planar as runner, spatial};
use tandem_cli::scenario::{self, Kind, Scenario};

/// Values that break naive code.
const NASTY: &[&str] = &[
    "0",
    "-0.0",
    "-1",
    "1e308",
    "-1e308",
    "1.7e308",
    "1e-308",
    "5e-324",
    "nan",
    "inf",
    "-inf",
    "1e20",
    "-1e20",
    "9223372036854775807",
    "-9223372036854775808",
    "1e9",
    "1e-9",
    "0.5",
    "2",
    "100",
    "\"x\"",
    "[]",
    "[1.0, 2.0, 3.0, 4.0]",
    "true",
    "{}",
];

/// One edit of the text.
#[derive(Clone, Debug)]
enum Mutation {
    /// Replace the `n`-th number with a nasty value.
    Number(usize, usize),
    /// Replace the `n`-th number with an arbitrary float.
    Float(usize, f64),
    /// Delete line `n`.
    Delete(usize),
    /// Duplicate line `n`.
    Duplicate(usize),
    /// Swap lines `a` and `b`.
    Swap(usize, usize),
    /// Append an entry to the `n`-th array.
    Lengthen(usize),
    /// Cut the text at a fraction of its length.
    Truncate(f64),
    /// Insert a string at a fraction of the text.
    Insert(f64, String),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (any::<usize>(), 0..NASTY.len()).prop_map(|(n, v)| Mutation::Number(n, v)),
        2 => (any::<usize>(), any::<f64>()).prop_map(|(n, v)| Mutation::Float(n, v)),
        1 => any::<usize>().prop_map(Mutation::Delete),
        1 => any::<usize>().prop_map(Mutation::Duplicate),
        1 => (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::Swap(a, b)),
        1 => any::<usize>().prop_map(Mutation::Lengthen),
        1 => (0.0..1.0f64).prop_map(Mutation::Truncate),
        1 => (0.0..1.0f64, "[ -~\u{feff}\n\"\\[\\]=]{0,12}").prop_map(|(f, s)| Mutation::Insert(f, s)),
    ]
}

/// Byte ranges of the numbers outside comments.
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut off = 0;
    for line in text.split_inclusive('\n') {
        let code = line.split('#').next().unwrap_or("");
        let b = code.as_bytes();
        let mut i = 0;
        while i < b.len() {
            let starts =
                (b[i].is_ascii_digit() || b[i] == b'-') && (i == 0 || b" =[,".contains(&b[i - 1]));
            if starts {
                let j = i + b[i..]
                    .iter()
                    .position(|c| !(c.is_ascii_alphanumeric() || b".-+_".contains(c)))
                    .unwrap_or(b.len() - i);
                if j > i + usize::from(b[i] == b'-') {
                    out.push((off + i, off + j));
                }
                i = j.max(i + 1);
            } else {
                i += 1;
            }
        }
        off += line.len();
    }
    out
}

fn floor(text: &str, mut i: usize) -> usize {
    i = i.min(text.len());
    while !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

fn apply(text: &str, m: &Mutation) -> String {
    let mut lines: Vec<&str> = text.split_inclusive('\n').collect();
    let n = lines.len();
    // An earlier mutation may have emptied the text: the line mutations have nothing to act on.
    if n == 0
        && matches!(
            m,
            Mutation::Delete(_) | Mutation::Duplicate(_) | Mutation::Swap(..)
        )
    {
        return text.to_string();
    }
    match m {
        Mutation::Number(k, _) | Mutation::Float(k, _) if !numbers(text).is_empty() => {
            let nums = numbers(text);
            let (a, b) = nums[k % nums.len()];
            let val = match m {
                Mutation::Float(_, f) => format!("{f:?}").replace("NaN", "nan"),
                Mutation::Number(_, v) => NASTY[*v].to_string(),
                _ => String::new(),
            };
            format!("{}{val}{}", &text[..a], &text[b..])
        }
        Mutation::Delete(k) => {
            lines.remove(k % n);
            lines.concat()
        }
        Mutation::Duplicate(k) => {
            let l = lines[k % n];
            lines.insert(k % n, l);
            lines.concat()
        }
        Mutation::Swap(a, b) => {
            lines.swap(a % n, b % n);
            lines.concat()
        }
        Mutation::Lengthen(k) => {
            let ends: Vec<usize> = text.match_indices(']').map(|(i, _)| i).collect();
            if ends.is_empty() {
                return text.to_string();
            }
            let i = ends[k % ends.len()];
            format!("{}, 1.0{}", &text[..i], &text[i..])
        }
        Mutation::Truncate(f) => text[..floor(text, (f * text.len() as f64) as usize)].to_string(),
        Mutation::Insert(f, s) => {
            let i = floor(text, (f * text.len() as f64) as usize);
            format!("{}{s}{}", &text[..i], &text[i..])
        }
        _ => text.to_string(),
    }
}

/// How far each case got: parse error, validation error, run completed, run faulted.
static STAGES: [std::sync::atomic::AtomicUsize; 4] =
    [const { std::sync::atomic::AtomicUsize::new(0) }; 4];

fn reached(stage: usize) {
    STAGES[stage].fetch_add(1, std::sync::atomic::Ordering::Relaxed);
}

/// A mutated scenario text as a file `fuzz.toml` (relative paths from the temporary folder).
fn fuzz_source(text: &str) -> scenario::Source {
    scenario::Source {
        name: "fuzz".into(),
        display: "fuzz.toml".into(),
        text: text.to_string(),
        dir: std::env::temp_dir(),
        file: None,
    }
}

/// Every logged value is finite (numerical trouble is a fault, never a NaN in the outputs).
fn all_finite(log: &tandem::sim::Log) -> Result<(), TestCaseError> {
    for c in &log.columns {
        if let Some(v) = c.data.iter().find(|v| !v.is_finite()) {
            return Err(TestCaseError::fail(format!("column {} logged {v}", c.name)));
        }
    }
    Ok(())
}

/// Parse, validate and run 50 ms; check what a run writes.
fn check(text: &str) -> Result<(), TestCaseError> {
    let src = fuzz_source(text);
    let Ok(Scenario::Planar(mut sc)) = scenario::parse(&src) else {
        reached(0);
        return Ok(());
    };
    let o = scenario::Overrides {
        duration: Some(0.05),
        ..scenario::Overrides::default()
    };
    if sc.apply(&o).is_err() {
        reached(1);
        return Ok(());
    }
    let Ok(p) = runner::prepare(sc, &src) else {
        reached(1);
        return Ok(());
    };
    let f = runner::execute(p, |_| {});
    reached(if f.outcome.fault.is_some() { 3 } else { 2 });
    all_finite(&f.outcome.log)?;
    let s = tandem_cli::output::planar::summary_json(&f, "fuzz", None);
    let reasons = &s["unavailable"];
    for (k, v) in s.as_object().into_iter().flatten() {
        if v.is_null() && k != "fault" && k != "fault_message" && reasons.get(k).is_none() {
            return Err(TestCaseError::fail(format!(
                "summary {k} is null without a reason"
            )));
        }
    }
    Ok(())
}

/// Parse, validate and run 50 ms of a spatial scenario (PD law: the same set-up checks as the
/// NN law without its `f^U` sampling); check what a run writes.
fn check_spatial(text: &str) -> Result<(), TestCaseError> {
    let src = fuzz_source(text);
    let o = scenario::Overrides {
        duration: Some(0.05),
        controller: Some(scenario::ControllerKind::Pd),
        ..Default::default()
    };
    let Ok(Scenario::Spatial(mut sc)) = scenario::parse(&src) else {
        reached(0);
        return Ok(());
    };
    if sc.apply(&o).is_err() {
        reached(0);
        return Ok(());
    }
    let Ok(p) = spatial::prepare(sc, &src) else {
        reached(1);
        return Ok(());
    };
    let f = spatial::execute(p, |_| {}).map_err(|e| TestCaseError::fail(format!("{e:#}")))?;
    reached(if f.outcome.fault.is_some() { 3 } else { 2 });
    all_finite(&f.outcome.log)?;
    Ok(())
}

/// The case being checked and since when; a watchdog thread prints a case that takes more than
/// 5 s (a hang would otherwise stop the test without saying which input).
static CURRENT: std::sync::Mutex<Option<(String, Instant)>> = std::sync::Mutex::new(None);

fn watchdog(case: String) {
    static START: std::sync::Once = std::sync::Once::new();
    START.call_once(|| {
        std::thread::spawn(|| {
            let mut reported = String::new();
            loop {
                std::thread::sleep(std::time::Duration::from_millis(500));
                let Ok(g) = CURRENT.lock() else { return };
                if let Some((c, t)) = g.as_ref()
                    && t.elapsed().as_secs_f64() > 5.0
                    && *c != reported
                {
                    eprintln!("slow fuzz case (> 5 s): {c}");
                    reported = c.clone();
                }
            }
        });
    });
    if let Ok(mut g) = CURRENT.lock() {
        *g = Some((case, Instant::now()));
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 1000,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn mutated_scenarios_never_panic_hang_or_write_non_finite_values(
        which in 0..scenario::embedded(Kind::Planar).count(),
        edits in proptest::collection::vec(mutation(), 1..4),
    ) {
        let mut text = scenario::embedded(Kind::Planar).nth(which).unwrap().text.to_string();
        for m in &edits {
            text = apply(&text, m);
        }
        let t0 = Instant::now();
        watchdog(format!("scenario {which}, edits {edits:?}"));
        check(&text)?;
        let dt = t0.elapsed().as_secs_f64();
        if std::env::var_os("FUZZ_TIMES").is_some() {
            let n: Vec<usize> = STAGES
                .iter()
                .map(|a| a.load(std::sync::atomic::Ordering::Relaxed))
                .collect();
            eprintln!(
                "{dt:.3} s: scenario {which}, edits {edits:?} (so far: {} parse errors, {} validation errors, {} runs completed, {} faulted)",
                n[0], n[1], n[2], n[3]
            );
        }
        prop_assert!(dt < 10.0, "{dt} s for one case");
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 48,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]
    #[test]
    fn mutated_spatial_scenarios_never_panic_hang_or_write_nan(
        which in 0..scenario::embedded(Kind::Spatial).count(),
        edits in proptest::collection::vec(mutation(), 1..4),
    ) {
        let mut text = scenario::embedded(Kind::Spatial).nth(which).unwrap().text.to_string();
        for m in &edits {
            text = apply(&text, m);
        }
        let t0 = Instant::now();
        watchdog(format!("spatial scenario {which}, edits {edits:?}"));
        check_spatial(&text)?;
        let dt = t0.elapsed().as_secs_f64();
        prop_assert!(dt < 10.0, "{dt} s for one case");
    }
}

#[test]
fn the_mutator_finds_the_numbers() {
    let nums = numbers("a = 1.5 # 3\nb = [-2, 3e-4]\nname = \"x1\"\n");
    assert_eq!(nums.len(), 3, "{nums:?}");
    let t = apply("k = [1.0, 2.0]\n", &Mutation::Lengthen(0));
    assert_eq!(t, "k = [1.0, 2.0, 1.0]\n");
}

#[test]
fn the_unmutated_spatial_presets_reach_the_run() {
    // The spatial fuzz cases start from texts that run: a mutation, not the base, is what fails.
    for e in scenario::embedded(Kind::Spatial) {
        let src = scenario::embedded_source(e);
        let o = scenario::Overrides {
            duration: Some(0.05),
            controller: Some(scenario::ControllerKind::Pd),
            ..Default::default()
        };
        let Ok((_, Scenario::Spatial(sc))) = scenario::load_source(src.clone(), &o) else {
            panic!("{} is spatial", e.name)
        };
        let p = spatial::prepare(sc, &src).unwrap();
        let f = spatial::execute(p, |_| {}).unwrap();
        assert!(
            f.outcome.fault.is_none() && f.outcome.log.len() == 5,
            "{}",
            e.name
        );
        check_spatial(e.text).unwrap();
    }
}

/// A mutation chain can empty the text (a truncation to 0 bytes); the line mutations after it
/// leave the empty text as it is (proptest found `Delete` panicking on it in CI).
#[test]
fn line_mutations_of_an_empty_text_leave_it_empty() {
    for m in [
        Mutation::Delete(3),
        Mutation::Duplicate(5),
        Mutation::Swap(1, 7),
        Mutation::Lengthen(2),
        Mutation::Truncate(0.5),
    ] {
        assert_eq!(apply("", &m), "");
    }
    assert_eq!(apply("a\nb\n", &Mutation::Delete(1)), "a\n");
}
