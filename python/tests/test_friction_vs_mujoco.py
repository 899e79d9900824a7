"""tandem's friction grasps (`[plant.contact_grasps]`) against MuJoCo on the same two-pad rig
(`mujoco_friction_rig.py`: a 1 kg box 0.1 x 0.08 x 0.1 m at (0, 0, 0.5), two pads of radius
0.01 m on its -y and +y faces pressing inward with F_g = 20 N each, mu = 0.5; MuJoCo with
condim 3, elliptic cones, noslip).

The tandem rig (written into the test's tmp dir, run with the `tandem` binary)
-----------------------------------------------------------------------------
* A spatial scenario needs two arms (the cooperative controller's set-up refuses one) and every
  arm must be a full 6-DOF chain (the path check refuses sigma_min < 0.02), so each pad is on its
  own arm, as each MuJoCo pad is on its own finger: a 6-DOF "carriage" URDF (prismatic z, x, y,
  then revolute x, y, z whose axes meet at the tool; every link 1e4 kg and 1e4 kg m^2, centres
  of mass on the axes, effort 1e7), bases at y = -0.54 m (arm 1) and y = +0.54 m yawed pi
  (arm 2), tools at the box's -y / +y face centres with tool z into the box, one pad per arm
  `{ position = [0, 0, 0], normal = [0, 0, 1], radius = 0.01 }` (tool frame). The brief's
  single arm carrying both pads is not expressible; one pad per arm is the MuJoCo rig exactly,
  and `contacts.slip_distance_m[i]` is then that one pad's anchor travel (no division by 2).
  Grasps may not coincide either (`arms[1].grasp: coincides with grasps[0]`).
* `[plant.contact_grasps]`: mu 0.5, grip 20 N, k_n = k_t = 1e5 N/m, d_n = d_t = 300 N s/m,
  plant_step 1e-4 s, control 1 ms (`tandem validate` prints no warning).
* The carriages are held by a replay of constant joint forces: lift 6e4 kg x g + m g / 2 (the
  links above it, plus the half of the box's weight each pad carries), y slide +20 N (the grip's
  reaction, like MuJoCo's squeeze actuators), 0 elsewhere. While the box slides the pads carry
  10 N instead of 4.9 N, so the 6e4 kg carriages sink by ~4e-6 m over a run; that is subtracted
  (the box's travel is measured against its pads).
* Pushes: tandem's `[[disturbance.pushes]]` wrench is the force ON the object (it enters F_d
  with a minus sign, `model/disturbance.rs`): wrench z = -15 N pushes the box DOWN (checked on a
  run: +15 N lifts it by 15 N / 2e5 N/m = 7.5e-5 m). A push is sampled at the control ticks
  (1 ms) and held over each tick, so `t0` is put half a tick before the first loaded tick: the
  same 1 ms held load history MuJoCo gets.

Compared
--------
1. Slip onset bracket. The extra load (on top of the weight) that the pads can hold is
   2 mu F_g - m g = 10.19 N. A step load overshoots: the box on the pads' springs (2 x 1e5 N/m,
   2 x 300 N s/m, zeta = 0.67) transmits ~25 % more than a step's size. So the load is
   raised as a staircase of 40 equal steps every 5 ms from t = 0.2 s (the box settled; each
   step's transient has decayed by exp(-5 ms x zeta omega) = 0.2 before the next; the staircase is
   a 50 N/s ramp on the 1 ms grid) to 0.98 x and 1.02 x that capacity, then held to 0.6 s. The
   last 0.255 N step overshoots by 0.064 N (measured, two pads), inside the 0.204 N (2 %) left
   below the cone. Both simulators must hold at 0.98 x and slip at 1.02 x, and at 1.02 x slide
   as far (the travel grows as (load - capacity) t^2, so it checks the capacity itself: 0.1 %
   of capacity moves it by 5 %).
2. Experiment B (15 N down for 0.1 s from t = 0.2 s) slip distance, z(0.2) - z(0.6). MuJoCo is
   Coulomb's rigid-contact 0.0354024 m to +1.2e-6 m. tandem's pads are compliant, which changes
   the answer by a predictable amount (`compliant_push_slip`):
   - before the pads reach their cone, their springs and dampers (k = 2e5 N/m, c = 600 N s/m in
     all) hold less than 20 N, so the box gains momentum a rigid pad would not give it (the
     pre-slip phase: 1.4 ms, +6.6e-3 m/s): +9.67e-4 m;
   - when it stops, the pads' springs unload from the cone (10 N each, 1e-4 m) to the weight
     (4.905 N, 4.905e-5 m): the box springs back by (mu F_g - m g / 2) / k_t = 5.095e-5 m.
     (The settled sag m g / (2 k_t) = 4.9e-5 m itself is the same at 0.2 s and 0.6 s and cancels.)
   tandem minus this correction is compared with MuJoCo; tandem's box travel against its pads
   must also equal its anchors' travel `slip_distance_m` (stuck at both ends).

Measured (mujoco 4.0.1, tandem 0.1.0 = /tmp/tandem-s13):
1. At 0.98 x (9.986 N extra) tandem holds: slipped false, slip_distance_m exactly [0, 0], the
   smallest cone margin 0.0699 N per pad (of the 0.102 N left: the staircase's overshoot is
   0.032 N a pad), the box sinks 4.993e-5 m on its springs (9.986 N / 2e5 N/m = 4.993e-5 m);
   MuJoCo travels 1.2e-10 m. At 1.02 x (10.394 N) tandem slips from 0.3964 s (the last step is at
   0.395 s), 4.316e-3 m per pad by 0.6 s; MuJoCo travels 4.302e-3 m (still sliding at 0.041 m/s:
   0.204 N / 1 kg for ~0.2 s; tandem's extra 1.4e-5 m is the same pre-slip momentum as in B).
2. MuJoCo 0.0354036 m (Coulomb 0.0354024 m). tandem: box 0.0363214 m, carriages sank
   4.06e-6 m, so 0.0363173 m against the pads = slip_distance_m 0.0363173 m (to 2e-16 m); first
   slip event 0.2036 s, stuck again 0.3479 s (MuJoCo at rest from 0.348 s). The compliant model
   predicts 0.0363183 m (tandem -9.4e-7 m); the correction to rigid Coulomb is +9.159e-4 m
   (+9.668e-4 m pre-slip momentum, -5.095e-5 m spring-back), so tandem corrected is 0.0354014 m
   and MuJoCo - tandem corrected = +2.2e-6 m.

Tolerances
----------
* HELD_TRAVEL = 1e-5 m, SLID_TRAVEL = 1e-3 m for the bracket: a held box moves by its elastic
  stretch only (tandem 5e-5 m, so tandem's hold is judged by its anchors, exactly 0; MuJoCo
  ~1e-10 m), a slipping one by 0.204 N / 1 kg over the ~0.2 s left: 4 mm.
* SLID_REL = 0.02 between the two 1.02 x travels (measured 0.3 %): 2 % of the travel is 0.04 %
  of the capacity (4 mN); the pre-slip momentum adds 1.4e-5 m to tandem's.
* SLIP_TOL = 1e-5 m (0.03 %) between tandem corrected and MuJoCo: MuJoCo's soft contact errs by
  +1.2e-6 m, tandem differs from its own compliant model by -9.4e-7 m (RK4 at 1e-4 s and the
  carriages' sinking while the pads slide); 1e-5 m is ~4x the measured 2.2e-6 m and fails a
  tandem that left out the end's spring-back (5.1e-5 m) or compared raw (9.2e-4 m).
* ANCHOR_TOL = 1e-7 m: box travel against the pads vs slip_distance_m (both springs are back at
  the weight's stretch at both ends; measured 2e-16 m).

Runtime: three tandem runs of 0.6 s simulated (0.05-0.08 s each, validate included) and three
MuJoCo runs (0.01 s each): 0.43 s for this file (pytest's own start-up aside).
"""

