"""Scenario.controller: a scenario's controller stepped from Python (issue 23).

The strongest equivalence available without a plant object: a run logged at every control tick
(`run.log_period = run.control_period`) holds what its controller read at each tick (the true
joints, which ideal encoders read exactly, and the wrist readings `F_meas*`) and the torques it
applied (`tau_q*`); a `Controller` fed those readings must give the same torques, bit for bit.
The planar log has no joint rates, so there only the first tick (the chain at rest) is checked
here; the Rust test `tandem-cli/tests/standalone.rs` steps the planar run and the controller in
lockstep.
"""

import warnings

import numpy as np
import pytest

import tandem

SPATIAL_AXES = ["fx", "fy", "fz", "tx", "ty", "tz"]


def _quiet(f, *a, **k):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tandem.ScenarioWarning)
        return f(*a, **k)


def _scenario(name, **fields):
    sc = _quiet(tandem.Scenario.preset, name)
    h = sc.get("run.control_period")
    return _quiet(sc.with_, **{"run.log_period": h, **fields})


def _logged(ts, c):
    nq, (n_arms, w) = c.n_q, c.wrench_shape
    axes = SPATIAL_AXES if w == 6 else ["x", "y"]
    q = np.stack([ts[f"q{j + 1}"] for j in range(nq)], 1)
    tau = np.stack([ts[f"tau_q{j + 1}"] for j in range(nq)], 1)
    wr = np.stack(
        [np.stack([ts[f"F_meas{i + 1}.{a}"] for a in axes], 1) for i in range(n_arms)], 1
    )
    qd = np.stack([ts[f"qd{j + 1}"] for j in range(nq)], 1) if "qd1" in ts else None
    return q, qd, wr, tau


@pytest.mark.parametrize("law", [None, "nn", "pd", "pd-gravity", "ctc"])
def test_dual_ur5_controller_reproduces_the_runs_torques(law):
    fields = {}
    if law is not None:
        fields["controller.kind"] = "pd" if law.startswith("pd") else law
        fields["controller.pd.gravity_compensation"] = law == "pd-gravity"
    sc = _scenario("dual-ur5", **fields)
    run = sc.run(duration=0.4)
    assert run.ok
    c = _quiet(sc.controller, law)
    assert (c.n_q, c.n_arms, c.wrench_shape) == (12, 2, (2, 6))
    q, qd, wr, tau = _logged(run.timeseries, c)
    q0, qd0, w0 = c.start_state()
    # The run starts where start_state says, reading what it says.
    assert np.array_equal(q0, q[0]) and np.array_equal(qd0, qd[0]) and np.array_equal(w0, wr[0])
    c.start(0.0, q0, qd0, w0)
    out = np.empty(c.n_q)
    worst = 0.0
    for k, t in enumerate(run.timeseries["t"]):
        r = c.tick(t, q[k], qd[k], wr[k], out=out)
        assert r is out
        worst = max(worst, float(np.abs(out - tau[k]).max()))
    assert worst <= 1e-12, worst
    rec = c.record
    for key in ["x_hat", "x_r", "z1", "z2", "alpha", "wrench", "w_norm"]:
        assert rec[key].shape == (6,)
    assert rec["internal"].shape == (2, 6)
    last = {k: v[-1] for k, v in run.timeseries.items()}
    np.testing.assert_array_equal(rec["z1"], [last[f"z1.{a}"] for a in ["x", "y", "z", "rx", "ry", "rz"]])
    np.testing.assert_array_equal(rec["x_r"], [last[f"x_r.{a}"] for a in ["x", "y", "z", "rx", "ry", "rz"]])
    assert rec["Q"] == last["Q"] and rec["margin"] == last["margin"]


@pytest.mark.parametrize("law", [None, "pd", "ctc"])
def test_planar_first_tick_is_the_runs(law):
    fields = {"controller.kind": law} if law else {}
    sc = _scenario("paper", **fields)
    run = sc.run(duration=0.05)
    c = _quiet(sc.controller, law)
    assert (c.n_q, c.n_arms, c.wrench_shape) == (4, 2, (2, 2))
    q, _, wr, tau = _logged(run.timeseries, c)
    q0, qd0, w0 = c.start_state()
    assert np.array_equal(q0, q[0]) and np.array_equal(w0, wr[0]) and not qd0.any()
    c.start(0.0, q0, qd0, w0)
    t1 = c.tick(0.0, q0, qd0, w0)
    assert t1.shape == (4,) and t1.dtype == np.float64
    assert np.abs(t1 - tau[0]).max() == 0.0
    rec = c.record
    assert rec["z1"].shape == (3,)
    assert rec["z1"][0] == run.timeseries["z1.x"][0]
    # reset(): back to the controller as built; the same first tick again.
    c.reset()
    with pytest.raises(RuntimeError, match="before Controller.start"):
        c.tick(0.0, q0, qd0, w0)
    c.start(0.0, q0, qd0, w0)
    assert np.array_equal(c.tick(0.0, q0, qd0, w0), t1)


