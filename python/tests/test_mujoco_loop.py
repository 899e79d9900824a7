"""Issue 23's proof on an independent simulator: `tandem export dual-ur5` loaded in MuJoCo
(`mujoco` from PyPI, which .ci/run installs), driven for 5 s at 1 kHz by `tandem.Controller`
(NN, PD + gravity, CTC) with readings taken from MuJoCo itself, exactly as a user would wire
tandem's controller to their own simulator or robot:

* joint angles and rates: `qpos`, `qvel` of the arms;
* each wrist reading: the generalised force of that arm's weld (`efc_J^T efc_force` on the arm's
  joints, after `mj_forward` with the previous torques held) mapped back through the tool-site
  Jacobian to the object's wrench on the tool, about the tool origin, then rotated into tool
  axes.

The loop starts as a robot would: the arms hold the box at rest with tandem's holding torques
(the MJCF keyframe's `ctrl`), and the same loop runs on tandem's own plant (`Scenario.plant()`,
`Plant.hold`). Checked: the sensor sanity check is silent with the right convention and warns
when a reading's sign is flipped or it is given in world axes; the S5 claims hold in MuJoCo
(position error ≤ 1 mm and rotation error ≤ 1 mrad after 2 s, the box inside the bounds); the
box's path in MuJoCo agrees with tandem's plant.

How close the two simulators can agree is set by MuJoCo's constraint model, not by tandem: a
MuJoCo weld is a soft constraint whose impedance is capped at d = 0.9999, so its force carries
a regularisation R = (1 − d)/d · A_ii (measured on this model: R = 1.1e-4 on the translational
rows, 0.27 on the rotational ones). With the arms falling from rest under zero torque, MuJoCo's
weld forces differ from the rigid solution by up to 7 % (0.42 N of the 5–9 N wrist forces),
while tandem's equal the rigid KKT solution on MuJoCo's own M, J and bias (5.336 N vs 5.3355 N).
Under control the difference stays small and does not drift: over 5 s the box's position
differs by at most 1.4e-4 m (NN 9.7e-5, PD + gravity 1.3e-4, CTC 1.4e-4), while each simulator's
box follows the desired path to within 3e-5 m after 2 s. The gap is the admittance model at
work, not a tracking error: it turns the wrist readings into the reference x_r, and MuJoCo's
soft-weld readings differ from tandem's by about 0.1 N under motion (CTC at 3 s), which moves
x_r by 7e-5 m (x_d is identical). The tolerance below, 5e-4 m, is that bound with margin;
1e-6 m (the issue's aim) would need MuJoCo's welds rigid.
"""

import json
import warnings

import numpy as np
import pytest

import tandem

try:
    import mujoco
except ImportError as e:  # pragma: no cover - depends on the venv
    mujoco = None
    MUJOCO_MISSING = (
        f"mujoco is not installed in this venv ({e}); .ci/run installs it with "
        "`pip install mujoco`"
    )

needs_mujoco = pytest.mark.skipif(mujoco is None, reason=globals().get("MUJOCO_MISSING", ""))

DURATION = 5.0
PATH_TOLERANCE = 5e-4  # m: see the module's docstring


@pytest.fixture(scope="module")
def scene(cli, tmp_path_factory):
    d = tmp_path_factory.mktemp("mujoco-loop")
    cli("export", "dual-ur5", "--out", d / "dual-ur5.xml")
    cli("export", "dual-ur5", "--out", d / "dual-ur5.json")
    js = json.loads((d / "dual-ur5.json").read_text())
    m = mujoco.MjModel.from_xml_path(str(d / "dual-ur5.xml"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", tandem.ScenarioWarning)
        sc = tandem.Scenario.preset("dual-ur5")
    return sc, m, js


class Readings:
    """What the arms' encoders and wrist sensors read in MuJoCo (see the module docstring)."""

    def __init__(self, m, js):
        self.m = m
        self.n_q = len(js["start"]["q"])
        dofs = [len(a["chain"]["joints"]) for a in js["arms"]]
        self.offs = np.cumsum([0] + dofs)
        self.n_arms = len(dofs)
        self.sites = [m.site(f"arm{i}_tool").id for i in range(self.n_arms)]
        self.jp, self.jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))

    def __call__(self, d, world_axes=False):
        m = self.m
        mujoco.mj_forward(m, d)
        J = d.efc_J.reshape(d.nefc, m.nv)
        w = np.zeros((self.n_arms, 6))
        for i in range(self.n_arms):
            rows = d.efc_id[: d.nefc] == i
            qf = J[rows].T @ d.efc_force[: d.nefc][rows]
            a, b = self.offs[i], self.offs[i + 1]
            mujoco.mj_jacSite(m, d, self.jp, self.jr, self.sites[i])
            ja = np.vstack([self.jp, self.jr])[:, a:b]
            wrench, *_ = np.linalg.lstsq(ja.T, qf[a:b], rcond=None)
            r = d.site_xmat[self.sites[i]].reshape(3, 3)
            if world_axes:
                w[i] = wrench
            else:
                w[i, :3], w[i, 3:] = r.T @ wrench[:3], r.T @ wrench[3:]
        return d.qpos[: self.n_q].copy(), d.qvel[: self.n_q].copy(), w


