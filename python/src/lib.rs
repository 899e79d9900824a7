//! `tandem._tandem`: the native part of the `tandem` Python package.
//!
//! Everything here binds the `tandem_cli` library, the code the `tandem` command line runs: a
//! scenario is parsed, overridden (by field path, as in sweeps), validated, run and written by the
//! same functions, so it means the same thing and gets the same error messages in Python as on
//! the command line. Simulations run with the GIL released; `rollout` runs a batch on a rayon
//! pool, as `tandem sweep` does.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use numpy::{IntoPyArray, PyArray1, PyArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::{PyFileExistsError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use rayon::prelude::*;
use serde_json::Value as Json;
use toml::{Table, Value};

use tandem_cli::BadInput;
use tandem_cli::files::{self as output, OutputDir};
use tandem_cli::output::planar::{self as planar_output, Outputs};
use tandem_cli::output::spatial as spatial_output;
use tandem_cli::run::planar::{self as runner, Finished};
use tandem_cli::run::spatial;
use tandem_cli::scenario::{
    self, Overrides, PlanarScenario, Scenario, ScenarioError as CliScenarioError, Source,
    SpatialScenario,
};
use tandem_cli::sweep;

create_exception!(
    tandem,
    ScenarioError,
    PyValueError,
    "Bad input: a scenario, a field override, a sweep, an argument. The message is the command \
line's; `path` is the scenario field it concerns (or None), `file` how the input is named."
);
create_exception!(
    tandem,
    PlantFault,
    PyRuntimeError,
    "The plant failed numerically (non-finite state, grasp drift, a singular arm): the message \
says what, when, and the last good state; `t` is the time (s). `Plant.step` raises it; the \
plant then refuses to step (make a new one with `Scenario.plant()`)."
);
create_exception!(
    tandem,
    ScenarioWarning,
    pyo3::exceptions::PyUserWarning,
    "A set-up warning of a scenario (the command line prints the same text)."
);

// ---------------------------------------------------------------------------------------------
// Errors.

/// An error on the way to Python.
enum Error {
    /// A scenario or sweep error of the library (message with file, line, excerpt).
    Scenario(CliScenarioError),
    /// Bad input with a known field path.
    Field {
        path: Option<String>,
        message: String,
    },
    /// A failure that is not the input's fault (I/O, a re-run that differs).
    Other(String),
}

impl From<CliScenarioError> for Error {
    fn from(e: CliScenarioError) -> Self {
        Error::Scenario(e)
    }
}

impl From<BadInput> for Error {
    fn from(e: BadInput) -> Self {
        Error::Field {
            path: None,
            message: e.to_string(),
        }
    }
}

fn bad(path: Option<&str>, message: impl Into<String>) -> Error {
    Error::Field {
        path: path.map(str::to_string),
        message: message.into(),
    }
}

/// The scenario field a library error concerns: the field whose value (or key) the error's span
/// falls in, or else a field path the message starts with (`controller.nn.k1[0] = -1: ...`).
fn error_path(e: &CliScenarioError) -> Option<String> {
    if let Some(span) = &e.span {
        if let Some(p) = field_path_at(&e.text, span.start) {
            return Some(p);
        }
    }
    leading_path(&e.message)
}

/// `a.b[1].c` at the start of a message, followed by ` = ` or `:`.
fn leading_path(msg: &str) -> Option<String> {
    let end = msg.find([' ', ':'])?;
    let head = &msg[..end];
    let rest = &msg[end..];
    let path_like = !head.is_empty()
        && head.contains(['.', '['])
        && head
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_.[]".contains(c))
        && head.starts_with(|c: char| c.is_ascii_alphabetic());
    (path_like && (rest.starts_with(" = ") || rest.starts_with(':'))).then(|| head.to_string())
}

/// The field path (`controller.nn.k1[0]`) of the innermost key or value at byte `offset` of a
/// TOML text.
fn field_path_at(text: &str, offset: usize) -> Option<String> {
    use toml::de::{DeTable, DeValue};
    fn join(path: &str, key: &str) -> String {
        if path.is_empty() {
            key.to_string()
        } else {
            format!("{path}.{key}")
        }
    }
    /// Depth first: the deepest entry whose key or value span holds `offset` (an array of
    /// tables' span may not cover its tables' bodies, so every child is searched).
    fn search(v: &DeValue, offset: usize, path: &str) -> Option<String> {
        if let Some(t) = v.as_table() {
            for (k, x) in t.iter() {
                let p = join(path, k.get_ref().as_ref());
                if let Some(found) = search(x.get_ref(), offset, &p) {
                    return Some(found);
                }
                if k.span().contains(&offset) || x.span().contains(&offset) {
                    return Some(p);
                }
            }
        } else if let Some(a) = v.as_array() {
            for (i, x) in a.iter().enumerate() {
                let p = format!("{path}[{i}]");
                if let Some(found) = search(x.get_ref(), offset, &p) {
                    return Some(found);
                }
                if x.span().contains(&offset) {
                    return Some(p);
                }
            }
        }
        None
    }
    let root = DeTable::parse(text).ok()?;
    let top = root.get_ref();
    for (k, x) in top.iter() {
        let p = k.get_ref().to_string();
        if let Some(found) = search(x.get_ref(), offset, &p) {
            return Some(found);
        }
        if k.span().contains(&offset) || x.span().contains(&offset) {
            return Some(p);
        }
    }
    None
}

