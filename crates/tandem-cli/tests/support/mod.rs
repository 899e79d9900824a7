//! Helpers shared by the integration tests: scratch folders, running the `tandem` binary, the
//! paper scenario with edits, reading the outputs, and structural checks of PNG and SVG files.
//! Each test file includes it with `mod support;` and uses a part of it.

#![allow(dead_code)]

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The `tandem` binary of this build.
pub const BIN: &str = env!("CARGO_BIN_EXE_tandem");

/// A fresh, empty scratch folder, named after the test file, `name`, the process and a counter.
pub fn scratch(name: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let d = std::env::temp_dir().join(format!(
        "tandem-{}-{name}-{}-{}",
        env!("CARGO_CRATE_NAME"),
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).expect("create scratch folder");
    d
}

/// Run the binary in `cwd` (outside any Slurm job array: a sweep picks its shard from those
/// variables).
pub fn tandem(cwd: &Path, args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(cwd)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("SLURM_ARRAY_TASK_COUNT")
        .output()
        .expect("run tandem")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn code(o: &Output) -> i32 {
    o.status.code().unwrap_or(-1)
}

/// Assert exit code `c`, showing the output otherwise.
pub fn exit(o: &Output, c: i32) {
    assert_eq!(
        code(o),
        c,
        "exit code\nstdout:\n{}\nstderr:\n{}",
        stdout(o),
        stderr(o)
    );
}

/// Assert success, showing the output otherwise.
pub fn ok(o: &Output) {
    exit(o, 0);
}

/// The embedded paper scenario's text.
pub fn paper_text(cwd: &Path) -> String {
    let o = tandem(cwd, &["scenario", "show", "paper"]);
    ok(&o);
    stdout(&o)
}

/// The paper scenario with each `from` replaced by `to` (which must occur once at least).
pub fn paper_edited(cwd: &Path, edits: &[(&str, &str)]) -> String {
    let mut text = paper_text(cwd);
    for (from, to) in edits {
        assert!(text.contains(from), "the paper scenario has no `{from}`");
        text = text.replacen(from, to, 1);
    }
    text
}

/// Write the edited paper scenario into `dir/name`.
pub fn paper_with(dir: &Path, name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let p = dir.join(name);
    fs::write(&p, paper_edited(dir, edits)).expect("write scenario");
    p
}

/// An embedded scenario (`tandem scenario show NAME`) with `nn` inserted at the top of its
/// `[controller.nn]` table and `tail` appended, written into `dir/file`; returns `file`.
pub fn embedded_with(dir: &Path, name: &str, file: &str, nn: &str, tail: &str) -> String {
    let o = tandem(dir, &["scenario", "show", name]);
    ok(&o);
    let mut text = stdout(&o);
    if !nn.is_empty() {
        assert!(
            text.contains("\n[controller.nn]\n"),
            "{name} has no [controller.nn]"
        );
        text = text.replacen(
            "\n[controller.nn]\n",
            &format!("\n[controller.nn]\n{nn}\n"),
            1,
        );
    }
    fs::write(dir.join(file), format!("{text}\n{tail}\n")).expect("write scenario");
    file.to_string()
}

/// The NN table lines that give the spatial presets the paper's switching and robust term
/// (SPEC §3.4: `ϖ` as given, `d1 = 1`, `d2 = 1.5`), as they were before the smooth default.
pub const PAPER_SWITCHING: &str = "smoothing = \"paper\"\nd1 = 1.0\nd2 = 1.5";

pub fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(path).expect("read json")).expect("parse json")
}

/// A CSV file as (header, columns); every record has the header's length.
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut rdr = csv::Reader::from_path(path).expect("open csv");
    let header: Vec<String> = rdr
        .headers()
        .expect("header")
        .iter()
        .map(String::from)
        .collect();
    let mut cols = vec![Vec::new(); header.len()];
    for rec in rdr.records() {
        let rec = rec.expect("record");
        assert_eq!(rec.len(), header.len());
        for (c, v) in rec.iter().enumerate() {
            cols[c].push(v.parse::<f64>().expect("number"));
        }
    }
    (header, cols)
}

/// The column `name` of [`read_csv`]'s output.
pub fn column<'a>(h: &[String], cols: &'a [Vec<f64>], name: &str) -> &'a [f64] {
    let i = h
        .iter()
        .position(|n| n == name)
        .unwrap_or_else(|| panic!("no column `{name}` in {h:?}"));
    &cols[i]
}

