//! The scenario infrastructure both kinds of scenario stand on: where a scenario's text comes
//! from ([`Source`], the embedded catalogue, the bounded file readers), and what a problem with it
//! says ([`ScenarioError`]: file, field path, line, column, excerpt and suggestion; [`parse_as`]
//! turns serde's errors into one). It is the foot of `scenario/`: it imports nothing else of it.

use std::fmt;
use std::ops::Range;
use std::path::{Path as FsPath, PathBuf};

use serde::Serialize;
use tandem::ModelError;

use crate::suggest;

// ---------------------------------------------------------------------------------------------
// Embedded scenarios.

/// Planar (2-link arms in the plane, SPEC) or spatial (6/7-DOF arms from URDF in SE(3),
/// SPEC-spatial): decided once per scenario, from its parsed document ([`Kind::of`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `[[arms]]` with `[[arms.links]]`.
    Planar,
    /// `[[arms]]` naming a robot model (`model = "ur5"` or `urdf = "..."`).
    Spatial,
}

impl Kind {
    /// The kind of a parsed scenario document: spatial when an arm names a robot model (`model`
    /// or `urdf`), or when no arm says (no `model`, `urdf` or `links`) and the object is a box
    /// with three edge lengths; planar otherwise (its own parser then names what is missing).
    pub fn of(doc: &toml::Table) -> Kind {
        let arms = doc.get("arms").and_then(toml::Value::as_array);
        let has = |key: &str| {
            arms.is_some_and(|arms| {
                arms.iter()
                    .any(|a| a.as_table().is_some_and(|t| t.contains_key(key)))
            })
        };
        if has("model") || has("urdf") {
            return Kind::Spatial;
        }
        // No arm says (`arms = []`, or arms that name neither a robot nor links): a box with
        // three edge lengths is a spatial object (a planar one has two).
        let box_3d = doc
            .get("object")
            .and_then(|o| o.get("size"))
            .and_then(toml::Value::as_array)
            .is_some_and(|s| s.len() == 3);
        if !has("links") && box_3d {
            Kind::Spatial
        } else {
            Kind::Planar
        }
    }

    /// `planar` or `spatial`.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Planar => "planar",
            Kind::Spatial => "spatial",
        }
    }
}

/// An embedded scenario: name, one-line description, TOML text.
pub struct Embedded {
    /// Planar or spatial.
    pub kind: Kind,
    /// Name used on the command line (`tandem run paper`).
    pub name: &'static str,
    /// One line for `tandem scenario list`.
    pub summary: &'static str,
    /// The file.
    pub text: &'static str,
}

/// The scenarios compiled into the binary, planar first; the first is the default.
pub const EMBEDDED: &[Embedded] = &[
    Embedded {
        kind: Kind::Planar,
        name: "paper",
        summary: "the paper's Section V: two 2-link arms carry a box around a 0.2 m circle for 90 s",
        text: include_str!("../../scenarios/paper.toml"),
    },
    Embedded {
        kind: Kind::Planar,
        name: "push",
        summary: "the paper scenario with a 2 N push on the object at t = 20 s for 2 s (admittance compliance)",
        text: include_str!("../../scenarios/push.toml"),
    },
    Embedded {
        kind: Kind::Planar,
        name: "lemniscate",
        summary: "the paper's arms carry the box along a figure eight (Gerono lemniscate), noisy sensors",
        text: include_str!("../../scenarios/lemniscate.toml"),
    },
    Embedded {
        kind: Kind::Spatial,
        name: "dual-ur5",
        summary: "SPEC-spatial S6: two UR5-class arms facing each other carry a 3 kg box on a circle while it pitches (NN law)",
        text: include_str!("../../scenarios/dual-ur5.toml"),
    },
    Embedded {
        kind: Kind::Spatial,
        name: "dual-franka",
        summary: "two 7-DOF Franka-class arms grasp the box from above and carry it on the S6 path (NN law)",
        text: include_str!("../../scenarios/dual-franka.toml"),
    },
    Embedded {
        kind: Kind::Spatial,
        name: "dual-ur5-grip",
        summary: "dual-ur5 held by friction: two-pad grippers (μ = 0.3, 100 N a pad) instead of welds; slip, events and cone margins",
        text: include_str!("../../scenarios/dual-ur5-grip.toml"),
    },
];