import csv
import json
import math
import pathlib

import pytest

try:
    import mujoco  # noqa: F401
except ImportError as e:  # pragma: no cover - depends on the venv
    mujoco = None
    MUJOCO_MISSING = (
        f"mujoco is not installed in this venv ({e}); .ci/run installs it with "
        "`pip install mujoco`"
    )

pytestmark = pytest.mark.skipif(mujoco is None, reason=globals().get("MUJOCO_MISSING", ""))

if mujoco is not None:
    import mujoco_friction_rig as rig

G = 9.81
MASS = 1.0
MU = 0.5
GRIP = 20.0
K_T = 1e5  # N/m, tandem's pad stiffness (normal and tangential)
D_T = 300.0  # N s/m, tandem's pad damping (normal and tangential)
LINK_MASS = 1e4  # kg, each of the carriage's six links
CONTROL = 1e-3  # s
START, END = 0.2, 0.6  # s: settled; end of every run
PUSH_FORCE, PUSH_DURATION = 15.0, 0.1
STAIRS, STAIR_DT = 40, 0.005  # steps of the onset staircase, s between them

HELD_TRAVEL = 1e-5  # m
SLID_TRAVEL = 1e-3  # m
SLID_REL = 0.02  # (measured 0.3 %)
SLIP_TOL = 1e-5  # m (measured 2.2e-6 m)
ANCHOR_TOL = 1e-7  # m (measured 2e-16 m)

