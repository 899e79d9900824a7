"""Issue 22's hardening, Python's part: ``Run.write(dir, force=True)`` never deletes an input
(the command line's table of cases, crates/tandem-cli/tests/hardening_files.rs); no value given
to ``with_`` crashes the interpreter; messages stay short; ``threads=`` is bounded; a sweep's run
count and ``shard="slurm"`` are checked before any work. Anything that could hang or crash runs in
a child interpreter with a timeout, so a regression fails instead of taking the suite down."""

import os
import subprocess
import sys
import textwrap

import pytest

import tandem

from conftest import REPO

UR5 = REPO / "crates" / "tandem" / "models" / "ur5.urdf"


def tree(d):
    """Every entry under ``d`` (files with content, folders, links with target), sorted."""
    out = []
    for root, dirs, files in os.walk(d):
        for n in sorted(dirs + files):
            p = os.path.join(root, n)
            if os.path.islink(p):
                out.append((p, "-> " + os.readlink(p)))
            elif os.path.isdir(p):
                out.append((p, "/"))
            else:
                with open(p, "rb") as f:
                    out.append((p, f.read()))
    return sorted(out)


def marked(d):
    d.mkdir(parents=True, exist_ok=True)
    (d / ".tandem-output").write_text("")
    return d


def planar_file(cli, p):
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(cli("scenario", "show", "paper").stdout)
    return p


def spatial_file(cli, p, urdf):
    p.parent.mkdir(parents=True, exist_ok=True)
    urdf.parent.mkdir(parents=True, exist_ok=True)
    urdf.write_text(UR5.read_text())
    text = cli("scenario", "show", "dual-ur5").stdout.replace(
        '\nmodel = "ur5"',
        f'\nurdf = "{urdf}"\nbase_link = "base_link"\ntool_link = "tool0"',
    )
    assert "urdf =" in text
    p.write_text(text)
    return p


# Each input a written run reads, as the subject: make(tmp, at) writes the inputs (the subject
# under tmp/at, the others under tmp/in) and returns (the Run, the subject's path).
def run_of_scenario(cli, tmp, at):
    p = planar_file(cli, tmp / at / "s.toml")
    return tandem.Scenario.load(p).run(duration=0.1), p


def run_of_urdf(cli, tmp, at):
    u = tmp / at / "arm.urdf"
    p = spatial_file(cli, tmp / "in" / "my.toml", u)
    return tandem.Scenario.load(p).run(duration=0.05), u


def run_of_replay(cli, tmp, at):
    r = tmp / at / "tau.csv"
    r.parent.mkdir(parents=True, exist_ok=True)
    r.write_text("t,tau1,tau2,tau3,tau4\n0,0,0,0,0\n")
    p = planar_file(cli, tmp / "in" / "s.toml")
    text = p.read_text().replace(
        '[controller]\nkind = "nn"', f'[controller]\nkind = "replay"\nreplay = "{r}"', 1
    )
    assert "replay = " in text
    p.write_text(text)
    return tandem.Scenario.load(p).run(duration=0.1), r


ROWS = {"the scenario": run_of_scenario, "arms[0].urdf": run_of_urdf, "controller.replay": run_of_replay}
CASES = [
    "user folder without marker",
    "input inside",
    "input is the folder",
    "parent of the current folder",
    "current folder",
    "symlink",
    "file",
]


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("row", list(ROWS))
def test_write_force_never_deletes_an_input(cli, tmp_path, monkeypatch, row, case):
    d = tmp_path / "d"
    d.mkdir()
    elsewhere = tmp_path / "inputs"
    root, at = (d, "res") if case == "input inside" else (d, "in")
    if case in ("parent of the current folder", "current folder"):
        root = elsewhere
    run, subject = ROWS[row](cli, root, at)
    if case == "user folder without marker":
        (d / "mine").mkdir()
        (d / "mine" / "photo.jpg").write_text("mine")
        out, expect = d / "mine", [".tandem-output"]
    elif case == "input inside":
        marked(d / "res")
        (d / "res" / "old.txt").write_text("old results")
        out, expect = d / "res", ["holds the input", subject.name]
    elif case == "input is the folder":
        out, expect = subject, ["is the input", subject.name]
    elif case in ("parent of the current folder", "current folder"):
        here = marked(d / "here")
        marked(d)
        (here / "notes.txt").write_text("mine")
        monkeypatch.chdir(here)
        out, expect = ("." if case == "current folder" else ".."), ["current folder"]
    elif case == "symlink":
        marked(d / "real")
        (d / "real" / "keep.txt").write_text("mine")
        os.symlink(d / "real", d / "link")
        out, expect = d / "link", ["symbolic link"]
    else:
        (d / "notes.txt").write_text("mine")
        out, expect = d / "notes.txt", ["is a file"]
    before = tree(tmp_path)
    with pytest.raises(tandem.ScenarioError) as e:
        run.write(out, force=True, figures=False)
    msg = str(e.value)
    for x in expect + ["nothing was run or deleted", "force=True"]:
        assert x in msg, msg
    assert "--force" not in msg, msg
    assert tree(tmp_path) == before, "nothing changed"