/// `msg` with every line longer than 400 characters cut in the middle (a message that echoes a
/// huge value keeps its start and end): no error message is megabytes long.
fn bounded(msg: String) -> String {
    if msg.lines().all(|l| l.len() <= 400) {
        return msg;
    }
    msg.lines()
        .map(|l| {
            if l.chars().count() > 400 {
                scenario::clip_middle(l, 300, 80)
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

impl Error {
    fn into_py(self, py: Python<'_>) -> PyErr {
        let (message, path, file) = match self {
            Error::Scenario(e) => {
                let path = error_path(&e);
                (bounded(e.to_string()), path, Some(e.file.clone()))
            }
            Error::Field { path, message } => (
                bounded(message),
                path.map(|p| scenario::clip_middle(&p, 150, 50)),
                None,
            ),
            Error::Other(m) => return PyRuntimeError::new_err(bounded(m)),
        };
        let err = ScenarioError::new_err(message.clone());
        let v = err.value(py);
        // Attribute errors on a fresh exception object cannot happen; ignore them rather than
        // replace the user's error with an internal one.
        let _ = v.setattr("message", message);
        let _ = v.setattr("path", path);
        let _ = v.setattr("file", file);
        err
    }
}

type Res<T> = Result<T, Error>;

fn py_res<T>(py: Python<'_>, r: Res<T>) -> PyResult<T> {
    r.map_err(|e| e.into_py(py))
}

// ---------------------------------------------------------------------------------------------
// Python values to TOML.

/// Deepest nesting of a value given to `with_` or `sweep` (a scenario's deepest field is a
/// handful of levels down): deeper is a recursive list or dict, or an object whose `tolist()`
/// returns itself, and is refused instead of overflowing the stack.
const MAX_VALUE_DEPTH: usize = 32;

/// A Python value for a scenario field: bool, int, float, str, list/tuple/NumPy array, dict.
/// `path` names it (the `with_` key); nested at most [`MAX_VALUE_DEPTH`] levels.
fn to_toml(v: &Bound<'_, PyAny>, path: &str) -> PyResult<Value> {
    to_toml_at(v, path, path, 0)
}

/// [`to_toml`] of the part `at` of the value given for `key`, `depth` levels down.
fn to_toml_at(v: &Bound<'_, PyAny>, key: &str, at: &str, depth: usize) -> PyResult<Value> {
    if depth > MAX_VALUE_DEPTH {
        return Err(bad(
            Some(key),
            format!(
                "{key}: the value is nested more than {MAX_VALUE_DEPTH} levels deep (at {}): a                  recursive list or dict, or an object whose tolist() returns itself?",
                scenario::clip_middle(at, 60, 60)
            ),
        )
        .into_py(v.py()));
    }
    if v.is_instance_of::<PyBool>() {
        return Ok(Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return v.extract::<i64>().map(Value::Integer).map_err(|_| {
            PyValueError::new_err(format!(
                "{at}: {} does not fit a TOML integer (64-bit signed)",
                scenario::echo(&v.repr().map(|r| r.to_string()).unwrap_or_default())
            ))
        });
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(Value::Float(v.extract()?));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(Value::String(s.to_cow()?.into_owned()));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = Table::new();
        for (k, x) in d.iter() {
            let k: String = k
                .extract()
                .map_err(|_| PyTypeError::new_err(format!("{at}: table keys must be strings")))?;
            let sub = format!("{at}.{k}");
            t.insert(k, to_toml_at(&x, key, &sub, depth + 1)?);
        }
        return Ok(Value::Table(t));
    }
    // NumPy arrays and scalars (np.float64 is a float; np.int64, np.bool_ and arrays are not).
    if v.hasattr("tolist")? && !v.is_instance_of::<PyList>() {
        return to_toml_at(&v.call_method0("tolist")?, key, at, depth + 1);
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let mut a = Vec::new();
        for (i, x) in v.try_iter()?.enumerate() {
            a.push(to_toml_at(&x?, key, &format!("{at}[{i}]"), depth + 1)?);
        }
        return Ok(Value::Array(a));
    }
    Err(PyTypeError::new_err(format!(
        "{at}: a {} cannot be a scenario value (give a bool, int, float, str, list, array or dict)",
        v.get_type().name()?
    )))
}

/// A JSON value as Python objects (`null` → None).
fn json_to_py<'py>(py: Python<'py>, v: &Json) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Json::Null => py.None().into_bound(py),
        Json::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Json::Number(n) => {
            if let Some(u) = n.as_u64() {
                u.into_pyobject(py)?.into_any()
            } else if let Some(i) = n.as_i64() {
                i.into_pyobject(py)?.into_any()
            } else {
                n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any()
            }
        }
        Json::String(s) => PyString::new(py, s).into_any(),
        Json::Array(a) => {
            let l = PyList::empty(py);
            for x in a {
                l.append(json_to_py(py, x)?)?;
            }
            l.into_any()
        }
        Json::Object(m) => {
            let d = PyDict::new(py);
            for (k, x) in m {
                d.set_item(k, json_to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

// ---------------------------------------------------------------------------------------------
// Scenarios.

/// A planar scenario: its source, its TOML document (overrides applied) and the parsed scenario.
#[derive(Clone)]
struct Planar {
    /// Name, how errors name it, the text errors point into, the folder relative paths use.
    src: Source,
    /// The document `with_` sets fields on.
    doc: Table,
    /// The parsed scenario (`doc` through the loader).
    sc: PlanarScenario,
    /// The replay file, resolved (for `to_toml`).
    replay: Option<PathBuf>,
    /// Set-up warnings (the command line prints them before a run).
    warnings: Vec<String>,
}

/// A spatial scenario (issue 9: `dual-ur5`, `dual-franka`, a file whose arms name a robot
/// model): its source, its TOML document (overrides applied) and the parsed scenario.
#[derive(Clone)]
struct Spatial {
    /// Name, how errors name it, the text errors point into, the folder relative paths use.
    src: Source,
    /// The document `with_` sets fields on.
    doc: Table,
    /// The parsed scenario as `spatial::prepare` returns it (file references absolute).
    sc: SpatialScenario,
    /// Set-up warnings (the command line prints them before a run).
    warnings: Vec<String>,
    /// The law's gains as the controller resolved them (the NN design's inertia filled in),
    /// for `get`; `None` for a replay.
    law: Option<tandem::control::law::Law<6>>,
}

/// What a scenario is: planar or spatial. The Python API (`preset`, `from_toml`, `with_`,
/// `run`, `rollout`, pickling through TOML) is the same for both.
// One value per scenario or run, behind an `Arc` or in a `Vec`: boxing a variant saves nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Clone)]
enum Kind {
    Planar(Planar),
    Spatial(Spatial),
}

/// A finished run of either kind.
// One value per scenario or run, behind an `Arc` or in a `Vec`: boxing a variant saves nothing.
#[allow(clippy::large_enum_variant)]
enum Fin {
    Planar(Finished),
    /// The spatial run and the quantities derived from its log (the summary's and the extra
    /// columns of `timeseries.csv`).
    Spatial(spatial::Finished, tandem_cli::output::spatial::Derived),
}

impl Fin {
    fn log(&self) -> &tandem::sim::Log {
        match self {
            Fin::Planar(f) => &f.outcome.log,
            Fin::Spatial(f, _) => &f.outcome.log,
        }
    }
    /// `summary.json` without write times.
    fn summary(&self, name: &str) -> Json {
        match self {
            Fin::Planar(f) => planar_output::summary_json(f, name, None),
            Fin::Spatial(f, d) => tandem_cli::output::spatial::summary(name, f, d, None),
        }
    }
    /// The columns `timeseries.csv` has after the log's: (name, unit, values). Planar: none;
    /// spatial: the true pose in the output chart `x_1.*` and the grasp wrenches in tool axes
    /// `F_tool{i}.*` (as `tandem_cli::output::spatial::write_timeseries`).
    fn derived_columns(&self) -> Vec<(String, String, &[f64])> {
        let mut out = Vec::new();
        if let Fin::Spatial(_, d) = self {
            use tandem::control::spatial::{AXES, WRENCH_AXES};
            if d.x1.len() == 6 {
                for (j, a) in AXES.iter().enumerate() {
                    let u = if j < 3 { "m" } else { "rad" };
                    out.push((format!("x_1.{a}"), u.to_string(), d.x1[j].as_slice()));
                }
            }
            for (i, w) in d.f_tool.iter().enumerate() {
                for (j, a) in WRENCH_AXES.iter().enumerate() {
                    let u = if j < 3 { "N" } else { "N m" };
                    out.push((
                        format!("F_tool{}.{a}", i + 1),
                        u.to_string(),
                        w[j].as_slice(),
                    ));
                }
            }
        }
        out
    }
}

impl Kind {
    /// The law's gains as the controller runs with them, under the law's key in
    /// `[controller]` (`nn`, `pd`, `ctc`): planar, the NN preset with the file's overrides
    /// (whatever the law: `gains` names a preset); spatial, the law's (the NN design's inertia
    /// filled in). `None` for a spatial replay.
    fn resolved_gains(&self) -> Result<Option<(String, Value)>, toml::ser::Error> {
        use tandem::control::law::Law;
        Ok(match self {
            Kind::Planar(p) => Some(("nn".into(), Value::try_from(p.sc.nn_gains())?)),
            Kind::Spatial(p) => match &p.law {
                None => None,
                Some(law @ Law::Nn(g)) => Some((law.name().into(), Value::try_from(g)?)),
                Some(law @ Law::Pd(g)) => Some((law.name().into(), Value::try_from(g)?)),
                Some(law @ Law::Ctc(g)) => Some((law.name().into(), Value::try_from(g)?)),
            },
        })
    }

    fn src(&self) -> &Source {
        match self {
            Kind::Planar(p) => &p.src,
            Kind::Spatial(p) => &p.src,
        }
    }
    fn doc(&self) -> &Table {
        match self {
            Kind::Planar(p) => &p.doc,
            Kind::Spatial(p) => &p.doc,
        }
    }
    fn warnings(&self) -> &[String] {
        match self {
            Kind::Planar(p) => &p.warnings,
            Kind::Spatial(p) => &p.warnings,
        }
    }
    fn with_run(&self, duration: Option<f64>, seed: Option<u64>) -> Res<Kind> {
        check_run_overrides(duration, seed)?;
        Ok(match self {
            Kind::Planar(p) => Kind::Planar(p.with_run(duration, seed)?),
            Kind::Spatial(p) => Kind::Spatial(p.with_run(duration, seed)?),
        })
    }
    fn to_toml(&self) -> Res<String> {
        match self {
            Kind::Planar(p) => p.to_toml(),
            Kind::Spatial(p) => spatial_output::scenario_toml(&p.sc, &p.src.name)
                .map_err(|e| Error::Other(format!("{e:#}"))),
        }
    }
    /// Prepare and simulate (no Python involved: called with the GIL released).
    fn execute(&self) -> Res<Fin> {
        check_kernel()?;
        match self {
            Kind::Planar(p) => Ok(Fin::Planar(p.execute()?)),
            Kind::Spatial(p) => p.execute(),
        }
    }
    /// Prepare and simulate with a user's law driving the loop (GIL released; the law takes
    /// it per tick).
    fn execute_external(&self, law: Box<dyn tandem::sim::ExternalLaw>) -> Res<Fin> {
        check_kernel()?;
        match self {
            Kind::Planar(p) => {
                let pr = runner::prepare_external(p.sc.clone(), &p.src, law)?;
                Ok(Fin::Planar(runner::execute(pr, |_| {})))
            }
            Kind::Spatial(p) => {
                let pr = spatial::prepare_external(p.sc.clone(), &p.src, law)?;
                spatial_fin(spatial::execute(pr, |_| {}))
            }
        }
    }
    /// Wrench channels per arm.
    fn wrench_dim(&self) -> usize {
        match self {
            Kind::Planar(_) => 2,
            Kind::Spatial(_) => 6,
        }
    }
    /// The law's label (`NN (tuned)`, `PD`; spatial `NN`, `PD + gravity`, `CTC`).
    fn label(&self) -> String {
        match self {
            Kind::Planar(p) => runner::label(&p.sc),
            Kind::Spatial(p) => spatial::label(&p.sc),
        }
    }
    fn duration(&self) -> f64 {
        match self {
            Kind::Planar(p) => p.sc.run.duration,
            Kind::Spatial(p) => p.sc.run.duration,
        }
    }
    fn seed(&self) -> u64 {
        match self {
            Kind::Planar(p) => p.sc.run.seed,
            Kind::Spatial(p) => p.sc.run.seed,
        }
    }
}

/// Parse and validate a source of either kind as the command line's `load` + `tandem validate`
/// do: the kind is decided once, by [`scenario::parse`]; a file may name itself (a resolved
/// `scenario.toml` keeps its run's name).
fn kind_from_source(mut src: Source) -> Res<Kind> {
    let sc = scenario::parse(&src)?;
    if let Some(n) = sc.name() {
        src.name = n.to_string();
    }
    match sc {
        Scenario::Planar(sc) => Ok(Kind::Planar(planar_from(src, sc)?)),
        Scenario::Spatial(sc) => Ok(Kind::Spatial(spatial_from(src, sc)?)),
    }
}

/// Validate a parsed spatial scenario as `tandem run` does before it simulates.
fn spatial_from(src: Source, sc: SpatialScenario) -> Res<Spatial> {
    let doc: Table = toml::from_str(&src.text).map_err(|e| bad(None, e.to_string()))?;
    let prepared = spatial::prepare(sc, &src)?;
    Ok(Spatial {
        law: prepared.ready.controller.as_ref().map(|c| c.law.clone()),
        warnings: prepared.ready.warnings.clone(),
        sc: prepared.sc,
        src,
        doc,
    })
}

/// `duration` and `seed` arguments: a positive duration, a seed TOML can hold.
fn check_run_overrides(duration: Option<f64>, seed: Option<u64>) -> Res<()> {
    if let Some(d) = duration {
        if !(d.is_finite() && d > 0.0) {
            return Err(bad(
                Some("run.duration"),
                format!(
                    "duration={}: must be a positive number of seconds",
                    scenario::num(d)
                ),
            ));
        }
    }
    if let Some(s) = seed {
        if s > i64::MAX as u64 {
            return Err(bad(
                Some("run.seed"),
                format!("seed={s}: at most 2^63 − 1 (a TOML integer)"),
            ));
        }
    }
    Ok(())
}

impl Spatial {
    /// The document and scenario with `run.duration` / `run.seed` overridden (as `--duration`
    /// and `--seed` do); validated when the run prepares.
    fn with_run(&self, duration: Option<f64>, seed: Option<u64>) -> Res<Spatial> {
        let mut p = self.clone();
        if let Some(d) = duration {
            p.sc.run.duration = d;
            sweep::fields::set(&mut p.doc, "run.duration", Value::Float(d))
                .map_err(|m| bad(Some("run.duration"), m))?;
        }
        if let Some(s) = seed {
            p.sc.run.seed = s;
            sweep::fields::set(&mut p.doc, "run.seed", Value::Integer(s as i64))
                .map_err(|m| bad(Some("run.seed"), m))?;
        }
        Ok(p)
    }

    /// Prepare, simulate and derive the log's kinematics (GIL released).
    fn execute(&self) -> Res<Fin> {
        let p = spatial::prepare(self.sc.clone(), &self.src)?;
        spatial_fin(spatial::execute(p, |_| {}))
    }
}

/// A bad `TANDEM_KERNEL` is bad input for every run, planar or spatial, NN or not (as the
/// command line refuses it before anything is read), not only for those that build a network.
fn check_kernel() -> Res<()> {
    tandem::control::rbf::Kernel::from_env()
        .map(|_| ())
        .map_err(|e| bad(None, format!("environment variable {e}")))
}

/// A finished spatial run with its derived quantities.
fn spatial_fin(f: anyhow::Result<spatial::Finished>) -> Res<Fin> {
    let f = f.map_err(|e| Error::Other(format!("{e:#}")))?;
    let d = tandem_cli::output::spatial::Derived::new(&f);
    Ok(Fin::Spatial(f, d))
}

/// Validate a parsed planar scenario as `tandem validate` does.
fn planar_from(src: Source, sc: PlanarScenario) -> Res<Planar> {
    let doc: Table = toml::from_str(&src.text).map_err(|e| bad(None, e.to_string()))?;
    let prepared = runner::prepare(sc.clone(), &src)?;
    Ok(Planar {
        replay: prepared.built.replay.clone(),
        warnings: prepared.ready.warnings,
        src,
        doc,
        sc,
    })
}

impl Planar {
    /// The document and scenario with `run.duration` / `run.seed` overridden (as `--duration`
    /// and `--seed` do); nothing is validated here (the run prepares).
    fn with_run(&self, duration: Option<f64>, seed: Option<u64>) -> Res<Planar> {
        check_run_overrides(duration, seed)?;
        let mut p = self.clone();
        p.sc.apply(&Overrides {
            duration,
            seed,
            ..Overrides::default()
        })?;
        if let Some(d) = duration {
            sweep::fields::set(&mut p.doc, "run.duration", Value::Float(d))
                .map_err(|m| bad(Some("run.duration"), m))?;
        }
        if let Some(s) = seed {
            sweep::fields::set(&mut p.doc, "run.seed", Value::Integer(s as i64))
                .map_err(|m| bad(Some("run.seed"), m))?;
        }
        Ok(p)
    }

    /// The resolved scenario as TOML (the run folder's `scenario.toml`).
    fn to_toml(&self) -> Res<String> {
        planar_output::scenario_toml(&self.sc, &self.src.name, self.replay.as_deref())
            .map_err(|e| Error::Other(format!("{e:#}")))
    }

    /// Prepare and simulate (no Python involved: called with the GIL released).
    fn execute(&self) -> Res<Finished> {
        let p = runner::prepare(self.sc.clone(), &self.src)?;
        Ok(runner::execute(p, |_| {}))
    }
}

fn warn_all(py: Python<'_>, warnings: &[String]) -> PyResult<()> {
    let cat = py.get_type::<ScenarioWarning>();
    for w in warnings {
        let msg = std::ffi::CString::new(w.replace('\0', " "))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        PyErr::warn(py, &cat, &msg, 1)?;
    }
    Ok(())
}

/// A scenario: what one run simulates (arms, object, path, controller, timing, seed).
///
/// Immutable: `with_` returns a new scenario. Picklable (as its resolved TOML), so it can be
/// sent to process pools, Ray and Dask workers.
#[pyclass(module = "tandem", name = "Scenario", frozen)]
struct PyScenario {
    kind: Arc<Kind>,
}

impl PyScenario {
    fn new(k: Kind) -> Self {
        PyScenario { kind: Arc::new(k) }
    }
}

/// A source from TOML text (`from_toml` and unpickling).
fn text_source(text: &str, name: Option<&str>) -> Source {
    Source {
        name: name.unwrap_or("scenario").to_string(),
        display: "scenario text".to_string(),
        text: text.strip_prefix('\u{feff}').unwrap_or(text).to_string(),
        // Relative paths in the text (a replay file) are relative to the folder the scenario
        // is made in, not to wherever it runs later.
        dir: std::env::current_dir().unwrap_or_else(|_| PathBuf::from(".")),
        file: None,
    }
}

/// The value at a field path of a TOML document.
fn get_path<'a>(doc: &'a Table, path: &str) -> Option<&'a Value> {
    let segs = sweep::fields::segments(path).ok()?;
    let mut cur: Option<&Value> = None;
    for s in segs {
        cur = match (s, cur) {
            (sweep::fields::Seg::Key(k), None) => doc.get(&k),
            (sweep::fields::Seg::Key(k), Some(Value::Table(t))) => t.get(&k),
            (sweep::fields::Seg::Index(i), Some(Value::Array(a))) => a.get(i),
            _ => None,
        };
        cur?;
    }
    cur
}

fn toml_to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    json_to_py(
        py,
        &serde_json::to_value(v).map_err(|e| PyValueError::new_err(e.to_string()))?,
    )
}

#[pymethods]
impl PyScenario {
    /// An embedded scenario by name (see `tandem.presets()`), e.g. `Scenario.preset("paper")`,
    /// `Scenario.preset("dual-ur5")` (spatial).
    #[staticmethod]
    fn preset(py: Python<'_>, name: &str) -> PyResult<Self> {
        let r = (|| -> Res<Kind> {
            if let Some(e) = scenario::EMBEDDED.iter().find(|e| e.name == name) {
                return kind_from_source(scenario::embedded_source(e));
            }
            // Not embedded: the command line's message (with its suggestion), unless a file of
            // that name exists, which `preset` does not read.
            if Path::new(name).exists() {
                let names = presets();
                return Err(bad(
                    None,
                    format!(
                        "`{name}` is not an embedded scenario (embedded scenarios: {}); load a \
                         file with Scenario.load(path)",
                        names.join(", ")
                    ),
                ));
            }
            Err(scenario::resolve(Some(name)).err().map_or_else(
                || bad(None, format!("`{name}` is not an embedded scenario")),
                Error::from,
            ))
        })();
        let p = py_res(py, r)?;
        warn_all(py, p.warnings())?;
        Ok(Self::new(p))
    }

    /// A scenario from TOML text (the format of `tandem scenario show paper`, planar or
    /// spatial: a spatial file's arms name a robot model). `name` names it (outputs, summaries)
    /// unless the text has a `name` field; relative paths in it (a replay file, a URDF) are
    /// relative to the current folder.
    #[staticmethod]
    #[pyo3(signature = (text, name=None))]
    fn from_toml(py: Python<'_>, text: &str, name: Option<&str>) -> PyResult<Self> {
        let p = py_res(py, kind_from_source(text_source(text, name)))?;
        warn_all(py, p.warnings())?;
        Ok(Self::new(p))
    }

    /// A scenario file (TOML). Its name is the file's stem unless it has a `name` field.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let r = (|| -> Res<Kind> {
            let arg = path.to_string_lossy().into_owned();
            if !path.is_file() && presets().contains(&arg.as_str()) {
                return Err(bad(
                    None,
                    format!(
                        "scenario file {arg} does not exist (for the embedded scenario use \
                         Scenario.preset(\"{arg}\"))"
                    ),
                ));
            }
            kind_from_source(scenario::resolve(Some(&arg))?)
        })();
        let p = py_res(py, r)?;
        warn_all(py, p.warnings())?;
        Ok(Self::new(p))
    }

    /// A new scenario with fields set by their paths, as in a sweep's `[set]`:
    /// `sc.with_(**{"controller.nn.k1": [8, 8, 8], "object.mass": 1.2})` or
    /// `sc.with_({"run.duration": 10})`. The values are checked together by every validation of
    /// a run, so their order does not matter; a rejected value raises ScenarioError with its
    /// `path` (the field without which the others are valid, else the first that fails in the
    /// order given).
    #[pyo3(signature = (overrides=None, /, **fields))]
    fn with_(
        &self,
        py: Python<'_>,
        overrides: Option<&Bound<'_, PyDict>>,
        fields: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let mut items: Vec<(String, Value)> = Vec::new();
        for d in [overrides, fields].into_iter().flatten() {
            for (k, v) in d.iter() {
                let k: String = k
                    .extract()
                    .map_err(|_| PyTypeError::new_err("field paths must be strings"))?;
                let v = to_toml(&v, &k)?;
                items.push((k, v));
            }
        }
        let base = self.kind.clone();
        let r = py.detach(move || -> Res<Kind> {
            let bsrc = base.src();
            let mut doc = base.doc().clone();
            let known = sweep::known_paths(&doc, bsrc);
            // The fields together first: the order of the keys does not matter (`kind =
            // "replay"` is only valid with its `replay` file, whichever comes first).
            let apply = |skip: Option<usize>| -> Option<Table> {
                let mut d = doc.clone();
                for (k, (path, v)) in items.iter().enumerate() {
                    if Some(k) != skip {
                        sweep::fields::set(&mut d, path, v.clone()).ok()?;
                    }
                }
                Some(d)
            };
            let together = apply(None).map(|d| {
                let r = sweep::check_doc(&d, bsrc, &bsrc.display);
                (d, r)
            });
            if let Some((d, Ok(()))) = together {
                doc = d;
            } else {
                // Blame the field the loader's message names (the longest such path); else the
                // one field without which the rest is valid; else the first that fails in the
                // order given.
                if let Some((_, Err(e))) = &together
                    && let Some(k) = (0..items.len())
                        .filter(|&k| e.contains(items[k].0.as_str()))
                        .max_by_key(|&k| items[k].0.len())
                {
                    // Its message as a sweep gives it: the field set on all the others.
                    let (path, v) = &items[k];
                    let rest = apply(Some(k)).unwrap_or_else(|| doc.clone());
                    let m = match sweep::check_field(&rest, bsrc, &bsrc.display, path, v, &known) {
                        Err(m) => m,
                        Ok(_) => e.clone(),
                    };
                    return Err(bad(Some(path), m));
                }
                for k in 0..items.len() {
                    if items.len() < 2 {
                        break;
                    }
                    let Some(rest) =
                        apply(Some(k)).filter(|d| sweep::check_doc(d, bsrc, &bsrc.display).is_ok())
                    else {
                        continue;
                    };
                    let (path, v) = &items[k];
                    sweep::check_field(&rest, bsrc, &bsrc.display, path, v, &known)
                        .map_err(|m| bad(Some(path), m))?;
                }
                for (path, v) in &items {
                    doc = sweep::check_field(&doc, bsrc, &bsrc.display, path, v, &known)
                        .map_err(|m| bad(Some(path), m))?;
                }
            }
            let text = toml::to_string(&doc).map_err(|e| Error::Other(e.to_string()))?;
            let src = Source {
                text,
                file: None,
                ..bsrc.clone()
            };
            // The name stays the base's (a file's stem is not in its text).
            Ok(match kind_from_source(src)? {
                Kind::Planar(mut p) => {
                    if p.sc.name.as_ref().is_none_or(|n| n.trim().is_empty()) {
                        p.src.name = bsrc.name.clone();
                    }
                    Kind::Planar(p)
                }
                Kind::Spatial(mut p) => {
                    if p.sc.name.as_ref().is_none_or(|n| n.trim().is_empty()) {
                        p.src.name = bsrc.name.clone();
                    }
                    Kind::Spatial(p)
                }
            })
        });
        let p = py_res(py, r)?;
        Ok(Self::new(p))
    }

    /// The value of a field of the resolved scenario, by path (`"controller.nn.k1"`,
    /// `"arms[0].links[1].mass"`); KeyError if there is none. A gain the file leaves to a
    /// preset (`gains = "tuned"`) or to the spatial NN design reads as the value the
    /// controller runs with.
    fn get(&self, py: Python<'_>, path: &str) -> PyResult<Py<PyAny>> {
        let resolved = match &*self.kind {
            Kind::Planar(p) => toml::Value::try_from(p.sc.resolved()),
            Kind::Spatial(p) => toml::Value::try_from(&p.sc),
        }
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        let from_resolved = resolved.as_table().and_then(|t| get_path(t, path));
        if let Some(v) = from_resolved.or_else(|| get_path(self.kind.doc(), path)) {
            return Ok(toml_to_py(py, v)?.unbind());
        }
        // A law's gain the file leaves to a preset (`gains = "tuned"`) or to the spatial design:
        // the value the controller runs with.
        let gains = self
            .kind
            .resolved_gains()
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        match gains.as_ref().and_then(|(key, t)| {
            let rest = path
                .strip_prefix("controller.")?
                .strip_prefix(key.as_str())?;
            match rest.strip_prefix('.') {
                Some(field) => t.as_table().and_then(|t| get_path(t, field)).cloned(),
                None if rest.is_empty() => Some(t.clone()),
                None => None,
            }
        }) {
            Some(v) => Ok(toml_to_py(py, &v)?.unbind()),
            None => Err(pyo3::exceptions::PyKeyError::new_err(path.to_string())),
        }
    }

    /// Simulate this scenario (GIL released) and return the Run. `duration` (s) and `seed`
    /// override `run.duration` and `run.seed`, as `tandem run --duration --seed` do. A run that
    /// hits a numerical fault returns normally: see `Run.fault`.
    ///
    /// `controller`: your law in tandem's loop instead of the scenario's, a function
    /// `f(t, q, qd, wrenches) -> tau` or an object with `tick(t, q, qd, wrenches) -> tau` (and
    /// optionally `start(t0, q, qd, wrenches)`, called once first), e.g. a `tandem.Controller`.
    /// It gets the readings `Controller.tick` gets (tandem's sensors, faults and seed), in
    /// arrays that are reused every tick and read-only (copy what you keep), once per control
    /// period from t = 0; it returns the joint torques (N m, `(n_q,)`). The run is scored on
    /// the true state against the scenario's path and bounds, as a torque replay is; its
    /// summary names the law `external`. An exception it raises stops the run and is raised
    /// here (with a note of the time); non-finite torques are a fault of the run
    /// (`Run.fault`).
    #[pyo3(signature = (duration=None, seed=None, controller=None))]
    fn run(
        &self,
        py: Python<'_>,
        duration: Option<f64>,
        seed: Option<u64>,
        controller: Option<Bound<'_, PyAny>>,
    ) -> PyResult<PyRun> {
        let p = Arc::new(py_res(py, self.kind.with_run(duration, seed))?);
        let k = p.clone();
        let fin = match controller {
            None => py.detach(move || k.execute()),
            Some(c) if c.is_instance_of::<PyJointPd>() => {
                let law = c.cast::<PyJointPd>()?.get().clone();
                py.detach(move || k.execute_external(Box::new(law)))
            }
            Some(c) => {
                let (law, raised) = PyLaw::new(&c, p.wrench_dim())?;
                let fin = py.detach(move || k.execute_external(Box::new(law)));
                let e = raised.lock().ok().and_then(|mut r| r.take());
                if let Some(e) = e {
                    return Err(e);
                }
                fin
            }
        };
        let fin = py_res(py, fin)?;
        PyRun::live(py, p, fin)
    }

    /// The scenario's plant, to step with your own torques: see `Plant`. Every validation of a
    /// run (a scenario `tandem run` refuses, this refuses too).
    fn plant(&self, py: Python<'_>) -> PyResult<PyPlant> {
        let kind = self.kind.clone();
        let r = py.detach(move || {
            check_kernel()?;
            let inner = build_plant(&kind)?;
            let n_q = inner.n_q;
            Ok(PyPlant {
                kind,
                inner,
                tau: vec![0.0; n_q],
            })
        });
        py_res(py, r)
    }

    /// The scenario's controller, built exactly as `tandem run` builds it (every validation,
    /// the spatial NN law's design-inertia probe), to step with your own measurements: see
    /// `Controller`. `law` is `"nn"`, `"pd"` (the scenario's `controller.pd` as it is, as
    /// `--controller pd`), `"pd-gravity"` (PD with the model's gravity) or `"ctc"`; None: the
    /// scenario's law. A torque replay is not a controller (ScenarioError).
    #[pyo3(signature = (law=None))]
    fn controller(&self, py: Python<'_>, law: Option<&str>) -> PyResult<PyController> {
        let law = match law {
            None => None,
            Some(l) => Some(
                tandem_cli::scenario::ControllerChoice::parse(l)
                    .map_err(|m| bad(Some("controller.kind"), m))
                    .map_err(|e| e.into_py(py))?,
            ),
        };
        let kind = self.kind.clone();
        let r = py.detach(move || PyController::new(kind, law));
        py_res(py, r)
    }

    /// The resolved scenario as TOML: every default written out, re-runnable
    /// (`tandem run FILE`, `Scenario.from_toml`); the run folder's `scenario.toml`.
    fn to_toml(&self, py: Python<'_>) -> PyResult<String> {
        py_res(py, self.kind.to_toml())
    }

    /// The scenario's name (outputs, summaries).
    #[getter]
    fn name(&self) -> String {
        self.kind.src().name.clone()
    }

    /// `"planar"` or `"spatial"` (arms with robot models, six outputs).
    #[getter]
    fn kind(&self) -> &'static str {
        match *self.kind {
            Kind::Planar(_) => "planar",
            Kind::Spatial(_) => "spatial",
        }
    }

    /// Free text of the scenario.
    #[getter]
    fn description(&self) -> String {
        match &*self.kind {
            Kind::Planar(p) => p.sc.description.clone(),
            Kind::Spatial(p) => p.sc.description.clone(),
        }
    }

    /// `run.duration`, s.
    #[getter]
    fn duration(&self) -> f64 {
        self.kind.duration()
    }

    /// `run.seed` (sensor noise).
    #[getter]
    fn seed(&self) -> u64 {
        self.kind.seed()
    }

    /// The controller label, e.g. `NN (tuned)`, `PD` (spatial: `NN`, `PD + gravity`, `CTC`).
    #[getter]
    fn label(&self) -> String {
        self.kind.label()
    }

    /// Set-up warnings (also issued as ScenarioWarning when the scenario is made).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.kind.warnings().to_vec()
    }

    fn __repr__(&self) -> String {
        let arms = match &*self.kind {
            Kind::Planar(p) => p.sc.arms.len(),
            Kind::Spatial(p) => p.sc.arms.len(),
        };
        format!(
            "<tandem.Scenario {:?}: {}, {} arms, {}, {} s, seed {}>",
            self.kind.src().name,
            self.kind(),
            arms,
            self.kind.label(),
            tandem_cli::output::table::num(self.kind.duration(), 6),
            self.kind.seed()
        )
    }

    /// Same name and same resolved scenario.
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        match other.cast::<PyScenario>() {
            Ok(o) => {
                // The name is compared as the scenario's (a resolved file carries it as a field).
                let same_name = self.kind.src().name == o.get().kind.src().name;
                same_name
                    && match (&*self.kind, &*o.get().kind) {
                        (Kind::Planar(a), Kind::Planar(b)) => {
                            let resolved = |p: &Planar| PlanarScenario {
                                name: None,
                                ..p.sc.resolved()
                            };
                            resolved(a) == resolved(b)
                        }
                        (Kind::Spatial(a), Kind::Spatial(b)) => {
                            let unnamed = |p: &Spatial| SpatialScenario {
                                name: None,
                                ..p.sc.clone()
                            };
                            unnamed(a) == unnamed(b)
                        }
                        _ => false,
                    }
            }
            Err(_) => false,
        }
    }

    fn __hash__(&self) -> PyResult<isize> {
        Err(PyTypeError::new_err("unhashable type: 'Scenario'"))
    }

    /// Pickled as its resolved TOML (`to_toml()`): `tandem._restore_scenario(text)`.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let f = py.import("tandem")?.getattr("_restore_scenario")?;
        let text = py_res(py, self.kind.to_toml())?;
        PyTuple::new(py, [f, PyTuple::new(py, [text])?.into_any()])
    }
}