# ---------------------------------------------------------------------------------------------
# The tandem rig.


def _urdf():
    inertial = (
        f'<inertial><origin xyz="0 0 0"/><mass value="{LINK_MASS:g}"/>'
        f'<inertia ixx="{LINK_MASS:g}" iyy="{LINK_MASS:g}" izz="{LINK_MASS:g}"/></inertial>'
    )
    joints = [  # name, type, axis, origin, limit
        ("lift", "prismatic", "0 0 1", "0 0 0", 1),
        ("slide_x", "prismatic", "1 0 0", "0 0 0", 1),
        ("slide_y", "prismatic", "0 1 0", "0 0 0", 1),
        ("roll", "revolute", "1 0 0", "0 0.5 0.5", 3),  # the wrist at the pad
        ("pitch", "revolute", "0 1 0", "0 0 0", 3),
        ("yaw", "revolute", "0 0 1", "0 0 0", 3),
    ]
    out = ['<?xml version="1.0"?>', '<robot name="carriage">', '  <link name="base_link"/>']
    parent = "base_link"
    for i, (name, kind, axis, origin, lim) in enumerate(joints):
        link = f"l{i + 1}"
        out.append(f'  <link name="{link}">{inertial}</link>')
        out.append(
            f'  <joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{link}"/>'
            f'<origin xyz="{origin}"/><axis xyz="{axis}"/>'
            f'<limit lower="-{lim}" upper="{lim}" effort="1e7" velocity="100"/></joint>'
        )
        parent = link
    # the tool's z (the pad's pressing direction) along the carriage's +y, into the box
    out.append('  <link name="tool"/>')
    out.append(
        '  <joint name="tool_mount" type="fixed"><parent link="l6"/><child link="tool"/>'
        '<origin xyz="0 0 0" rpy="-1.5707963267948966 0 0"/></joint>'
    )
    out.append("</robot>")
    return "\n".join(out) + "\n"


# The grasp frames' axes (columns, object axes): tool z into the box, tool y down.
AXES_1 = "[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]"  # -y face: z = +y
AXES_2 = "[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, -1.0, 0.0]"  # +y face: z = -y


def _scenario(pushes, grip=GRIP):
    """The scenario's TOML; `pushes` = [(t0, duration, downward force N)]."""
    push_text = "".join(
        f"\n[[disturbance.pushes]]\nt0 = {t0!r}\nduration = {dur!r}\n"
        f"wrench = [0.0, 0.0, {-f!r}, 0.0, 0.0, 0.0]\n"
        for t0, dur, f in pushes
    )
    return f"""name = "friction-rig"
description = "mujoco_friction_rig.py's two-pad rig: one pad on each of two 6-DOF carriages"

[[arms]]
urdf = "carriage.urdf"
base_link = "base_link"
tool_link = "tool"
base = {{ position = [0.0, -0.54, 0.0] }}
grasp = {{ position = [0.0, -0.04, 0.0], axes = [{AXES_1}] }}

[[arms]]
urdf = "carriage.urdf"
base_link = "base_link"
tool_link = "tool"
base = {{ position = [0.0, 0.54, 0.0], rpy = [0.0, 0.0, 3.141592653589793] }}
grasp = {{ position = [0.0, 0.04, 0.0], axes = [{AXES_2}] }}

[object]
size = [0.1, 0.08, 0.1]
mass = {MASS!r}

[plant]
gravity = [0.0, 0.0, -{G!r}]

[plant.contact_grasps]
mu = {MU!r}
grip = {grip!r}
normal_stiffness = {K_T!r}
normal_damping = {D_T!r}
tangential_stiffness = {K_T!r}
tangential_damping = {D_T!r}
pads = [{{ position = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0], radius = 0.01 }}]

[path]
kind = "point_to_point"
from = {{ position = [0.0, 0.0, 0.5] }}
to = {{ position = [0.0, 0.0, 0.5] }}
duration = 1.0
{push_text}
[controller]
kind = "replay"
k_c = [0.1, 0.1, 0.1, 0.3, 0.3, 0.3]
replay = "hold.csv"

[run]
duration = {END!r}
plant_step = 0.0001
control_period = {CONTROL!r}
log_period = {CONTROL!r}
"""


