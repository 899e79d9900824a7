"""Issue 23: tandem's plant in your loop (`Scenario.plant()`), your law in tandem's loop
(`Scenario.run(controller=...)`), and the loop contract they share with `Controller`.

The proofs are identities: a loop written in Python around `Plant` and `Controller` gives the
run `tandem run` gives, bit for bit; a law handed to `Scenario.run` as a Python function gives
the same run as the same law in Rust (`JointPD`), bit for bit; a `Controller` handed to
`Scenario.run` gives the built-in law's run.
"""

import warnings

import numpy as np
import pytest

import tandem

HORIZON = 1.0  # s: long enough for the path to move, the laws to act and errors to show


@pytest.fixture(scope="module")
def ur5():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tandem.ScenarioWarning)
        return tandem.Scenario.preset("dual-ur5")


@pytest.fixture(scope="module")
def paper():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tandem.ScenarioWarning)
        return tandem.Scenario.preset("paper")


def object_xyz(run):
    ts = run.timeseries
    return np.stack([ts["x_o.x"], ts["x_o.y"]] + ([ts["x_o.z"]] if "x_o.z" in ts else []), 1)


@pytest.mark.parametrize("name,law", [("dual-ur5", "ctc"), ("dual-ur5", "nn"), ("paper", "nn")])
def test_a_python_loop_around_plant_and_controller_is_the_run(name, law, ur5, paper):
    """`Plant` + `Controller` stepped from Python reproduce the built-in run bit for bit: the
    same start readings, the same order (read with the previous torque held, tick, hold the
    torque over one period), the same sensors and seed."""
    sc = ur5 if name == "dual-ur5" else paper
    run = sc.with_(**{"controller.kind": law}).run(duration=HORIZON)
    assert run.fault is None
    plant, c = sc.plant(), sc.controller(law)
    q, qd, w = plant.sensors()
    q0, qd0, w0 = c.start_state()
    assert np.array_equal(q, q0) and np.array_equal(qd, qd0) and np.array_equal(w, w0)
    c.start(0.0, q, qd, w)
    tau = np.zeros(plant.n_q)
    h = plant.control_period
    xyz = object_xyz(run)
    t_log = run.timeseries["t"]
    row = 0
    for k in range(int(round(HORIZON / h))):
        t = k * h
        if row < len(t_log) and abs(t_log[row] - t) < 1e-12:
            pose = plant.state["object_pose"]
            assert np.array_equal(pose[: xyz.shape[1]], xyz[row]), (t, pose, xyz[row])
            row += 1
        c.tick(t, *plant.sensors(), out=tau)
        plant.step(tau)
    assert row == len(t_log)  # every logged row was checked (the log ends before t = HORIZON)
    assert abs(plant.time - HORIZON) < 1e-12


def test_a_controller_passed_to_run_is_the_built_in_law(ur5):
    """`Scenario.run(controller=sc.controller("ctc"))`: the same torques and path as the run of
    the scenario's own CTC law (the external run is scored on the true state)."""
    ext = ur5.run(duration=HORIZON, controller=ur5.controller("ctc"))
    own = ur5.with_(**{"controller.kind": "ctc"}).run(duration=HORIZON)
    assert ext.summary["controller"] == "external" and ext.fault is None
    for k in ("path_error_p_rms_m", "path_error_p_max_m", "path_error_rot_rms_rad",
              "joint_torque_rms_Nm", "joint_torque_peak_Nm", "max_drift_m"):
        assert ext.summary[k] == own.summary[k], k
    for col in ("x_o.x", "x_o.y", "x_o.z", "tau_q1", "tau_q12", "F_meas2.fz"):
        assert np.array_equal(ext.timeseries[col], own.timeseries[col]), col