/// The embedded scenarios of one kind, in catalogue order.
pub fn embedded(kind: Kind) -> impl Iterator<Item = &'static Embedded> {
    EMBEDDED.iter().filter(move |e| e.kind == kind)
}

/// The default scenario's name.
pub const DEFAULT: &str = "paper";

/// Where a scenario's text comes from.
#[derive(Clone, Debug)]
pub struct Source {
    /// Scenario name: the embedded name, or the file's stem.
    pub name: String,
    /// How errors name it: the file path, or `embedded scenario `paper``.
    pub display: String,
    /// The TOML text.
    pub text: String,
    /// Folder that relative paths inside the file (a replay file) are resolved against.
    pub dir: PathBuf,
    /// The scenario file, if it is one (never inside a folder `--force` replaces).
    pub file: Option<PathBuf>,
}

/// Resolve the command line's `SCENARIO`: an existing file, else an embedded name; `None` is the
/// default scenario.
pub fn resolve(arg: Option<&str>) -> Result<Source, crate::BadInput> {
    let arg = arg.unwrap_or(DEFAULT);
    let p = FsPath::new(arg);
    if p.is_file() {
        let text = read_limited(p, MAX_SCENARIO_BYTES).map_err(|e| {
            crate::BadInput::msg(format!("cannot read scenario file {}: {e}", p.display()))
        })?;
        let name = p
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scenario".into());
        let dir = p
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .map(FsPath::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("."));
        return Ok(Source {
            name,
            display: p.display().to_string(),
            text,
            dir,
            file: Some(p.to_path_buf()),
        });
    }
    let all = || EMBEDDED.iter();
    if let Some(e) = all().find(|e| e.name == arg) {
        return Ok(embedded_source(e));
    }
    let names: Vec<&str> = all().map(|e| e.name).collect();
    let looks_like_file = arg.ends_with(".toml") || arg.contains('/') || arg.contains('\\');
    let mut msg = if p.exists() {
        format!("scenario {arg} is not a file")
    } else if looks_like_file {
        format!("scenario file {arg} does not exist")
    } else {
        format!("`{arg}` is neither a scenario file nor an embedded scenario")
    };
    if !looks_like_file && let Some(s) = suggest::closest(arg, names.iter().copied()) {
        msg.push_str(&format!(" — did you mean `{s}`?"));
    }
    msg.push_str(&format!(
        " (embedded scenarios: {}; see `tandem scenario list`)",
        names.join(", ")
    ));
    Err(crate::BadInput::msg(msg))
}

/// Largest scenario file read, bytes (16 MiB; the embedded paper scenario is 12 kB).
pub const MAX_SCENARIO_BYTES: u64 = 16 << 20;

/// Most arms, and links per arm, a scenario may have (the plant's matrices grow with the
/// square of the joint count).
pub const MAX_ARMS: usize = 16;
/// See [`MAX_ARMS`].
pub const MAX_LINKS: usize = 16;

/// `O_NONBLOCK` of `open(2)` (without the `libc` crate): opening a FIFO for reading with it
/// returns at once instead of waiting for a writer. Zero (no flag) where the value is not
/// known; the file type is checked on the opened handle all the same.
#[cfg(all(
    any(target_os = "linux", target_os = "android"),
    not(any(
        target_arch = "mips",
        target_arch = "mips64",
        target_arch = "sparc",
        target_arch = "sparc64"
    ))
))]
const O_NONBLOCK: i32 = 0o4000;
#[cfg(any(
    target_os = "macos",
    target_os = "ios",
    target_os = "freebsd",
    target_os = "netbsd",
    target_os = "openbsd",
    target_os = "dragonfly"
))]
const O_NONBLOCK: i32 = 0x4;
#[cfg(not(any(
    all(
        any(target_os = "linux", target_os = "android"),
        not(any(
            target_arch = "mips",
            target_arch = "mips64",
            target_arch = "sparc",
            target_arch = "sparc64"
        ))
    ),
    target_os = "macos",
    target_os = "ios",
    target_os = "freebsd",
    target_os = "netbsd",
    target_os = "openbsd",
    target_os = "dragonfly"
)))]
const O_NONBLOCK: i32 = 0;

