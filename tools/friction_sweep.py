#!/usr/bin/env python3
"""The payload × path-speed sweep of docs/friction-grasps.md: `dual-ur5-grip` with the box's
mass and the S6 path's speed varied, each with the weld-assuming and the friction-aware load
distribution; where the box slips (any pad's anchor moved), where the run stops.

    python3 tools/friction_sweep.py TANDEM_BIN OUT_DIR [DURATION]

Writes OUT_DIR/friction_sweep.json (every run's numbers), OUT_DIR/friction_sweep.md (the table)
and OUT_DIR/friction_sweep.svg (the figure). Needs only the standard library.
"""
import json
import subprocess
import sys
from pathlib import Path

MASSES = [3.0, 6.0, 9.0, 12.0, 15.0, 18.0]
SPEEDS = [1.0, 4.0, 16.0]
MODES = ["weld", "friction"]
OMEGA = 0.10471975511965977


def scenario(base: str, mass: float, speed: float, mode: str) -> str:
    t = base.replace("mass = 3.0", f"mass = {mass}", 1)
    t = t.replace(f"omega = {OMEGA}", f"omega = {OMEGA * speed}", 1)
    t = t.replace("omega_rot = 0.20943951023931953", f"omega_rot = {2 * OMEGA * speed}", 1)
    t = t.replace('distribution = "friction"', f'distribution = "{mode}"', 1)
    if mode == "weld":
        t = t.replace("friction_margin = 2.0", "", 1)
    return t


def main() -> None:
    bin_, out = sys.argv[1], Path(sys.argv[2])
    duration = sys.argv[3] if len(sys.argv) > 3 else "10"
    out.mkdir(parents=True, exist_ok=True)
    base = subprocess.run(
        [bin_, "scenario", "show", "dual-ur5-grip"], check=True, capture_output=True, text=True
    ).stdout
    rows = []
    for mode in MODES:
        for speed in SPEEDS:
            for mass in MASSES:
                name = f"{mode}-v{speed:g}-m{mass:g}"
                f = out / f"{name}.toml"
                f.write_text(scenario(base, mass, speed, mode))
                d = out / name
                if not (d / "summary.json").exists():
                    subprocess.run(
                        [bin_, "run", str(f), "--duration", duration, "--out", str(d)],
                        capture_output=True,
                        text=True,
                    )
                s = json.loads((d / "summary.json").read_text())
                c = s["contacts"]
                rows.append(
                    {
                        "mode": mode,
                        "speed": speed,
                        "mass": mass,
                        "status": s["status"],
                        "t_end_s": s["t_end_s"],
                        "slipped": c["slipped"],
                        "first_slip_t_s": c["first_slip_t_s"],
                        "slip_m": max(c["slip_distance_m"]),
                        "slip_rad": max(c["slip_angle_rad"]),
                        "min_margin_N": min(p["min_margin_N"] for p in c["pads"]),
                        "fallbacks": c["distribution"].get("fallbacks"),
                        "z1_after_2s_m": s.get("z1_p_max_after_2s_m"),
                    }
                )
                print(name, rows[-1], flush=True)
    (out / "friction_sweep.json").write_text(json.dumps(rows, indent=1))
    # Table.
    lines = ["| distribution | speed × | " + " | ".join(f"{m:g} kg" for m in MASSES) + " |"]
    lines.append("|---|---|" + "---|" * len(MASSES))
    for mode in MODES:
        for speed in SPEEDS:
            cells = []
            for mass in MASSES:
                r = next(x for x in rows if x["mode"] == mode and x["speed"] == speed and x["mass"] == mass)
                if r["status"] != "completed":
                    cells.append(f"lost at {r['t_end_s']:.2f} s")
                elif r["slipped"]:
                    cells.append(f"slips {r['slip_m'] * 1e3:.2f} mm, {r['slip_rad'] * 1e3:.1f} mrad")
                else:
                    cells.append(f"holds (margin {r['min_margin_N']:.1f} N)")
            lines.append(f"| {mode} | {speed:g} | " + " | ".join(cells) + " |")
    (out / "friction_sweep.md").write_text("\n".join(lines) + "\n")
    # Figure: one panel per distribution, cells coloured held / slipped / lost.
    cw, ch, left, top = 90, 44, 90, 60
    pw = left + cw * len(MASSES) + 30
    svg = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{2 * pw}" height="{top + ch * len(SPEEDS) + 90}" font-family="sans-serif" font-size="12">',
        f'<text x="{pw}" y="20" text-anchor="middle" font-size="15">dual-ur5-grip, NN law, 10 s: does the box stay in the grippers?</text>',
    ]
    colour = {"holds": "#4caf50", "slips": "#ffb300", "lost": "#e53935"}
    for k, mode in enumerate(MODES):
        x0 = k * pw
        svg.append(f'<text x="{x0 + left + cw * len(MASSES) / 2}" y="45" text-anchor="middle" font-size="13">{mode}-assuming distribution</text>' if mode == "weld" else f'<text x="{x0 + left + cw * len(MASSES) / 2}" y="45" text-anchor="middle" font-size="13">friction-aware distribution</text>')
        for a, speed in enumerate(SPEEDS):
            y = top + a * ch
            svg.append(f'<text x="{x0 + left - 8}" y="{y + ch / 2 + 4}" text-anchor="end">path × {speed:g}</text>')
            for b, mass in enumerate(MASSES):
                r = next(x for x in rows if x["mode"] == mode and x["speed"] == speed and x["mass"] == mass)
                kind = "lost" if r["status"] != "completed" else ("slips" if r["slipped"] else "holds")
                label = (
                    f"{r['t_end_s']:.2f} s" if kind == "lost" else (f"{r['slip_m'] * 1e3:.2f} mm" if kind == "slips" else "held")
                )
                xx = x0 + left + b * cw
                svg.append(f'<rect x="{xx}" y="{y}" width="{cw - 2}" height="{ch - 2}" fill="{colour[kind]}"/>')
                svg.append(f'<text x="{xx + cw / 2}" y="{y + ch / 2 + 4}" text-anchor="middle">{label}</text>')
        for b, mass in enumerate(MASSES):
            svg.append(f'<text x="{x0 + left + b * cw + cw / 2}" y="{top + ch * len(SPEEDS) + 16}" text-anchor="middle">{mass:g} kg</text>')
        svg.append(f'<text x="{x0 + left + cw * len(MASSES) / 2}" y="{top + ch * len(SPEEDS) + 34}" text-anchor="middle">box mass</text>')
    yl = top + ch * len(SPEEDS) + 60
    for i, (kind, c) in enumerate(colour.items()):
        text = {"holds": "held: no pad slipped", "slips": "slipped (largest slip distance)", "lost": "lost: run stopped (grasp slid 5 cm / 0.05 rad)"}[kind]
        svg.append(f'<rect x="{20 + i * 300}" y="{yl}" width="14" height="14" fill="{c}"/><text x="{40 + i * 300}" y="{yl + 12}">{text}</text>')
    svg.append("</svg>")
    (out / "friction_sweep.svg").write_text("\n".join(svg) + "\n")


if __name__ == "__main__":
    main()