/// The file names in `dir`, sorted.
pub fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .expect("read_dir")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Reads a big-endian u32.
fn be32(b: &[u8], at: usize) -> u32 {
    u32::from_be_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// CRC-32 (ISO-HDLC, as PNG uses).
fn crc32(data: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in data {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// Checks a PNG file's structure: signature, IHDR size and colour type, every chunk's CRC,
/// non-empty image data, IEND last. Returns (width, height).
pub fn check_png(path: &Path) -> (u32, u32) {
    let b = fs::read(path).expect("read png");
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
    assert_eq!(&b[12..16], b"IHDR");
    let (w, h) = (be32(&b, 16), be32(&b, 20));
    assert_eq!(b[24], 8, "bit depth");
    let mut at = 8;
    let mut idat = 0usize;
    let mut last = [0u8; 4];
    while at + 12 <= b.len() {
        let len = be32(&b, at) as usize;
        let kind = &b[at + 4..at + 8];
        let body = &b[at + 4..at + 8 + len];
        assert_eq!(crc32(body), be32(&b, at + 8 + len), "CRC of chunk {kind:?}");
        if kind == b"IDAT" {
            idat += len;
        }
        last.copy_from_slice(kind);
        at += 12 + len;
    }
    assert_eq!(at, b.len(), "chunks fill the file");
    assert_eq!(&last, b"IEND");
    assert!(idat > 1000, "image data is non-trivial ({idat} bytes)");
    (w, h)
}

/// A minimal well-formedness check: every element opened is closed in order, one root `svg`.
pub fn check_xml(text: &str) {
    assert!(text.contains("<svg"), "has an <svg> element");
    assert!(text.trim_end().ends_with("</svg>"), "ends with </svg>");
    let mut stack: Vec<String> = Vec::new();
    let mut roots = 0;
    let mut rest = text;
    while let Some(start) = rest.find('<') {
        let end = rest[start..].find('>').expect("tag closed") + start;
        let tag = &rest[start + 1..end];
        rest = &rest[end + 1..];
        if tag.starts_with('?') || tag.starts_with('!') {
            continue;
        }
        if let Some(name) = tag.strip_prefix('/') {
            let open = stack.pop().expect("closing tag without opening");
            assert_eq!(open, name.trim(), "tags nest");
            continue;
        }
        let name: String = tag
            .chars()
            .take_while(|c| !c.is_whitespace() && *c != '/')
            .collect();
        if stack.is_empty() {
            roots += 1;
        }
        if !tag.ends_with('/') {
            stack.push(name);
        }
    }
    assert!(stack.is_empty(), "unclosed elements: {stack:?}");
    assert_eq!(roots, 1, "one root element");
    assert!(
        !text.contains("NaN") && !text.contains("inf\""),
        "no non-finite numbers"
    );
}

/// Run the binary in `cwd` (outside any Slurm job array, no standard input); `None` if it had
/// to be killed after `limit` (a regression that hangs fails its test instead of the suite).
pub fn within<S: AsRef<std::ffi::OsStr>>(
    cwd: &Path,
    args: &[S],
    limit: std::time::Duration,
) -> Option<Output> {
    use std::process::Stdio;
    let mut child = Command::new(BIN)
        .args(args)
        .current_dir(cwd)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("SLURM_ARRAY_TASK_COUNT")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn tandem");
    let t0 = std::time::Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            return Some(child.wait_with_output().expect("output"));
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

/// Copy a folder tree (files and sub-folders).
pub fn copy_dir(from: &Path, to: &Path) {
    fs::create_dir_all(to).expect("mkdir");
    for e in fs::read_dir(from).expect("read_dir").flatten() {
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            fs::copy(&p, to.join(e.file_name())).expect("copy");
        }
    }
}

/// The hardening tests' inputs, made once per test binary: the `paper` and `dual-ur5` texts and
/// a folder holding the two shards `A` and `B` of a small PD sweep (`sw.toml`).
pub struct Fixture {
    pub paper: String,
    pub spatial: String,
    pub shards: PathBuf,
}

pub const SHARD_SWEEP: &str = r#"
base = "paper"
duration = 0.2
[set]
"controller.kind" = "pd"
[vary]
"object.mass" = { grid = [1.0, 1.1] }
"#;

pub fn fixture() -> &'static Fixture {
    static F: std::sync::OnceLock<Fixture> = std::sync::OnceLock::new();
    F.get_or_init(|| {
        let d = scratch("fixture");
        let show = |name: &str| {
            let o = tandem(&d, &["scenario", "show", name]);
            ok(&o);
            stdout(&o)
        };
        let (paper, spatial) = (show("paper"), show("dual-ur5"));
        fs::write(d.join("sw.toml"), SHARD_SWEEP).expect("write");
        for (s, out) in [("0/2", "A"), ("1/2", "B")] {
            ok(&tandem(
                &d,
                &[
                    "sweep",
                    "sw.toml",
                    "--shard",
                    s,
                    "--out",
                    out,
                    "--no-figures",
                ],
            ));
        }
        Fixture {
            paper,
            spatial,
            shards: d,
        }
    })
}
