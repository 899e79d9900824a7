"""Spatial scenarios (dual UR5, dual Franka) from Python: the same API as planar ones, the same
numbers as the command line's `tandem run`."""

import csv
import json
import pickle

import numpy as np
import pytest

import tandem


def without_timing(summary):
    # `timing` holds wall times (different on every run; the CLI's tests drop it too).
    return {k: v for k, v in summary.items() if k != "timing"}


def test_spatial_presets_load():
    assert {"dual-ur5", "dual-franka"} <= set(tandem.presets())
    sc = tandem.Scenario.preset("dual-ur5")
    assert sc.kind == "spatial" and sc.name == "dual-ur5"
    assert sc.duration == 60.0 and sc.label == "NN"
    assert sc.get("object.mass") == 3.0
    assert "spatial, 2 arms" in repr(sc)


def test_dual_ur5_run_equals_cli(cli, tmp_path):
    out = tmp_path / "cli"
    cli("run", "dual-ur5", "--duration", "1.5", "--no-figures", "--out", out)
    expected = json.loads((out / "summary.json").read_text())
    run = tandem.Scenario.preset("dual-ur5").run(duration=1.5)
    # Same code, same inputs: identical numbers (JSON floats round-trip exactly), so the
    # comparison is exact equality.
    assert without_timing(run.summary) == without_timing(expected)
    assert run.ok and run.fault is None and run.summary["status"] == "completed"
    assert run.summary["t_end_s"] == 1.5
    # The time series equals timeseries.csv column by column, bit for bit (log columns, then
    # the derived x_1.* and F_tool*.* columns).
    with open(out / "timeseries.csv", newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], np.array(rows[1:], dtype=np.float64)
    ts = run.timeseries
    assert [f"{n} [{u}]" if u else n for n, u in run.units.items()] == header
    for j, name in enumerate(ts):
        assert np.array_equal(ts[name], body[:, j]), name
        assert not ts[name].flags.writeable
    assert "x_1.ry" in ts and "F_tool2.tz" in ts
    assert len(run) == body.shape[0] == ts["t"].shape[0]

    # write(dir) writes the command line's files.
    run.write(tmp_path / "py", figures=False)
    for f in ["timeseries.csv", "scenario.toml"]:
        assert (tmp_path / "py" / f).read_bytes() == (out / f).read_bytes(), f
    assert (tmp_path / "py" / "viewer.html").is_file()
    a = json.loads((tmp_path / "py" / "summary.json").read_text())
    assert without_timing(a) == without_timing(expected)


def test_spatial_rollout_threads_equal_sequential_mixed_with_planar():
    ur5 = tandem.Scenario.preset("dual-ur5")
    scs = [
        ur5,
        ur5.with_(**{"object.mass": 4.0, "controller.nn.design.k1": 6.0}),
        tandem.Scenario.preset("paper"),
    ]
    par = tandem.rollout(scs, threads=2, duration=0.5)
    seq = [s.run(duration=0.5) for s in scs]
    for a, b in zip(par, seq):
        # Deterministic runs: bitwise equal whatever the threads.
        assert without_timing(a.summary) == without_timing(b.summary)
        assert list(a.timeseries) == list(b.timeseries)
        for k in a.timeseries:
            assert np.array_equal(a.timeseries[k], b.timeseries[k]), k
    assert [r.scenario.kind for r in par] == ["spatial", "spatial", "planar"]
    # The heavier box is a different run.
    assert par[0].summary["z1_p_rms_m"] != par[1].summary["z1_p_rms_m"]


def test_spatial_pickling_round_trips(tmp_path):
    sc = tandem.Scenario.preset("dual-ur5").with_(**{"object.mass": 3.5, "run.seed": 9})
    back = pickle.loads(pickle.dumps(sc))
    assert back == sc and back.kind == "spatial" and back.name == "dual-ur5"
    assert back.get("object.mass") == 3.5 and back.seed == 9
    assert back.to_toml() == sc.to_toml()
    assert back != tandem.Scenario.preset("dual-ur5")

    run = sc.run(duration=0.3)
    rb = pickle.loads(pickle.dumps(run))
    assert rb.summary == run.summary and rb.units == run.units
    for k, v in run.timeseries.items():
        assert np.array_equal(rb.timeseries[k], v)
    # An unpickled run is simulated again to write, and checked against the pickled summary.
    run.write(tmp_path / "a", figures=False)
    rb.write(tmp_path / "b", figures=False)
    for f in ["timeseries.csv", "scenario.toml"]:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()


def test_bad_spatial_field_raises_with_path():
    sc = tandem.Scenario.preset("dual-ur5")
    with pytest.raises(tandem.ScenarioError) as e:
        sc.with_(**{"object.mass": -1.0})
    assert e.value.path == "object.mass"
    assert str(e.value) == (
        "the scenario rejects object.mass = -1: object.mass = -1: must be finite and > 0"
    )
    with pytest.raises(tandem.ScenarioError) as e:
        sc.with_(**{"controller.nn.design.kk1": 8.0})
    assert e.value.path == "controller.nn.design.kk1"
    assert "is not a field of the scenario" in str(e.value)
    # A bad field in a spatial file names its path too.
    text = sc.to_toml().replace("radius = 0.1", "radius = -0.1", 1)
    with pytest.raises(tandem.ScenarioError) as e:
        tandem.Scenario.from_toml(text)
    assert e.value.path == "path.radius", str(e.value)


def test_spatial_sweep_equals_cli(cli, tmp_path):
    f = tmp_path / "s.toml"
    f.write_text(
        'base = "dual-ur5"\nduration = 0.3\n[vary]\n"object.mass" = { grid = [2.0, 4.0] }\n'
    )
    cli("sweep", f, "--out", tmp_path / "out", "--no-figures", "--threads", "1")
    expected = (tmp_path / "out" / "runs.csv").read_text()
    got = tandem.sweep(
        {"base": "dual-ur5", "duration": 0.3, "vary": {"object.mass": {"grid": [2.0, 4.0]}}},
        threads=2,
        frame=False,
    )
    header = expected.splitlines()[0].split(",")
    assert list(got) == header and "z1_p_rms_m" in header
    assert list(got["status"]) == ["completed", "completed"]
    # The same numbers as the command line's table (shortest round-trip text both ways).
    for j, name in enumerate(header):
        cells = [line.split(",")[j] for line in expected.splitlines()[1:]]
        if got[name].dtype == np.float64:
            want = np.array([float(c) if c else np.nan for c in cells])
            assert np.array_equal(got[name], want, equal_nan=True), name
        else:
            assert [str(v) for v in got[name]] == cells, name