/// Why a file that is not a regular file cannot be read (its type, in words).
fn not_regular(t: &std::fs::FileType) -> String {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "it is a named pipe (FIFO), not a regular file".into();
        }
        if t.is_char_device() {
            return "it is a character device, not a regular file".into();
        }
        if t.is_block_device() {
            return "it is a block device, not a regular file".into();
        }
        if t.is_socket() {
            return "it is a socket, not a regular file".into();
        }
    }
    if t.is_dir() {
        "it is a folder, not a file".into()
    } else {
        "it is not a regular file".into()
    }
}

/// Open `p` for reading if it is a regular file; a FIFO, a device (`/dev/zero`), a folder or
/// a socket is refused at once. The file is opened with `O_NONBLOCK` (a FIFO does not wait
/// for a writer) and its type checked on the opened handle (nothing can swap the path between
/// the check and the read). Every file tandem reads is opened here: scenario, URDF, replay,
/// sweep file, a shard's `sweep.json` and `runs.csv`.
pub fn open_regular(p: &FsPath) -> Result<std::fs::File, String> {
    let mut o = std::fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(O_NONBLOCK);
    }
    let f = o.open(p).map_err(|e| e.to_string())?;
    let m = f.metadata().map_err(|e| e.to_string())?;
    if !m.is_file() {
        return Err(not_regular(&m.file_type()));
    }
    Ok(f)
}

/// A reader that fails (instead of ending) once more than its limit has been read: a file
/// read as a stream (replay, `runs.csv`) is never read past the limit, and never cut short
/// silently.
pub struct Limited<R> {
    inner: R,
    left: u64,
    limit: u64,
}

impl<R: std::io::Read> std::io::Read for Limited<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let max = (buf.len() as u64).min(self.left.saturating_add(1)) as usize;
        let n = self.inner.read(&mut buf[..max])?;
        if n as u64 > self.left {
            return Err(std::io::Error::other(format!(
                "the file is larger than {}",
                size_text(self.limit)
            )));
        }
        self.left -= n as u64;
        Ok(n)
    }
}

/// `limit` bytes in words (`16 MiB`).
fn size_text(limit: u64) -> String {
    if limit >= 1 << 30 && limit.is_multiple_of(1 << 30) {
        format!("{} GiB", limit >> 30)
    } else if limit >= 1 << 20 {
        format!("{} MiB", limit >> 20)
    } else {
        format!("{limit} bytes")
    }
}

/// [`open_regular`], read through a [`Limited`] reader of `limit` bytes.
pub fn open_limited(p: &FsPath, limit: u64) -> Result<Limited<std::fs::File>, String> {
    Ok(Limited {
        inner: open_regular(p)?,
        left: limit,
        limit,
    })
}

/// Read a UTF-8 regular file (see [`open_regular`]) of at most `limit` bytes (a larger one is
/// refused, never read whole). A leading UTF-8 byte-order mark (some editors write one) is
/// dropped: it is not part of the TOML or the URDF. The scenario, sweep, URDF and shard
/// `sweep.json` readers all read through here.
pub fn read_limited(p: &FsPath, limit: u64) -> Result<String, String> {
    use std::io::Read;
    let f = open_regular(p)?;
    let mut buf = Vec::new();
    f.take(limit + 1)
        .read_to_end(&mut buf)
        .map_err(|e| e.to_string())?;
    if buf.len() as u64 > limit {
        return Err(format!(
            "the file is larger than {} (scenario, sweep and URDF files are far smaller)",
            size_text(limit)
        ));
    }
    let bom = if buf.starts_with(b"\xef\xbb\xbf") {
        3
    } else {
        0
    };
    String::from_utf8(buf.split_off(bom)).map_err(|e| {
        let at = bom + e.utf8_error().valid_up_to();
        format!("the file is not UTF-8 text (invalid byte at offset {at})")
    })
}

