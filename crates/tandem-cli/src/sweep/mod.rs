//! Parameter sweeps: a sweep file (TOML) names a base scenario, fixed overrides and the varied
//! fields; [`Sweep::load`] resolves and checks it, [`run::run_all`] runs a shard of it across cores,
//! [`merge::merge`] joins shard folders. See `docs/sweeps.md`.
//!
//! Every run is the base scenario's TOML document with the run's values set at their field paths
//! ([`fields::set`]), parsed by the normal scenario loader: validation and its messages are the
//! scenario's own. The base may be planar or spatial ([`Kind`]): a spatial base's runs go
//! through the spatial loader ([`crate::run::spatial::prepare`], [`crate::run::spatial::execute`]) and
//! their table has the spatial metrics ([`run::SPATIAL_METRICS`]).

pub mod fields;
pub mod figures;
pub mod merge;
pub mod run;

use std::ops::Range;
use std::path::{Path, PathBuf};

use serde_json::{Value as Json, json};
use tandem::math::random::splitmix64;
use toml::{Table, Value};

use crate::scenario::{self, Kind, Scenario, ScenarioError, Source};
use crate::suggest;

/// Largest number of runs a sweep may have.
pub const MAX_RUNS: u64 = 10_000_000;

/// How one field varies.
#[derive(Clone, Debug, PartialEq)]
pub enum Dist {
    /// Every value in turn (grid × grid × … products).
    Grid(Vec<Value>),
    /// Uniform on `[lo, hi]`.
    Uniform(f64, f64),
    /// Gaussian with mean and standard deviation.
    Normal(f64, f64),
    /// `exp` of a uniform on `[ln lo, ln hi]`.
    LogUniform(f64, f64),
    /// One of the values, each with the same probability.
    Choice(Vec<Value>),
}

impl Dist {
    fn is_random(&self) -> bool {
        !matches!(self, Dist::Grid(_))
    }
    fn name(&self) -> &'static str {
        match self {
            Dist::Grid(_) => "grid",
            Dist::Uniform(..) => "uniform",
            Dist::Normal(..) => "normal",
            Dist::LogUniform(..) => "log_uniform",
            Dist::Choice(_) => "choice",
        }
    }
    fn to_json(&self) -> Json {
        let list = |v: &[Value]| Json::Array(v.iter().map(toml_to_json).collect());
        match self {
            Dist::Grid(v) => json!({ "grid": list(v) }),
            Dist::Uniform(a, b) => json!({ "uniform": [a, b] }),
            Dist::Normal(a, b) => json!({ "normal": [a, b] }),
            Dist::LogUniform(a, b) => json!({ "log_uniform": [a, b] }),
            Dist::Choice(v) => json!({ "choice": list(v) }),
        }
    }
}

/// One varied field.
#[derive(Clone, Debug)]
pub struct Param {
    /// The scenario field path (`controller.nn.k1`).
    pub path: String,
    /// Its values.
    pub dist: Dist,
}

/// A resolved, checked sweep.
#[derive(Clone, Debug)]
pub struct Sweep {
    /// How messages name the sweep file.
    pub display: String,
    /// The base scenario's source (its text is the original file's).
    pub base: Source,
    /// The base scenario's document with the sweep's fixed overrides applied.
    pub doc: Table,
    /// The varied fields, in alphabetical order of their paths.
    pub params: Vec<Param>,
    /// Random draws per grid point (1 when nothing is random).
    pub draws: u64,
    /// The sweep seed.
    pub seed: u64,
    /// Total number of runs.
    pub total: u64,
    /// The base as the sweep file names it.
    pub base_name: String,
    /// Planar or spatial (from the base).
    pub kind: Kind,
}

/// The value of one run's varied field.
pub type RunValues = Vec<Value>;

fn toml_to_json(v: &Value) -> Json {
    serde_json::to_value(v).unwrap_or(Json::Null)
}

