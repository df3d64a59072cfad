#!/usr/bin/env bash
# Per-step solve time of RL-guided MPC beside plain MPC at the same horizon (docs/benchmarks.md):
# the 40-day Venlo season, both model variants, one season at a time (run it on a quiet
# machine), REPEATS seasons per cell. Each run writes runs/step-time/<variant>-<controller>-
# <H>h-r<i>/summary.json; finished runs are kept, so the script resumes where it stopped.
# Tabulate with benches/step_time_table.py. Needs ../shared.
set -euo pipefail
cd "$(dirname "$0")/.."
ghm=${GHM:-target/release/ghm}
weather=(--weather ../shared/data/venlo2014_30min_model_units.csv --start-row 1394)
horizons=${HORIZONS:-"1 3 6"}
repeats=${REPEATS:-3}
for r in $(seq 1 "$repeats"); do
  for variant in lettuce-thesis lettuce; do
    for h in $horizons; do
      for controller in mpc rlmpc; do
        out=runs/step-time/$variant-$controller-${h}h-r$r
        [ -f "$out/summary.json" ] && continue
        echo "== $variant $controller ${h}h (repeat $r)"
        rm -rf "$out.tmp"
        "$ghm" "$controller" "models/$variant.ghm" "${weather[@]}" --horizon "${h}h" \
          --out "$out.tmp" > /dev/null
        rm -rf "$out" && mv "$out.tmp" "$out"
      done
    done
  done
done