// ---------------------------------------------------------------------------------------------
// A scenario's controller, stepped by the caller.

/// A NumPy float64 array (or anything `numpy.asarray` makes one of) of exactly `shape`, all
/// finite, copied into `buf` (preallocated: nothing is allocated on the Rust side). Errors are
/// ValueError naming the argument `name` and the shape expected.
fn read_arg(
    arg: &Bound<'_, PyAny>,
    name: &'static str,
    shape: &[usize],
    buf: &mut [f64],
) -> PyResult<()> {
    read_shaped(arg, name, shape, buf)?;
    let cols = if shape.len() == 2 { shape[1] } else { 0 };
    scenario::standalone::check_finite(name, buf, cols).map_err(input_err)
}

/// [`read_arg`] without the finiteness check: a float64 array of exactly `shape` into `buf`.
fn read_shaped(
    arg: &Bound<'_, PyAny>,
    name: &str,
    shape: &[usize],
    buf: &mut [f64],
) -> PyResult<()> {
    use numpy::{PyArrayDyn, PyUntypedArrayMethods};
    let shape_text = |s: &[usize]| {
        if s.len() == 1 {
            format!("({},)", s[0])
        } else {
            format!(
                "({})",
                s.iter()
                    .map(|d| d.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        }
    };
    let arr = match arg.cast::<PyArrayDyn<f64>>() {
        Ok(a) => a.clone(),
        Err(_) => {
            let np = arg.py().import("numpy")?;
            let converted = np
                .getattr("asarray")?
                .call1((arg, np.getattr("float64")?))
                .map_err(|e| {
                    PyTypeError::new_err(format!(
                        "{name}: expected a float64 array of shape {}, got {} ({e})",
                        shape_text(shape),
                        arg.get_type()
                            .name()
                            .map(|n| n.to_string())
                            .unwrap_or_default()
                    ))
                })?;
            converted.cast_into::<PyArrayDyn<f64>>().map_err(|_| {
                PyTypeError::new_err(format!(
                    "{name}: expected a float64 array of shape {}",
                    shape_text(shape)
                ))
            })?
        }
    };
    if arr.shape() != shape {
        return Err(PyValueError::new_err(format!(
            "{name}: expected shape {}, got {}",
            shape_text(shape),
            shape_text(arr.shape())
        )));
    }
    let ro = arr
        .try_readonly()
        .map_err(|e| PyValueError::new_err(format!("{name}: {e}")))?;
    let view = ro.as_array();
    for (b, v) in buf.iter_mut().zip(view.iter()) {
        *b = *v;
    }
    Ok(())
}

/// A time argument: finite.
fn read_time(t: f64) -> PyResult<f64> {
    scenario::standalone::check_time(t).map_err(input_err)?;
    Ok(t)
}

/// The standalone controller's input checks as Python exceptions: a tick before the start is
/// a RuntimeError, a bad value a ValueError naming the argument.
fn input_err(e: scenario::standalone::InputError) -> PyErr {
    match e {
        scenario::standalone::InputError::NotStarted => PyRuntimeError::new_err(
            "Controller.tick before Controller.start: call start(t0, q, qd, wrenches) first \
             (e.g. with start_state())",
        ),
        e => PyValueError::new_err(e.to_string()),
    }
}

/// A scenario's controller, built exactly as `tandem run` builds it, stepped by you.
///
/// Made by `Scenario.controller(law=None)`. Call `start(t0, q, qd, wrenches)` once with the
/// first readings, then `tick(t, q, qd, wrenches)` once per control period (`control_period`,
/// the scenario's `run.control_period`) from `t0` on, the first tick at `t0` itself: the
/// controller integrates its own states over `control_period` per tick. Inputs are float64
/// arrays: `q`, `qd` of shape `(n_q,)` (joint angles in rad and rates in rad/s, stacked over
/// arms in the scenario's order), `wrenches` of shape `wrench_shape` = `(n_arms, 2)` planar, the
/// object's force on each end effector in world axes (N), or `(n_arms, 6)` spatial, the
/// object's wrench `[fx, fy, fz, tx, ty, tz]` on each tool, about the tool origin, in the
/// tool's axes (N, N m): what a wrist force/torque sensor at the tool reads. A wrong shape,
/// NaN or infinity raises ValueError naming the argument.
#[pyclass(module = "tandem", name = "Controller")]
struct PyController {
    kind: Arc<Kind>,
    law: Option<tandem_cli::scenario::ControllerChoice>,
    inner: scenario::standalone::Standalone,
    q: Vec<f64>,
    qd: Vec<f64>,
    w: Vec<f64>,
}

fn build_controller(
    kind: &Kind,
    law: Option<tandem_cli::scenario::ControllerChoice>,
) -> Res<scenario::standalone::Standalone> {
    check_kernel()?;
    Ok(match kind {
        Kind::Planar(p) => scenario::standalone::planar(&p.sc, &p.src, law)?,
        Kind::Spatial(p) => scenario::standalone::spatial(&p.sc, &p.src, law)?,
    })
}

impl PyController {
    fn new(kind: Arc<Kind>, law: Option<tandem_cli::scenario::ControllerChoice>) -> Res<Self> {
        let inner = build_controller(&kind, law)?;
        let (n_q, nw) = (inner.n_q, inner.n_arms * inner.wrench_dim);
        Ok(PyController {
            kind,
            law,
            inner,
            q: vec![0.0; n_q],
            qd: vec![0.0; n_q],
            w: vec![0.0; nw],
        })
    }

    fn read_inputs(
        &mut self,
        q: &Bound<'_, PyAny>,
        qd: &Bound<'_, PyAny>,
        wrenches: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let n_q = self.inner.n_q;
        let ws = [self.inner.n_arms, self.inner.wrench_dim];
        read_arg(q, "q", &[n_q], &mut self.q)?;
        read_arg(qd, "qd", &[n_q], &mut self.qd)?;
        read_arg(wrenches, "wrenches", &ws, &mut self.w)
    }
}

/// `(q, qd, wrenches)` of `Controller.start_state()`.
type StartState<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyAny>,
);

fn array1<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, v)
}

