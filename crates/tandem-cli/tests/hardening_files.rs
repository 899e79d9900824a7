//! Issue 22, "Never delete or overwrite an input": every entry point that replaces a folder
//! (`run`, `compare`, `robustness`, `sweep`, `merge`; Python's `Run.write` in
//! python/tests/test_hardening.py) goes through one table of cases, and an interrupted
//! `--force` leaves nothing that the next run does not clean up (and the next run cleans up
//! nothing else).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod support;
use support::*;

/// Every entry under `dir` (files with their content, folders, symbolic links with their
/// target), sorted, to compare a tree before and after.
fn tree(dir: &Path) -> Vec<(PathBuf, String)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(rd) = fs::read_dir(&d) else { continue };
        for e in rd.flatten() {
            let p = e.path();
            let m = fs::symlink_metadata(&p).expect("metadata");
            if m.file_type().is_symlink() {
                let t = fs::read_link(&p).expect("read_link");
                out.push((p, format!("-> {}", t.display())));
            } else if m.is_dir() {
                out.push((p.clone(), "/".into()));
                stack.push(p);
            } else {
                let b = fs::read(&p).expect("read");
                out.push((p, String::from_utf8_lossy(&b).into_owned()));
            }
        }
    }
    out.sort();
    out
}

fn run_in(cwd: &Path, args: &[String]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(cwd)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("SLURM_ARRAY_TASK_COUNT")
        .output()
        .expect("run tandem")
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// A planar scenario (paper, PD, 0.2 s) at `p`.
fn planar(p: &Path) {
    fs::create_dir_all(p.parent().expect("parent")).expect("mkdir");
    fs::write(p, &fixture().paper).expect("write scenario");
}

/// The dual-UR5 scenario at `p`, reading its arms from the URDF file `urdf` (as the scenario
/// names it, relative to its folder).
fn spatial(p: &Path, urdf_abs: &Path) {
    fs::create_dir_all(p.parent().expect("parent")).expect("mkdir");
    fs::create_dir_all(urdf_abs.parent().expect("parent")).expect("mkdir");
    fs::write(urdf_abs, tandem::model::spatial::urdf::UR5_URDF).expect("write urdf");
    let text = fixture().spatial.replace(
        "\nmodel = \"ur5\"",
        &format!(
            "\nurdf = \"{}\"\nbase_link = \"base_link\"\ntool_link = \"tool0\"",
            urdf_abs.display()
        ),
    );
    assert!(text.contains("urdf ="), "the preset names its model");
    fs::write(p, text).expect("write scenario");
}

/// One entry point with one of its inputs as the subject: `make(root, at)` writes the work's
/// inputs under `root` (the subject under `root/at`, every other input under `root/in`) and
/// returns the command line (without `--out`, `--force`) and the subject's path.
struct Row {
    entry: &'static str,
    input: &'static str,
    make: fn(&Path, &str) -> (Vec<String>, PathBuf),
}

fn args(v: &[&str]) -> Vec<String> {
    v.iter().map(|a| a.to_string()).collect()
}

const SHORT: [&str; 5] = ["--duration", "0.2", "--no-figures", "--controller", "pd"];

fn rows() -> Vec<Row> {
    vec![
        Row {
            entry: "run",
            input: "the scenario",
            make: |root, at| {
                let p = root.join(at).join("s.toml");
                planar(&p);
                let mut a = args(&["run", &s(&p)]);
                a.extend(args(&SHORT));
                (a, p)
            },
        },
        Row {
            entry: "run",
            input: "--replay",
            make: |root, at| {
                let sc = root.join("in/s.toml");
                planar(&sc);
                let r = root.join(at).join("tau.csv");
                fs::create_dir_all(r.parent().expect("parent")).expect("mkdir");
                fs::write(&r, "t,tau1,tau2,tau3,tau4\n0,0,0,0,0\n").expect("write");
                let a = args(&[
                    "run",
                    &s(&sc),
                    "--controller",
                    "replay",
                    "--replay",
                    &s(&r),
                    "--duration",
                    "0.2",
                    "--no-figures",
                ]);
                (a, r)
            },
        },
        Row {
            entry: "run (spatial)",
            input: "arms[0].urdf",
            make: |root, at| {
                let sc = root.join("in/my.toml");
                let u = root.join(at).join("arm.urdf");
                spatial(&sc, &u);
                (
                    args(&["run", &s(&sc), "--duration", "0.1", "--no-figures"]),
                    u,
                )
            },
        },
        Row {
            entry: "compare",
            input: "the scenario",
            make: |root, at| {
                let p = root.join(at).join("s.toml");
                planar(&p);
                (
                    args(&["compare", &s(&p), "--duration", "0.2", "--no-figures"]),
                    p,
                )
            },
        },
        Row {
            entry: "compare (spatial)",
            input: "arms[0].urdf",
            make: |root, at| {
                let sc = root.join("in/my.toml");
                let u = root.join(at).join("arm.urdf");
                spatial(&sc, &u);
                (
                    args(&["compare", &s(&sc), "--duration", "0.1", "--no-figures"]),
                    u,
                )
            },
        },
        Row {
            entry: "robustness",
            input: "the scenario",
            make: |root, at| {
                let p = root.join(at).join("s.toml");
                planar(&p);
                (args(&["robustness", &s(&p), "--duration", "0.2"]), p)
            },
        },
        Row {
            entry: "sweep",
            input: "the sweep file",
            make: |root, at| {
                let p = root.join(at).join("sw.toml");
                fs::create_dir_all(p.parent().expect("parent")).expect("mkdir");
                fs::write(&p, SHARD_SWEEP).expect("write");
                (args(&["sweep", &s(&p), "--no-figures"]), p)
            },
        },
        Row {
            entry: "sweep",
            input: "the base scenario",
            make: |root, at| {
                let b = root.join(at).join("base.toml");
                planar(&b);
                let p = root.join("in/sw.toml");
                fs::create_dir_all(p.parent().expect("parent")).expect("mkdir");
                let text =
                    SHARD_SWEEP.replace("base = \"paper\"", &format!("base = \"{}\"", s(&b)));
                fs::write(&p, text).expect("write");
                (args(&["sweep", &s(&p), "--no-figures"]), b)
            },
        },
        Row {
            entry: "sweep (spatial)",
            input: "the base's arms[0].urdf",
            make: |root, at| {
                let b = root.join("in/base.toml");
                let u = root.join(at).join("arm.urdf");
                spatial(&b, &u);
                let p = root.join("in/sw.toml");
                fs::write(
                    &p,
                    "base = \"base.toml\"\nduration = 0.1\n[vary]\n\"object.mass\" = { grid = [2.0] }\n",
                )
                .expect("write");
                (args(&["sweep", &s(&p), "--no-figures"]), u)
            },
        },
        Row {
            entry: "merge",
            input: "a shard folder",
            make: |root, at| {
                let a = root.join("in/A");
                let b = root.join(at).join("B");
                copy_dir(&fixture().shards.join("A"), &a);
                copy_dir(&fixture().shards.join("B"), &b);
                (args(&["merge", &s(&a), &s(&b), "--no-figures"]), b)
            },
        },
    ]
}

/// The table: for every entry point and input, each way `--out DIR --force` could destroy
/// something is refused, names what it protects, and leaves every file as it was.
#[test]
fn force_never_deletes_an_input_or_a_folder_tandem_did_not_write_at_any_entry_point() {
    let mut failures = Vec::new();
    for row in rows() {
        for case in [
            "user folder without marker",
            "input inside",
            "input is the folder",
            "parent of the current folder",
            "current folder",
            "symlink",
            "file",
        ] {
            let d = scratch("table");
            // The inputs live in `d` except in the current/parent cases, where they live in a
            // folder of their own (so that the refusal is about the current folder).
            let elsewhere = scratch("table-inputs");
            let mut cwd = d.clone();
            let (root, at) = match case {
                "input inside" => (d.clone(), "res"),
                "parent of the current folder" | "current folder" => (elsewhere.clone(), "in"),
                _ => (d.clone(), "in"),
            };
            let (mut argv, subject) = (row.make)(&root, at);
            let subject_name = subject
                .file_name()
                .expect("name")
                .to_string_lossy()
                .into_owned();
            // What `--out` names, made a tandem output (with the marker) wherever it is a
            // folder, so that only the protection of inputs stands between it and deletion.
            let marker = |p: &Path| fs::write(p.join(".tandem-output"), "").expect("marker");
            let (out, expect): (String, Vec<String>) = match case {
                "user folder without marker" => {
                    fs::create_dir_all(d.join("mine")).expect("mkdir");
                    fs::write(d.join("mine/photo.jpg"), "mine").expect("write");
                    ("mine".into(), vec![".tandem-output".into()])
                }
                "input inside" => {
                    marker(&d.join("res"));
                    fs::write(d.join("res/old.txt"), "old results").expect("write");
                    (
                        "res".into(),
                        vec!["holds the input".into(), subject_name.clone()],
                    )
                }
                "input is the folder" => (
                    s(&subject),
                    vec!["is the input".into(), subject_name.clone()],
                ),
                "parent of the current folder" | "current folder" => {
                    cwd = d.join("here");
                    fs::create_dir_all(&cwd).expect("mkdir");
                    marker(&d);
                    marker(&cwd);
                    fs::write(cwd.join("notes.txt"), "mine").expect("write");
                    (
                        if case == "current folder" { "." } else { ".." }.into(),
                        vec!["current folder".into()],
                    )
                }
                "symlink" => {
                    fs::create_dir_all(d.join("real")).expect("mkdir");
                    marker(&d.join("real"));
                    fs::write(d.join("real/keep.txt"), "mine").expect("write");
                    std::os::unix::fs::symlink(d.join("real"), d.join("link")).expect("symlink");
                    ("link".into(), vec!["symbolic link".into()])
                }
                "file" => {
                    fs::write(d.join("notes.txt"), "mine").expect("write");
                    ("notes.txt".into(), vec!["is a file".into()])
                }
                _ => unreachable!(),
            };
            argv.extend(["--out".to_string(), out.clone(), "--force".to_string()]);
            let (before, before_inputs) = (tree(&d), tree(&elsewhere));
            let o = run_in(&cwd, &argv);
            let err = stderr(&o);
            let mut wrong = Vec::new();
            if code(&o) != 2 {
                wrong.push(format!("exit {}", code(&o)));
            }
            for e in expect
                .iter()
                .map(String::as_str)
                .chain(["nothing was run or deleted"])
            {
                if !err.contains(e) {
                    wrong.push(format!("message lacks `{e}`"));
                }
            }
            if tree(&d) != before || tree(&elsewhere) != before_inputs {
                wrong.push("files changed".into());
            }
            if !wrong.is_empty() {
                failures.push(format!(
                    "{} / {} / {case} (--out {out}): {}\n    {}",
                    row.entry,
                    row.input,
                    wrong.join("; "),
                    err.trim().replace('\n', "\n    ")
                ));
            }
            let _ = fs::remove_dir_all(&d);
            let _ = fs::remove_dir_all(&elsewhere);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// `merge A B --out A --force` and `--out` holding the shards (the two cases the issue reports),
/// with real shard folders whose kept runs would be lost for good.
#[test]
fn merge_never_replaces_its_own_shards() {
    let d = scratch("merge-own");
    copy_dir(&fixture().shards.join("A"), &d.join("A"));
    copy_dir(&fixture().shards.join("B"), &d.join("sub/B"));
    fs::write(d.join("sub/.tandem-output"), "").expect("marker");
    let before = tree(&d);
    for (out, name) in [("A", "A"), ("sub", "B")] {
        let o = tandem(&d, &["merge", "A", "sub/B", "--out", out, "--force"]);
        exit(&o, 2);
        assert!(
            stderr(&o).contains(&format!(
                "input folder {}",
                if name == "A" { "A" } else { "sub/B" }
            )),
            "{}",
            stderr(&o)
        );
    }
    assert_eq!(tree(&d), before, "nothing changed");
    // A folder that holds no input is still replaced.
    ok(&tandem(
        &d,
        &["merge", "A", "sub/B", "--out", "m", "--no-figures"],
    ));
    ok(&tandem(
        &d,
        &[
            "merge",
            "A",
            "sub/B",
            "--out",
            "m",
            "--force",
            "--no-figures",
        ],
    ));
    assert!(d.join("m/runs.csv").is_file());
    let _ = fs::remove_dir_all(&d);
}

/// A `--force` interrupted between moving the old folder aside and deleting it (or while
/// writing) leaves `.NAME.old-PID-N` / `.NAME.tmp-PID-N`: the next run to NAME removes those
/// tandem left (its marker inside, its process gone) and nothing else (not another output's,
/// whose pid may live on another machine sharing the folder).
#[test]
fn leftovers_of_an_interrupted_force_are_cleaned_up_and_nothing_else() {
    let d = scratch("leftovers");
    // A pid that is certainly not alive: a child that has exited.
    let mut child = Command::new("true").spawn().expect("spawn");
    let dead = child.id();
    child.wait().expect("wait");
    let alive = std::process::id();
    let make = |name: &str, marker: bool| {
        let p = d.join(name);
        fs::create_dir_all(&p).expect("mkdir");
        fs::write(p.join("runs.csv"), "x").expect("write");
        if marker {
            fs::write(p.join(".tandem-output"), "").expect("marker");
        }
    };
    // Tandem's leftovers: removed.
    make(&format!(".res.old-{dead}-0"), true);
    make(&format!(".res.tmp-{dead}-3"), true);
    // Not tandem's, or not left over: kept.
    make(&format!(".res.old-{dead}-1"), false); // no marker
    make(&format!(".res.tmp-{alive}-0"), true); // its process is running
    make(&format!(".res.old-{dead}"), true); // not tandem's pattern
    make(&format!("res.old-{dead}-0"), true); // not hidden
    make(&format!(".res.old-x{dead}-0"), true); // not a pid
    // Another output's: on a shared file system its pid may be alive on another machine.
    make(&format!(".other.tmp-{dead}-1"), true);
    make(&format!(".res2.old-{dead}-0"), true);
    make("target", true);
    std::os::unix::fs::symlink(d.join("target"), d.join(format!(".res.old-{dead}-2")))
        .expect("symlink"); // a link is never followed
    fs::write(d.join(format!(".res.tmp-{dead}-9")), "a file").expect("write"); // a file
    let o = tandem(
        &d,
        &["run", "--out", "res", "--duration", "0.2", "--no-figures"],
    );
    ok(&o);
    let mut expect = vec![
        format!(".res.old-{dead}-1"),
        format!(".res.tmp-{alive}-0"),
        format!(".res.old-{dead}"),
        format!("res.old-{dead}-0"),
        format!(".res.old-x{dead}-0"),
        format!(".other.tmp-{dead}-1"),
        format!(".res2.old-{dead}-0"),
        "target".into(),
        format!(".res.old-{dead}-2"),
        format!(".res.tmp-{dead}-9"),
        "res".into(),
    ];
    expect.sort();
    assert_eq!(listing(&d), expect, "{}", stderr(&o));
    assert!(
        d.join("target/runs.csv").is_file(),
        "the link's target is kept"
    );
    assert!(
        stderr(&o).contains(&format!(".res.old-{dead}-0")),
        "the removal is reported: {}",
        stderr(&o)
    );
    let _ = fs::remove_dir_all(&d);
}
