#!/usr/bin/env python3
"""golden_cmp.py BASE TIP: compares two folders written by golden.sh.

Every CSV must be byte-identical; every JSON value of BASE must be in TIP, equal (keys TIP adds
are listed, not errors); the terminal texts are diffed with the output folders' own paths
replaced. Exit 1 on any CSV or JSON difference."""
import difflib, filecmp, json, os, sys

base, tip = sys.argv[1], sys.argv[2]
bad, n_csv, n_json, added = 0, 0, 0, set()


def walk(x, y, path, where):
    global bad
    if isinstance(x, dict) and isinstance(y, dict):
        for k in x:
            if k not in y:
                print(f"{where}: key {path}{k} removed")
                bad += 1
            else:
                walk(x[k], y[k], f"{path}{k}.", where)
        added.update(f"{path}{k}" for k in y if k not in x)
    elif x != y:
        print(f"{where}: {path} {str(x)[:80]} -> {str(y)[:80]}")
        bad += 1


text_diffs = 0
for root, _, files in os.walk(base):
    for f in sorted(files):
        b = os.path.join(root, f)
        rel = os.path.relpath(b, base)
        t = os.path.join(tip, rel)
        if not os.path.exists(t):
            print(f"{rel}: missing in {tip}")
            bad += 1
        elif f.endswith(".csv"):
            n_csv += 1
            if not filecmp.cmp(b, t, shallow=False):
                print(f"{rel}: CSV differs")
                bad += 1
        elif f.endswith(".json"):
            n_json += 1
            walk(json.load(open(b)), json.load(open(t)), "", rel)
        else:
            lb = open(b, errors="replace").read().replace(os.path.abspath(base), "OUT").splitlines()
            lt = open(t, errors="replace").read().replace(os.path.abspath(tip), "OUT").splitlines()
            d = [l for l in difflib.unified_diff(lb, lt, rel, rel, n=0, lineterm="")]
            if d:
                text_diffs += 1
                print("\n".join(d[:12]) + ("\n…" if len(d) > 12 else ""))
print(f"{n_csv} CSV and {n_json} JSON files compared: {bad} differences; {text_diffs} text files differ (above)")
if added:
    print("keys added in TIP:", ", ".join(sorted(added)))
sys.exit(1 if bad else 0)
