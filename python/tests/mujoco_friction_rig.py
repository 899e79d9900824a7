"""MuJoCo half of the independent check of tandem's friction grasp model: a 1 kg box held
between two friction pads, its slip onset under a slowly growing load (experiment A), its slip
distance after a short push (experiment B), and its creep while held (experiment C), all
compared with Coulomb's law. `test_mujoco_friction.py` runs it; `python mujoco_friction_rig.py`
prints the numbers.

The rig (tandem's side uses the same numbers)
--------------------------------------------
* Gravity (0, 0, -9.81) m/s^2; `timestep` 1 ms, `integrator="implicitfast"` (nothing here is
  velocity-dependent, so it is the semi-implicit Euler step; 1 ms resolves a 0.1 s push in 100
  steps, and with the push held over whole steps Euler's position error cancels between the
  speeding-up and slowing-down phases: a T dt / 2 - v0 dt / 2 = 0 with v0 = a T).
* Box: 1 kg, edges 0.1 x 0.08 x 0.1 m (x, y, z), uniform inertia (MuJoCo's default for a box
  geom with `mass`), centre at (0, 0, 0.5), free joint.
* Two fingers, each a body on a world-fixed slide joint along y, 0.05 kg (small but not zero:
  the slide joint carries the tangential load into the world, the actuator sets the normal
  force). Each is driven by a `motor` with a constant `ctrl` = F_g (gear +1 for pad 0 at
  y = -0.04 pressing +y, gear -1 for pad 1 at y = +0.04 pressing -y). In equilibrium the
  finger's only y forces are the actuator and the contact, so the normal force is exactly F_g;
  while sliding it chatters (see below) but its time average stays F_g by the finger's
  momentum balance.
* Pads: the disc of radius 0.01 m is modelled as a sphere geom of radius 0.01 m whose pole
  touches the box face at its centre. MuJoCo's contact force depends on the geometry only
  through the contact point, frame and penetration, and a sphere-box pair gives exactly one
  contact at the face centre with normal +-y: the point contact with a torsional patch
  coefficient that tandem models. A thin cylinder or small box pad was rejected: in
  mujoco 4.0.1 cylinder-box and box-box give four rim/corner contacts per pad (for the
  cylinder at asymmetric points, e.g. (-0.0092, 0.0038) and (0.01, 0) about the centre), which
  splits the normal force unevenly and, with condim 4, would count torsion twice (the rim
  contacts' lever arm plus each contact's own torsional coefficient).
* Friction mu = 0.5 (geom `friction="0.5 torsion 0.0001"`; MuJoCo takes the max of the pair,
  the box has the same value). condim 3 (tangential only) and condim 4 with torsional
  coefficient 0.002 m. `cone="elliptic"` (the Coulomb cone, not a pyramid).
* `noslip_iterations=20`: the noslip post-processor re-solves the friction forces without the
  soft-constraint regulariser (measured: 10 iterations already give the same numbers to
  1e-12; 1 iteration leaves creep of 4.3e-5 m over 10 s and an onset at 10.04 N).
* `impratio=10` (friction-to-normal impedance ratio; MuJoCo's advice for elliptic cones to
  reduce slip). With noslip on its effect is second order: creep 0.2 -> 10 s 1.5e-8 m at
  impratio 1, 1.6e-9 m at 10; slip distance (B) 0.0354081 vs 0.0354036 m.
* `solref="0.002 1"`: time constant 2 ms = 2 x timestep, the stiffest MuJoCo's stability rule
  (time constant >= 2 timesteps) allows, critically damped. `solimp="0.99 0.999 0.001 0.5 2"`:
  impedance 0.99 at zero penetration rising to 0.999 at 1 mm (MuJoCo's regulariser is
  R = (1 - d) / d x A, so d near 1 makes the constraint nearly hard; the default 0.9-0.95 is
  ten times softer). Penetration at 20 N: 1.7e-5 m.

Experiments
-----------
A (slip onset): F_g = 20 N; settle 0.5 s; then `xfrc_applied` pushes the box down with
  F(t) = 1 N/s x (t - 0.5 s) on top of its weight; load = m g + F. Onset is the first step at
  which the box's downward displacement relative to the pads (the pads cannot move in z)
  since the ramp began exceeds ONSET_THRESHOLD = 1e-6 m (50x more than the creep before onset,
  see below). Under Coulomb the box slides from load 2 mu F_g with acceleration
  (load - 20 N)/m, i.e. z = (1 N/s)(t - t0)^3 / (6 m), so a threshold delta is crossed
  (6 m delta / 1 N/s)^(1/3) = 0.018 s = 0.018 N of load late; `onset_load_corrected` removes
  that lag. Coulomb: 2 mu F_g = 20 N.
B (push): F_g = 20 N; settle 0.2 s; push 15 N down for 0.1 s (100 steps from t = 0.2 s); then
  nothing; slip = z(0.2 s) - z(0.6 s) (the box is at rest again from t = 0.348 s). Coulomb with
  rigid contacts: 4.81 m/s^2 for 0.1 s (0.02405 m, 0.481 m/s) then 10.19 m/s^2 to rest
  (0.011352 m): 0.035402 m.
C (creep): F_g = 12 N (capacity 12 N > 9.81 N), no push, 10 s; reported as the sag from the
  start (mostly the first steps: the contacts start at zero penetration and carry no force
  for one step) and the creep from 0.2 s to 10 s. tandem's anchor model creeps exactly 0.

MuJoCo's soft-contact error sources
-----------------------------------
* solref time constant tau: every constraint is a critically damped spring-damper reaching its
  reference in ~tau. It sets the penetration (1.7e-5 m at 20 N), the initial sag
  (~ g dt tau / 2 = 9.8e-6 m) and how fast sticking is re-established at the end of a slip.
  Slip distance (B) minus Coulomb's vs tau (timestep 1 ms): 2 ms +1.2e-6 m, 5 ms +5.2e-5 m,
  20 ms +5.7e-4 m; with tau = 2 x timestep: 0.5 ms / 1 ms +3.7e-7 m, 2 ms / 4 ms +4.1e-6 m.
  Onset (A, corrected) and creep (C) hardly move (20 ms: 19.9978 N, 5.4e-9 m).
* Friction regularisation (impratio): without noslip, MuJoCo's friction is a soft constraint
  whose force needs a small sliding velocity, so a held box creeps. With noslip off the box
  creeps 1.0e-3 m in 10 s at F_g = 12 N (impratio 10; 0.0102 m at impratio 1) and in A it
  creeps 1.5e-3 m (0.0146 m) before reaching the Coulomb load and crosses the 1e-6 m
  threshold at 9.82 N (9.81 N), i.e. as soon as the ramp starts: without noslip MuJoCo has no
  sticking at all. impratio scales the creep down; noslip removes it.
* noslip: re-solves friction with no regulariser, leaving creep at 1.6e-9 m (C) and 2.3e-9 m
  before onset (A). It needs ~10 iterations here (1 iteration: creep 4.3e-5 m in C, onset at
  10.04 N; 10 and 20 give the same numbers to 1e-12).
* Sliding separation (observed; MuJoCo's contact model is a convex relaxation of the
  complementarity problem, whose sliding solutions carry a normal separation velocity of the
  order of mu times the slip speed): a sliding contact pushes the pads apart. While
  the box slides in B (148 steps) the pads are pushed off (finger speed up to 0.59 m/s), are
  out of contact on 51 steps and are driven back by the 20 N actuators (0.05 kg: 400 m/s^2),
  so the normal force chatters between 15.5 and 67.4 N, averaging 19.9 N over the sliding
  steps. The time average of the normal force is F_g by the finger's momentum balance, so the
  slip distance stays Coulomb's to the residual of a chatter cycle at the start and end of
  sliding. Heavier fingers chatter harder (0.5 kg: out of contact on 112 of 148 steps, up to
  222 N) with the same slip to 5e-6 m (0.0354079 m). Before onset (A) and while held (C)
  nothing slides and the normal force is F_g to 6e-7 N (measured through A's ramp).
* Detection and stepping: loads are held over each 1 ms step (the ramp moves 1 mN per step),
  and a displacement threshold is crossed after the onset (the Coulomb lag removed above).

Measured (mujoco 4.0.1; condim 3 and condim 4 with torsion 0.002 m give the same numbers to
1e-12 in A, B and C, and the torsional moment stays exactly 0: the load passes through the pads'
axis, so torsion is never loaded there):
A: creep before onset (load 19.31 N) 2.3e-9 m; the 1e-6 m threshold is crossed at load
20.018 N, 19.9998 N with the 0.0182 N Coulomb lag removed (thresholds 1e-5 / 1e-4 m: 20.039 /
20.084 N, corrected 19.9999 / 19.9997 N). Coulomb: 20 N.
B: slip 0.0354036 m, at rest again by t = 0.35 s (speed at 0.6 s 1.6e-10 m/s). Coulomb:
0.0354024 m (+1.2e-6 m, 0.003 %).
C: sag 9.80e-6 m from the start (the first steps), creep 0.2 -> 10 s 1.6e-9 m.
D (torque about the pads' axis, 0.01 N m/s, threshold 1e-6 rad): condim 4 turns at 0.06981 N m,
0.06971 N m with the lag removed, against Coulomb's elliptic-cone limit
2 x 0.002 x sqrt(20^2 - 9.81^2) = 0.069715 N m; condim 3 turns at once (0.0001 N m, the lag).
One full set (A, B, C, D) takes ~0.3 s.
"""

