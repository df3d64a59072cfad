#!/usr/bin/env bash
# Issue 39's value fit beside PyTorch: `ghm value` with its defaults (the paper variant's
# shipped SAC agent, 1000 roll-outs, 100 epochs of batches of 256, Adam at 3e-3) writes the
# points it fitted, then `benches/value_fit_torch.py` fits the same network to them the same
# way; both pinned to core 1, one after the other, three rounds. Needs a release build
# (`cargo build --release`) and a Python with torch and numpy (PYTHON, default python3).
# About 25 minutes; results under OUT.
#   benches/value_fit_side_by_side.sh [OUT] [ROUNDS]   (default /tmp/value-fit-side-by-side 3)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-/tmp/value-fit-side-by-side}
ROUNDS=${2:-3}
PYTHON=${PYTHON:-python3}
mkdir -p "$OUT"
WEATHER=$(cd ../shared/data && pwd)/venlo2014_30min_model_units.csv
for r in $(seq 1 "$ROUNDS"); do
    start=$(date +%s.%N)
    taskset -c 1 target/release/ghm value models/lettuce.ghm --weather "$WEATHER" --start-row 1394 \
        --save-data --out "$OUT/ghm_$r" --overwrite > "$OUT/ghm_$r.txt"
    echo "round $r: ghm value, whole command $(awk "BEGIN { print $(date +%s.%N) - $start }") s" | tee -a "$OUT/times.txt"
    OMP_NUM_THREADS=1 taskset -c 1 "$PYTHON" benches/value_fit_torch.py "$OUT/ghm_$r" --threads 1 \
        | tee "$OUT/torch_$r.txt" | tail -2 | tee -a "$OUT/times.txt"
done
