//! End-to-end tests of `tandem sweep` and `tandem merge`: shards run as separate processes (as a
//! job array would) merge into a table byte-identical to the unsharded one, for any thread count;
//! a shard of another sweep is refused; bad sweep files are reported with the field and line;
//! a faulted run is a row; `object.mass` changes the physics as it should; and the shards run
//! through a real Dask `LocalCluster` (see `tests/dask/shards.py`).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

const BIN: &str = env!("CARGO_BIN_EXE_tandem");

fn scratch(name: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let d = std::env::temp_dir().join(format!(
        "tandem-sweep-test-{name}-{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).expect("create scratch folder");
    d
}

fn tandem(cwd: &Path, args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(cwd)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("SLURM_ARRAY_TASK_COUNT")
        .output()
        .expect("run tandem")
}

fn ok(o: &Output) {
    assert_eq!(
        o.status.code(),
        Some(0),
        "tandem failed\nstdout:\n{}\nstderr:\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn bad(o: &Output) -> String {
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(
        o.status.code(),
        Some(2),
        "expected bad input (exit 2):\n{e}"
    );
    e
}

/// A grid × random sweep of 2 × 3 = 6 short runs.
const SWEEP: &str = r#"
base = "paper"
runs = 3
seed = 7
duration = 1.5
[vary]
"controller.nn.k1" = { grid = [[4, 4, 4], [8, 8, 8]] }
"object.mass" = { uniform = [0.8, 1.2] }
"sensors.force.std_dev" = { normal = [0.05, 0.01] }
"admittance.k_e" = { log_uniform = [500, 2000] }
"controller.gains" = { choice = ["paper", "tuned"] }
"#;

fn read(p: &Path) -> Vec<u8> {
    fs::read(p).unwrap_or_else(|e| panic!("read {}: {e}", p.display()))
}

#[test]
fn shards_merge_into_the_unsharded_table_for_any_thread_count() {
    let d = scratch("shards");
    fs::write(d.join("s.toml"), SWEEP).unwrap();
    ok(&tandem(
        &d,
        &["sweep", "s.toml", "--out", "one", "--threads", "1"],
    ));
    ok(&tandem(
        &d,
        &[
            "sweep",
            "s.toml",
            "--out",
            "two",
            "--threads",
            "2",
            "--no-figures",
        ],
    ));
    let whole = read(&d.join("one/runs.csv"));
    assert_eq!(
        whole,
        read(&d.join("two/runs.csv")),
        "1 thread vs 2 threads"
    );
    let text = String::from_utf8(whole.clone()).unwrap();
    assert_eq!(text.lines().count(), 7, "header + 6 runs:\n{text}");
    assert!(text.starts_with(
        "index,seed,admittance.k_e,controller.gains,controller.nn.k1,object.mass,sensors.force.std_dev,status,message,"
    ));
    assert!(text.contains("\"[8, 8, 8]\""), "{text}");
    assert!(d.join("one/sweep_rms_z1.png").is_file());
    assert!(d.join("one/sweep_histograms.svg").is_file());

    // Three shard processes at once, as a job array would run them; the last one finds its
    // shard in the Slurm variables.
    let mut kids = Vec::new();
    for i in 0..3 {
        let mut c = Command::new(BIN);
        c.current_dir(&d)
            .args(["sweep", "s.toml", "--threads", "1", "--no-figures"])
            .args(["--out", &format!("shard{i}")]);
        if i == 2 {
            c.env("SLURM_ARRAY_TASK_ID", "2")
                .env("SLURM_ARRAY_TASK_COUNT", "3");
        } else {
            c.env_remove("SLURM_ARRAY_TASK_ID")
                .env_remove("SLURM_ARRAY_TASK_COUNT")
                .args(["--shard", &format!("{i}/3")]);
        }
        kids.push(c.spawn().expect("spawn shard"));
    }
    for mut k in kids {
        assert!(k.wait().unwrap().success());
    }
    let shard2: serde_json::Value =
        serde_json::from_slice(&read(&d.join("shard2/sweep.json"))).unwrap();
    assert_eq!(shard2["shard"]["index"], 2);
    assert_eq!(shard2["runs_in_folder"], 2);
    ok(&tandem(
        &d,
        &["merge", "shard2", "shard0", "shard1", "--out", "merged"],
    ));
    assert_eq!(
        whole,
        read(&d.join("merged/runs.csv")),
        "merged vs unsharded"
    );
    assert_eq!(
        read(&d.join("one/sweep.json")),
        read(&d.join("merged/sweep.json"))
    );

    // A missing shard, a repeated one.
    let e = bad(&tandem(&d, &["merge", "shard0", "shard1", "--out", "m2"]));
    assert!(e.contains("shard is missing") || e.contains("2/3"), "{e}");
    let e = bad(&tandem(
        &d,
        &["merge", "shard0", "shard0", "shard1", "--out", "m3"],
    ));
    assert!(e.contains("given twice"), "{e}");

    // A shard of another sweep (another seed) is refused, and the message says why.
    fs::write(d.join("t.toml"), SWEEP.replace("seed = 7", "seed = 8")).unwrap();
    ok(&tandem(
        &d,
        &[
            "sweep",
            "t.toml",
            "--shard",
            "1/3",
            "--out",
            "other1",
            "--no-figures",
        ],
    ));
    let e = bad(&tandem(
        &d,
        &["merge", "shard0", "other1", "shard2", "--out", "m4"],
    ));
    assert!(e.contains("another sweep") && e.contains("seed"), "{e}");
    assert!(!d.join("m4").exists());

    // --force replaces only a folder tandem wrote.
    fs::create_dir_all(d.join("mine")).unwrap();
    fs::write(d.join("mine/notes.txt"), "keep").unwrap();
    let e = bad(&tandem(
        &d,
        &["sweep", "s.toml", "--out", "mine", "--force"],
    ));
    assert!(e.contains("marker"), "{e}");
    assert!(d.join("mine/notes.txt").is_file());
    ok(&tandem(
        &d,
        &["sweep", "s.toml", "--out", "one", "--force", "--no-figures"],
    ));
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn bad_sweep_files_name_the_field_and_line() {
    let d = scratch("bad");
    let cases: &[(&str, &[&str])] = &[
        (
            "base = \"paper\"\nruns = 2\n[vary]\n\"object.mas\" = { uniform = [0.8, 1.2] }\n",
            &[
                "vary.\"object.mas\"",
                "line 4",
                "did you mean \"object.mass\"",
            ],
        ),
        (
            "base = \"paper\"\n[vary]\n\"controller.nn.k1\" = { grid = [] }\n",
            &["vary.\"controller.nn.k1\"", "empty", "line 3"],
        ),
        (
            "base = \"paper\"\nruns = 2\n[vary]\n\"object.mass\" = { uniform = [1.2, 0.8] }\n",
            &["vary.\"object.mass\"", "lo ≤ hi"],
        ),
        (
            "base = \"paper\"\nruns = 2\n[vary]\n\"sensors.force.std_dev\" = { normal = [0.05, -0.01] }\n",
            &["vary.\"sensors.force.std_dev\"", "standard deviation ≥ 0"],
        ),
        (
            "base = \"paper\"\nruns = 2\n[vary]\n\"plant.baumgarte\" = { log_uniform = [0, 10] }\n",
            &["vary.\"plant.baumgarte\"", "0 < lo"],
        ),
        (
            "base = \"paper\"\n[vary]\n\"sensors.force.std_dev\" = { grid = [0.1, -1.0] }\n",
            &["vary.\"sensors.force.std_dev\"", "must be finite and >= 0"],
        ),
        (
            "base = \"paper\"\n[vary]\n\"object.mass\" = { gird = [1.0] }\n",
            &["did you mean `grid`"],
        ),
        ("base = \"papr\"\n", &["base", "did you mean `paper`"]),
        (
            "base = \"paper\"\nrunz = 3\n",
            &["unknown sweep field `runz`", "`runs`"],
        ),
        (
            "base = \"paper\"\n[vary]\n\"object.mass\" = { uniform = [1, 2] }\n",
            &["missing field `runs`"],
        ),
    ];
    for (i, (text, wants)) in cases.iter().enumerate() {
        let f = format!("b{i}.toml");
        fs::write(d.join(&f), text).unwrap();
        let e = bad(&tandem(&d, &["sweep", &f, "--out", "x"]));
        assert!(e.contains(&f), "names the file: {e}");
        for w in *wants {
            assert!(e.contains(w), "case {i}: wanted {w:?} in:\n{e}");
        }
        assert!(!d.join("x").exists());
    }
    fs::write(
        d.join("ok.toml"),
        "base = \"paper\"\n[vary]\n\"run.duration\" = { grid = [0.1] }\n",
    )
    .unwrap();
    for s in ["3/2", "1/0", "x/2", "2"] {
        let e = bad(&tandem(
            &d,
            &["sweep", "ok.toml", "--shard", s, "--out", "x"],
        ));
        assert!(e.contains(&format!("--shard {s}")), "{e}");
    }
    let _ = fs::remove_dir_all(&d);
}

/// Column `name` of a CSV text, as numbers.
fn column(text: &str, name: &str) -> Vec<f64> {
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let k = head
        .iter()
        .position(|h| h.split(' ').next() == Some(name))
        .unwrap_or_else(|| panic!("no column {name}"));
    lines
        .map(|l| l.split(',').nth(k).unwrap().parse().unwrap())
        .collect()
}

#[test]
fn object_mass_changes_the_physics_and_a_fault_is_a_row() {
    let d = scratch("mass");
    fs::write(
        d.join("m.toml"),
        "base = \"paper\"\nduration = 8\n[vary]\n\"object.mass\" = { grid = [1.0, 2.0] }\n\
         \"run.min_sigma\" = { grid = [0.001, 0.13] }\n",
    )
    .unwrap();
    ok(&tandem(
        &d,
        &[
            "sweep",
            "m.toml",
            "--out",
            "o",
            "--keep-runs",
            "--no-figures",
        ],
    ));
    let table = fs::read_to_string(d.join("o/runs.csv")).unwrap();
    let rows: Vec<&str> = table.lines().skip(1).collect();
    assert_eq!(rows.len(), 4);
    // Runs 1 and 3 stop at a singular configuration (σ_min < 0.13): a row with the fault.
    for r in [rows[1], rows[3]] {
        assert!(r.contains(",fault,") && r.contains("singular"), "{r}");
    }
    // The static part of the grasp forces carries the object's weight: Σ F_i,y = m g (plus the
    // small damping, inertia and disturbance terms), and it doubles with the mass.
    let mut weight = Vec::new();
    for (i, m) in [(0, 1.0), (2, 2.0)] {
        let ts = fs::read_to_string(d.join(format!("o/runs/{i}/timeseries.csv"))).unwrap();
        let t = column(&ts, "t");
        let f1 = column(&ts, "F1.y");
        let f2 = column(&ts, "F2.y");
        let after: Vec<f64> = (0..t.len())
            .filter(|&k| t[k] >= 3.0)
            .map(|k| f1[k] + f2[k])
            .collect();
        let mean = after.iter().sum::<f64>() / after.len() as f64;
        assert!(
            (mean.abs() - m * 9.8).abs() < 0.02 * m * 9.8,
            "mass {m}: mean Σ F_y = {mean} N, expected ±{} N",
            m * 9.8
        );
        weight.push(mean);
        let sc = fs::read_to_string(d.join(format!("o/runs/{i}/scenario.toml"))).unwrap();
        assert!(
            sc.contains(&format!("inertia = [{m:?}, {m:?}, 1.0]")),
            "{sc}"
        );
    }
    assert!((weight[1] / weight[0] - 2.0).abs() < 0.02, "{weight:?}");
    let _ = fs::remove_dir_all(&d);
}

/// The shards through a real engine: dask.distributed's LocalCluster (`tests/dask/shards.py`)
/// in the venv `.ci/run` creates (`.venv-dask`, or `TANDEM_DASK_PYTHON`). Without it the test
/// prints a skip notice, or fails when `TANDEM_REQUIRE_DASK=1` (as in CI).
#[test]
fn shards_through_a_dask_local_cluster() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let python = std::env::var_os("TANDEM_DASK_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join(".venv-dask/bin/python"));
    let usable = Command::new(&python)
        .args(["-c", "import dask.distributed"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !usable {
        let msg = format!(
            "dask.distributed is not importable with {} (run .ci/run, or set TANDEM_DASK_PYTHON)",
            python.display()
        );
        if std::env::var("TANDEM_REQUIRE_DASK").as_deref() == Ok("1") {
            panic!("TANDEM_REQUIRE_DASK=1: {msg}");
        }
        eprintln!("skipped: {msg}");
        return;
    }
    let d = scratch("dask");
    fs::write(d.join("s.toml"), SWEEP).unwrap();
    ok(&tandem(
        &d,
        &["sweep", "s.toml", "--out", "whole", "--no-figures"],
    ));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/dask/shards.py");
    let o = Command::new(&python)
        .arg(&script)
        .arg(BIN)
        .arg(d.join("s.toml"))
        .arg(&d)
        .arg("4")
        .current_dir(&d)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("SLURM_ARRAY_TASK_COUNT")
        .output()
        .expect("run python");
    ok(&o);
    assert_eq!(
        read(&d.join("whole/runs.csv")),
        read(&d.join("merged/runs.csv")),
        "the Dask-merged table equals the unsharded one"
    );
    let _ = fs::remove_dir_all(&d);
}
