"""Benchmark (issue 23): what the Python doors of the loop cost.

    python python/bench/bench_loop.py [--ticks 200000] [--repeat 3]

1. `Controller.tick(t, q, qd, w, out=tau)` from Python, per call (median and p99 of
   `perf_counter_ns` around each call, which adds about 50 ns), for the NN law of `paper` and
   `dual-ur5` fed their start state. Compare with the Rust tick of the same controllers
   (`cargo run --release -p tandem-ffi --example latency`, run just before or after): the
   difference is the Python overhead (argument checks, NumPy views, the call).
2. `Plant.step(tau)` from Python, per call, against the same plant stepped inside a run with a
   Rust law (`JointPD`: the run's wall time per tick), so the difference is the call's overhead.
3. `Scenario.run(controller=f)` with a trivial Python law on `dual-ur5` (10 s): the real-time
   factor, against the same law in Rust (`JointPD`).

Prints Markdown rows for docs/performance.md.
"""

import argparse
import statistics
import time
import warnings

import numpy as np

import tandem


def percentiles(ns):
    ns = sorted(ns)
    return ns[len(ns) // 2] / 1e3, ns[int(len(ns) * 0.99)] / 1e3


def bench_tick(name, ticks):
    sc = tandem.Scenario.preset(name)
    c = sc.controller("nn")
    q, qd, w = c.start_state()
    c.start(0.0, q, qd, w)
    tau = np.zeros(c.n_q)
    h = c.control_period
    ns = []
    clock = time.perf_counter_ns
    for k in range(ticks):
        t0 = clock()
        c.tick(k * h, q, qd, w, out=tau)
        ns.append(clock() - t0)
    return percentiles(ns)


def bench_step(name, steps):
    sc = tandem.Scenario.preset(name)
    p = sc.plant()
    hold = p.holding_torques() if name != "paper" else np.zeros(p.n_q)
    q0 = p.state["q"].copy()
    ns = []
    clock = time.perf_counter_ns
    for k in range(steps):
        if k % 200 == 0:
            p.reset()  # open loop, the chain drifts off its rest pose (limp planar: 0.25 s)
        t0 = clock()
        p.step(hold)
        ns.append(clock() - t0)
    # The same plant inside a run, driven by a Rust law: wall time per tick.
    law = tandem.JointPD(np.zeros(p.n_q), np.zeros(p.n_q), q0, hold)
    dur = 200 * p.control_period
    r = sc.run(duration=dur, controller=law)
    timing = r.summary["timing"]
    wall = timing.get("wall_time_s", timing.get("wall_time"))
    t_end = r.summary.get("t_end_s", r.summary.get("t_end"))
    per_tick = wall / (t_end / p.control_period) * 1e6
    return percentiles(ns) + (per_tick,)


def bench_run(seconds):
    sc = tandem.Scenario.preset("dual-ur5")
    p = sc.plant()
    q0, hold = p.state["q"].copy(), p.holding_torques()
    kp = np.tile([100.0, 100.0, 100.0, 10.0, 10.0, 10.0], 2)
    kd = kp / 10.0

    def law(t, q, qd, w):
        return kp * (q0 - q) - kd * qd + hold

    t0 = time.perf_counter()
    r_py = sc.run(duration=seconds, controller=law)
    wall_py = time.perf_counter() - t0
    t0 = time.perf_counter()
    r_rs = sc.run(duration=seconds, controller=tandem.JointPD(kp, kd, q0, hold))
    wall_rs = time.perf_counter() - t0
    assert r_py.summary["path_error_p_rms_m"] == r_rs.summary["path_error_p_rms_m"]
    return seconds / wall_py, seconds / wall_rs


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ticks", type=int, default=200_000)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    warnings.simplefilter("ignore", tandem.ScenarioWarning)
    for rep in range(a.repeat):
        for name in ("paper", "dual-ur5"):
            med, p99 = bench_tick(name, a.ticks)
            print(f"| {rep} | Controller.tick (Python) | {name} NN | {med:.2f} µs | {p99:.2f} µs |")
        for name in ("paper", "dual-ur5"):
            med, p99, inrun = bench_step(name, a.ticks // 10)
            print(
                f"| {rep} | Plant.step (Python) | {name} | {med:.2f} µs | {p99:.2f} µs | "
                f"in a run: {inrun:.2f} µs/tick |"
            )
        py, rs = bench_run(10.0)
        print(f"| {rep} | Scenario.run(controller=f), dual-ur5 10 s | real-time factor | Python {py:.1f}× | Rust JointPD {rs:.1f}× |")


if __name__ == "__main__":
    main()
