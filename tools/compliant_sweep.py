#!/usr/bin/env python3
"""The compliant-grasp sweep of docs/robot-ready.md: `dual-ur5` and `dual-franka` with compliant
true grasps (the laws assume welds), stiffness × damping × law, without and with the actuator
stage's output filter (5 control periods). Each cell: completed or not, violating ticks,
chattering ticks, the S5 claims.

    python3 tools/compliant_sweep.py TANDEM_BIN OUT_DIR [DURATION]

Runs `tandem sweep` four times (robot × filter) and writes OUT_DIR/compliant_sweep.md (the
tables), OUT_DIR/compliant_sweep.svg (the figure) and OUT_DIR/compliant_sweep.json (every run's
numbers). Needs only the standard library.
"""
import csv
import math
import json
import subprocess
import sys
from pathlib import Path

# Stiffness (N/m, N m/rad): a soft pad, a firm parallel gripper (the 1e5 / 1e3), a stiff
# one. Damping: 0.3, 1 and 3 times critical on the UR5 tip at the firm level (0.2 kg, 1e-4 kg m²).
STIFFNESS = [(1e4, 1e2), (1e5, 1e3), (1e6, 1e4)]
DAMPING = [(90.0, 0.2), (283.0, 0.632), (900.0, 2.0)]
LAWS = ["nn", "pd", "ctc"]
LAW_NAMES = {"nn": "NN", "pd": "PD + g", "ctc": "CTC"}
ROBOTS = ["dual-ur5", "dual-franka"]
FILTERS = [None, 0.005]
PLANT_STEP = 5e-5  # h ω ≤ 1 on the stiffest level's flange mode (UR5: 10 900 rad/s → 0.55)


def base_text(bin_: str, robot: str) -> str:
    t = subprocess.run(
        [bin_, "scenario", "show", robot], check=True, capture_output=True, text=True
    ).stdout
    t = t.replace(
        "\n[path]\n",
        "\n[plant.compliant_grasps]\nstiffness = [1e5, 1e5, 1e5, 1e3, 1e3, 1e3]\n"
        "damping = [283.0, 283.0, 283.0, 0.632, 0.632, 0.632]\n\n[path]\n",
        1,
    )
    t = t.replace("gravity_compensation = false", "gravity_compensation = true", 1)
    t = t.replace("plant_step = 0.001 ", f"plant_step = {PLANT_STEP} ", 1)
    lines = [l for l in t.splitlines() if not l.startswith("max_drift")]
    t = "\n".join(lines) + "\n"
    assert "[plant.compliant_grasps]" in t and "gravity_compensation = true" in t
    return t


def vec(a: float, b: float) -> str:
    return f"[{a}, {a}, {a}, {b}, {b}, {b}]"


def sweep_text(base: str, duration: str, filt) -> str:
    s = [f'base = "{base}"', f"duration = {duration}", "seed = 1", "", "[set]"]
    if filt is not None:
        s.append(f'"controller.actuator.filter_time_constant" = {filt}')
    s += ["", "[vary]"]
    s.append('"plant.compliant_grasps.stiffness" = { grid = [' + ", ".join(vec(*k) for k in STIFFNESS) + "] }")
    s.append('"plant.compliant_grasps.damping" = { grid = [' + ", ".join(vec(*d) for d in DAMPING) + "] }")
    s.append('"controller.kind" = { grid = [' + ", ".join(f'"{l}"' for l in LAWS) + "] }")
    return "\n".join(s) + "\n"


def run_sweeps(bin_: str, out: Path, duration: str) -> list:
    rows = []
    for robot in ROBOTS:
        (out / f"{robot}-compliant.toml").write_text(base_text(bin_, robot))
        for filt in FILTERS:
            tag = f"{robot}-{'filter' if filt else 'bare'}"
            sw = out / f"{tag}.sweep.toml"
            sw.write_text(sweep_text(f"{robot}-compliant.toml", duration, filt))
            subprocess.run(
                [bin_, "sweep", str(sw), "--out", str(out / tag), "--force", "--no-figures"],
                check=True,
                stdout=subprocess.DEVNULL,
            )
            with open(out / tag / "runs.csv", newline="") as f:
                for r in csv.DictReader(f):
                    k = json.loads(r["plant.compliant_grasps.stiffness"])
                    d = json.loads(r["plant.compliant_grasps.damping"])
                    num = lambda c: float(r[c]) if r.get(c) not in (None, "") else None
                    rows.append(
                        {
                            "robot": robot,
                            "filter_s": filt,
                            "law": r["controller.kind"].strip('"'),
                            "stiffness": [k[0], k[3]],
                            "damping": [d[0], d[3]],
                            "status": r["status"],
                            "message": r["message"],
                            "t_end_s": num("t_end_s"),
                            "violation_ticks": num("violation_ticks"),
                            "chatter_ticks": num("chatter_ticks"),
                            "s5_pass": r.get("s5_pass"),
                            "z1_p_max_after_2s_m": num("z1_p_max_after_2s_m"),
                            "z1_rot_max_after_2s_rad": num("z1_rot_max_after_2s_rad"),
                        }
                    )
    return rows