def test_write_force_still_replaces_what_tandem_wrote(tmp_path):
    run = tandem.Scenario.preset("paper").run(duration=0.1)
    run.write(tmp_path / "o", figures=False)
    run.write(tmp_path / "o", force=True, figures=False)
    assert (tmp_path / "o" / "timeseries.csv").is_file()
    with pytest.raises(ValueError, match="output folder"):
        run.write("", figures=False)


def in_child(code, timeout=60):
    """Run ``code`` in a child interpreter (a crash there is a failed test, not a dead suite)."""
    p = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    return p


@pytest.mark.parametrize(
    "build",
    [
        "v = []; v.append(v)",
        "v = {}; v['a'] = v",
        "v = 0\nfor _ in range(100000): v = [v]",
        "class T:\n    def tolist(self): return self\nv = T()",
        "class T:\n    def tolist(self): return [T()]\nv = T()",
    ],
    ids=["recursive list", "recursive dict", "nested 1e5", "tolist returns itself", "tolist nests"],
)
def test_with_never_crashes_the_interpreter(build):
    p = in_child(
        f"""
import tandem
{build}
try:
    tandem.Scenario.preset("paper").with_(**{{"object.mass": v}})
except tandem.ScenarioError as e:
    assert e.path == "object.mass", e.path
    assert "nested more than 32 levels" in str(e), str(e)
    assert len(str(e)) < 1000, len(str(e))
    print("refused")
"""
    )
    assert p.returncode == 0 and p.stdout.strip() == "refused", (p.returncode, p.stderr[-2000:])


@pytest.mark.parametrize(
    "value",
    ["x" * 10_000_000, ["x" * 10_000_000], 10 ** 4000],
    ids=["10 MB string", "10 MB string in a list", "4000-digit int"],
)
@pytest.mark.parametrize("path", ["object.mass", "name", "controller.nn.k1"])
def test_messages_echo_a_bounded_excerpt_of_a_huge_value(path, value):
    with pytest.raises((tandem.ScenarioError, ValueError, TypeError)) as e:
        tandem.Scenario.preset("paper").with_(**{path: value})
    msg = str(e.value)
    assert len(msg) < 3000, (len(msg), msg[:300])


def test_a_huge_key_is_echoed_bounded():
    with pytest.raises(tandem.ScenarioError) as e:
        tandem.Scenario.preset("paper").with_(**{"a" * 10_000_000: 1})
    assert len(str(e.value)) < 3000
    assert len(e.value.path) < 300


@pytest.mark.parametrize("threads", [1025, 100_000])
def test_threads_are_bounded_and_named(threads):
    # In a child: a regression would start 10^5 threads (minutes, then os error 11).
    p = in_child(
        f"""
import tandem
sc = tandem.Scenario.preset("paper")
spec = {{"base": "paper", "duration": 0.1, "vary": {{"object.mass": {{"grid": [1.0]}}}}}}
for call in (lambda: tandem.rollout([sc], threads={threads}, duration=0.1),
             lambda: tandem.sweep(spec, threads={threads})):
    try:
        call()
    except ValueError as e:
        assert "threads={threads}: at most 1024" in str(e), str(e)
        print("refused")
""",
        timeout=30,
    )
    assert p.returncode == 0 and p.stdout.split() == ["refused", "refused"], (p.stdout, p.stderr[-2000:])


def test_a_billion_run_sweep_is_refused_at_once():
    spec = {
        "base": "dual-ur5",
        "vary": {
            f: {"grid": [1.0 + i * 1e-4 for i in range(1000)]}
            for f in ["object.mass", "run.duration", "admittance.k_e"]
        },
    }
    p = in_child(
        f"""
import time, tandem
t0 = time.time()
try:
    tandem.sweep({spec!r})
except tandem.ScenarioError as e:
    assert "1000000000 (10^9) runs" in str(e), str(e)
    print(round(time.time() - t0, 3))
""",
        timeout=30,
    )
    assert p.returncode == 0 and p.stdout.strip(), p.stderr[-2000:]
    assert float(p.stdout) < 5, p.stdout