def _hold_csv(grip=GRIP):
    """Constant joint forces: the lift carries its six links and half the box's weight, the y
    slide presses the pad on with the grip."""
    lift = 6 * LINK_MASS * G + MASS * G / 2
    row = [lift, 0.0, grip, 0.0, 0.0, 0.0] * 2
    head = "t," + ",".join(f"tau{j + 1}" for j in range(12))
    return head + "\n0," + ",".join(repr(x) for x in row) + "\n"


def run_tandem(cli, folder: pathlib.Path, pushes):
    """Write the rig into `folder`, validate and run it; returns the box's travel down from
    START to END against its pads, the carriage's sinking, and the contacts block."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "carriage.urdf").write_text(_urdf())
    (folder / "hold.csv").write_text(_hold_csv())
    (folder / "rig.toml").write_text(_scenario(pushes))
    v = cli("validate", folder / "rig.toml")
    assert "warning" not in v.stdout + v.stderr, v.stdout + v.stderr
    cli("run", folder / "rig.toml", "--out", folder / "out", "--force", "--no-figures")
    with open(folder / "out" / "timeseries.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    times = [float(r["t [s]"]) for r in rows]
    i0 = min(range(len(times)), key=lambda i: abs(times[i] - START))
    # the last row is the state at END - 1 ms: the box is at rest by then in every case here
    # but a slipping one, for which only the threshold matters
    box = float(rows[i0]["x_o.z [m]"]) - float(rows[-1]["x_o.z [m]"])
    carriage = float(rows[i0]["q1 [m]"]) - float(rows[-1]["q1 [m]"])
    summary = json.loads((folder / "out" / "summary.json").read_text())
    assert summary["status"] == "completed", summary["status"]
    return {"travel": box - carriage, "carriage": carriage, "box": box,
            "contacts": summary["contacts"]}


# ---------------------------------------------------------------------------------------------
# Load histories, the same on both sides (held over 1 ms steps / ticks).


def capacity_extra(grip=GRIP):
    """The extra downward load the two pads hold on top of the weight, N."""
    return 2 * MU * grip - MASS * G


def staircase_pushes(load):
    """tandem: STAIRS pushes of load / STAIRS, one every STAIR_DT from START, each held to the end
    (t0 half a tick before its first tick)."""
    return [(START + i * STAIR_DT - CONTROL / 2, END + 1.0 - (START + i * STAIR_DT), load / STAIRS)
            for i in range(STAIRS)]


def staircase(load):
    """MuJoCo: the same staircase as a function of the step's start time."""
    def push(t):
        if t < START - CONTROL / 2:
            return 0.0
        i = min(STAIRS, int(math.floor((t - START + CONTROL / 2) / STAIR_DT)) + 1)
        return load * i / STAIRS
    return push