@pytest.mark.parametrize("name", ["paper", "dual-ur5"])
def test_errors_name_the_argument_and_shape(name):
    c = _quiet(_quiet(tandem.Scenario.preset, name).controller)
    q, qd, w = c.start_state()
    n, ws = c.n_q, c.wrench_shape
    with pytest.raises(RuntimeError, match="before Controller.start"):
        c.tick(0.0, q, qd, w)
    with pytest.raises(ValueError, match=rf"^q: expected shape \({n},\), got \({n + 1},\)"):
        c.start(0.0, np.zeros(n + 1), qd, w)
    with pytest.raises(ValueError, match=rf"^qd: expected shape \({n},\)"):
        c.start(0.0, q, qd.reshape(1, n), w)
    with pytest.raises(ValueError, match=rf"^wrenches: expected shape \({ws[0]}, {ws[1]}\), got \({ws[0] * ws[1]},\)"):
        c.start(0.0, q, qd, w.ravel())
    bad = q.copy()
    bad[1] = np.nan
    with pytest.raises(ValueError, match=r"^q\[1\] = NaN: every value must be finite"):
        c.start(0.0, bad, qd, w)
    c.start(0.0, q, qd, w)
    w_inf = w.copy()
    w_inf[1, 0] = np.inf
    with pytest.raises(ValueError, match=r"^wrenches\[1, 0\] = inf"):
        c.tick(0.0, q, qd, w_inf)
    with pytest.raises(ValueError, match="^t = NaN: must be finite"):
        c.tick(float("nan"), q, qd, w)
    h = c.control_period
    c.tick(0.0, q, qd, w)
    c.tick(h, q, qd, w)
    with pytest.raises(ValueError, match="time went back"):
        c.tick(h, q, qd, w)
    with pytest.raises(ValueError, match="time went back"):
        c.tick(0.0, q, qd, w)
    with pytest.raises(ValueError, match=rf"^out: expected shape \({n},\)"):
        c.tick(2 * h, q, qd, w, out=np.empty(n + 2))
    with pytest.raises(ValueError, match="^out: expected a float64 array"):
        c.tick(2 * h, q, qd, w, out=np.empty(n, dtype=np.float32))
    ro = np.empty(n)
    ro.flags.writeable = False
    with pytest.raises(ValueError, match="^out: must be writeable"):
        c.tick(2 * h, q, qd, w, out=ro)
    # Lists convert (and are copied on the Python side); the failed calls changed nothing.
    out = np.full(n, np.nan)
    r = c.tick(2 * h, list(q), tuple(qd), w.tolist(), out=out)
    assert r is out and np.isfinite(out).all()


def test_law_names():
    sc = _quiet(tandem.Scenario.preset, "dual-ur5")
    assert _quiet(sc.controller, "pd-gravity").law == "pd-gravity"
    assert _quiet(sc.controller).law == "nn"
    assert _quiet(sc.with_, **{"controller.kind": "ctc"}).controller().law == "ctc"
    with pytest.raises(tandem.ScenarioError, match="must be one of nn, pd, pd-gravity, ctc") as e:
        sc.controller("lqr")
    assert e.value.path == "controller.kind"


def test_pickles_through_its_scenario():
    import pickle

    c = _quiet(_quiet(tandem.Scenario.preset, "paper").controller, "pd")
    q, qd, w = c.start_state()
    c.start(0.0, q, qd, w)
    tau = c.tick(0.0, q, qd, w)
    c2 = _quiet(pickle.loads, pickle.dumps(c))
    assert c2.law == "pd" and c2.n_q == c.n_q
    with pytest.raises(RuntimeError):
        c2.tick(0.0, q, qd, w)
    c2.start(0.0, q, qd, w)
    assert np.array_equal(c2.tick(0.0, q, qd, w), tau)