import mujoco
import numpy as np

G = 9.81
MASS = 1.0
MU = 0.5
TORSION = 0.002  # m, condim 4's torsional coefficient
PAD_RADIUS = 0.01
HALF = (0.05, 0.04, 0.05)  # box half-edges
Z0 = 0.5
TIMESTEP = 1e-3
SOLREF = "0.002 1"
SOLIMP = "0.99 0.999 0.001 0.5 2"
IMPRATIO = 10
NOSLIP_ITERATIONS = 20
FINGER_MASS = 0.05

ONSET_THRESHOLD = 1e-6  # m
RAMP_START = 0.5  # s
RAMP_RATE = 1.0  # N/s
TORQUE_RATE = 0.01  # N m/s
PUSH_START, PUSH_DURATION, PUSH_FORCE, PUSH_END = 0.2, 0.1, 15.0, 0.6


def coulomb_onset(grip, mu=MU):
    return 2 * mu * grip


def coulomb_push_slip(grip=20.0, push=PUSH_FORCE, duration=PUSH_DURATION, mass=MASS, mu=MU):
    a = (mass * G + push - 2 * mu * grip) / mass
    b = (2 * mu * grip - mass * G) / mass
    v = a * duration
    return 0.5 * a * duration**2 + v * v / (2 * b)


