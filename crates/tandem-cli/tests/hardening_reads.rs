//! Issue 22, "Never abort or hang on a file": only regular files are read, with a size limit,
//! everywhere (scenario, URDF, replay, sweep file and its base, a shard's `sweep.json` and
//! `runs.csv`). A FIFO, `/dev/zero`, `/dev/null`, a folder is refused at once, naming the field
//! or argument. Every run is killed (and the test fails) if it does not return within a few
//! seconds, so a regression cannot hang the suite.

use std::fs;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

mod support;
use support::*;

/// The longest a refusal may take; a FIFO that blocks, or a `/dev/zero` read to the end, is
/// killed there.
const LIMIT: Duration = Duration::from_secs(15);

/// What stands where a file should be.
#[derive(Clone, Copy, Debug)]
enum Bad {
    Fifo,
    DevZero,
    DevNull,
    Folder,
}

const BADS: [Bad; 4] = [Bad::Fifo, Bad::DevZero, Bad::DevNull, Bad::Folder];

impl Bad {
    /// Put it at `p` (the devices through a symbolic link: the link is followed, the device
    /// refused).
    fn place(self, p: &Path) {
        if let Some(d) = p.parent() {
            fs::create_dir_all(d).expect("mkdir");
        }
        let _ = fs::remove_file(p);
        match self {
            Bad::Fifo => {
                let st = Command::new("mkfifo").arg(p).status().expect("mkfifo");
                assert!(st.success(), "mkfifo {}", p.display());
            }
            Bad::DevZero => std::os::unix::fs::symlink("/dev/zero", p).expect("symlink"),
            Bad::DevNull => std::os::unix::fs::symlink("/dev/null", p).expect("symlink"),
            Bad::Folder => fs::create_dir_all(p).expect("mkdir"),
        }
    }

    /// The words of the refusal.
    fn words(self) -> &'static str {
        match self {
            Bad::Fifo => "named pipe (FIFO), not a regular file",
            Bad::DevZero | Bad::DevNull => "character device, not a regular file",
            Bad::Folder => "folder, not a file",
        }
    }
}

fn args(v: &[&str]) -> Vec<String> {
    v.iter().map(|a| a.to_string()).collect()
}

/// A command line and the parts its refusal must hold.
type Call = (Vec<String>, Vec<String>);

/// One reader: `make(d, bad)` writes the inputs into `d`, places `bad` where the file under
/// test goes, and returns the command line and what the refusal must name.
struct Reader {
    name: &'static str,
    make: fn(&Path, Bad) -> Call,
}

fn readers() -> Vec<Reader> {
    vec![
        Reader {
            name: "scenario",
            make: |d, bad| {
                bad.place(&d.join("s.toml"));
                (
                    args(&["run", "s.toml", "--out", "o", "--no-figures"]),
                    vec!["s.toml".into(), "not a file".into()],
                )
            },
        },
        Reader {
            name: "arms[0].urdf",
            make: |d, bad| {
                bad.place(&d.join("bad.urdf"));
                let text = fixture().spatial.replacen(
                    "\nmodel = \"ur5\"",
                    "\nurdf = \"bad.urdf\"\nbase_link = \"base_link\"\ntool_link = \"tool0\"",
                    1,
                );
                fs::write(d.join("my.toml"), text).expect("write");
                (
                    args(&["run", "my.toml", "--out", "o", "--duration", "0.1"]),
                    vec!["arms[0].urdf".into(), "bad.urdf".into(), bad.words().into()],
                )
            },
        },
        Reader {
            name: "--replay",
            make: |d, bad| {
                bad.place(&d.join("tau.csv"));
                fs::write(d.join("s.toml"), &fixture().paper).expect("write");
                (
                    args(&[
                        "run",
                        "s.toml",
                        "--controller",
                        "replay",
                        "--replay",
                        "tau.csv",
                        "--out",
                        "o",
                        "--duration",
                        "0.2",
                        "--no-figures",
                    ]),
                    vec!["--replay".into(), "tau.csv".into(), bad.words().into()],
                )
            },
        },
        Reader {
            name: "controller.replay",
            make: |d, bad| {
                bad.place(&d.join("tau.csv"));
                let text = fixture().paper.replacen(
                    "[controller]\nkind = \"nn\"",
                    "[controller]\nkind = \"replay\"\nreplay = \"tau.csv\"",
                    1,
                );
                assert!(text.contains("replay = \"tau.csv\""));
                fs::write(d.join("s.toml"), text).expect("write");
                (
                    args(&["run", "s.toml", "--out", "o", "--duration", "0.2"]),
                    vec![
                        "controller.replay".into(),
                        "tau.csv".into(),
                        bad.words().into(),
                    ],
                )
            },
        },
        Reader {
            name: "spatial --replay",
            make: |d, bad| {
                bad.place(&d.join("tau.csv"));
                fs::write(d.join("my.toml"), &fixture().spatial).expect("write");
                (
                    args(&[
                        "run",
                        "my.toml",
                        "--controller",
                        "replay",
                        "--replay",
                        "tau.csv",
                        "--out",
                        "o",
                        "--duration",
                        "0.1",
                        "--no-figures",
                    ]),
                    vec!["--replay".into(), "tau.csv".into(), bad.words().into()],
                )
            },
        },
        Reader {
            name: "sweep file",
            make: |d, bad| {
                bad.place(&d.join("sw.toml"));
                (
                    args(&["sweep", "sw.toml", "--out", "o", "--no-figures"]),
                    vec!["sw.toml".into(), "sweep file".into(), bad.words().into()],
                )
            },
        },
        Reader {
            name: "sweep base",
            make: |d, bad| {
                bad.place(&d.join("base.toml"));
                fs::write(
                    d.join("sw.toml"),
                    SHARD_SWEEP.replace("base = \"paper\"", "base = \"base.toml\""),
                )
                .expect("write");
                (
                    args(&["sweep", "sw.toml", "--out", "o", "--no-figures"]),
                    vec!["base".into(), "base.toml".into(), "not a file".into()],
                )
            },
        },
        Reader {
            name: "shard sweep.json",
            make: |d, bad| {
                copy_dir(&fixture().shards.join("A"), &d.join("A"));
                copy_dir(&fixture().shards.join("B"), &d.join("B"));
                let _ = fs::remove_file(d.join("B/sweep.json"));
                bad.place(&d.join("B/sweep.json"));
                (
                    args(&["merge", "A", "B", "--out", "o", "--no-figures"]),
                    vec!["B".into(), "sweep.json".into(), bad.words().into()],
                )
            },
        },
        Reader {
            name: "shard runs.csv",
            make: |d, bad| {
                copy_dir(&fixture().shards.join("A"), &d.join("A"));
                copy_dir(&fixture().shards.join("B"), &d.join("B"));
                let _ = fs::remove_file(d.join("A/runs.csv"));
                bad.place(&d.join("A/runs.csv"));
                (
                    args(&["merge", "A", "B", "--out", "o", "--no-figures"]),
                    vec!["A".into(), "runs.csv".into(), bad.words().into()],
                )
            },
        },
    ]
}