#[pymethods]
impl PyController {
    /// Joints, all arms.
    #[getter]
    fn n_q(&self) -> usize {
        self.inner.n_q
    }

    /// Arms.
    #[getter]
    fn n_arms(&self) -> usize {
        self.inner.n_arms
    }

    /// The shape of `wrenches`: `(n_arms, 2)` planar, `(n_arms, 6)` spatial.
    #[getter]
    fn wrench_shape(&self) -> (usize, usize) {
        (self.inner.n_arms, self.inner.wrench_dim)
    }

    /// The scenario's control period, s: tick once per period.
    #[getter]
    fn control_period(&self) -> f64 {
        self.inner.control_period
    }

    /// The law: `"nn"`, `"pd"`, `"pd-gravity"` or `"ctc"` (the scenario's when none was given).
    #[getter]
    fn law(&self) -> String {
        use tandem_cli::scenario::ControllerChoice;
        self.law
            .unwrap_or_else(|| match &*self.kind {
                Kind::Planar(p) => ControllerChoice::of(
                    p.sc.controller.kind,
                    p.sc.controller.pd.gravity_compensation,
                ),
                Kind::Spatial(p) => ControllerChoice::of(
                    p.sc.controller.kind,
                    p.sc.controller.pd.gravity_compensation,
                ),
            })
            .name()
            .to_string()
    }

