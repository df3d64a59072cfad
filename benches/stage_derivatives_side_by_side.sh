#!/usr/bin/env bash
# The lettuce step's value, Jacobian and Hessian: ghm's criterion bench and CasADi's
# generated C (benches/casadi_stage_derivatives.py), both pinned to core 1, alternated
# ROUNDS times in this one script. Needs casadi (`pip install casadi`; set PYTHON to the
# interpreter that has it) and gcc. About 2 minutes a round.
#   benches/stage_derivatives_side_by_side.sh [ROUNDS]   (default 3)
set -euo pipefail
cd "$(dirname "$0")/.."
ROUNDS=${1:-3}
PYTHON=${PYTHON:-python3}
BENCH=$(cargo bench --bench lettuce_step --no-run --message-format=json 2>/dev/null \
    | "$PYTHON" -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "lettuce_step" and m.get("executable"):
        print(m["executable"])')
for r in $(seq "$ROUNDS"); do
    echo "== round $r: ghm"
    taskset -c 1 "$BENCH" --bench "lettuce step" --noplot 2>&1 | grep -E "^lettuce|time:"
    echo "== round $r: CasADi"
    taskset -c 1 "$PYTHON" benches/casadi_stage_derivatives.py --shared ../shared
done
