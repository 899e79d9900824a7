#!/usr/bin/env bash
# golden.sh BIN OUT: runs every embedded scenario with every controller, compare, the example
# sweep, robustness and a replay with the binary BIN into OUT, with wall times stripped (timing
# blocks in JSON, figures, times in the terminal text). For refactors that must not change a
# number: run it with the base and the new binary and compare with golden_cmp.py.
set -u
BIN=$(realpath "$1"); OUT=$(realpath -m "$2"); ROOT=$(cd "$(dirname "$0")/.." && pwd)
if [ -e "$OUT" ]; then echo "golden.sh: $OUT exists; give a new folder" >&2; exit 2; fi
mkdir -p "$OUT"
strip() { # drop timing blocks from json files in folder $1
  find "$1" -name '*.json' | while read -r f; do
    python3 - "$f" <<'PY'
import json,sys
p=sys.argv[1]
try: d=json.load(open(p))
except Exception: sys.exit(0)
def walk(x):
    if isinstance(x,dict):
        for k in list(x):
            if k in ("timing","wall_time_s","elapsed_s","output_time_s","realtime_factor","real_time_factor"): del x[k]
            else: walk(x[k])
    elif isinstance(x,list):
        for v in x: walk(v)
walk(d); json.dump(d,open(p,"w"),indent=1,sort_keys=True)
PY
  done
  find "$1" \( -name '*.png' -o -name '*.svg' -o -name '*.html' \) -delete
}
run() { local name=$1; shift; "$BIN" "$@" --out "$OUT/$name" >"$OUT/$name.stdout" 2>"$OUT/$name.stderr"; echo "rc=$?" >>"$OUT/$name.stdout"; strip "$OUT/$name"; }
for s in paper push lemniscate; do
  run $s-pd run $s --controller pd
  run $s-nn-paper run $s --controller nn --gains paper
  run $s-nn-tuned run $s --controller nn --gains tuned
  run $s-ctc run $s --controller ctc
  run $s-compare compare $s --duration 20
done
for s in dual-ur5 dual-franka; do
  for c in nn pd ctc; do run $s-$c run $s --controller $c; done
  run $s-compare compare $s --duration 3
done
run sweep sweep "$ROOT/docs/examples/sweep.toml" --threads 2
run robustness robustness paper --duration 10
run robustness-ur5 robustness dual-ur5 --duration 2
# replay: replay the paper pd run's torques
run paper-replay run paper --replay "$OUT/paper-pd/timeseries.csv" --duration 10
# wall-time-ish lines in stdout
sed -i -E 's/[0-9.]+ ?(ms|s|µs|us)\b/T/g; s/[0-9.]+x real time/T/g; s/[0-9.]+×/T/g' "$OUT"/*.stdout "$OUT"/*.stderr
