#!/usr/bin/env bash
# The 2-day loop of ../shared/spec/peer-solvers.md (thesis variant, 96 steps from row 1394)
# with compiled fatrop (the peers' CasADi implementation) and ghm's ipm (both restarts:
# `ipm` restarts from the shifted plan, `ipm-pd` from the shifted plan and multipliers) and
# sqp, each pinned to core 1, one after the other in this one script. Needs `pip install casadi numpy` and a
# release build (`cargo build --release`). About 20 minutes; results under $OUT.
#   benches/fatrop_side_by_side.sh [OUT]   (default /tmp/fatrop-side-by-side)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-/tmp/fatrop-side-by-side}
mkdir -p "$OUT"
SHARED=$(cd ../shared && pwd)
GHM=$(pwd)/target/release/ghm
(cd "$OUT" && GH_RESULTS="$OUT" OMP_NUM_THREADS=1 taskset -c 1 python3 "$SHARED/peers/peers/run_casadi_jit.py" \
    --hours 1 6 --reps 1 --skip ipopt_zeros ipopt_zeros_jit fatrop_zeros_jit ipopt_warm_jit) | tee "$OUT/peer.txt"
for h in 1h 6h; do for s in ipm ipm-pd sqp; do for r in 1 2 3; do
    case $s in
        ipm-pd) solver=(--solver ipm --warm-start primal-dual) ;;
        *) solver=(--solver "$s") ;;
    esac
    taskset -c 1 "$GHM" mpc models/lettuce-thesis.ghm --weather "$SHARED/data/venlo2014_30min_model_units.csv" \
        --start-row 1394 --days 2 --horizon $h "${solver[@]}" --out "$OUT/ghm_${h}_${s}_$r" --overwrite > /dev/null
done; done; done
python3 - "$OUT" <<'PY'
import csv, json, statistics, sys
out = sys.argv[1]
for h in ("1h", "6h"):
    for s in ("ipm", "ipm-pd", "sqp"):
        ms, its, first = [], [], []
        for r in (1, 2, 3):
            rows = list(csv.DictReader(open(f"{out}/ghm_{h}_{s}_{r}/trajectory.csv")))
            ms += [float(x["solve_ms"]) for x in rows]
            its += [int(x["iterations"]) for x in rows]
            first.append(float(rows[0]["solve_ms"]))
            reward = json.load(open(f"{out}/ghm_{h}_{s}_{r}/summary.json"))["metrics"]["cumulative_reward"]
        ms.sort()
        print(f"ghm {s} H={h}: median {statistics.median(ms):.2f} p95 {ms[int(0.95 * len(ms))]:.2f} "
              f"max {ms[-1]:.2f} ms (first steps {', '.join(f'{f:.2f}' for f in first)}), "
              f"mean iterations {sum(its) / len(its):.2f}, reward {reward:.6f}")
PY