/// A value for a table cell: numbers in shortest round-trip form, strings bare, arrays as
/// `[a, b, c]`.
pub fn cell(v: &Value) -> String {
    match v {
        Value::Float(x) => fmt_f64(*x),
        Value::Integer(i) => i.to_string(),
        Value::String(s) => s.clone(),
        Value::Boolean(b) => b.to_string(),
        Value::Array(a) => format!("[{}]", a.iter().map(cell).collect::<Vec<_>>().join(", ")),
        other => other.to_string().trim().to_string(),
    }
}

/// Shortest round-trip form of a float (`0.1`, `1e-7`, `12`).
pub fn fmt_f64(x: f64) -> String {
    if !x.is_finite() {
        return String::new();
    }
    let a = x.abs();
    if a != 0.0 && !(1e-5..1e16).contains(&a) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// The `(line L, column C)` suffix and span of the value at `keys` in a TOML text.
fn span_of_keys(text: &str, keys: &[&str]) -> Option<Range<usize>> {
    use toml::de::DeTable;
    let root = DeTable::parse(text).ok()?;
    let mut table = root.get_ref();
    let mut span = None;
    for (i, key) in keys.iter().enumerate() {
        let (_, v) = table.iter().find(|(k, _)| k.get_ref().as_ref() == *key)?;
        span = Some(v.span());
        if i + 1 < keys.len() {
            table = v.get_ref().as_table()?;
        }
    }
    span
}

/// Remove `(line L, column C)` place notes of a generated document from a loader message.
fn strip_places(msg: &str) -> String {
    let mut out = String::new();
    let mut rest = msg;
    while let Some(i) = rest.find(" (line ") {
        out.push_str(&rest[..i]);
        let tail = &rest[i + 1..];
        match tail.find(')') {
            Some(j) => rest = &tail[j + 1..],
            None => {
                rest = "";
            }
        }
    }
    out.push_str(rest);
    out.replace(" (not set in the file: a default or preset value)", "")
}

/// The first line of a scenario error's message (no excerpt of the generated document), its
/// places removed.
pub fn loader_message(e: &ScenarioError) -> String {
    strip_places(e.message.lines().next().unwrap_or(""))
}

struct Ctx<'a> {
    display: &'a str,
    text: &'a str,
}