def mjcf(grip, condim, torsion=TORSION, noslip_iterations=NOSLIP_ITERATIONS, impratio=IMPRATIO,
         solref=SOLREF, timestep=TIMESTEP, finger_mass=FINGER_MASS):
    """The rig's MJCF. `grip` is recorded in the actuators' default `ctrl` via a keyframe."""
    hx, hy, hz = HALF
    fric = f"{MU} {torsion} 0.0001"
    pad = f'type="sphere" size="{PAD_RADIUS}" mass="{finger_mass}" contype="2" conaffinity="1"'
    return f"""<mujoco model="friction-rig">
  <option gravity="0 0 -{G}" timestep="{timestep}" integrator="implicitfast" cone="elliptic"
          impratio="{impratio}" noslip_iterations="{noslip_iterations}"/>
  <default>
    <geom condim="{condim}" friction="{fric}" solref="{solref}" solimp="{SOLIMP}"/>
  </default>
  <worldbody>
    <body name="box" pos="0 0 {Z0}">
      <freejoint/>
      <geom name="box" type="box" size="{hx} {hy} {hz}" mass="{MASS}" contype="1" conaffinity="2"/>
    </body>
    <body name="finger0" pos="0 {-hy - PAD_RADIUS} {Z0}">
      <joint name="slide0" type="slide" axis="0 1 0"/>
      <geom name="pad0" {pad}/>
    </body>
    <body name="finger1" pos="0 {hy + PAD_RADIUS} {Z0}">
      <joint name="slide1" type="slide" axis="0 1 0"/>
      <geom name="pad1" {pad}/>
    </body>
  </worldbody>
  <actuator>
    <motor name="squeeze0" joint="slide0" gear="1"/>
    <motor name="squeeze1" joint="slide1" gear="-1"/>
  </actuator>
  <keyframe>
    <key name="grip" ctrl="{grip} {grip}"/>
  </keyframe>
</mujoco>"""