def start_data(m):
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("start").id)  # ctrl = tandem's holding torques
    return d


def angle(qa, qb):
    """The rotation angle between unit quaternions (w, x, y, z), rad."""
    return 2.0 * np.arccos(min(1.0, abs(float(np.dot(qa, qb)))))


@needs_mujoco
def test_the_sensor_sanity_check_on_mujoco_readings(scene):
    sc, m, js = scene
    read = Readings(m, js)
    c = sc.controller("nn")
    q, qd, w = read(start_data(m))
    with warnings.catch_warnings():
        warnings.simplefilter("error", tandem.ScenarioWarning)
        c.start(0.0, q, qd, w)  # the right convention: silent
    flipped = w.copy()
    flipped[1] *= -1
    with pytest.warns(tandem.ScenarioWarning, match=r"arm 2: .*its sign looks flipped"):
        c.start(0.0, q, qd, flipped)
    with pytest.warns(tandem.ScenarioWarning, match="Every reading's sign looks flipped"):
        c.start(0.0, q, qd, -w)
    _, _, world = read(start_data(m), world_axes=True)
    with pytest.warns(tandem.ScenarioWarning, match="look given in world axes"):
        c.start(0.0, q, qd, world)
    with pytest.warns(tandem.ScenarioWarning, match="tool axes"):
        c.start(0.0, q, qd, 1000.0 * w)  # N given as mN


@needs_mujoco
@pytest.mark.parametrize("law", ["nn", "pd-gravity", "ctc"])
def test_tandems_controller_drives_mujoco_and_meets_s5(scene, law):
    sc, m, js = scene
    read = Readings(m, js)
    n_q = read.n_q
    own = sc.with_(**{"controller.kind": "ctc"}).run(duration=DURATION)
    ts = own.timeseries
    # The output chart's centre (x_1 = p − c) and the desired path (x_d, in the chart).
    centre = np.array([ts[f"x_o.{a}"][0] - ts[f"x_1.{a}"][0] for a in "xyz"])
    k_c = np.array(sc.get("controller.k_c")[:3])

    def loop(step, sense, t_end):
        c = sc.controller(law)
        with warnings.catch_warnings():
            warnings.simplefilter("error", tandem.ScenarioWarning)  # the check stays silent
            c.start(0.0, *sense())
        h = c.control_period
        tau = np.zeros(n_q)
        poses = []
        for k in range(int(round(t_end / h))):
            c.tick(k * h, *sense(), out=tau)
            poses.append(step(tau))
        return np.array(poses)  # row k: the box at t = (k + 1) h

    d = start_data(m)

    def mj_step(tau):
        d.ctrl[:] = tau
        mujoco.mj_step(m, d)
        return d.qpos[n_q : n_q + 7].copy()

    in_mujoco = loop(mj_step, lambda: read(d), DURATION)

    plant = sc.plant()
    plant.hold(js["start"]["holding_torques"])

    def tandem_step(tau):
        plant.step(tau)
        return plant.state["object_pose"]

    in_tandem = loop(tandem_step, plant.sensors, DURATION)

    # S5 in MuJoCo, against the desired path and the bounds.
    t = (np.arange(len(in_mujoco)) + 1) * 1e-3
    rows = np.round(ts["t"] / 1e-3).astype(int) - 1  # the log's times, 10 ms apart
    keep = rows >= 0
    p_d = np.stack([ts[f"x_d.{a}"] for a in "xyz"], 1)[keep] + centre
    p_mj = in_mujoco[rows[keep], :3]
    after = t[rows[keep]] >= 2.0
    z1 = np.linalg.norm(p_mj - p_d, axis=1)
    assert z1[after].max() <= 1e-3, z1[after].max()
    assert np.all(np.abs(in_mujoco[:, :3] - centre) < k_c), "the box left the bounds"
    # Rotation: MuJoCo's box against tandem's (whose own error is in its summary).
    rot = max(angle(a, b) for a, b in zip(in_mujoco[1999:, 3:], in_tandem[1999:, 3:]))
    assert rot + own.summary["s5_claims"]["z1_rot_after_2s"]["max_rad"] <= 1e-3, rot
    # The same loop on tandem's plant: the two simulators agree.
    gap = np.linalg.norm(in_mujoco[:, :3] - in_tandem[:, :3], axis=1)
    assert gap.max() <= PATH_TOLERANCE, gap.max()
    print(
        f"\n{law}: MuJoCo z1 after 2 s {z1[after].max():.2e} m; MuJoCo vs tandem box "
        f"{gap.max():.2e} m (at 2 s {gap[1999]:.2e}, at 5 s {gap[-1]:.2e}), "
        f"{rot:.2e} rad"
    )