    /// `(q, qd, wrenches)` where the scenario's run starts: the chain at rest on the start
    /// pose holding the object with zero torque, and what the wrist sensors read there (the
    /// readings `tandem run` starts its controller with).
    fn start_state<'py>(&self, py: Python<'py>) -> PyResult<StartState<'py>> {
        let s = &self.inner.start;
        let w = array1(py, &s.wrenches)
            .reshape([self.inner.n_arms, self.inner.wrench_dim])?
            .into_any();
        Ok((array1(py, &s.q), array1(py, &s.qd), w))
    }

    /// Start (or restart) at time `t` with the first readings: the admittance at rest with
    /// its wrench filters at the expected wrenches, the pose estimate from `q`. Adaptive
    /// weights are kept (`reset()` zeroes them). The sensor sanity check: when the readings'
    /// forces (in world axes) do not sum to the object's weight within 25 %, as a robot holding
    /// the object at rest reads them (nor are tandem's own start, `start_state()`), a
    /// `ScenarioWarning` names each arm with its reading and the hold's, and the arm whose sign
    /// looks flipped or whose reading looks given in world axes.
    fn start(
        &mut self,
        py: Python<'_>,
        t: f64,
        q: &Bound<'_, PyAny>,
        qd: &Bound<'_, PyAny>,
        wrenches: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let t = read_time(t)?;
        self.read_inputs(q, qd, wrenches)?;
        warn_all(py, &self.inner.check_start(&self.w))?;
        self.inner
            .try_start(t, &self.q, &self.qd, &self.w)
            .map_err(input_err)
    }

    /// One control tick at time `t`: the joint torques `tau` (N m, shape `(n_q,)`), written
    /// into `out` (a writeable, contiguous float64 array of shape `(n_q,)`) and returned when
    /// given, else into a new array. `t` must not go back: the first tick after `start` may be
    /// at the start's time, every later one after the previous tick. Never returns NaN.
    #[pyo3(signature = (t, q, qd, wrenches, out=None))]
    fn tick<'py>(
        &mut self,
        py: Python<'py>,
        t: f64,
        q: &Bound<'py, PyAny>,
        qd: &Bound<'py, PyAny>,
        wrenches: &Bound<'py, PyAny>,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        // The time first (a tick before the start, or back in time), then the inputs.
        self.inner.check_tick_time(t).map_err(input_err)?;
        self.read_inputs(q, qd, wrenches)?;
        use numpy::PyUntypedArrayMethods;
        let n_q = self.inner.n_q;
        let out = match out {
            Some(o) => {
                let a = o.cast::<PyArray1<f64>>().map_err(|_| {
                    PyValueError::new_err(format!(
                        "out: expected a float64 array of shape ({n_q},)"
                    ))
                })?;
                if PyUntypedArrayMethods::len(a) != n_q {
                    return Err(PyValueError::new_err(format!(
                        "out: expected shape ({n_q},), got ({},)",
                        PyUntypedArrayMethods::len(a)
                    )));
                }
                {
                    let mut rw = a.try_readwrite().map_err(|e| {
                        PyValueError::new_err(format!("out: must be writeable ({e})"))
                    })?;
                    let tau = rw
                        .as_slice_mut()
                        .map_err(|_| PyValueError::new_err("out: must be a contiguous array"))?;
                    self.inner
                        .try_tick(t, &self.q, &self.qd, &self.w, tau)
                        .map_err(input_err)?;
                }
                o
            }
            None => {
                let a = PyArray1::<f64>::zeros(py, n_q, false);
                {
                    let mut rw = a.readwrite();
                    let tau = rw
                        .as_slice_mut()
                        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
                    self.inner
                        .try_tick(t, &self.q, &self.qd, &self.w, tau)
                        .map_err(input_err)?;
                }
                a.into_any()
            }
        };
        Ok(out)
    }

    /// The last tick's internals: arrays (3 outputs planar, 6 spatial, in the output chart)
    /// `x_hat`, `xd_hat` (the pose and rate estimated from the encoders), `x_d`, `x_r`, `xd_r`
    /// (desired and admittance reference), `z1`, `z2`, `alpha`, `alpha_dot`, `wrench` (the
    /// object wrench commanded: the log's `tau.*`), `w_norm` (NN weight norms); floats `Q`
    /// (NN switching value, 1 for other laws), `margin` (output-bound margin of the estimate),
    /// spatial `angle_error`; spatial `internal` `(n_arms, 6)` (each arm's internal wrench);
    /// bools `barrier_hit`, `torque_clipped`, `non_finite`; and `events`, the counts since the
    /// start. Copies, taken when read.
    #[getter]
    fn record<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in self.inner.record_vectors() {
            d.set_item(k, array1(py, v))?;
        }
        for (k, v) in self.inner.record_scalars() {
            d.set_item(k, v)?;
        }
        for (k, v) in self.inner.record_flags() {
            d.set_item(k, v)?;
        }
        if let Some(int) = self.inner.record_internal() {
            let flat: Vec<f64> = int.iter().flat_map(|w| w.iter().copied()).collect();
            d.set_item("internal", array1(py, &flat).reshape([int.len(), 6])?)?;
        }
        let e = self.inner.events();
        let ev = PyDict::new(py);
        ev.set_item("barrier_hits", e.barrier_hits)?;
        ev.set_item("torque_clips", e.torque_clips)?;
        ev.set_item("non_finite", e.non_finite)?;
        ev.set_item("degenerate", e.degenerate)?;
        d.set_item("events", ev)?;
        Ok(d)
    }

    /// Back to the controller as built (adaptive weights zeroed, admittance at rest, no
    /// record): call `start` again before `tick`.
    fn reset(&mut self, py: Python<'_>) -> PyResult<()> {
        let inner = py_res(py, build_controller(&self.kind, self.law))?;
        self.inner = inner;
        Ok(())
    }

    /// Pickled through its scenario and law: `tandem._restore_controller(scenario, law)`
    /// gives the controller as built (not its state: `start` it again).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let f = py.import("tandem")?.getattr("_restore_controller")?;
        let sc = Bound::new(
            py,
            PyScenario {
                kind: self.kind.clone(),
            },
        )?;
        let law = self.law.map(|_| self.law());
        let args = PyTuple::new(py, [sc.into_any(), law.into_pyobject(py)?.into_any()])?;
        PyTuple::new(py, [f, args.into_any()])
    }

    fn __repr__(&self) -> String {
        format!(
            "<tandem.Controller {:?}: {}, {} joints, {} arms, wrenches {:?}, h = {} s>",
            self.kind.src().name,
            self.law(),
            self.inner.n_q,
            self.inner.n_arms,
            (self.inner.n_arms, self.inner.wrench_dim),
            self.inner.control_period
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Your law in tandem's loop; tandem's plant in your loop.

/// What a Python law raised, kept for `Scenario.run` to re-raise once the loop has stopped.
type Raised = Arc<std::sync::Mutex<Option<PyErr>>>;

/// A Python law as the driver of tandem's loop (`Scenario.run(controller=...)`): a function
/// `f(t, q, qd, wrenches) -> tau`, or an object with `tick(t, q, qd, wrenches) -> tau` (and,
/// optionally, `start(t0, q, qd, wrenches)`, called once before the first tick), such as a
/// `tandem.Controller`. The arrays it is given are tandem's own, reused every tick and
/// read-only; the GIL is taken for the call only.
struct PyLaw {
    /// The tick callable.
    tick: Py<PyAny>,
    /// The start callable, if the object has one.
    start: Option<Py<PyAny>>,
    /// `q`, `qd` `(n_q,)` and `wrenches` `(n_arms, W)`, made at start.
    arrays: Option<[Py<PyAny>; 3]>,
    /// Wrench channels per arm.
    w: usize,
    raised: Raised,
}

impl PyLaw {
    /// The law of `obj` (a callable, or an object with a callable `tick`), or TypeError naming
    /// the argument.
    fn new(obj: &Bound<'_, PyAny>, w: usize) -> PyResult<(Self, Raised)> {
        let (tick, start) = match obj.getattr_opt("tick")? {
            Some(t) if t.is_callable() => {
                let start = obj.getattr_opt("start")?.filter(|s| s.is_callable());
                (t.unbind(), start.map(Bound::unbind))
            }
            _ if obj.is_callable() => (obj.clone().unbind(), None),
            _ => {
                return Err(PyTypeError::new_err(format!(
                    "controller: expected a function f(t, q, qd, wrenches) -> tau or an object \
                     with a tick(t, q, qd, wrenches) method (e.g. a tandem.Controller), got {}",
                    obj.get_type().name()?
                )));
            }
        };
        let raised: Raised = Arc::default();
        Ok((
            PyLaw {
                tick,
                start,
                arrays: None,
                w,
                raised: raised.clone(),
            },
            raised,
        ))
    }

    /// Copy the readings into the law's arrays (made read-only to Python on first use).
    fn fill<'py>(
        &mut self,
        py: Python<'py>,
        meas: &tandem::drive::Measurements<'_>,
    ) -> PyResult<[Bound<'py, PyAny>; 3]> {
        if self.arrays.is_none() {
            let n = meas.q.len();
            let n_arms = meas.wrenches.len() / self.w;
            let q = PyArray1::<f64>::zeros(py, n, false).into_any();
            let qd = PyArray1::<f64>::zeros(py, n, false).into_any();
            let wr = PyArray1::<f64>::zeros(py, n_arms * self.w, false)
                .reshape([n_arms, self.w])?
                .into_any();
            for a in [&q, &qd, &wr] {
                a.getattr("flags")?.setattr("writeable", false)?;
            }
            self.arrays = Some([q.unbind(), qd.unbind(), wr.unbind()]);
        }
        let [q, qd, wr] = self.arrays.as_ref().expect("made above");
        let (q, qd, wr) = (q.bind(py), qd.bind(py), wr.bind(py));
        for (a, v) in [(q, meas.q), (qd, meas.qd)] {
            let a = a.cast::<PyArray1<f64>>()?;
            // SAFETY: tandem made these arrays (contiguous, owned); Python sees them read-only
            // and no borrow of them is alive while the law is not running.
            unsafe { a.as_slice_mut() }
                .map_err(|e| PyRuntimeError::new_err(e.to_string()))?
                .copy_from_slice(v);
        }
        let a = wr.cast::<numpy::PyArray2<f64>>()?;
        // SAFETY: as above.
        unsafe { a.as_slice_mut() }
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?
            .copy_from_slice(meas.wrenches);
        Ok([q.clone(), qd.clone(), wr.clone()])
    }

    /// Keep the exception for `Scenario.run` and give the loop its message.
    fn fail(&self, py: Python<'_>, e: PyErr, t: f64) -> String {
        let msg = bounded(e.to_string());
        let _ = e.value(py).call_method1(
            "add_note",
            (format!(
                "raised by the controller given to Scenario.run, at t = {t} s"
            ),),
        );
        if let Ok(mut r) = self.raised.lock() {
            if r.is_none() {
                *r = Some(e);
            }
        }
        msg
    }
}

impl tandem::sim::ExternalLaw for PyLaw {
    fn start(&mut self, t0: f64, meas: &tandem::drive::Measurements<'_>) -> Result<(), String> {
        Python::attach(|py| {
            let r = self
                .fill(py, meas)
                .and_then(|[q, qd, w]| match &self.start {
                    Some(s) => s.bind(py).call1((t0, q, qd, w)).map(|_| ()),
                    None => Ok(()),
                });
            r.map_err(|e| self.fail(py, e, t0))
        })
    }
    fn tick(
        &mut self,
        t: f64,
        meas: &tandem::drive::Measurements<'_>,
        tau: &mut [f64],
    ) -> Result<(), String> {
        Python::attach(|py| {
            let n = tau.len();
            let r = self.fill(py, meas).and_then(|[q, qd, w]| {
                let v = self.tick.bind(py).call1((t, q, qd, w))?;
                read_shaped(&v, "the controller's return value (tau)", &[n], tau)
            });
            r.map_err(|e| self.fail(py, e, t))
        })
    }
}

/// A scenario's plant, stepped by you (made by `Scenario.plant()`).
///
/// The plant a run simulates: the scenario's (true) arms and object, the start pose at rest
/// with zero torque held, the sensor models and seed, the disturbance, the timing. `step(tau,
/// dt)` holds the joint torques `tau` (N m, shape `(n_q,)`) over `dt` (whole control periods;
/// default one) and integrates with the scenario's plant step; `sensors()` is what the
/// encoders and wrist sensors read at the current state (the wrenches as
/// `Controller.tick` takes them); `state`, `wrenches`, `residual` and `energy` are the truth.
/// Numerical trouble raises `tandem.PlantFault` with its time and the last good state; the
/// plant then refuses to step.
#[pyclass(module = "tandem", name = "Plant")]
struct PyPlant {
    kind: Arc<Kind>,
    inner: scenario::standalone::PlantSession,
    tau: Vec<f64>,
}

/// The most control periods one `Plant.step` call may take.
const MAX_STEP_PERIODS: usize = 10_000_000;

fn build_plant(kind: &Kind) -> Res<scenario::standalone::PlantSession> {
    Ok(match kind {
        Kind::Planar(p) => scenario::standalone::planar_plant(&p.sc, &p.src)?,
        Kind::Spatial(p) => scenario::standalone::spatial_plant(&p.sc, &p.src)?,
    })
}

fn plant_fault(py: Python<'_>, f: &tandem::sim::Fault) -> PyErr {
    let e = PlantFault::new_err(f.to_string());
    let _ = e.value(py).setattr("t", f.t);
    e
}

#[pymethods]
impl PyPlant {
    /// Joints, all arms.
    #[getter]
    fn n_q(&self) -> usize {
        self.inner.n_q
    }
    /// Arms.
    #[getter]
    fn n_arms(&self) -> usize {
        self.inner.n_arms
    }
    /// `(n_arms, 2)` planar, `(n_arms, 6)` spatial: the shape of `sensors()`'s wrenches.
    #[getter]
    fn wrench_shape(&self) -> (usize, usize) {
        (self.inner.n_arms, self.inner.wrench_dim)
    }
    /// The scenario's `run.control_period`, s: the unit of `step`.
    #[getter]
    fn control_period(&self) -> f64 {
        self.inner.control_period()
    }
    /// Simulated time, s.
    #[getter]
    fn time(&self) -> f64 {
        self.inner.time()
    }

    /// The true state (copies): `q` (rad), `qd` (rad/s), `object_pose` (planar `(x, y, θ)`;
    /// spatial `(x, y, z, qw, qx, qy, qz)`, world frame) and `object_twist` (planar
    /// `(ẋ, ẏ, θ̇)`; spatial `(v, ω)`, world axes).
    #[getter]
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let (q, qd) = self.inner.joints();
        let (pose, twist) = self.inner.object();
        d.set_item("q", array1(py, q))?;
        d.set_item("qd", array1(py, qd))?;
        d.set_item("object_pose", array1(py, pose))?;
        d.set_item("object_twist", array1(py, twist))?;
        Ok(d)
    }

    /// What the sensors read at the current state, with the scenario's sensor models and seed:
    /// `(q, qd, wrenches)`, the arguments of `Controller.tick` (wrenches of shape
    /// `wrench_shape`: planar world axes, spatial the object's wrench on each tool, about the
    /// tool origin, in tool axes). Injected sensor faults (`[faults]`) are not applied here.
    fn sensors<'py>(&self, py: Python<'py>) -> PyResult<StartState<'py>> {
        let (q, qd) = self.inner.encoders();
        let w = array1(py, self.inner.readings())
            .reshape([self.inner.n_arms, self.inner.wrench_dim])?
            .into_any();
        Ok((array1(py, q), array1(py, qd), w))
    }

    /// The true grasp wrenches at the current state with the last torques held: the object's
    /// wrench on each arm, world axes, shape `wrench_shape` (N; spatial `[f; τ]`, N m, about
    /// the tool origin).
    #[getter]
    fn wrenches<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(array1(py, self.inner.wrenches())
            .reshape([self.inner.n_arms, self.inner.wrench_dim])?
            .into_any())
    }

    /// The grasp-constraint residual of the current state: `(position (m), rotation (rad))`
    /// spatial; `(position (m), velocity (m/s))` planar.
    #[getter]
    fn residual(&mut self) -> (f64, f64) {
        self.inner.residual()
    }

    /// Mechanical energy of arms and object, J: `kinetic`, `potential`, `total`.
    #[getter]
    fn energy<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let e = self.inner.energy();
        let d = PyDict::new(py);
        d.set_item("kinetic", e.kinetic)?;
        d.set_item("potential", e.potential)?;
        d.set_item("total", e.total())?;
        Ok(d)
    }

    /// Spatial: the joint torques that hold the current configuration at rest (each arm's
    /// gravity and an equal share of the object's weight, no internal wrench), N m, `(n_q,)`.
    /// Planar plants raise NotImplementedError.
    fn holding_torques<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let mut tau = vec![0.0; self.inner.n_q];
        if !self.inner.holding_torques(&mut tau) {
            return Err(pyo3::exceptions::PyNotImplementedError::new_err(
                "holding_torques: spatial plants only",
            ));
        }
        Ok(array1(py, &tau))
    }

    /// Hold the joint torques `tau` (N m, float64 `(n_q,)`, finite) over `dt` seconds, a whole
    /// number of control periods (default: one), integrating with the scenario's plant step;
    /// the GIL is released for more than one period. Raises ValueError naming `tau` or `dt` (nothing is
    /// stepped), PlantFault when the plant fails.
    #[pyo3(signature = (tau, dt=None))]
    fn step(&mut self, py: Python<'_>, tau: &Bound<'_, PyAny>, dt: Option<f64>) -> PyResult<()> {
        let h = self.inner.control_period();
        let periods = match dt {
            None => 1,
            Some(dt) => {
                let n = (dt / h).round();
                if !(dt.is_finite() && dt > 0.0) {
                    return Err(PyValueError::new_err(format!(
                        "dt = {dt}: must be a positive number of seconds"
                    )));
                }
                if n < 1.0 || (n * h - dt).abs() > 1e-9 * dt.max(h) {
                    return Err(PyValueError::new_err(format!(
                        "dt = {dt}: must be a whole number of control periods ({h} s)"
                    )));
                }
                if n > MAX_STEP_PERIODS as f64 {
                    return Err(PyValueError::new_err(format!(
                        "dt = {}: at most {MAX_STEP_PERIODS} control periods ({} s) per call",
                        scenario::num(dt),
                        MAX_STEP_PERIODS as f64 * h
                    )));
                }
                n as usize
            }
        };
        let n_q = self.inner.n_q;
        read_arg(tau, "tau", &[n_q], &mut self.tau)?;
        if let Some(f) = self.inner.fault() {
            return Err(plant_fault(py, f));
        }
        let (inner, tau) = (&mut self.inner, &self.tau);
        // One period takes microseconds: releasing the GIL would cost a good part of it.
        let r = if periods > 1 {
            py.detach(|| inner.step(tau, periods))
        } else {
            inner.step(tau, periods)
        };
        r.map_err(|f| plant_fault(py, &f))
    }

    /// Hold the joint torques `tau` (N m, `(n_q,)`, finite) from now on without stepping, as a
    /// robot holds its pose before your loop starts: `sensors()` reads again with them held
    /// (the readings are always taken with the torques held since the last step; a fresh
    /// plant holds zero). ValueError naming `tau`; PlantFault.
    fn hold(&mut self, py: Python<'_>, tau: &Bound<'_, PyAny>) -> PyResult<()> {
        let n_q = self.inner.n_q;
        read_arg(tau, "tau", &[n_q], &mut self.tau)?;
        self.inner.hold(&self.tau).map_err(|f| plant_fault(py, &f))
    }

    /// Back to the start (a new plant as `Scenario.plant()` makes it).
    fn reset(&mut self, py: Python<'_>) -> PyResult<()> {
        self.inner = py_res(py, build_plant(&self.kind))?;
        Ok(())
    }

    fn __repr__(&self) -> String {
        format!(
            "<tandem.Plant {:?}: {} joints, {} arms, t = {} s, h = {} s>",
            self.kind.src().name,
            self.inner.n_q,
            self.inner.n_arms,
            self.inner.time(),
            self.inner.control_period()
        )
    }
}

