#!/usr/bin/env bash
# The 40-day Venlo season under MPC for H = 1..6 h, both model variants, both back-ends.
# Each run writes runs/bench/<variant>-<solver>-<H>h/summary.json; finished runs are kept,
# so the script resumes where it stopped. Tabulate with benches/mpc_table.py.
# Needs ../shared (the Venlo weather) and, for ipopt, a build with `--features ipopt`.
set -euo pipefail
cd "$(dirname "$0")/.."
ghm=${GHM:-target/release/ghm}
weather=(--weather ../shared/data/venlo2014_30min_model_units.csv --start-row 1394)
solvers=${SOLVERS:-"sqp ipopt"}
for solver in $solvers; do
  for variant in lettuce-thesis lettuce; do
    for h in 1 2 3 4 5 6; do
      out=runs/bench/$variant-$solver-${h}h
      [ -f "$out/summary.json" ] && continue
      echo "== $variant $solver ${h}h"
      rm -rf "$out.tmp"
      /usr/bin/time -f "%e" -o /tmp/ghm-bench-time "$ghm" mpc "models/$variant.ghm" "${weather[@]}" \
        --horizon "${h}h" --solver "$solver" --out "$out.tmp" > /dev/null
      cp /tmp/ghm-bench-time "$out.tmp/wall_s"
      rm -rf "$out" && mv "$out.tmp" "$out"
    done
  done
done