/// The inputs of a scenario's run, for [`crate::files::check_replaceable`]: the scenario file
/// and every file the scenario names (any string field `urdf` or `replay`: `arms[0].urdf`,
/// `controller.replay`), resolved as the loaders resolve them (relative to the scenario file's
/// folder). `sc` is the scenario as run (with the command line's overrides); when it does not
/// serialize, the file's own text is read instead.
pub fn inputs<T: Serialize>(src: &Source, sc: &T) -> Vec<crate::files::Input> {
    let doc = toml::Table::try_from(sc)
        .ok()
        .or_else(|| toml::from_str::<toml::Table>(&src.text).ok())
        .unwrap_or_default();
    let mut v: Vec<crate::files::Input> = src
        .file
        .iter()
        .map(|f| crate::files::Input::new("the scenario", f))
        .collect();
    v.extend(named_files(src, &doc, ""));
    v
}

/// The files a scenario document names (see [`inputs`]); `what` prefixes their field paths.
pub fn named_files(src: &Source, doc: &toml::Table, what: &str) -> Vec<crate::files::Input> {
    fn walk(v: &toml::Value, path: &str, out: &mut Vec<(String, String)>) {
        match v {
            toml::Value::Table(t) => {
                for (k, x) in t {
                    let p = if path.is_empty() {
                        k.clone()
                    } else {
                        format!("{path}.{k}")
                    };
                    if let (true, toml::Value::String(f)) = (k == "urdf" || k == "replay", x) {
                        out.push((p.clone(), f.clone()));
                    }
                    walk(x, &p, out);
                }
            }
            toml::Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    walk(x, &format!("{path}[{i}]"), out);
                }
            }
            _ => {}
        }
    }
    let mut found = Vec::new();
    walk(&toml::Value::Table(doc.clone()), "", &mut found);
    found
        .into_iter()
        .map(|(p, f)| crate::files::Input::new(format!("{what}{p}"), resolve_named(src, &f)))
        .collect()
}

/// A file a scenario names, as its loaders resolve it: absolute, or relative to the
/// scenario file's folder.
pub fn resolve_named(src: &Source, f: &str) -> PathBuf {
    let p = FsPath::new(f);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        src.dir.join(p)
    }
}

/// The source of an embedded scenario.
pub fn embedded_source(e: &Embedded) -> Source {
    Source {
        name: e.name.to_string(),
        display: format!("embedded scenario `{}`", e.name),
        text: e.text.to_string(),
        dir: PathBuf::from("."),
        file: None,
    }
}

// ---------------------------------------------------------------------------------------------
// Errors.

/// A problem with a scenario: where (file, field path, line and column) and why.
#[derive(Debug, Clone)]
pub struct ScenarioError {
    /// The file (or `embedded scenario `name``).
    pub file: String,
    /// The message, including the field path.
    pub message: String,
    /// Byte range in the text, if known.
    pub span: Option<Range<usize>>,
    /// The text (for line, column and the source excerpt).
    pub text: String,
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // A message may quote the input (a value, a key): never more than a line of it.
        write!(f, "{}: {}", self.file, clip_middle(&self.message, 300, 100))?;
        if let Some(span) = &self.span
            && let Some(snippet) = excerpt(&self.text, span.clone())
        {
            write!(f, "\n{snippet}")?;
        }
        Ok(())
    }
}

impl std::error::Error for ScenarioError {}

/// A number for a message: shortest round-trip form, with an exponent outside
/// [1e-4, 1e6) (`1e9`, `1.7e96`, `-2.5e-7`), never hundreds of digits.
pub fn num(v: f64) -> String {
    let a = v.abs();
    if !v.is_finite() || a == 0.0 || (1e-4..1e6).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// To the thousandth (a millimetre, a thousandth of a degree), trailing zeros dropped, for
/// messages.
pub fn num_short(v: f64) -> String {
    let s = format!("{v:.3}");
    let t = s.trim_end_matches('0').trim_end_matches('.');
    if t.is_empty() || t == "-" {
        "0".into()
    } else {
        t.into()
    }
}

/// 1-based (line, column) of a byte offset (column in characters).
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..floor_char(text, offset)];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

