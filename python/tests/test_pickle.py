"""Scenarios and runs survive pickling (process pools, Ray, Dask send them that way)."""

import concurrent.futures as cf
import multiprocessing as mp
import pickle

import numpy as np

import tandem


def _run_in_worker(sc):
    return sc.run(duration=1.0, seed=7)


def test_scenario_round_trip_keeps_overrides():
    sc = tandem.Scenario.preset("paper").with_(
        **{"controller.nn.k1": [8, 8, 8], "object.mass": 1.2, "run.seed": 11}
    )
    back = pickle.loads(pickle.dumps(sc))
    assert back == sc
    assert back.name == "paper"
    assert back.get("controller.nn.k1") == [8.0, 8.0, 8.0]
    assert back.get("object.inertia")[:2] == [1.2, 1.2]
    assert back.seed == 11
    assert back.to_toml() == sc.to_toml()
    assert back != tandem.Scenario.preset("paper")


def test_run_round_trip_carries_the_data(tmp_path):
    run = tandem.Scenario.preset("paper").with_({"controller.kind": "pd"}).run(duration=1.0)
    back = pickle.loads(pickle.dumps(run))
    assert back.summary == run.summary
    assert list(back.timeseries) == list(run.timeseries)
    for k, v in run.timeseries.items():
        assert np.array_equal(back.timeseries[k], v)
        assert not back.timeseries[k].flags.writeable
    assert back.units == run.units
    assert back.scenario == run.scenario
    # Writing an unpickled run simulates it again (runs are deterministic) and checks that the
    # re-run equals the pickled data; the files equal the original run's.
    run.write(tmp_path / "a", figures=False)
    back.write(tmp_path / "b", figures=False)
    for f in ["timeseries.csv", "scenario.toml"]:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()


def test_process_pool():
    sc = tandem.Scenario.preset("paper").with_(**{"controller.nn.k2": [20, 20, 20]})
    ctx = mp.get_context("spawn")  # a fresh interpreter: everything goes through pickle
    with cf.ProcessPoolExecutor(max_workers=2, mp_context=ctx) as ex:
        remote = list(ex.map(_run_in_worker, [sc, sc]))
    local = _run_in_worker(sc)
    for r in remote:
        assert r.summary["rms_z1"] == local.summary["rms_z1"]
        assert r.summary["gains"] == "tuned+overrides"
        assert np.array_equal(r.timeseries["z1.x"], local.timeseries["z1.x"])
