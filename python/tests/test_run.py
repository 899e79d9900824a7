"""Runs from Python against the command line's outputs, rollouts against single runs."""

import csv
import json

import numpy as np
import pytest

import tandem


def without_timing(summary):
    # `timing` holds wall times (different on every run, excluded from determinism checks by the
    # CLI too); everything else is deterministic.
    return {k: v for k, v in summary.items() if k != "timing"}


def test_paper_run_equals_cli_summary(cli, tmp_path):
    out = tmp_path / "cli"
    cli("run", "paper", "--duration", "10", "--no-figures", "--out", out)
    expected = json.loads((out / "summary.json").read_text())
    run = tandem.Scenario.preset("paper").run(duration=10)
    # Same code, same inputs: the numbers are identical, not merely close (JSON floats
    # round-trip exactly), so the comparison is exact equality.
    assert without_timing(run.summary) == without_timing(expected)
    assert run.summary["rms_z1"] > 0 and run.ok and run.fault is None

    # The time series equals timeseries.csv column by column, bit for bit (the CSV writes
    # shortest round-trip numbers).
    with open(out / "timeseries.csv", newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], np.array(rows[1:], dtype=np.float64)
    ts = run.timeseries
    assert [f"{n} [{u}]" for n, u in run.units.items()] == header
    assert list(ts) == [h.split(" [")[0] for h in header]
    for j, name in enumerate(ts):
        assert np.array_equal(ts[name], body[:, j]), name
    assert len(run) == body.shape[0] == ts["t"].shape[0]


def test_timeseries_are_read_only_views():
    run = tandem.Scenario.preset("paper").run(duration=0.5)
    x = run.timeseries["x_o.x"]
    assert x.dtype == np.float64 and not x.flags.writeable
    with pytest.raises(ValueError):
        x[0] = 1.0
    # Zero-copy: the array does not own its memory (it is a view of the run's log).
    assert not x.flags.owndata
    # Every access hands out the same memory.
    assert np.shares_memory(x, run.timeseries["x_o.x"])


def test_to_pandas():
    pd = pytest.importorskip("pandas")
    run = tandem.Scenario.preset("paper").run(duration=0.5)
    df = run.to_pandas()
    assert isinstance(df, pd.DataFrame)
    assert list(df.columns) == list(run.timeseries)
    assert len(df) == len(run)
    assert np.array_equal(df["z1.x"].to_numpy(), run.timeseries["z1.x"])
    assert df.attrs["units"]["t"] == "s"


def test_rollout_threads_equal_sequential():
    sc = tandem.Scenario.preset("paper")
    scs = [sc, sc.with_(**{"controller.nn.k1": [6, 6, 6]}), sc.with_({"controller.kind": "pd"})]
    seeds = [3, 4, 5]
    par = tandem.rollout(scs, seeds=seeds, threads=2, duration=1.5)
    seq = [s.run(duration=1.5, seed=k) for s, k in zip(scs, seeds)]
    one = tandem.rollout(scs, seeds=seeds, threads=1, duration=1.5)
    assert len(par) == 3
    for a, b, c in zip(par, seq, one):
        # Deterministic runs: bitwise equal whatever the threads.
        assert without_timing(a.summary) == without_timing(b.summary) == without_timing(c.summary)
        for k in a.timeseries:
            assert np.array_equal(a.timeseries[k], b.timeseries[k])
            assert np.array_equal(a.timeseries[k], c.timeseries[k])
    assert [r.summary["seed"] for r in par] == seeds
    assert par[2].summary["controller"] == "pd"
    # Different seeds give different noise only where the scenario has noise; different gains
    # give a different run.
    assert par[0].summary["rms_z1"] != par[1].summary["rms_z1"]


def test_rollout_one_scenario_many_seeds():
    sc = tandem.Scenario.preset("lemniscate")  # noisy sensors: the seed matters
    runs = tandem.rollout(sc, seeds=[1, 2], duration=0.5)
    assert [r.seed if hasattr(r, "seed") else r.summary["seed"] for r in runs] == [1, 2]
    assert runs[0].summary["rms_z1"] != runs[1].summary["rms_z1"]
    with pytest.raises(ValueError, match="2 seeds for 3 scenarios"):
        tandem.rollout([sc, sc, sc], seeds=[1, 2])
    with pytest.raises(TypeError, match=r"scenarios\[1\]"):
        tandem.rollout([sc, "paper"])
    with pytest.raises(ValueError, match="threads=0"):
        tandem.rollout([sc], threads=0)


def test_write_matches_cli(cli, tmp_path):
    run = tandem.Scenario.preset("paper").run(duration=2)
    d = run.write(tmp_path / "py", figures=False)
    cli("run", "paper", "--duration", "2", "--no-figures", "--out", tmp_path / "cli")
    for f in ["timeseries.csv", "scenario.toml"]:
        assert (tmp_path / "py" / f).read_text() == (tmp_path / "cli" / f).read_text(), f
    a = json.loads((tmp_path / "py" / "summary.json").read_text())
    b = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert without_timing(a) == without_timing(b)
    assert d.endswith("py")
    # An existing folder is kept without force; with force a folder tandem wrote is replaced.
    with pytest.raises(FileExistsError, match="force=True"):
        run.write(tmp_path / "py", figures=False)
    run.write(tmp_path / "py", force=True, figures=False)
    # A folder tandem did not write is never replaced.
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep me")
    with pytest.raises(tandem.ScenarioError, match="did not write it"):
        run.write(tmp_path / "mine", force=True)
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep me"


def test_the_kernel_follows_tandem_kernel(monkeypatch):
    # The NN law's weight-pass kernel comes from TANDEM_KERNEL, read when a run builds its
    # controller (README, "Speed and determinism"); the summary records it, and an unknown
    # name is bad input that names the variable.
    monkeypatch.setenv("TANDEM_KERNEL", "portable")
    run = tandem.Scenario.preset("paper").run(duration=0.2)
    assert run.summary["rbf_kernel"] == "portable"
    monkeypatch.setenv("TANDEM_KERNEL", "sse9")
    with pytest.raises(ValueError, match="TANDEM_KERNEL"):
        tandem.Scenario.preset("paper").run(duration=0.2)