/// Every reader refuses every kind of non-file at once, naming the field or argument, writes
/// nothing, and never hangs or aborts.
#[test]
fn only_regular_files_are_read_and_the_refusal_names_the_field() {
    let mut failures = Vec::new();
    for r in readers() {
        for bad in BADS {
            let d = scratch("reads");
            let (argv, expect) = (r.make)(&d, bad);
            let t0 = Instant::now();
            let Some(o) = within(&d, &argv, LIMIT) else {
                failures.push(format!(
                    "{} / {bad:?}: killed after {LIMIT:?} (hangs on the file)",
                    r.name
                ));
                let _ = fs::remove_dir_all(&d);
                continue;
            };
            let err = stderr(&o);
            let mut wrong = Vec::new();
            if code(&o) != 2 {
                wrong.push(format!("exit {}", code(&o)));
            }
            for e in &expect {
                if !err.contains(e.as_str()) {
                    wrong.push(format!("message lacks `{e}`"));
                }
            }
            if d.join("o").exists() {
                wrong.push("an output folder was written".into());
            }
            if t0.elapsed() > Duration::from_secs(5) {
                wrong.push(format!("took {:?}", t0.elapsed()));
            }
            if !wrong.is_empty() {
                failures.push(format!(
                    "{} / {bad:?}: {}\n    {}",
                    r.name,
                    wrong.join("; "),
                    err.trim().replace('\n', "\n    ")
                ));
            }
            let _ = fs::remove_dir_all(&d);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Issue 22, "a DTD at line 37 is reported at line 1": a URDF whose `<!DOCTYPE` stands on line
/// 37 (after its XML declaration and a comment header) is refused by `tandem validate` with the
/// field, the URDF file, line 37 and column 1, and why (URDF takes no DTD); nothing is
/// expanded and nothing hangs.
#[test]
fn a_dtd_in_a_urdf_is_reported_by_validate_at_its_line() {
    let d = scratch("reads-dtd");
    let ur5 = tandem::model::spatial::urdf::UR5_URDF;
    let body = ur5
        .strip_prefix("<?xml version=\"1.0\"?>\n")
        .expect("UR5 starts with the XML declaration");
    let mut urdf = String::from("<?xml version=\"1.0\"?>\n");
    for k in 2..=36 {
        urdf.push_str(&format!("<!-- header line {k} -->\n"));
    }
    urdf.push_str("<!DOCTYPE robot [ <!ENTITY lol \"lol\"> ]>\n");
    urdf.push_str(body);
    assert_eq!(
        urdf.lines().nth(36),
        Some("<!DOCTYPE robot [ <!ENTITY lol \"lol\"> ]>")
    );
    fs::write(d.join("dtd.urdf"), &urdf).expect("write");
    let text = include_str!("../scenarios/dual-ur5.toml").replacen(
        "\nmodel = \"ur5\"",
        "\nurdf = \"dtd.urdf\"\nbase_link = \"base_link\"\ntool_link = \"tool0\"",
        1,
    );
    assert!(text.contains("urdf = \"dtd.urdf\""));
    fs::write(d.join("my.toml"), text).expect("write");
    let o = within(&d, &args(&["validate", "my.toml"]), LIMIT).expect("validate returns");
    let err = stderr(&o);
    assert_eq!(code(&o), 2, "{err}");
    for want in [
        "arms[0].urdf",
        "dtd.urdf",
        "URDF line 37, column 1",
        "a DTD is not accepted in a URDF file",
    ] {
        assert!(err.contains(want), "lacks `{want}`:\n{err}");
    }
    assert!(!err.contains("line 1,"), "{err}");
    let _ = fs::remove_dir_all(&d);
}