def compliant_push_slip(grip=GRIP, push=PUSH_FORCE, duration=PUSH_DURATION, mass=MASS, mu=MU,
                        k=K_T, c=D_T, pads=2, h=1e-7):
    """The push's slip of a box on compliant pads (spring k, damper c each, anchored while their
    force is inside the cone): below the cone the box sinks on the springs and dampers,
    m y'' = push - K y - C y' (integrated at h), until K y + C y' reaches the cone's extra
    2 mu F_g - m g; then Coulomb (friction 2 mu F_g) to rest; then the springs unload from the
    cone to the weight. Returns the anchors' travel (= the box's, at rest at both ends)."""
    kk, cc = pads * k, pads * c
    cap = pads * mu * grip
    extra = cap - mass * G
    y = v = t = 0.0
    while kk * y + cc * v < extra:
        v += (push - kk * y - cc * v) / mass * h
        y += v * h
        t += h
    a = (mass * G + push - cap) / mass
    b = (cap - mass * G) / mass
    rest = duration - t
    y += v * rest + 0.5 * a * rest**2
    v += a * rest
    y += v * v / (2 * b)
    return y - (mu * grip - mass * G / pads) / k


# ---------------------------------------------------------------------------------------------
# The runs, once per module.


@pytest.fixture(scope="module")
def bracket(cli, tmp_path_factory):
    out = {}
    for f in (0.98, 1.02):
        load = f * capacity_extra()
        t = run_tandem(cli, tmp_path_factory.mktemp(f"onset{f}"), staircase_pushes(load))
        m = rig.travel_under(3, staircase(load), START, END)
        out[f] = {"load": load, "tandem": t, "mujoco": m}
    return out


@pytest.fixture(scope="module")
def push_b(cli, tmp_path_factory):
    t = run_tandem(cli, tmp_path_factory.mktemp("push"),
                   [(START - CONTROL / 2, PUSH_DURATION, PUSH_FORCE)])
    m = rig.push_slip(3)
    return {"tandem": t, "mujoco": m}


def test_onset_bracket_held_below(bracket):
    r = bracket[0.98]
    c = r["tandem"]["contacts"]
    assert c["slipped"] is False, c
    assert c["slip_distance_m"] == [0.0, 0.0], c  # the anchors never moved
    assert all(p["final_status"] == "stick" for p in c["pads"]), c
    # close to the cone, not far from it: 2 % of 10.19 N is 0.1 N per pad
    assert all(0.0 < p["min_margin_N"] < 0.2 for p in c["pads"]), c
    # the box sinks by its springs' stretch only: 9.986 N / 2e5 N/m = 5e-5 m
    assert r["tandem"]["travel"] == pytest.approx(r["load"] / (2 * K_T), rel=0.01), r
    assert abs(r["mujoco"]["travel"]) < HELD_TRAVEL, r


def test_onset_bracket_slides_above(bracket):
    r = bracket[1.02]
    c = r["tandem"]["contacts"]
    assert c["slipped"] is True, c
    # not before the staircase's last step (START + 39 x 5 ms = 0.395 s)
    assert c["first_slip_t_s"] >= START + (STAIRS - 1) * STAIR_DT, c
    assert min(c["slip_distance_m"]) > SLID_TRAVEL, c
    assert r["mujoco"]["travel"] > SLID_TRAVEL, r
    for d in c["slip_distance_m"]:
        assert d == pytest.approx(r["mujoco"]["travel"], rel=SLID_REL), r


def test_push_slip_matches_mujoco(push_b):
    t, m = push_b["tandem"], push_b["mujoco"]
    c = t["contacts"]
    assert c["slipped"] is True and c["first_slip_t_s"] > START, c
    # the box against its pads moved as far as the pads' anchors (springs at the weight's stretch
    # at both ends)
    for d in c["slip_distance_m"]:
        assert t["travel"] == pytest.approx(d, abs=ANCHOR_TOL), (t, d)
    # MuJoCo is Coulomb's rigid pads (test_mujoco_friction.py checks it to 2e-5 m)
    coulomb = rig.coulomb_push_slip(GRIP)
    assert m["slip"] == pytest.approx(coulomb, abs=SLIP_TOL), m
    correction = compliant_push_slip() - coulomb
    assert correction == pytest.approx(9.16e-4, abs=1e-5)  # pre-slip momentum - spring-back
    assert t["travel"] - correction == pytest.approx(m["slip"], abs=SLIP_TOL), (t, m, correction)
    # the carriages stood still to ~1e-4 of the box's travel
    assert abs(t["carriage"]) < 2e-4 * t["travel"], t