def _simulate(grip, condim, push, duration, **kw):
    """Run the rig for `duration` s with the downward push `push(t)` (N) held over each step;
    returns (times, box z) sampled after every step, z[0] the initial height."""
    m = mujoco.MjModel.from_xml_string(mjcf(grip, condim, **kw))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    box = m.body("box").id
    n = int(round(duration / m.opt.timestep))
    z = np.empty(n + 1)
    z[0] = d.qpos[2]
    for k in range(n):
        d.xfrc_applied[box, 2] = -push(k * m.opt.timestep)
        mujoco.mj_step(m, d)
        z[k + 1] = d.qpos[2]
    return np.arange(n + 1) * m.opt.timestep, z


def travel_under(condim, push, start, end, grip=20.0, **kw):
    """The box's downward travel (m) from `start` to `end` s under the downward push `push(t)`
    (N, held over each step; the same load history a tandem run is given), and its speed at
    `end` (for `test_friction_vs_mujoco.py`)."""
    dt = kw.get("timestep", TIMESTEP)
    t, z = _simulate(grip, condim, push, end, **kw)
    i0 = int(round(start / dt))
    return {"travel": float(z[i0] - z[-1]), "final_speed": float(abs(z[-1] - z[-2]) / dt)}


def slip_onset(condim, grip=20.0, threshold=ONSET_THRESHOLD, **kw):
    """Experiment A. Returns the load (m g + F) at which the box's slip since the ramp began
    first exceeds `threshold`, that load less the Coulomb detection lag, the creep before
    onset (at load 2 mu F_g - 0.69 N) and the settled sag."""
    dt = kw.get("timestep", TIMESTEP)
    limit = coulomb_onset(grip)
    end = RAMP_START + (limit - MASS * G) / RAMP_RATE + 1.0
    t, z = _simulate(grip, condim, lambda s: max(0.0, RAMP_RATE * (s - RAMP_START)), end, **kw)
    i0 = int(round(RAMP_START / dt))
    slip = z[i0] - z
    # z[k] is the first sample past the threshold; the push held over the step into it was
    # F(t[k - 1])
    k = int(np.argmax(slip > threshold))
    if slip[k] <= threshold:
        raise AssertionError(f"no slip onset within {end} s")
    load = MASS * G + RAMP_RATE * (t[k - 1] - RAMP_START)
    lag = RAMP_RATE * (6 * MASS * threshold / RAMP_RATE) ** (1 / 3)
    before = int(round((RAMP_START + (limit - 0.69 - MASS * G) / RAMP_RATE) / dt))
    return {
        "onset_load": float(load),
        "onset_load_corrected": float(load - lag),
        "detection_lag": float(lag),
        "creep_before_onset": float(slip[before]),
        "settle_sag": float(Z0 - z[i0]),
    }


def push_slip(condim, grip=20.0, **kw):
    """Experiment B: the box's slip (m, down positive) from t = 0.2 s to t = 0.6 s, and its
    speed at 0.6 s."""
    dt = kw.get("timestep", TIMESTEP)
    # held over the 100 steps starting at t = 0.2 s (half-step margins against rounding)
    on, off = PUSH_START - dt / 2, PUSH_START + PUSH_DURATION - dt / 2
    t, z = _simulate(grip, condim, lambda s: PUSH_FORCE if on <= s < off else 0.0, PUSH_END, **kw)
    i0 = int(round(PUSH_START / dt))
    return {"slip": float(z[i0] - z[-1]), "final_speed": float(abs(z[-1] - z[-2]) / dt)}


def creep(condim, grip=12.0, duration=10.0, **kw):
    """Experiment C: held (capacity 2 mu F_g > m g), no push. Sag from the start and creep from
    0.2 s to the end (m, down positive)."""
    dt = kw.get("timestep", TIMESTEP)
    t, z = _simulate(grip, condim, lambda s: 0.0, duration, **kw)
    return {"sag": float(Z0 - z[-1]), "creep": float(z[int(round(0.2 / dt))] - z[-1])}