fn floor_char(text: &str, mut i: usize) -> usize {
    while i > 0 && !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// ` (line L, column C)` for a span.
fn at_line(text: &str, span: &Option<Range<usize>>) -> String {
    match span {
        Some(s) => {
            let (l, c) = line_col(text, s.start);
            format!(" (line {l}, column {c})")
        }
        None => String::new(),
    }
}

/// Characters of a source line shown before and after the error's column.
const CONTEXT_BEFORE: usize = 40;
/// See [`CONTEXT_BEFORE`].
const CONTEXT_AFTER: usize = 60;

/// The source line of `span` with carets under it, rustc style; a long line is cut to
/// [`CONTEXT_BEFORE`] + [`CONTEXT_AFTER`] characters around the span (`…` marks the cuts).
fn excerpt(text: &str, span: Range<usize>) -> Option<String> {
    if text.is_empty() {
        return None;
    }
    let start = floor_char(text, span.start.min(text.len()));
    let (line, _) = line_col(text, start);
    // The line's bounds by search from the span (never a scan of the whole text's lines).
    let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
    let src = text[line_start..line_end].trim_end_matches('\r');
    let col = text[line_start..start].chars().count();
    let width = text[start..floor_char(text, span.end.clamp(start, line_end))]
        .chars()
        .count()
        .clamp(1, CONTEXT_AFTER);
    // The window [from, from + shown) of the line's characters.
    let from = col.saturating_sub(CONTEXT_BEFORE);
    let shown: String = src
        .chars()
        .skip(from)
        .take(CONTEXT_BEFORE + CONTEXT_AFTER)
        .collect();
    let cut_left = from > 0;
    let cut_right = src.chars().count() > from + CONTEXT_BEFORE + CONTEXT_AFTER;
    let n = line.to_string();
    let pad = " ".repeat(n.len());
    Some(format!(
        "{pad} |\n{n} | {}{shown}{}\n{pad} | {}{}",
        if cut_left { "…" } else { "" },
        if cut_right { "…" } else { "" },
        " ".repeat(col - from + usize::from(cut_left)),
        "^".repeat(width)
    ))
}

/// `s` cut to its first `head` and last `tail` characters (with `…` between) when longer: a
/// message that quotes a huge value keeps its start and its place (`(line L, column C)`).
pub fn clip_middle(s: &str, head: usize, tail: usize) -> String {
    let n = s.chars().count();
    if n <= head + tail + 1 {
        return s.to_string();
    }
    let a: String = s.chars().take(head).collect();
    let b: String = s.chars().skip(n - tail).collect();
    format!("{a}…{b}")
}

/// A value echoed in a message: whole up to 200 characters, else its first 200 and its length
/// (`xxxx… (10000000 chars)`), so that a message about a huge value is not itself huge.
pub fn echo(s: &str) -> String {
    let n = s.chars().count();
    if n <= 200 {
        s.to_string()
    } else {
        let head: String = s.chars().take(200).collect();
        format!("{head}… ({n} chars)")
    }
}

/// `s` cut to at most `n` characters (with `…`), for messages that echo the input.
pub fn clip(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        let mut c: String = s.chars().take(n).collect();
        c.push('…');
        c
    }
}

impl Source {
    /// An error at a field path (its span looked up in the text when the field is there).
    pub fn error_at(&self, path: &str, message: impl Into<String>) -> ScenarioError {
        let (span, exact) = match span_of(&self.text, path) {
            Some((s, e)) => (Some(s), e),
            None => (None, false),
        };
        let mut message = message.into();
        if !exact && !path.is_empty() {
            message.push_str(" (not set in the file: a default or preset value)");
        }
        let message = format!("{message}{}", at_line(&self.text, &span));
        ScenarioError {
            file: self.display.clone(),
            message,
            span,
            text: self.text.clone(),
        }
    }