def test_a_python_law_equals_the_same_law_in_rust(ur5):
    """Joint PD plus the start's holding torques, as a NumPy function and as `JointPD`
    (Rust): the same run, bit for bit (same operations in the same order), over 2 s."""
    plant = ur5.plant()
    q0, hold = plant.state["q"].copy(), plant.holding_torques()
    kp = np.tile([100.0, 100.0, 100.0, 10.0, 10.0, 10.0], 2)
    kd = np.tile([10.0, 10.0, 10.0, 1.0, 1.0, 1.0], 2)
    calls = []

    def law(t, q, qd, wrenches):
        calls.append(t)
        assert q.shape == (12,) and qd.shape == (12,) and wrenches.shape == (2, 6)
        return kp * (q0 - q) - kd * qd + hold

    py = ur5.run(duration=2.0, controller=law)
    rs = ur5.run(duration=2.0, controller=tandem.JointPD(kp, kd, q0, hold))
    assert py.fault is None and rs.fault is None
    assert len(calls) == 2000 and calls[0] == 0.0 and abs(calls[-1] - 1.999) < 1e-12
    a, b = dict(py.summary), dict(rs.summary)
    for s in (a, b):
        s.pop("timing")
    assert a == b
    for col in py.timeseries:
        assert np.array_equal(py.timeseries[col], rs.timeseries[col]), col
    # It holds the box (the welds are exact, no fault) but does not follow the path.
    assert py.summary["max_drift_m"] < 1e-9
    assert py.summary["path_error_p_rms_m"] > 1e-3


def test_a_law_that_raises_stops_the_run_and_its_exception_reaches_you(ur5):
    hold = ur5.plant().holding_torques()

    def law(t, q, qd, w):
        if t >= 0.25:
            raise KeyError("my law broke")
        return hold

    with pytest.raises(KeyError, match="my law broke") as e:
        ur5.run(duration=1.0, controller=law)
    assert any("t = 0.25" in n for n in getattr(e.value, "__notes__", [])), e.value

    class Stateful:
        def start(self, t0, q, qd, w):
            raise RuntimeError("no start for you")

        def tick(self, t, q, qd, w):  # pragma: no cover - never reached
            return hold

    with pytest.raises(RuntimeError, match="no start for you"):
        ur5.run(duration=0.1, controller=Stateful())


def test_bad_laws_get_clear_errors_or_faults(ur5):
    hold = ur5.plant().holding_torques()
    with pytest.raises(ValueError, match=r"return value \(tau\): expected shape \(12,\), got \(3,\)"):
        ur5.run(duration=0.1, controller=lambda t, q, qd, w: hold[:3])
    with pytest.raises(TypeError, match="controller: expected a function"):
        ur5.run(duration=0.1, controller=3)

    def writes(t, q, qd, w):
        q[0] = 1.0
        return hold

    with pytest.raises(ValueError, match="read-only"):
        ur5.run(duration=0.1, controller=writes)
    # Non-finite torques are numerical trouble: a fault of the run, with its time and state.
    r = ur5.run(duration=0.1, controller=lambda t, q, qd, w: hold * np.nan)
    assert r.fault is not None and "tau_q1 became non-finite at t = 0.0000 s" in r.fault
    assert not r.ok
    # A JointPD of the wrong size is refused at the start, as a fault naming both sizes.
    small = tandem.JointPD(np.ones(3), np.ones(3), np.zeros(3), np.zeros(3))
    r = ur5.run(duration=0.1, controller=small)
    assert r.fault is not None and "JointPD has 3 joints, the scenario 12" in r.fault
    with pytest.raises(ValueError, match="kd: expected shape"):
        tandem.JointPD(np.ones(3), np.ones(4), np.zeros(3), np.zeros(3))