impl Ctx<'_> {
    /// An error at the sweep field `keys` (e.g. `["vary", "object.mass"]`).
    fn err(&self, keys: &[&str], message: impl Into<String>) -> ScenarioError {
        let span = span_of_keys(self.text, keys);
        let name = keys
            .iter()
            .map(|k| {
                if k.contains('.') || k.contains('[') {
                    format!("\"{k}\"")
                } else {
                    k.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join(".");
        let place = span
            .as_ref()
            .map(|s| {
                let (l, c) = scenario::line_col(self.text, s.start);
                format!(" (line {l}, column {c})")
            })
            .unwrap_or_default();
        ScenarioError {
            file: self.display.to_string(),
            message: format!("{name}: {}{place}", message.into()),
            span,
            text: self.text.to_string(),
        }
    }
}

fn num_pair(v: &Value) -> Option<(f64, f64)> {
    let a = v.as_array()?;
    if a.len() != 2 {
        return None;
    }
    let f = |x: &Value| match x {
        Value::Float(f) => Some(*f),
        Value::Integer(i) => Some(*i as f64),
        _ => None,
    };
    Some((f(&a[0])?, f(&a[1])?))
}

const TOP_KEYS: [&str; 6] = ["base", "runs", "seed", "duration", "set", "vary"];
const DISTS: [&str; 5] = ["grid", "uniform", "normal", "log_uniform", "choice"];

/// Parse the text of a scenario document (the base with values set) through the loader.
pub fn load_doc(doc: &Table, base: &Source, label: &str) -> Result<Scenario, String> {
    let text = toml::to_string(doc).map_err(|e| e.to_string())?;
    let src = Source {
        name: base.name.clone(),
        display: label.to_string(),
        text,
        dir: base.dir.clone(),
        file: None,
    };
    scenario::parse(&src).map_err(|e| loader_message(&e))
}

/// The source of a run's document: the base's name and folder, the document's text.
pub fn doc_source(doc: &Table, base: &Source, label: &str) -> Result<Source, String> {
    Ok(Source {
        name: base.name.clone(),
        display: label.to_string(),
        text: toml::to_string(doc).map_err(|e| e.to_string())?,
        dir: base.dir.clone(),
        file: None,
    })
}

/// Parse a scenario document and run every validation of a run (nothing is simulated); the
/// loader is the document's kind's ([`scenario::parse`]).
pub fn check_doc(doc: &Table, base: &Source, label: &str) -> Result<(), String> {
    let src = doc_source(doc, base, label)?;
    match load_doc(doc, base, label)? {
        Scenario::Planar(sc) => crate::run::planar::prepare(sc, &src)
            .map(|_| ())
            .map_err(|e| loader_message(&e)),
        Scenario::Spatial(sc) => crate::run::spatial::prepare(sc, &src)
            .map(|_| ())
            .map_err(|e| loader_message(&e)),
    }
}

/// Every field path of a scenario document, for "did you mean" suggestions: the document's own,
/// those of its base scenario's resolved form (every default written out), the NN gain overrides
/// and the derived fields ([`fields::DERIVED`]); for a spatial base, the document's own and
/// those of its resolved form.
pub fn known_paths(doc: &Table, base: &Source) -> Vec<String> {
    let mut known = fields::all_paths(doc);
    let sc = match scenario::parse(base) {
        Ok(Scenario::Spatial(sc)) => {
            if let Ok(toml::Value::Table(t)) = toml::Value::try_from(sc) {
                known.extend(fields::all_paths(&t));
            }
            known.sort();
            known.dedup();
            return known;
        }
        Ok(Scenario::Planar(sc)) => Some(sc),
        Err(_) => None,
    };
    if let Some(sc) = sc
        && let Ok(toml::Value::Table(t)) = toml::Value::try_from(sc.resolved())
    {
        known.extend(fields::all_paths(&t));
    }
    for k in [
        "k1",
        "k2",
        "k_r",
        "theta",
        "sigma",
        "varpi",
        "fu_safety",
        "width2",
        "levels",
        "d1",
        "d2",
        "omega",
    ] {
        known.push(format!("controller.nn.{k}"));
    }
    known.extend(fields::DERIVED.iter().map(|(p, _)| p.to_string()));
    known.sort();
    known.dedup();
    known
}

/// Set `v` at the field `path` of a copy of `doc` and run every validation of a run on the result
/// (nothing is simulated); the new document, or why not: a malformed path, `` `path` is not a
/// field of the scenario (...) — did you mean "..."? `` (suggested from `known`, see
/// [`known_paths`]) or `the scenario rejects path = v: why`. The sweep file's `[set]` and `[vary]`
/// and the Python package's `Scenario.with_` check values with it.
pub fn check_field(
    doc: &Table,
    base: &Source,
    display: &str,
    path: &str,
    v: &Value,
    known: &[String],
) -> Result<Table, String> {
    // A scenario's field paths are short; a huge one is refused before it is parsed or
    // compared with every known path (which takes minutes for a 10 MB key).
    const MAX_PATH_CHARS: usize = 256;
    if path.chars().count() > MAX_PATH_CHARS {
        return Err(format!(
            "`{}` is not a field of the scenario (a field path has at most {MAX_PATH_CHARS} characters)",
            scenario::echo(path)
        ));
    }
    let mut d = doc.clone();
    fields::set(&mut d, path, v.clone())?;
    check_doc(&d, base, display).map_err(|e| {
        let m = if e.contains("unknown field") {
            let mut m = format!("`{path}` is not a field of the scenario ({e})");
            if let Some(s) = suggest::closest(path, known.iter().map(String::as_str)) {
                m.push_str(&format!(" — did you mean \"{s}\"?"));
            }
            m
        } else {
            format!(
                "the scenario rejects {path} = {}: {e}",
                scenario::echo(&cell(v))
            )
        };
        m.replace("  ", " ")
    })?;
    Ok(d)
}

/// `n` runs in words: the exact count, and its power of ten when large (`1000000000 (10^9)`).
fn count_text(n: u128) -> String {
    if n >= 100_000 {
        let e = n.ilog10();
        if 10u128.pow(e) == n {
            format!("{n} (10^{e})")
        } else {
            format!("{n} (about 10^{e})")
        }
    } else {
        n.to_string()
    }
}

/// Why a sweep file's run count is refused, from its `[vary]` and `runs` alone (the grid
/// product times the random draws, overflow detected): `None` when it is at most
/// [`MAX_RUNS`], or when the file is malformed (the full check reports that).
fn count_refusal(top: &Table) -> Option<String> {
    let vary = top.get("vary")?.as_table()?;
    let mut grids: Vec<u64> = Vec::new();
    let mut random = false;
    for spec in vary.values() {
        let Some((kind, arg)) = spec
            .as_table()
            .filter(|t| t.len() == 1)
            .and_then(|t| t.iter().next())
        else {
            continue;
        };
        match (kind.as_str(), arg) {
            ("grid", Value::Array(a)) => grids.push(a.len() as u64),
            ("grid", _) => {}
            _ => random = true,
        }
    }
    let draws = match top.get("runs") {
        Some(Value::Integer(i)) if random && *i >= 1 => *i as u64,
        _ => 1,
    };
    let factors: Vec<u64> = grids
        .iter()
        .copied()
        .chain((draws > 1).then_some(draws))
        .collect();
    let exact = factors
        .iter()
        .try_fold(1u128, |a, &n| a.checked_mul(u128::from(n)));
    if exact.is_some_and(|n| n <= u128::from(MAX_RUNS)) {
        return None;
    }
    let count = match exact {
        Some(n) => count_text(n),
        None => format!(
            "about 10^{:.0}",
            factors.iter().map(|&n| (n as f64).log10()).sum::<f64>()
        ),
    };
    let product = factors
        .iter()
        .map(u64::to_string)
        .collect::<Vec<_>>()
        .join(" × ");
    Some(format!(
        "{count} runs ({product}{}): at most {MAX_RUNS} are supported (nothing was set up or run)",
        if draws > 1 {
            ", grid points × random draws"
        } else {
            ""
        }
    ))
}

impl Sweep {
    /// Read, resolve and check a sweep file.
    pub fn load(path: &Path) -> Result<Sweep, ScenarioError> {
        let display = path.display().to_string();
        let text = scenario::read_limited(path, scenario::MAX_SCENARIO_BYTES).map_err(|e| {
            ScenarioError {
                file: display.clone(),
                message: format!("cannot read the sweep file: {e}"),
                span: None,
                text: String::new(),
            }
        })?;
        let dir = path
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("."));
        Sweep::from_text(&display, &text, &dir)
    }

    /// Resolve and check a sweep file's text; `dir` is the folder a base file is relative to.
    pub fn from_text(display: &str, text: &str, dir: &Path) -> Result<Sweep, ScenarioError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let cx = Ctx { display, text };
        let top: Table = toml::from_str(text).map_err(|e| {
            let span = e.span();
            let place = span
                .as_ref()
                .map(|s| {
                    let (l, c) = scenario::line_col(text, s.start);
                    format!(" (line {l}, column {c})")
                })
                .unwrap_or_default();
            ScenarioError {
                file: display.to_string(),
                message: format!("TOML syntax error: {}{place}", e.message().trim_end()),
                span,
                text: text.to_string(),
            }
        })?;
        for k in top.keys() {
            if !TOP_KEYS.contains(&k.as_str()) {
                let mut m = format!("unknown sweep field `{k}`");
                match suggest::closest(k, TOP_KEYS) {
                    Some(s) => m.push_str(&format!(" — did you mean `{s}`?")),
                    None => m.push_str(&format!(
                        "; a sweep file has {}",
                        TOP_KEYS.map(|k| format!("`{k}`")).join(", ")
                    )),
                }
                if k.contains('.') || top.get(k).is_some_and(|v| !v.is_table()) {
                    m.push_str(" (scenario fields go under [set] or [vary])");
                }
                return Err(cx.err(&[k], m));
            }
        }
        // The run count first, before any set-up (the base is read, every value checked):
        // a grid of 10^9 runs is refused at once, with its true count.
        if let Some(m) = count_refusal(&top) {
            return Err(cx.err(&["vary"], m));
        }
        // The base scenario.
        let base_name = match top.get("base") {
            Some(Value::String(s)) => s.clone(),
            Some(_) => {
                return Err(cx.err(
                    &["base"],
                    "must be a preset name or a scenario file (a string)",
                ));
            }
            None => {
                return Err(cx.err(
                    &[],
                    "missing field `base` (a preset name such as \"paper\", or a scenario file \
                     relative to the sweep file)",
                ));
            }
        };
        let rel = dir.join(&base_name);
        let arg = if Path::new(&base_name).is_absolute() || !rel.is_file() {
            base_name.clone()
        } else {
            rel.display().to_string()
        };
        let base = scenario::resolve(Some(&arg)).map_err(|e| cx.err(&["base"], e.to_string()))?;
        // The base must itself be valid; its kind decides the metric columns.
        let kind = scenario::parse(&base).map(|sc| sc.kind()).map_err(|e| {
            cx.err(
                &["base"],
                format!("the base scenario is invalid: {}", e.to_string().trim()),
            )
        })?;
        let mut doc: Table = toml::from_str(&base.text).map_err(|e| {
            cx.err(
                &["base"],
                format!("the base scenario is invalid: {}", e.message()),
            )
        })?;
        let seed = match top.get("seed") {
            None => 0,
            Some(Value::Integer(i)) if *i >= 0 => *i as u64,
            Some(_) => return Err(cx.err(&["seed"], "must be a non-negative integer")),
        };
        let runs = match top.get("runs") {
            None => None,
            Some(Value::Integer(i)) if *i >= 1 && (*i as u64) <= MAX_RUNS => Some(*i as u64),
            Some(_) => {
                return Err(cx.err(
                    &["runs"],
                    format!("must be an integer from 1 to {MAX_RUNS}"),
                ));
            }
        };
        let known = known_paths(&doc, &base);
        let check =
            |doc: &Table, keys: &[&str], path: &str, v: &Value| -> Result<(), ScenarioError> {
                check_field(doc, &base, display, path, v, &known)
                    .map(|_| ())
                    .map_err(|m| cx.err(keys, m))
            };
        // Fixed overrides.
        if let Some(set) = top.get("set") {
            let Some(t) = set.as_table() else {
                return Err(cx.err(&["set"], "must be a table of field path = value"));
            };
            for (path, v) in t {
                check(&doc, &["set", path], path, v)?;
                fields::set(&mut doc, path, v.clone()).map_err(|e| cx.err(&["set", path], e))?;
            }
        }
        // The duration after the fixed overrides, which may be what makes the base runnable
        // (a shorter plant step for stiffer grasps): checked with them, blamed on itself.
        if let Some(d) = top.get("duration") {
            let ok = match d {
                Value::Float(x) => x.is_finite() && *x > 0.0,
                Value::Integer(i) => *i > 0,
                _ => false,
            };
            if !ok {
                return Err(cx.err(&["duration"], "must be a positive number of seconds"));
            }
            fields::set(&mut doc, "run.duration", d.clone())
                .map_err(|e| cx.err(&["duration"], e))?;
            check_doc(&doc, &base, display).map_err(|e| cx.err(&["duration"], e))?;
        }
        // Varied fields.
        let mut params = Vec::new();
        if let Some(vary) = top.get("vary") {
            let Some(t) = vary.as_table() else {
                return Err(cx.err(
                    &["vary"],
                    "must be a table of field path = { grid = [...] }",
                ));
            };
            for (path, spec) in t {
                let keys = ["vary", path.as_str()];
                let Some(st) = spec.as_table().filter(|s| s.len() == 1) else {
                    return Err(cx.err(
                        &keys,
                        "must be an inline table with one of grid, uniform, normal, log_uniform, \
                         choice, e.g. { uniform = [0.8, 1.2] }",
                    ));
                };
                let (kind, arg) = st.iter().next().expect("one entry");
                let bad = |m: String| cx.err(&keys, m);
                let pair = |what: &str| {
                    num_pair(arg).ok_or_else(|| bad(format!("{kind} takes two numbers [{what}]")))
                };
                let dist = match kind.as_str() {
                    "grid" | "choice" => {
                        let Some(list) = arg.as_array() else {
                            return Err(bad(format!("{kind} takes a list of values")));
                        };
                        if list.is_empty() {
                            return Err(bad(format!("{kind} is empty: give at least one value")));
                        }
                        for v in list {
                            check(&doc, &keys, path, v)?;
                        }
                        if kind == "grid" {
                            Dist::Grid(list.clone())
                        } else {
                            Dist::Choice(list.clone())
                        }
                    }
                    "uniform" => {
                        let (lo, hi) = pair("lo, hi")?;
                        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                            return Err(bad(format!(
                                "uniform = [{}, {}]: needs finite lo ≤ hi",
                                fmt_f64(lo),
                                fmt_f64(hi)
                            )));
                        }
                        check(&doc, &keys, path, &Value::Float(lo))?;
                        check(&doc, &keys, path, &Value::Float(hi))?;
                        Dist::Uniform(lo, hi)
                    }
                    "normal" => {
                        let (mu, sd) = pair("mean, std_dev")?;
                        if !(mu.is_finite() && sd.is_finite() && sd >= 0.0) {
                            return Err(bad(format!(
                                "normal = [{}, {}]: needs a finite mean and a standard deviation ≥ 0",
                                fmt_f64(mu),
                                fmt_f64(sd)
                            )));
                        }
                        check(&doc, &keys, path, &Value::Float(mu))?;
                        Dist::Normal(mu, sd)
                    }
                    "log_uniform" => {
                        let (lo, hi) = pair("lo, hi")?;
                        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
                            return Err(bad(format!(
                                "log_uniform = [{}, {}]: needs 0 < lo ≤ hi",
                                fmt_f64(lo),
                                fmt_f64(hi)
                            )));
                        }
                        check(&doc, &keys, path, &Value::Float(lo))?;
                        check(&doc, &keys, path, &Value::Float(hi))?;
                        Dist::LogUniform(lo, hi)
                    }
                    other => {
                        let mut m = format!("unknown distribution `{other}`");
                        match suggest::closest(other, DISTS) {
                            Some(s) => m.push_str(&format!(" — did you mean `{s}`?")),
                            None => m.push_str(&format!(
                                "; one of {}",
                                DISTS.map(|d| format!("`{d}`")).join(", ")
                            )),
                        }
                        return Err(bad(m));
                    }
                };
                params.push(Param {
                    path: path.clone(),
                    dist,
                });
            }
        }
        let random = params.iter().any(|p| p.dist.is_random());
        let grid: u64 = params
            .iter()
            .filter_map(|p| match &p.dist {
                Dist::Grid(v) => Some(v.len() as u64),
                _ => None,
            })
            .try_fold(1u64, |a, n| a.checked_mul(n))
            .unwrap_or(u64::MAX);
        let draws = if random {
            match runs {
                Some(r) => r,
                None => {
                    return Err(cx.err(
                        &[],
                        "missing field `runs`: the number of random draws (per grid point)",
                    ));
                }
            }
        } else {
            if let Some(r) = runs
                && r != grid
            {
                return Err(cx.err(
                    &["runs"],
                    format!(
                        "runs = {r}, but with no random field the sweep runs its grid \
                             product, {grid} runs (remove `runs`, or add a random field)"
                    ),
                ));
            }
            1
        };
        let total = grid.saturating_mul(draws);
        if total > MAX_RUNS {
            return Err(cx.err(
                &["vary"],
                format!("{total} runs: at most {MAX_RUNS} are supported"),
            ));
        }
        Ok(Sweep {
            display: display.to_string(),
            base,
            doc,
            params,
            draws,
            seed,
            total,
            base_name,
            kind,
        })
    }

    /// The inputs of the sweep, for [`crate::files::check_replaceable`]: the sweep file
    /// (`file`), the base scenario file, every file the base (with `[set]`) names, and every
    /// file a `[vary]` grid or choice names (`arms[0].urdf`, `controller.replay`).
    pub fn inputs(&self, file: Option<&Path>) -> Vec<crate::files::Input> {
        use crate::files::Input;
        let mut v: Vec<Input> = file
            .map(|f| Input::new("the sweep file", f))
            .into_iter()
            .collect();
        v.extend(
            self.base
                .file
                .iter()
                .map(|f| Input::new("the sweep's base scenario", f)),
        );
        v.extend(scenario::named_files(&self.base, &self.doc, "the base's "));
        for p in &self.params {
            let last = p.path.rsplit(['.', ']']).next().unwrap_or("");
            if let (true, Dist::Grid(vals) | Dist::Choice(vals)) =
                (last == "urdf" || last == "replay", &p.dist)
            {
                for x in vals.iter().filter_map(Value::as_str) {
                    v.push(Input::new(
                        format!("vary.{}", p.path),
                        scenario::resolve_named(&self.base, x),
                    ));
                }
            }
        }
        v
    }

    /// The seed of run `index`: from (sweep seed, index) only.
    pub fn run_seed(&self, index: u64) -> u64 {
        splitmix64(splitmix64(self.seed) ^ splitmix64(index.wrapping_add(0x5eed)))
    }

    /// The varied values of run `index`. Runs are ordered grid point by grid point (the first
    /// grid field in path order slowest), each with `draws` random draws.
    pub fn values(&self, index: u64) -> RunValues {
        let mut point = index / self.draws;
        let seed = self.run_seed(index);
        let mut grid_idx = vec![0usize; self.params.len()];
        for (k, p) in self.params.iter().enumerate().rev() {
            if let Dist::Grid(v) = &p.dist {
                let n = v.len() as u64;
                grid_idx[k] = (point % n) as usize;
                point /= n;
            }
        }
        let uni = |k: usize, j: u64| -> f64 {
            let x = splitmix64(seed ^ splitmix64(((k as u64) << 8 | j) ^ 0xd1ce));
            ((x >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        self.params
            .iter()
            .enumerate()
            .map(|(k, p)| match &p.dist {
                Dist::Grid(v) => v[grid_idx[k]].clone(),
                Dist::Uniform(lo, hi) => Value::Float(lo + (hi - lo) * uni(k, 0)),
                Dist::Normal(mu, sd) => {
                    let (u1, u2) = (uni(k, 0), uni(k, 1));
                    let n = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                    Value::Float(mu + sd * n)
                }
                Dist::LogUniform(lo, hi) => {
                    Value::Float((lo.ln() + (hi.ln() - lo.ln()) * uni(k, 0)).exp())
                }
                Dist::Choice(v) => {
                    let i = ((uni(k, 0) * v.len() as f64) as usize).min(v.len() - 1);
                    v[i].clone()
                }
            })
            .collect()
    }

    /// The scenario document of run `index` (values set, `run.seed` the run's seed).
    pub fn run_doc(&self, index: u64, values: &RunValues) -> Result<Table, String> {
        let mut d = self.doc.clone();
        for (p, v) in self.params.iter().zip(values) {
            fields::set(&mut d, &p.path, v.clone())?;
        }
        let seed = self.run_seed(index);
        // TOML integers are signed 64-bit: the seed is kept below 2^63.
        fields::set(&mut d, "run.seed", Value::Integer((seed >> 1) as i64))?;
        Ok(d)
    }

    /// The seed written into run `index`'s scenario (`run.seed`).
    pub fn scenario_seed(&self, index: u64) -> u64 {
        self.run_seed(index) >> 1
    }

    /// The resolved sweep (everything that determines the runs) as JSON.
    pub fn resolved_json(&self) -> Json {
        let base_text = toml::to_string(&self.doc).unwrap_or_default();
        json!({
            "tandem_version": env!("CARGO_PKG_VERSION"),
            "base": self.base_name,
            "seed": self.seed,
            "draws_per_grid_point": self.draws,
            "runs": self.total,
            "vary": Json::Array(self.params.iter().map(|p| json!({
                "path": p.path,
                "kind": p.dist.name(),
                "values": p.dist.to_json(),
            })).collect()),
            "base_scenario_hash": format!("{:016x}", fnv1a(base_text.as_bytes())),
            "base_scenario": base_text,
        })
    }

    /// A hash of [`Sweep::resolved_json`]: shards of one sweep share it.
    pub fn hash(&self) -> String {
        format!(
            "{:016x}",
            fnv1a(self.resolved_json().to_string().as_bytes())
        )
    }
}

/// FNV-1a, 64 bit.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// A shard: this process runs the runs with `index % count == index_of_shard`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// `I` of `I/N`.
    pub index: u64,
    /// `N` of `I/N`.
    pub count: u64,
}

impl Shard {
    /// Parse `I/N` (`0 ≤ I < N`).
    pub fn parse(s: &str, what: &str) -> Result<Shard, crate::BadInput> {
        let bad = |why: &str| crate::BadInput::msg(format!("{what} {s}: {why}"));
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| bad("expected I/N, e.g. 0/4 (shard I of N, from 0)"))?;
        let i: u64 = i
            .trim()
            .parse()
            .map_err(|_| bad("I must be a whole number from 0 to N − 1 (shard I of N, from 0)"))?;
        let n: u64 = n
            .trim()
            .parse()
            .map_err(|_| bad("N must be a whole number, at least 1 (the number of shards)"))?;
        Shard::new(i, n).map_err(|w| bad(&w))
    }

    /// A checked shard.
    pub fn new(index: u64, count: u64) -> Result<Shard, String> {
        if count == 0 {
            return Err("N must be at least 1".into());
        }
        if count > MAX_RUNS {
            return Err(format!(
                "N = {count}: at most {MAX_RUNS} shards (a sweep has at most {MAX_RUNS} runs)"
            ));
        }
        if index >= count {
            return Err(format!(
                "shard {index} of {count} does not exist: I counts from 0 to {}",
                count - 1
            ));
        }
        Ok(Shard { index, count })
    }

    /// From `SLURM_ARRAY_TASK_ID` / `SLURM_ARRAY_TASK_COUNT` (and `SLURM_ARRAY_TASK_MIN`, when
    /// the array does not start at 0).
    pub fn from_env() -> Result<Option<Shard>, crate::BadInput> {
        let get = |k: &str| std::env::var(k).ok().filter(|v| !v.trim().is_empty());
        let (Some(id), Some(count)) = (get("SLURM_ARRAY_TASK_ID"), get("SLURM_ARRAY_TASK_COUNT"))
        else {
            return Ok(None);
        };
        let min = get("SLURM_ARRAY_TASK_MIN").unwrap_or_else(|| "0".into());
        let p = |k: &str, v: &str| {
            v.trim()
                .parse::<u64>()
                .map_err(|_| crate::BadInput::msg(format!("{k}={v}: not a whole number")))
        };
        let (id, count, min) = (
            p("SLURM_ARRAY_TASK_ID", &id)?,
            p("SLURM_ARRAY_TASK_COUNT", &count)?,
            p("SLURM_ARRAY_TASK_MIN", &min)?,
        );
        let i = id.checked_sub(min).ok_or_else(|| {
            crate::BadInput::msg(format!(
                "SLURM_ARRAY_TASK_ID={id} is below SLURM_ARRAY_TASK_MIN={min}"
            ))
        })?;
        Shard::new(i, count).map(Some).map_err(|w| {
            crate::BadInput::msg(format!("SLURM array task {id} (count {count}): {w}"))
        })
    }

    /// Whether run `index` belongs to this shard.
    pub fn has(&self, index: u64) -> bool {
        index % self.count == self.index
    }
}