    /// A warning about the field at `path`: `path: text (line L)`, or `(preset or default
    /// value, not set in the file)` when the file does not set it.
    pub fn warning_at(&self, path: &str, text: &str) -> String {
        let body = text
            .strip_prefix(path)
            .map_or(text, |r| r.trim_start_matches([':', ' ']));
        let body = if text.starts_with(path) && !text[path.len()..].starts_with(':') {
            // `admittance.m_e[0] = 0 selects ...`: keep the sentence whole.
            text
        } else {
            body
        };
        let place = match span_of(&self.text, path) {
            Some((s, true)) => {
                let (l, _) = line_col(&self.text, s.start);
                format!(" ({}, line {l})", self.display)
            }
            _ => " (preset or default value, not set in the file)".to_string(),
        };
        if body.starts_with(path) {
            format!("{body}{place}")
        } else {
            format!("{path}: {body}{place}")
        }
    }

    /// A library validation error, its parameter path mapped to the file's by `map`.
    pub fn model_error(&self, e: ModelError, map: impl Fn(&str) -> String) -> ScenarioError {
        match e {
            ModelError::Invalid {
                param,
                value,
                reason,
            } => {
                let path = map(&param);
                self.error_at(&path, format!("{path} = {}: {reason}", num(value)))
            }
            // The kernel comes from the environment, not from the file: no field, no line.
            ModelError::Geometry { what, reason } if what == tandem::control::rbf::KERNEL_ENV => {
                self.error_at("", format!("environment variable {what}: {reason}"))
            }
            ModelError::Geometry { what, reason } => {
                let path = map(&what);
                self.error_at(&path, format!("{path}: {reason}"))
            }
            other => self.error_at("", other.to_string()),
        }
    }
}

/// Path segments of `a.b[1].c`.
pub(crate) fn segments(path: &str) -> Vec<Result<String, usize>> {
    let mut out = Vec::new();
    for part in path.split('.').filter(|s| !s.is_empty()) {
        let mut rest = part;
        if let Some(i) = rest.find('[') {
            if i > 0 {
                out.push(Ok(rest[..i].to_string()));
            }
            rest = &rest[i..];
            while let Some(stripped) = rest.strip_prefix('[') {
                let Some(end) = stripped.find(']') else { break };
                if let Ok(k) = stripped[..end].parse() {
                    out.push(Err(k));
                }
                rest = &stripped[end + 1..];
            }
        } else {
            out.push(Ok(rest.to_string()));
        }
    }
    out
}

/// The span of the value at `path` (or of its nearest ancestor present in the file, with
/// `false`).
pub fn span_of(text: &str, path: &str) -> Option<(Range<usize>, bool)> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(text).ok()?;
    let segs = segments(path);
    let mut best: Option<Range<usize>> = None;
    let mut table: Option<&DeTable> = Some(root.get_ref());
    let mut value: Option<&DeValue> = None;
    for (i, seg) in segs.iter().enumerate() {
        // A scalar given for a per-axis value (`m_e = 200` for `m_e[1]`) is the value itself.
        if let (Err(_), Some(v)) = (seg, value)
            && !v.is_array()
            && segs[i..].iter().all(|s| s.is_err())
        {
            return best.map(|b| (b, true));
        }
        let next = match (seg, value, table) {
            (Ok(key), _, Some(t)) => t
                .iter()
                .find(|(k, _)| k.get_ref().as_ref() == key.as_str())
                .map(|(_, v)| v),
            (Err(k), Some(v), _) => v.as_array().and_then(|a| a.get(*k)),
            _ => None,
        };
        match next {
            Some(v) => {
                best = Some(v.span());
                value = Some(v.get_ref());
                table = v.get_ref().as_table();
            }
            None => return best.map(|b| (b, false)),
        }
    }
    best.map(|b| (b, true))
}