def test_plant_state_sensors_and_truth(ur5, paper):
    p = ur5.plant()
    assert (p.n_q, p.n_arms, p.wrench_shape, p.control_period, p.time) == (12, 2, (2, 6), 1e-3, 0.0)
    s = p.state
    assert s["object_pose"].shape == (7,) and s["object_twist"].shape == (6,)
    assert np.array_equal(s["qd"], np.zeros(12))
    lin, ang = p.residual
    assert lin < 1e-12 and ang < 1e-12
    e = p.energy
    assert e["kinetic"] == 0.0 and e["total"] == e["potential"]
    # The holding torques hold the (open-loop unstable) rest pose: over 0.1 s the box moves
    # less than 1 % of what it falls with zero torque, and the energy is kept.
    hold = p.holding_torques()
    p.step(hold, dt=0.1)
    assert abs(p.time - 0.1) < 1e-12
    held = np.abs(p.state["object_pose"][:3] - s["object_pose"][:3]).max()
    limp = ur5.plant()
    limp.step(np.zeros(12), dt=0.1)
    fell = np.abs(limp.state["object_pose"][:3] - s["object_pose"][:3]).max()
    assert held < 1e-2 * fell, (held, fell)
    assert abs(p.energy["total"] - e["total"]) < 1e-6 * abs(e["total"])
    # What the grippers feel: each arm carries half the 3 kg box (world axes, upwards).
    w = p.wrenches
    assert w.shape == (2, 6)
    np.testing.assert_allclose(w[:, 2], -3.0 * 9.81 / 2, rtol=1e-3)
    pp = paper.plant()
    assert pp.wrench_shape == (2, 2) and pp.state["object_pose"].shape == (3,)
    with pytest.raises(NotImplementedError, match="spatial plants only"):
        pp.holding_torques()
    pp.step(np.zeros(pp.n_q))
    p.reset()
    assert p.time == 0.0


def test_plant_bad_input_changes_nothing_and_faults_are_reported(ur5):
    p = ur5.plant()
    before = p.state["q"].copy()
    for kwargs, err, msg in [
        (dict(tau=np.zeros(3)), ValueError, r"tau: expected shape \(12,\), got \(3,\)"),
        (dict(tau=np.full(12, np.nan)), ValueError, r"tau\[0\] = NaN"),
        (dict(tau=np.zeros(12), dt=-1.0), ValueError, "dt = -1: must be a positive"),
        (dict(tau=np.zeros(12), dt=0.0), ValueError, "must be a positive"),
        (dict(tau=np.zeros(12), dt=0.0015), ValueError, "whole number of control periods"),
        (dict(tau=np.zeros(12), dt=1e300), ValueError, "dt = 1e300: at most"),
        (dict(tau=np.zeros(12), dt=float("inf")), ValueError, "must be a positive"),
        (dict(tau="x" * 12), TypeError, "tau: expected a float64 array"),
    ]:
        with pytest.raises(err, match=msg):
            p.step(**kwargs)
        assert p.time == 0.0 and np.array_equal(p.state["q"], before)
    p.step(np.zeros(12), dt=0.002)
    assert abs(p.time - 0.002) < 1e-15
    # A torque that tears the chain apart: PlantFault with the time (the state diverges before
    # the drift check every 10 periods sees it); the state shown is the last good one, finite;
    # then the plant refuses.
    with pytest.raises(tandem.PlantFault, match="non-finite|grasp constraint drift") as e:
        p.step(np.full(12, 1e6), dt=0.5)
    assert 0.002 < e.value.t < 0.5
    assert np.isfinite(p.state["q"]).all()
    with pytest.raises(tandem.PlantFault):
        p.step(np.zeros(12))
    p.reset()
    p.step(np.zeros(12))


def test_an_external_run_writes_its_outputs_and_pickles(ur5, tmp_path):
    import json
    import pickle

    plant = ur5.plant()
    q0, hold = plant.state["q"].copy(), plant.holding_torques()
    law = tandem.JointPD(np.full(12, 100.0), np.full(12, 10.0), q0, hold)
    run = ur5.run(duration=0.5, controller=law)
    out = run.write(tmp_path / "ext", False, True)
    summary = json.loads((tmp_path / "ext" / "summary.json").read_text())
    assert summary["controller"] == "external" and (tmp_path / "ext" / "path.png").exists()
    assert str(out).endswith("ext")
    back = pickle.loads(pickle.dumps(run))
    assert back.summary["controller"] == "external"
    assert np.array_equal(back.timeseries["tau_q1"], run.timeseries["tau_q1"])
    # tandem cannot run your law again to rebuild the figures of an unpickled run: it says so.
    with pytest.raises(RuntimeError, match="driven by your own law"):
        back.write(tmp_path / "again", False, True)
    assert not (tmp_path / "again").exists()