/// A joint-space PD law with a feedforward, in Rust: `tau = kp * (q_ref - q) - kd * qd +
/// tau_ff`, per joint (e.g. `tau_ff = Plant.holding_torques()` at the start: PD plus the
/// gravity of the set point). A baseline to pass to `Scenario.run(controller=...)` and a
/// reference for your own Python laws (the same law in NumPy gives the same run, bit for bit).
#[pyclass(module = "tandem", name = "JointPD", frozen)]
#[derive(Clone)]
struct PyJointPd {
    kp: Vec<f64>,
    kd: Vec<f64>,
    q_ref: Vec<f64>,
    tau_ff: Vec<f64>,
}

#[pymethods]
impl PyJointPd {
    /// `kp` (N m/rad), `kd` (N m s/rad), `q_ref` (rad), `tau_ff` (N m): float64 arrays of one
    /// shape `(n_q,)`, finite.
    #[new]
    fn new(
        kp: &Bound<'_, PyAny>,
        kd: &Bound<'_, PyAny>,
        q_ref: &Bound<'_, PyAny>,
        tau_ff: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        use numpy::PyUntypedArrayMethods;
        let np = q_ref.py().import("numpy")?;
        let n = np
            .getattr("asarray")?
            .call1((q_ref,))?
            .cast_into::<numpy::PyUntypedArray>()
            .map_err(|_| PyTypeError::new_err("q_ref: expected a float64 array"))?
            .len();
        let mut v = [vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        for (buf, (a, name)) in
            v.iter_mut()
                .zip([(kp, "kp"), (kd, "kd"), (q_ref, "q_ref"), (tau_ff, "tau_ff")])
        {
            read_arg(a, name, &[n], buf)?;
        }
        let [kp, kd, q_ref, tau_ff] = v;
        Ok(PyJointPd {
            kp,
            kd,
            q_ref,
            tau_ff,
        })
    }
    fn __repr__(&self) -> String {
        format!("<tandem.JointPD: {} joints>", self.q_ref.len())
    }
}

impl tandem::sim::ExternalLaw for PyJointPd {
    fn start(&mut self, _t0: f64, meas: &tandem::drive::Measurements<'_>) -> Result<(), String> {
        if meas.q.len() != self.q_ref.len() {
            return Err(format!(
                "JointPD has {} joints, the scenario {}",
                self.q_ref.len(),
                meas.q.len()
            ));
        }
        Ok(())
    }
    fn tick(
        &mut self,
        _t: f64,
        meas: &tandem::drive::Measurements<'_>,
        tau: &mut [f64],
    ) -> Result<(), String> {
        for (i, t) in tau.iter_mut().enumerate() {
            *t =
                self.kp[i] * (self.q_ref[i] - meas.q[i]) - self.kd[i] * meas.qd[i] + self.tau_ff[i];
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Runs.

/// Keeps a live run's log alive while NumPy arrays point into it.
#[pyclass(module = "tandem", frozen)]
struct LogOwner {
    /// Never read: owning it is the point.
    #[allow(dead_code)]
    fin: Arc<Fin>,
}

/// The finished simulation behind a Run.
enum Data {
    /// Run in this process: the whole result (the arrays are views of its log).
    Live(Arc<Fin>),
    /// Unpickled: the summary and time series travelled, the rest is rebuilt by a re-run on
    /// `write` (runs are deterministic).
    Restored,
}

/// One finished run: `summary` (the command line's `summary.json`), `timeseries` (NumPy arrays,
/// read-only views of the run's memory), `to_pandas()`, `write(dir)` (the command line's output
/// folder). Picklable: the summary and time series travel, not a re-run.
#[pyclass(module = "tandem", name = "Run", frozen)]
struct PyRun {
    /// The scenario as run (duration and seed overrides applied).
    kind: Arc<Kind>,
    /// `summary.json` without write times.
    summary: Json,
    /// Column (name, unit), in log order.
    columns: Vec<(String, String)>,
    /// The columns as NumPy arrays (read-only).
    arrays: Vec<Py<PyArray1<f64>>>,
    data: Data,
}

fn readonly(a: &Bound<'_, PyArray1<f64>>) -> PyResult<()> {
    let kw = PyDict::new(a.py());
    kw.set_item("write", false)?;
    a.call_method("setflags", (), Some(&kw))?;
    Ok(())
}

impl PyRun {
    fn live(py: Python<'_>, kind: Arc<Kind>, fin: Fin) -> PyResult<Self> {
        let summary = fin.summary(&kind.src().name);
        let fin = Arc::new(fin);
        let owner = Bound::new(py, LogOwner { fin: fin.clone() })?.into_any();
        let log = fin.log();
        let derived = fin.derived_columns();
        let mut columns = Vec::with_capacity(log.columns.len() + derived.len());
        let mut arrays = Vec::with_capacity(columns.capacity());
        let all = log
            .columns
            .iter()
            .map(|c| (c.name.clone(), c.unit.clone(), c.data.as_slice()))
            .chain(derived);
        for (name, unit, data) in all {
            let view = numpy::ndarray::ArrayView1::from(data);
            // SAFETY: the array's base object is `owner`, which holds an `Arc` of the finished
            // run (its log, and for a spatial run its derived columns); neither is modified or
            // reallocated after the run (they are only read, by `write`), so the memory stays
            // valid and unchanged as long as the array exists. The array is made read-only, so
            // NumPy does not write into it either.
            let a = unsafe { PyArray1::borrow_from_array(&view, owner.clone()) };
            readonly(&a)?;
            columns.push((name, unit));
            arrays.push(a.unbind());
        }
        Ok(PyRun {
            kind,
            summary,
            columns,
            arrays,
            data: Data::Live(fin),
        })
    }

    fn summary_without_timing(&self) -> Json {
        let mut s = self.summary.clone();
        if let Json::Object(m) = &mut s {
            m.remove("timing");
        }
        s
    }
}

#[pymethods]
impl PyRun {
    /// The summary: `summary.json` of `tandem run` (metrics, seed, fault, warnings, and in
    /// `timing` the loop's wall time), as a dict. `None` where a metric does not exist for the
    /// run (`unavailable` says why).
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.summary)
    }

    /// The time series: column name (`t`, `x_o.x`, `tau_q1`, ...) → NumPy float64 array, the
    /// columns of `timeseries.csv` in its order (spatial: the log's, then the derived `x_1.*`
    /// and `F_tool{i}.*`). The arrays are read-only views of the run's memory (no copy).
    #[getter]
    fn timeseries<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for ((n, _), a) in self.columns.iter().zip(&self.arrays) {
            d.set_item(n, a.bind(py))?;
        }
        Ok(d)
    }