def test_shard_slurm_outside_a_job_array_is_an_error(monkeypatch):
    monkeypatch.delenv("SLURM_ARRAY_TASK_ID", raising=False)
    monkeypatch.delenv("SLURM_ARRAY_TASK_COUNT", raising=False)
    spec = {"base": "paper", "duration": 0.1, "vary": {"object.mass": {"grid": [1.0, 1.1]}}}
    with pytest.raises(tandem.ScenarioError, match="SLURM_ARRAY_TASK_ID"):
        tandem.sweep(spec, shard="slurm")


@pytest.mark.parametrize("kind", ["fifo", "/dev/zero", "folder"])
def test_files_that_are_not_regular_are_refused_at_once(tmp_path, kind):
    bad = tmp_path / "bad.toml"
    if kind == "fifo":
        os.mkfifo(bad)
    elif kind == "folder":
        bad.mkdir()
    else:
        os.symlink("/dev/zero", bad)
    for call in [f"tandem.Scenario.load({str(bad)!r})", f"tandem.sweep({str(bad)!r})"]:
        p = in_child(
            f"""
import tandem
try:
    {call}
except tandem.ScenarioError as e:
    print("refused:", e)
""",
            timeout=20,
        )
        assert p.returncode == 0 and "refused" in p.stdout, (call, p.stdout, p.stderr[-2000:])
        assert "not a" in p.stdout, p.stdout


@pytest.mark.parametrize("kind", ["nn", "pd"])
def test_a_bad_tandem_kernel_is_refused_for_a_spatial_run(monkeypatch, kind):
    sc = tandem.Scenario.preset("dual-ur5").with_(**{"controller.kind": kind})
    monkeypatch.setenv("TANDEM_KERNEL", "sse9")
    with pytest.raises(ValueError, match="TANDEM_KERNEL"):
        sc.run(duration=0.05)
    with pytest.raises(ValueError, match="TANDEM_KERNEL"):
        tandem.rollout([sc], duration=0.05)


def test_get_reads_the_gains_a_preset_resolves_to():
    """``get`` of a gain the file leaves to its preset (``gains = "tuned"``) or to the spatial
    design is the value the controller runs with (it was a KeyError)."""
    paper = tandem.Scenario.preset("paper")
    # The tuned preset (SPEC §3.4's starting point): K1 = 8, K2 = (233, 700, 50).
    assert paper.get("controller.nn.k1") == [8.0, 8.0, 8.0]
    assert paper.get("controller.nn.k2") == [233.0, 700.0, 50.0]
    # The paper's own gains (Section V): K1 = diag(15, 20, 15), K2 = diag(11, 15, 10).
    own = paper.with_({"controller.gains": "paper"})
    assert own.get("controller.nn.k1") == [15.0, 20.0, 15.0]
    assert own.get("controller.nn.k2") == [11.0, 15.0, 10.0]
    # An override is read back as set, the rest from the preset.
    mixed = own.with_({"controller.nn.k1": [9, 9, 9]})
    assert mixed.get("controller.nn.k1") == [9.0, 9.0, 9.0]
    assert mixed.get("controller.nn.k2") == [11.0, 15.0, 10.0]
    assert isinstance(paper.get("controller.nn"), dict)
    # Spatial: the per-axis design K2 = 2 ζ M ω_n (ζ = 0.8, ω_n = 20 on the file's inertia).
    franka = tandem.Scenario.preset("dual-franka")
    k2 = franka.get("controller.nn.k2")
    assert k2 == pytest.approx([32 * m for m in [26.0, 12.0, 12.0, 0.7, 2.2, 0.2]], rel=1e-12)
    with pytest.raises(KeyError):
        paper.get("controller.nn.no_such_gain")


def test_scenario_toml_lists_the_gains_of_the_preset(tmp_path):
    """``scenario.toml`` keeps the preset's name (so ``--gains`` still switches it) and lists
    what it resolves to as a comment."""
    run = tandem.Scenario.preset("paper").run(duration=0.2)
    run.write(tmp_path / "o")
    text = (tmp_path / "o" / "scenario.toml").read_text()
    assert 'gains = "tuned"' in text
    assert '# The NN gains `gains = "tuned"` resolves to' in text
    assert "#   k1 = [8.0, 8.0, 8.0]" in text
    assert "#   k2 = [233.0, 700.0, 50.0]" in text
    # The comment is a comment: the file runs as the scenario it came from.
    back = tandem.Scenario.from_toml(text)
    assert back.get("controller.nn.k2") == [233.0, 700.0, 50.0]
