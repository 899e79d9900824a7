"""Benchmark: tandem.rollout against `tandem sweep`, and the Python overhead of one Run.

    python python/bench/bench_rollout.py [--tandem target/release/tandem] [--repeat 3]

1. The same 16 paper runs of 10 s (16 values of controller.nn.k1, the sweep's seeds), on the
   same number of threads: `tandem sweep FILE --threads N --no-figures` (wall time of the
   process: start, sweep validation, runs, runs.csv) against `tandem.rollout(...)` (the call:
   runs plus the 16 Run objects with their summaries and arrays). Both check every run's
   scenario before running it. The summaries are compared (they must be equal).
2. Python overhead per Run: `Scenario.run()` of a short run, minus the simulation loop's own
   wall time (`summary["timing"]["wall_time"]`): what is left is the set-up the CLI does too
   (validation, controller construction), the summary, and the Python objects.

Prints a Markdown table for docs/performance.md.
"""

import argparse
import csv
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import tandem

K1 = [5.0 + 0.5 * i for i in range(16)]


def sweep_file(dirname, duration):
    path = os.path.join(dirname, "bench.toml")
    grid = ", ".join(f"[{k}, {k}, {k}]" for k in K1)
    with open(path, "w") as f:
        f.write(
            f'base = "paper"\nduration = {duration}\nseed = 1\n\n[vary]\n'
            f'"controller.nn.k1" = {{ grid = [{grid}] }}\n'
        )
    return path


def main():
    ap = argparse.ArgumentParser()
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--tandem", default=os.path.join(here, "..", "..", "target", "release", "tandem"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--duration", type=float, default=10.0)
    a = ap.parse_args()

    tmp = tempfile.mkdtemp(prefix="tandem-bench-")
    try:
        f = sweep_file(tmp, a.duration)
        base = tandem.Scenario.preset("paper")
        cli_times, py_times, cli_cpu, py_cpu = [], [], [], []
        seeds = None
        for r in range(a.repeat):
            out = os.path.join(tmp, f"out{r}")
            c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            subprocess.run(
                [a.tandem, "sweep", f, "--threads", str(a.threads), "--no-figures", "--out", out],
                check=True,
                capture_output=True,
            )
            cli_times.append(time.perf_counter() - t0)
            c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            cli_cpu.append((c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime))
            with open(os.path.join(out, "runs.csv"), newline="") as fh:
                rows = list(csv.DictReader(fh))
            seeds = [int(x["seed"]) for x in rows]
            t0 = time.perf_counter()
            scs = [base.with_(**{"controller.nn.k1": [k, k, k]}) for k in K1]
            t_with = time.perf_counter() - t0
            p0 = time.process_time()
            t0 = time.perf_counter()
            runs = tandem.rollout(scs, seeds=seeds, threads=a.threads, duration=a.duration)
            py_times.append(time.perf_counter() - t0)
            py_cpu.append(time.process_time() - p0)
            for row, run in zip(rows, runs):
                assert float(row["rms_z1"]) == run.summary["rms_z1"], "sweep and rollout differ"
        loop = sum(r.summary["timing"]["wall_time"] for r in runs)

        # Per-Run overhead on short runs.
        over, total = [], []
        for d in (0.06, 0.6):
            for _ in range(30):
                t0 = time.perf_counter()
                run = base.run(duration=d)
                dt = time.perf_counter() - t0
                total.append((d, dt))
                over.append((d, dt - run.summary["timing"]["wall_time"]))
        rows_short = {d: len(base.run(duration=d)) for d in (0.06, 0.6)}

        # A full-length run: the same overhead plus the summary over more rows (no copy of the
        # samples: the arrays are views).
        o10 = []
        for _ in range(5):
            t0 = time.perf_counter()
            r10 = base.run(duration=a.duration)
            o10.append((time.perf_counter() - t0, time.perf_counter() - t0 - r10.summary["timing"]["wall_time"]))
        n_cols = len(r10.timeseries)

        load = os.getloadavg()
        print(f"machine: {platform.node()} {platform.machine()}, {os.cpu_count()} cores, "
              f"Python {platform.python_version()}, tandem {tandem.__version__}")
        print(f"date: {time.strftime('%Y-%m-%d %H:%M %Z')}, load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
        print()
        print(f"| 16 paper runs × {a.duration:g} s, {a.threads} threads | min | median | all |")
        print("|---|---|---|---|")
        fmt = lambda v: " ".join(f"{x:.3f}" for x in v)
        print(f"| `tandem sweep` (process) | {min(cli_times):.3f} s | {statistics.median(cli_times):.3f} s | {fmt(cli_times)} |")
        print(f"| `tandem.rollout` | {min(py_times):.3f} s | {statistics.median(py_times):.3f} s | {fmt(py_times)} |")
        print(f"| ratio rollout/sweep | {min(py_times)/min(cli_times):.3f} | {statistics.median(py_times)/statistics.median(cli_times):.3f} | |")
        print(f"| CPU time (user + sys, all threads): `tandem sweep` | {min(cli_cpu):.3f} s | {statistics.median(cli_cpu):.3f} s | {fmt(cli_cpu)} |")
        print(f"| CPU time: `tandem.rollout` | {min(py_cpu):.3f} s | {statistics.median(py_cpu):.3f} s | {fmt(py_cpu)} |")
        print(f"| CPU ratio rollout/sweep | {min(py_cpu)/min(cli_cpu):.3f} | {statistics.median(py_cpu)/statistics.median(cli_cpu):.3f} | |")
        print(f"\n(16 × `with_` to build the scenarios: {t_with*1e3:.1f} ms, not in the rollout time; "
              f"sum of the 16 loops' wall times in the last rollout: {loop:.3f} s)")
        print()
        print("| one `Scenario.run()` | rows | median total | overhead (total − loop): min | median | max |")
        print("|---|---|---|---|---|---|")
        for d in (0.06, 0.6):
            o = [x for dd, x in over if dd == d]
            t = [x for dd, x in total if dd == d]
            print(f"| duration {d:g} s | {rows_short[d]} | {statistics.median(t)*1e3:.2f} ms | "
                  f"{min(o)*1e3:.2f} ms | {statistics.median(o)*1e3:.2f} ms | {max(o)*1e3:.2f} ms |")
        ov = [o for _, o in o10]
        print(f"| duration {a.duration:g} s ({n_cols} columns) | {len(r10)} | {statistics.median([t for t, _ in o10])*1e3:.1f} ms | "
              f"{min(ov)*1e3:.2f} ms | {statistics.median(ov)*1e3:.2f} ms | {max(ov)*1e3:.2f} ms |")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