def cell(r) -> str:
    if r["status"] != "completed":
        return f"**fault {r['t_end_s']:.2f} s**" if r["t_end_s"] is not None else "**fault**"
    v, c = int(r["violation_ticks"] or 0), int(r["chatter_ticks"] or 0)
    s5 = "S5" if r["s5_pass"] == "true" else "S5 ✗"
    return f"{v} / {c}, {s5}"


def table(rows) -> str:
    md = []
    for robot in ROBOTS:
        for filt in FILTERS:
            what = f"filter {filt * 1e3:g} ms" if filt else "no filter"
            md.append(f"\n**{robot}, {what}** (violating ticks / chattering ticks, S5 after 2 s)\n")
            md.append("| stiffness (N/m, N m/rad) | damping (N s/m, N m s/rad) | " + " | ".join(LAW_NAMES[l] for l in LAWS) + " |")
            md.append("|---|---|" + "---|" * len(LAWS))
            for k in STIFFNESS:
                for d in DAMPING:
                    cells = []
                    for law in LAWS:
                        r = next(
                            x for x in rows
                            if x["robot"] == robot and x["filter_s"] == filt and x["law"] == law
                            and x["stiffness"] == list(k) and x["damping"] == list(d)
                        )
                        cells.append(cell(r))
                    md.append(f"| {e10(k[0])}, {e10(k[1])} | {d[0]:g}, {d[1]:g} | " + " | ".join(cells) + " |")
    return "\n".join(md) + "\n"


def e10(v: float) -> str:
    """1e5 for 100000.0 (the stiffness levels are powers of ten)."""
    return f"1e{round(math.log10(v))}"


def svg(rows) -> str:
    """One panel per robot × filter: rows stiffness × damping, columns laws; green = completed
    without violation or chatter, amber = completed with chatter, red = violations or a fault."""
    cw, ch, left, top, gap = 70, 22, 175, 60, 30
    pw = left + cw * len(LAWS)
    ph = top + ch * len(STIFFNESS) * len(DAMPING)
    W, H = 2 * pw + gap + 20, 2 * ph + gap + 60
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="DejaVu Sans, sans-serif" font-size="11">',
        f'<rect width="{W}" height="{H}" fill="white"/>',
        f'<text x="{W / 2}" y="18" text-anchor="middle" font-size="14">Compliant grasps under laws that assume welds '
        "(green: clean; amber: chattering; red: violations or fault)</text>",
    ]
    for ri, robot in enumerate(ROBOTS):
        for fi, filt in enumerate(FILTERS):
            x0, y0 = fi * (pw + gap), 30 + ri * (ph + gap)
            what = f"filter {filt * 1e3:g} ms" if filt else "no filter"
            out.append(f'<text x="{x0 + left}" y="{y0 + 20}" font-size="12">{robot}, {what}</text>')
            for li, law in enumerate(LAWS):
                out.append(f'<text x="{x0 + left + cw * li + cw / 2}" y="{y0 + top - 6}" text-anchor="middle">{LAW_NAMES[law]}</text>')
            for ki, k in enumerate(STIFFNESS):
                for di, d in enumerate(DAMPING):
                    y = y0 + top + ch * (ki * len(DAMPING) + di)
                    out.append(
                        f'<text x="{x0 + left - 6}" y="{y + 15}" text-anchor="end">k {e10(k[0])} / {e10(k[1])}, d {d[0]:g} / {d[1]:g}</text>'
                    )
                    for li, law in enumerate(LAWS):
                        r = next(
                            x for x in rows
                            if x["robot"] == robot and x["filter_s"] == filt and x["law"] == law
                            and x["stiffness"] == list(k) and x["damping"] == list(d)
                        )
                        bad = r["status"] != "completed" or (r["violation_ticks"] or 0) > 0
                        chat = (r["chatter_ticks"] or 0) > 0
                        col = "#d62728" if bad else ("#ffbf47" if chat else "#2ca02c")
                        label = "fault" if r["status"] != "completed" else f"{int(r['violation_ticks'] or 0)}/{int(r['chatter_ticks'] or 0)}"
                        xx = x0 + left + cw * li
                        out.append(f'<rect x="{xx + 1}" y="{y + 1}" width="{cw - 2}" height="{ch - 2}" fill="{col}"/>')
                        out.append(f'<text x="{xx + cw / 2}" y="{y + 15}" text-anchor="middle">{label}</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


def main() -> None:
    bin_, out = sys.argv[1], Path(sys.argv[2])
    duration = sys.argv[3] if len(sys.argv) > 3 else "4"
    out.mkdir(parents=True, exist_ok=True)
    rows = run_sweeps(bin_, out, duration)
    (out / "compliant_sweep.json").write_text(json.dumps(rows, indent=1) + "\n")
    (out / "compliant_sweep.md").write_text(table(rows))
    (out / "compliant_sweep.svg").write_text(svg(rows))
    print(table(rows))


if __name__ == "__main__":
    main()