/// Parse a TOML text into `T` (planar or spatial scenario): syntax errors and serde errors with
/// the file, line, column, field path and a suggestion for a misspelt field, then the strict
/// array lengths of `check_lengths`.
pub fn parse_as<T: serde::de::DeserializeOwned + Serialize>(
    src: &Source,
) -> Result<T, ScenarioError> {
    let err = |message: String, span: Option<Range<usize>>| ScenarioError {
        file: src.display.clone(),
        message,
        span,
        text: src.text.clone(),
    };
    let de = toml::Deserializer::parse(&src.text).map_err(|e| {
        let span = e.span();
        err(
            format!(
                "TOML syntax error: {}{}",
                e.message().trim_end(),
                at_line(&src.text, &span)
            ),
            span,
        )
    })?;
    let sc = serde_path_to_error::deserialize::<_, T>(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.inner();
        let span = inner.span();
        let msg = inner.message().trim_end().to_string();
        err(describe(&path, &msg, &src.text, &span), span)
    })?;
    check_lengths(src, &sc)?;
    Ok(sc)
}

/// A scenario `name` becomes part of the default output folder `out/<name>-...`: it must be a
/// plain name (no path separators, not `.` or `..`, no leading dot, no control characters, at
/// most 100 characters), so the folder stays inside `out/`.
pub fn check_name(src: &Source, n: &str) -> Result<(), ScenarioError> {
    let why = if n.trim().is_empty() {
        None
    } else if n.contains('/') || n.contains('\\') {
        Some("must not contain a path separator (it names the output folder out/<name>-...)")
    } else if n.starts_with('.') {
        Some("must not start with a dot (it names the output folder out/<name>-...)")
    } else if n.chars().any(char::is_control) {
        Some("must not contain control characters")
    } else if n.chars().count() > 100 {
        Some("must be at most 100 characters")
    } else {
        None
    };
    match why {
        None => Ok(()),
        Some(w) => Err(src.error_at("name", format!("name = {:?}: {w}", clip(n, 60)))),
    }
}

/// Every array in the file has exactly the length of the field it fills: serde reads the first
/// N entries of a fixed-size array and ignores the rest (`base = [-0.38, 0.0, 99.0, "x"]` was
/// read as `[-0.38, 0.0]`). The parsed scenario is written back and every array of the file
/// compared with the one at the same path, whatever struct (the CLI's or the library's) it
/// filled.
fn check_lengths<T: Serialize>(src: &Source, sc: &T) -> Result<(), ScenarioError> {
    use toml::de::DeValue;
    first_in_file(src, sc, &mut |path, v, back| match (v.get_ref(), back) {
        (DeValue::Array(a), toml::Value::Array(b)) if a.len() != b.len() => Some(format!(
            "{path} has {} entries; it takes exactly {}",
            a.len(),
            b.len()
        )),
        _ => None,
    })
}

/// A number that is not finite (`nan`, `inf`) anywhere in the file's known fields, also in a
/// section the run does not use (the gains of another law, which `tandem compare` would use),
/// is an error naming the field. Run after the field-specific checks, whose messages say more.
/// The actuator's limits take `inf` ("no limit": `effort` on a joint without one, and
/// `rate_limit = inf` to turn an embedded robot's default off), never `-inf` or `nan`.
pub(crate) fn check_finite<T: Serialize>(src: &Source, sc: &T) -> Result<(), ScenarioError> {
    first_in_file(src, sc, &mut |path, _, back| match back {
        toml::Value::Float(x)
            if *x == f64::INFINITY
                && (path == "controller.actuator.rate_limit"
                    || path.starts_with("controller.actuator.effort")) =>
        {
            None
        }
        toml::Value::Float(x) if !x.is_finite() => {
            Some(format!("{path} = {}: must be a finite number", num(*x)))
        }
        _ => None,
    })
}

