"""The friction grasp rig of `mujoco_friction_rig.py` (its docstring has the model, every
parameter and MuJoCo's soft-contact error sources) on MuJoCo, against Coulomb's law: a 1 kg box
squeezed between two pads (mu = 0.5, F_g per pad), for condim 3 and condim 4 (torsion 0.002 m),
elliptic cones, noslip on. This is MuJoCo's half of the independent check of tandem's friction
model; tandem's side runs the same rig.

Checked, per condim:

* A, slip onset under a load ramp of 1 N/s: with the displacement threshold's Coulomb lag
  removed, the onset load is 2 mu F_g = 20 N to ONSET_TOL; the box creeps less than
  CREEP_TOL before it.
* B, a 15 N push for 0.1 s: the slip distance is Coulomb's rigid-contact 0.0354024 m to
  SLIP_TOL, and the box is at rest again at 0.6 s.
* C, held at F_g = 12 N for 10 s: the box creeps (0.2 s -> 10 s) less than CREEP_TOL.
* D, a torque ramp about the pads' axis: condim 4 turns at Coulomb's elliptic-cone limit
  2 x 0.002 x sqrt(F_g^2 - (m g / (2 mu))^2) = 0.069715 N m to TORSION_TOL, condim 3 at once
  (this shows that condim 4's torsion is wired, since A to C do not load it).

And that noslip is what makes these checks pass: without it MuJoCo's soft friction creeps
(1.0e-3 m in 10 s) and the box slides as soon as the ramp starts (9.82 N).

Measured (mujoco 4.0.1; condim 3 and 4 agree to 1e-12 in A to C): A 20.018 N at the 1e-6 m
threshold, 19.9998 N with the 0.0182 N lag removed (-1.7e-4 N), creep before onset 2.3e-9 m;
B 0.0354036 m (+1.2e-6 m, 0.003 %); C creep 1.6e-9 m (sag from the start 9.8e-6 m, the first
steps); D 0.06971 N m (-5e-6 N m), condim 3 0 N m. Without noslip: onset 9.819 N, creep
1.02e-3 m. The whole file runs in ~2 s on one core.

Tolerances (each ~10x the measured error, and each fails a rig that is clearly wrong):
ONSET_TOL = 0.01 N (0.05 %): the ramp is held over 1 ms steps (1 mN a step) and the onset step
is known to a step; measured -1.7e-4 N, and -2.2e-3 N with a 10x softer contact (tau 20 ms).
Soft friction without noslip, or with a single noslip iteration, is 10 N off.
SLIP_TOL = 2e-5 m (0.06 %): the sliding pads chatter (MuJoCo pushes sliding contacts apart,
the 20 N actuators press them back; see the rig's docstring), so the normal force equals F_g
only on average; measured +1.2e-6 m, +4.1e-6 m at timestep 2 ms (tau 4 ms), +5e-6 m with
10x heavier fingers; a 2.5x softer contact (tau 5 ms) errs by +5.2e-5 m and fails.
CREEP_TOL = 1e-7 m: measured 1.6e-9 m (C), 2.3e-9 m (A), 1.5e-8 m at impratio 1; without
noslip 1e-3 m, with one noslip iteration 4.3e-5 m.
TORSION_TOL = 5e-4 N m (0.7 %): measured -5e-6 N m; the ramp moves 1e-5 N m a step and the
lag correction assumes pure rotation, while the box also starts to slide down once the
elliptic cone saturates.
"""

import pytest

try:
    import mujoco  # noqa: F401
except ImportError as e:  # pragma: no cover - depends on the venv
    mujoco = None
    MUJOCO_MISSING = (
        f"mujoco is not installed in this venv ({e}); .ci/run installs it with "
        "`pip install mujoco`"
    )

needs_mujoco = pytest.mark.skipif(mujoco is None, reason=globals().get("MUJOCO_MISSING", ""))

if mujoco is not None:
    import mujoco_friction_rig as rig

ONSET_TOL = 0.01  # N (measured -1.7e-4 N)
SLIP_TOL = 2e-5  # m (measured +1.2e-6 m)
CREEP_TOL = 1e-7  # m (measured 1.6e-9 m over 10 s, 2.3e-9 m before onset)
TORSION_TOL = 5e-4  # N m (measured -5e-6 N m)
GRIP = 20.0  # N per pad

CONDIMS = [pytest.param(3, id="condim3"), pytest.param(4, id="condim4")]


@pytest.fixture(scope="module")
def results():
    """A, B, C and D for both condims, run once (~0.3 s each)."""
    return {condim: rig.run_all(condim) for condim in (3, 4)}


@needs_mujoco
@pytest.mark.parametrize("condim", CONDIMS)
def test_slip_onset_is_coulomb(results, condim):
    a = results[condim]["A"]
    limit = rig.coulomb_onset(GRIP)
    assert limit == pytest.approx(20.0)
    assert a["onset_load_corrected"] == pytest.approx(limit, abs=ONSET_TOL), a
    # the raw crossing comes after the Coulomb load, by the threshold's lag
    assert limit <= a["onset_load"] <= limit + a["detection_lag"] + ONSET_TOL, a
    assert abs(a["creep_before_onset"]) < CREEP_TOL, a


@needs_mujoco
@pytest.mark.parametrize("condim", CONDIMS)
def test_push_slip_is_coulomb(results, condim):
    b = results[condim]["B"]
    expected = rig.coulomb_push_slip(GRIP)
    assert expected == pytest.approx(0.02405 + 0.481**2 / (2 * 10.19), abs=1e-9)
    assert b["slip"] == pytest.approx(expected, abs=SLIP_TOL), b
    assert b["final_speed"] < 1e-6, b  # stopped again well before 0.6 s


@needs_mujoco
@pytest.mark.parametrize("condim", CONDIMS)
def test_held_box_barely_creeps(results, condim):
    c = results[condim]["C"]
    assert abs(c["creep"]) < CREEP_TOL, c
    # the start's sag is the soft contact taking up the load: ~g dt tau / 2 = 9.8e-6 m
    assert 0 < c["sag"] < 2e-5, c


@needs_mujoco
def test_torsion_is_wired(results):
    limit = rig.coulomb_torsion_onset(GRIP)
    assert limit == pytest.approx(0.069715, abs=1e-6)
    d4 = results[4]["D"]
    assert d4["onset_torque_corrected"] == pytest.approx(limit, abs=TORSION_TOL), d4
    d3 = results[3]["D"]
    assert abs(d3["onset_torque_corrected"]) < TORSION_TOL, d3  # no torsional friction at all


@needs_mujoco
def test_condims_agree_when_torsion_is_unloaded(results):
    """The load passes through the pads' axis, so condim 4's torsion carries nothing in A to C."""
    for exp in ("A", "B", "C"):
        for key, v3 in results[3][exp].items():
            assert results[4][exp][key] == pytest.approx(v3, rel=1e-9, abs=1e-12), (exp, key)


@needs_mujoco
def test_without_noslip_soft_friction_creeps():
    """The checks above resolve what noslip fixes: MuJoCo's regularised friction alone creeps and
    never sticks (measured: slides at 9.819 N, creeps 1.02e-3 m in 10 s)."""
    a = rig.slip_onset(3, noslip_iterations=0)
    assert a["onset_load"] < 10.0, a
    c = rig.creep(3, noslip_iterations=0)
    assert c["creep"] > 1e-4, c