def coulomb_torsion_onset(grip=20.0, mu=MU, torsion=TORSION, mass=MASS):
    """Torque about y at which both pads' elliptic cones saturate while each also carries
    half the weight: (f_t / mu)^2 + (tau / torsion)^2 = F_g^2 per pad."""
    return 2 * torsion * np.sqrt(grip**2 - (mass * G / (2 * mu)) ** 2)


def torsion_onset(condim, grip=20.0, threshold=ONSET_THRESHOLD, rate=TORQUE_RATE, **kw):
    """Experiment D (a check that condim 4's torsional friction is wired, not one of tandem's
    cases): settle 0.5 s, then a torque about y (the pads' axis) growing at `rate` N m/s.
    Returns the torque at which the box's rotation about y since the ramp began first exceeds
    `threshold` rad, and that torque less the Coulomb detection lag rate (6 I theta / rate)^(1/3)
    (I = m (x^2 + z^2) / 12 about y)."""
    dt = kw.get("timestep", TIMESTEP)
    m = mujoco.MjModel.from_xml_string(mjcf(grip, condim, **kw))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    box = m.body("box").id
    limit = coulomb_torsion_onset(grip, torsion=kw.get("torsion", TORSION))
    n = int(round((RAMP_START + limit / rate + 1.0) / dt))
    theta = np.empty(n + 1)
    theta[0] = 0.0
    for k in range(n):
        d.xfrc_applied[box, 4] = max(0.0, rate * (k * dt - RAMP_START))
        mujoco.mj_step(m, d)
        q = d.qpos[3:7]
        theta[k + 1] = 2 * np.arctan2(q[2], q[0])
    i0 = int(round(RAMP_START / dt))
    turned = np.abs(theta - theta[i0])
    k = int(np.argmax(turned > threshold))
    if turned[k] <= threshold:
        raise AssertionError("no rotation onset")
    torque = max(0.0, rate * (k - 1) * dt - rate * RAMP_START)
    inertia = MASS * ((2 * HALF[0]) ** 2 + (2 * HALF[2]) ** 2) / 12
    lag = rate * (6 * inertia * threshold / rate) ** (1 / 3)
    return {"onset_torque": float(torque), "onset_torque_corrected": float(torque - lag)}


def run_all(condim, **kw):
    return {"A": slip_onset(condim, **kw), "B": push_slip(condim, **kw), "C": creep(condim, **kw),
            "D": torsion_onset(condim, **kw)}


def rotation_under(condim, torque, start, end, grip=20.0, **kw):
    """The box's rotation about y (rad, positive with the torque) from `start` to `end` s under
    the torque about y `torque(t)` (N m, held over each step; the same history a tandem run is
    given, for `test_friction_vs_mujoco.py`), its angular speed about y at `end` and its
    downward travel over the same interval (m)."""
    dt = kw.get("timestep", TIMESTEP)
    m = mujoco.MjModel.from_xml_string(mjcf(grip, condim, **kw))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    box = m.body("box").id
    n = int(round(end / dt))
    i0 = int(round(start / dt))
    theta0 = z0 = 0.0
    for k in range(n):
        if k == i0:
            theta0, z0 = 2 * np.arctan2(d.qpos[5], d.qpos[3]), d.qpos[2]
        d.xfrc_applied[box, 4] = torque(k * dt)
        mujoco.mj_step(m, d)
    theta = 2 * np.arctan2(d.qpos[5], d.qpos[3])
    return {"rotation": float(theta - theta0), "final_speed": float(abs(d.qvel[4])),
            "travel": float(z0 - d.qpos[2])}


if __name__ == "__main__":  # pragma: no cover
    import time

    print(f"Coulomb: onset {coulomb_onset(20.0):.4f} N, push slip {coulomb_push_slip():.7f} m, "
          f"torsion onset {coulomb_torsion_onset():.6f} N m")
    for condim in (3, 4):
        t0 = time.perf_counter()
        r = run_all(condim)
        print(f"condim {condim}: {r}  ({time.perf_counter() - t0:.2f} s)")