/// What [`first_in_file`] asks of each field: `(path, the value in the file, the value as read)`
/// → an error message, or `None` to go on.
type Visit<'v> =
    dyn FnMut(&str, &toml::Spanned<toml::de::DeValue<'_>>, &toml::Value) -> Option<String> + 'v;

/// Walks the fields the file sets together with their values as read (`sc` serialized back),
/// depth first in the file's order, and returns the first for which `visit(path, in the file,
/// as read)` gives a message as an error at that field.
fn first_in_file<T: Serialize>(
    src: &Source,
    sc: &T,
    visit: &mut Visit<'_>,
) -> Result<(), ScenarioError> {
    use toml::de::{DeTable, DeValue};
    let Ok(back) = toml::Value::try_from(sc) else {
        return Ok(());
    };
    let Ok(root) = DeTable::parse(&src.text) else {
        return Ok(());
    };
    fn walk(
        path: &str,
        v: &toml::Spanned<DeValue<'_>>,
        back: &toml::Value,
        visit: &mut Visit<'_>,
    ) -> Option<(String, Range<usize>)> {
        if let Some(m) = visit(path, v, back) {
            return Some((m, v.span()));
        }
        match (v.get_ref(), back) {
            (DeValue::Array(a), toml::Value::Array(b)) => a
                .iter()
                .zip(b.iter())
                .enumerate()
                .find_map(|(i, (x, y))| walk(&format!("{path}[{i}]"), x, y, visit)),
            (DeValue::Table(t), toml::Value::Table(b)) => t.iter().find_map(|(k, x)| {
                let key = k.get_ref().as_ref();
                let y = b.get(key)?;
                let p = if path.is_empty() {
                    key.to_string()
                } else {
                    format!("{path}.{key}")
                };
                walk(&p, x, y, visit)
            }),
            _ => None,
        }
    }
    let toml::Value::Table(b) = &back else {
        return Ok(());
    };
    let found = root.get_ref().iter().find_map(|(k, x)| {
        let key = k.get_ref().as_ref();
        walk(key, x, b.get(key)?, visit)
    });
    match found {
        None => Ok(()),
        Some((message, span)) => Err(ScenarioError {
            file: src.display.clone(),
            message: format!("{message}{}", at_line(&src.text, &Some(span.clone()))),
            span: Some(span),
            text: src.text.clone(),
        }),
    }
}

/// Turn serde's message and path into a sentence with the place and a suggestion.
fn describe(path: &str, msg: &str, text: &str, span: &Option<Range<usize>>) -> String {
    let place = at_line(text, span);
    let parent = |p: &str| -> String {
        // The path of an unknown field ends with the field itself.
        let cut = p.rfind('.').unwrap_or(0);
        let parent = &p[..cut];
        if parent.is_empty() || parent == "." {
            "the top level".to_string()
        } else {
            parent.to_string()
        }
    };
    let ticks: Vec<&str> = msg.split('`').skip(1).step_by(2).collect();
    if msg.starts_with("unknown field ") {
        let name = ticks.first().copied().unwrap_or("");
        let expected: Vec<&str> = ticks.iter().skip(1).copied().collect();
        let mut s = format!("unknown field `{name}` at {}{place}", parent(path));
        match suggest::closest(name, expected.iter().copied()) {
            Some(c) => s.push_str(&format!(" — did you mean `{c}`?")),
            None if !expected.is_empty() => s.push_str(&format!(
                "; expected one of {}",
                expected
                    .iter()
                    .map(|e| format!("`{e}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
            None => s.push_str("; this table takes no fields"),
        }
        return s;
    }
    if msg.starts_with("unknown variant ") {
        let name = ticks.first().copied().unwrap_or("");
        let expected: Vec<&str> = ticks.iter().skip(1).copied().collect();
        let mut s = format!("unknown value \"{name}\" for {path}{place}");
        if let Some(c) = suggest::closest(name, expected.iter().copied()) {
            s.push_str(&format!(" — did you mean \"{c}\"?"));
        } else {
            s.push_str(&format!(
                "; expected one of {}",
                expected
                    .iter()
                    .map(|e| format!("\"{e}\""))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        return s;
    }
    if msg.starts_with("missing field ") {
        let name = ticks.first().copied().unwrap_or("");
        let at = if path.is_empty() || path == "." {
            "the top level".to_string()
        } else {
            path.to_string()
        };
        return format!("missing field `{name}` in {at}{place}");
    }
    let at = if path.is_empty() || path == "." {
        String::new()
    } else {
        format!(" at {path}")
    };
    format!("{msg}{at}{place}")
}