    /// Column name → unit (`"m"`, `"N"`, `"rad/s"`, ...).
    #[getter]
    fn units<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (n, u) in &self.columns {
            d.set_item(n, u)?;
        }
        Ok(d)
    }

    /// The time series as a pandas DataFrame (one column per signal, units in `df.attrs`).
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let pd = py.import("pandas").map_err(|e| {
            pyo3::exceptions::PyImportError::new_err(format!(
                "Run.to_pandas needs pandas (pip install pandas): {e}"
            ))
        })?;
        let df = pd.getattr("DataFrame")?.call1((self.timeseries(py)?,))?;
        df.getattr("attrs")?.set_item("units", self.units(py)?)?;
        Ok(df)
    }

    /// The scenario as run (duration and seed overrides applied).
    #[getter]
    fn scenario(&self) -> PyScenario {
        PyScenario {
            kind: self.kind.clone(),
        }
    }

    /// The fault that stopped the run early (its message), or None.
    #[getter]
    fn fault(&self) -> Option<String> {
        let key = match *self.kind {
            Kind::Planar(_) => "fault_message",
            Kind::Spatial(_) => "fault",
        };
        self.summary
            .get(key)
            .and_then(Json::as_str)
            .map(str::to_string)
    }

    /// True when the run completed without a fault.
    #[getter]
    fn ok(&self) -> bool {
        self.fault().is_none()
    }

    /// Number of logged rows.
    fn __len__(&self) -> usize {
        self.summary.get("rows").and_then(Json::as_u64).unwrap_or(0) as usize
    }

    fn __repr__(&self) -> String {
        let k = &self.kind;
        format!(
            "<tandem.Run {:?}: {}, {} s, seed {}, {} rows, {}>",
            k.src().name,
            k.label(),
            tandem_cli::output::table::num(k.duration(), 6),
            k.seed(),
            self.__len__(),
            match self.fault() {
                Some(f) => format!("fault: {f}"),
                None => "completed".into(),
            }
        )
    }

    /// Write the command line's output folder for this run (`timeseries.csv`, `summary.json`,
    /// `scenario.toml`, and with `figures` the figures and `animation.svg`; a spatial run also
    /// `viewer.html` and the snapshots, as `tandem run`), atomically. An
    /// existing folder is kept unless `force`, which replaces only a folder tandem wrote.
    /// Returns the folder's path. An unpickled run is simulated again first (runs are
    /// deterministic; a re-run that differs is an error).
    #[pyo3(signature = (dir, force=false, figures=true))]
    fn write(&self, py: Python<'_>, dir: PathBuf, force: bool, figures: bool) -> PyResult<String> {
        if dir.as_os_str().is_empty() {
            return Err(PyValueError::new_err(
                "write(\"\"): give the output folder's path",
            ));
        }
        if std::fs::symlink_metadata(&dir).is_ok() && !force {
            return Err(PyFileExistsError::new_err(format!(
                "output folder {} exists (nothing was written); pass force=True to replace it \
                 (only a folder tandem wrote is replaced)",
                dir.display()
            )));
        }
        let kind = self.kind.clone();
        let expected = self.summary_without_timing();
        let live = match &self.data {
            Data::Live(f) => Some(f.clone()),
            Data::Restored => None,
        };
        let r = py.detach(move || -> Res<(PathBuf, Vec<String>)> {
            // The work's inputs are never replaced (the same decision as the command line's);
            // checked before anything is simulated again.
            let protected = match &*kind {
                Kind::Planar(p) => scenario::inputs(&p.src, &p.sc),
                Kind::Spatial(p) => scenario::inputs(&p.src, &p.sc),
            };
            let other = |e: anyhow::Error| match e.downcast_ref::<output::Refused>() {
                Some(r) => bad(None, r.to_string().replacen("--force", "force=True", 1)),
                None => Error::Other(format!("{e:#}")),
            };
            if force {
                output::check_replaceable(&dir, &protected).map_err(other)?;
            }
            let name = &kind.src().name;
            let fin = match live {
                Some(f) => f,
                None if expected.get("controller").and_then(Json::as_str)
                    == Some(tandem_cli::run::planar::EXTERNAL) =>
                {
                    return Err(Error::Other(
                        "this unpickled run was driven by your own law (Scenario.run(controller=...)), \
                         which tandem cannot run again to rebuild its outputs: write() it in the \
                         process that ran it"
                            .into(),
                    ));
                }
                None => {
                    let f = kind.execute()?;
                    let mut again = f.summary(name);
                    if let Json::Object(m) = &mut again {
                        m.remove("timing");
                    }
                    if again != expected {
                        return Err(Error::Other(
                            "the unpickled run, simulated again to write its outputs, differs \
                             from the original (was it made by another tandem version?)"
                                .into(),
                        ));
                    }
                    Arc::new(f)
                }
            };
            let out = OutputDir::create(&dir, force, &protected).map_err(other)?;
            let problems = match (&*fin, &*kind) {
                (Fin::Planar(f), _) => {
                    planar_output::write_run(out.tmp_dir(), f, name, Outputs { figures })
                        .map_err(other)?
                        .1
                }
                (Fin::Spatial(f, _), Kind::Spatial(p)) => {
                    // As `tandem run` (spatial::cmd_run): the outputs, then scenario.toml.
                    let text = spatial_output::scenario_toml(&p.sc, name).map_err(other)?;
                    let (_, _, problems) =
                        tandem_cli::output::spatial::write(out.tmp_dir(), name, f, figures)
                            .map_err(other)?;
                    output::write_text_atomic(&out.tmp_dir().join("scenario.toml"), &text)
                        .map_err(other)?;
                    problems
                }
                (Fin::Spatial(..), Kind::Planar(_)) => {
                    return Err(Error::Other("a spatial run of a planar scenario".into()));
                }
            };
            let d = out.commit().map_err(other)?;
            Ok((d, problems))
        });
        let (d, problems) = py_res(py, r)?;
        let cat = py.get_type::<pyo3::exceptions::PyRuntimeWarning>();
        for p in problems {
            let msg = std::ffi::CString::new(p.replace('\0', " "))
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
            PyErr::warn(py, &cat, &msg, 1)?;
        }
        Ok(d.display().to_string())
    }

    /// Pickled as (scenario TOML, summary JSON, column names and units, the samples as bytes):
    /// the data travels, so a run returned from a worker process is not simulated again.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let f = py.import("tandem")?.getattr("_restore_run")?;
        let text = py_res(py, self.kind.to_toml())?;
        let summary = self.summary.to_string();
        let names: Vec<&str> = self.columns.iter().map(|c| c.0.as_str()).collect();
        let units: Vec<&str> = self.columns.iter().map(|c| c.1.as_str()).collect();
        let mut bytes = Vec::new();
        for a in &self.arrays {
            let a = a.bind(py).readonly();
            for x in a.as_slice()? {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
        }
        let args = (text, summary, names, units, PyBytes::new(py, &bytes)).into_pyobject(py)?;
        PyTuple::new(py, [f, args.into_any()])
    }

    /// Rebuild an unpickled run (see `__reduce__`).
    #[staticmethod]
    fn _from_state(
        py: Python<'_>,
        scenario_toml: &str,
        summary: &str,
        names: Vec<String>,
        units: Vec<String>,
        data: &[u8],
    ) -> PyResult<Self> {
        let p = py_res(py, kind_from_source(text_source(scenario_toml, None)))?;
        let summary: Json = serde_json::from_str(summary)
            .map_err(|e| PyValueError::new_err(format!("a pickled Run's summary: {e}")))?;
        let n = names.len();
        if units.len() != n || n == 0 || data.len() % (8 * n) != 0 {
            return Err(PyValueError::new_err(
                "a pickled Run's time series is malformed",
            ));
        }
        let rows = data.len() / (8 * n);
        let mut arrays = Vec::with_capacity(n);
        for j in 0..n {
            let col: Vec<f64> = data[j * rows * 8..(j + 1) * rows * 8]
                .chunks_exact(8)
                .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")))
                .collect();
            let a = col.into_pyarray(py);
            readonly(&a)?;
            arrays.push(a.unbind());
        }
        Ok(PyRun {
            kind: Arc::new(p),
            summary,
            columns: names.into_iter().zip(units).collect(),
            arrays,
            data: Data::Restored,
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Batches and sweeps.

/// The worker thread count of `threads=`: 1 to [`tandem_cli::MAX_THREADS`] (ValueError
/// otherwise, before any work), every core by default.
fn thread_count(threads: Option<usize>) -> PyResult<usize> {
    tandem_cli::threads(threads, "threads=").map_err(|e| PyValueError::new_err(e.to_string()))
}

fn pool(threads: Option<usize>) -> PyResult<rayon::ThreadPool> {
    let n = thread_count(threads)?;
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// A prepared run of either kind.
// One value per scenario or run, behind an `Arc` or in a `Vec`: boxing a variant saves nothing.
#[allow(clippy::large_enum_variant)]
enum Prep {
    Planar(runner::Prepared),
    Spatial(spatial::Prepared),
}

/// Closed-loop runs of many scenarios in Rust, on `threads` threads (default: every core), with
/// the GIL released; the Runs in input order (planar and spatial scenarios may be mixed). `scenarios` is a Scenario or a sequence of them;
/// `seeds` (one per scenario, or for a single scenario one run per seed) and `duration` override
/// `run.seed` and `run.duration`. The results do not depend on the thread count.
#[pyfunction]
#[pyo3(signature = (scenarios, seeds=None, threads=None, duration=None))]
fn rollout(
    py: Python<'_>,
    scenarios: &Bound<'_, PyAny>,
    seeds: Option<Vec<u64>>,
    threads: Option<usize>,
    duration: Option<f64>,
) -> PyResult<Vec<PyRun>> {
    let list: Vec<Arc<Kind>> = if let Ok(s) = scenarios.cast::<PyScenario>() {
        let n = seeds.as_ref().map_or(1, Vec::len);
        vec![s.get().kind.clone(); n]
    } else {
        let mut v = Vec::new();
        for (i, x) in scenarios.try_iter()?.enumerate() {
            let x = x?;
            let s = x.cast::<PyScenario>().map_err(|_| {
                PyTypeError::new_err(format!(
                    "scenarios[{i}] is a {}, not a tandem.Scenario",
                    x.get_type()
                        .name()
                        .map(|n| n.to_string())
                        .unwrap_or_default()
                ))
            })?;
            v.push(s.get().kind.clone());
        }
        v
    };
    if let Some(s) = &seeds {
        if s.len() != list.len() {
            return Err(PyValueError::new_err(format!(
                "{} seeds for {} scenarios: give one seed per scenario",
                s.len(),
                list.len()
            )));
        }
    }
    let pool = pool(threads)?;
    py_res(py, check_kernel())?;
    let mut jobs = Vec::with_capacity(list.len());
    for (i, k) in list.iter().enumerate() {
        let seed = seeds.as_ref().map(|s| s[i]);
        let p = k.with_run(duration, seed).map_err(|e| {
            let e = match e {
                Error::Field { path, message } => Error::Field {
                    path,
                    message: format!("scenarios[{i}]: {message}"),
                },
                other => other,
            };
            e.into_py(py)
        })?;
        jobs.push(Arc::new(p));
    }
    let work = jobs.clone();
    // Every run is prepared (validated) before any runs, so bad input fails fast.
    let results: Result<Vec<Fin>, (usize, Error)> = py.detach(move || {
        pool.install(|| {
            let prepared = work
                .par_iter()
                .enumerate()
                .map(|(i, k)| {
                    match &**k {
                        Kind::Planar(p) => runner::prepare(p.sc.clone(), &p.src).map(Prep::Planar),
                        Kind::Spatial(p) => {
                            spatial::prepare(p.sc.clone(), &p.src).map(Prep::Spatial)
                        }
                    }
                    .map_err(|e| (i, Error::from(e)))
                })
                .collect::<Vec<_>>()
                // In index order: the error reported is the first scenario's, whichever thread
                // finished first (rayon's own Result collect returns any of them).
                .into_iter()
                .collect::<Result<Vec<_>, _>>()?;
            prepared
                .into_par_iter()
                .enumerate()
                .map(|(i, p)| match p {
                    Prep::Planar(p) => Ok(Fin::Planar(runner::execute(p, |_| {}))),
                    Prep::Spatial(p) => {
                        spatial_fin(spatial::execute(p, |_| {})).map_err(|e| (i, e))
                    }
                })
                .collect::<Vec<_>>()
                .into_iter()
                .collect()
        })
    });
    let finished = results.map_err(|(i, e)| {
        match e {
            Error::Scenario(e) => Error::Field {
                path: error_path(&e),
                message: format!("scenarios[{i}]: {e}"),
            },
            other => other,
        }
        .into_py(py)
    })?;
    let mut out = Vec::with_capacity(finished.len());
    for (k, fin) in jobs.into_iter().zip(finished) {
        out.push(PyRun::live(py, k, fin)?);
    }
    Ok(out)
}

/// Run a sweep (a sweep file's path, or its content as a dict) and return
/// `(csv_text, header)`: the `runs.csv` of `tandem sweep`. `tandem.sweep` wraps it.
#[pyfunction]
#[pyo3(signature = (spec, shard=None, threads=None))]
fn _sweep_csv(
    py: Python<'_>,
    spec: &Bound<'_, PyAny>,
    shard: Option<&Bound<'_, PyAny>>,
    threads: Option<usize>,
) -> PyResult<(String, Vec<String>)> {
    thread_count(threads)?;
    let sw = if let Ok(d) = spec.cast::<PyDict>() {
        let Value::Table(t) = to_toml(d.as_any(), "sweep")? else {
            unreachable!("a dict converts to a table")
        };
        let text = toml::to_string(&t).map_err(|e| PyValueError::new_err(e.to_string()))?;
        let dir = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
        py_res(
            py,
            sweep::Sweep::from_text("sweep dict", &text, &dir).map_err(Error::from),
        )?
    } else {
        let path: PathBuf = spec.extract().map_err(|_| {
            PyTypeError::new_err("sweep: give the path of a sweep file or a dict of its content")
        })?;
        py_res(py, sweep::Sweep::load(&path).map_err(Error::from))?
    };
    let shard = match shard {
        None => None,
        Some(s) => {
            if let Ok(t) = s.extract::<(u64, u64)>() {
                Some(py_res(
                    py,
                    sweep::Shard::new(t.0, t.1).map_err(|m| bad(None, format!("shard={t:?}: {m}"))),
                )?)
            } else {
                let s: String = s.extract().map_err(|_| {
                    PyTypeError::new_err("shard: give \"I/N\", (I, N) or \"slurm\"")
                })?;
                if s == "slurm" {
                    let from_env = py_res(py, sweep::Shard::from_env().map_err(Error::from))?;
                    if from_env.is_none() {
                        return Err(bad(
                            None,
                            "shard=\"slurm\": SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT are \
                             not set (is this a Slurm job array task?); nothing was run",
                        )
                        .into_py(py));
                    }
                    from_env
                } else {
                    Some(py_res(
                        py,
                        sweep::Shard::parse(&s, "shard=").map_err(Error::from),
                    )?)
                }
            }
        }
    };
    let pool_threads = thread_count(threads)?;
    let r = py.detach(move || -> Result<(String, Vec<String>), String> {
        let idx = sweep::run::indices(&sw, shard);
        let results =
            sweep::run::run_all(&sw, &idx, pool_threads, None).map_err(|e| format!("{e:#}"))?;
        let header = sweep::run::header(&sw);
        let rows: Vec<sweep::run::Row> = results.into_iter().map(|r| r.row).collect();
        let csv = sweep::run::csv_text(&header, &rows).map_err(|e| format!("{e:#}"))?;
        Ok((csv, header))
    });
    r.map_err(PyRuntimeError::new_err)
}

/// The names of the embedded scenarios, for `Scenario.preset`: the planar ones, then the
/// spatial ones (`dual-ur5`, `dual-franka`).
#[pyfunction]
fn presets() -> Vec<&'static str> {
    scenario::EMBEDDED.iter().map(|e| e.name).collect()
}

#[pymodule]
fn _tandem(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<PyScenario>()?;
    m.add_class::<PyRun>()?;
    m.add_class::<PyController>()?;
    m.add_class::<PyPlant>()?;
    m.add_class::<PyJointPd>()?;
    m.add_class::<LogOwner>()?;
    m.add_function(wrap_pyfunction!(rollout, m)?)?;
    m.add_function(wrap_pyfunction!(presets, m)?)?;
    m.add_function(wrap_pyfunction!(_sweep_csv, m)?)?;
    m.add("ScenarioError", py.get_type::<ScenarioError>())?;
    m.add("ScenarioWarning", py.get_type::<ScenarioWarning>())?;
    m.add("PlantFault", py.get_type::<PlantFault>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
