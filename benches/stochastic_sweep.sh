#!/usr/bin/env bash
# The stochastic seasons of docs/results.md: the 40-day Venlo season with the plant's
# parameters drawn (paper variant: δ = 5 %, drawn once per season, as the model file says),
# SEEDS seasons, H in HORIZONS, under the SAC agent alone, MPC and RL-MPC (SAC guide, shipped
# agent and value network, trained on the nominal plant); the controllers predict with the
# nominal model and plan with the tightened humidity band. Each run writes
# runs/stochastic/<variant>-<controller>[-<H>h]-s<seed>/summary.json; finished runs are kept,
# so the script resumes where it stopped. JOBS run in parallel (default 2). Tabulate with
# benches/stochastic_table.py. Needs ../shared.
set -euo pipefail
cd "$(dirname "$0")/.."
ghm=${GHM:-target/release/ghm}
jobs=${JOBS:-2}
variant=${VARIANT:-lettuce}
delta=${DELTA:-0.05}
seeds=${SEEDS:-"1 2 3 4 5 6 7 8 9 10"}
horizons=${HORIZONS:-"1 3 6"}
weather="--weather ../shared/data/venlo2014_30min_model_units.csv --start-row 1394"
list=()
for s in $seeds; do
  list+=("$variant-agent-s$s|policy models/$variant.ghm --uncertainty $delta --seed $s")
  for h in $horizons; do
    list+=("$variant-mpc-${h}h-s$s|mpc models/$variant.ghm --horizon ${h}h --uncertainty $delta --seed $s")
    list+=("$variant-rlmpc-${h}h-s$s|rlmpc models/$variant.ghm --horizon ${h}h --uncertainty $delta --seed $s")
  done
done
SWEEP_ROOT=runs/stochastic
# shellcheck source=benches/sweep_lib.sh
source benches/sweep_lib.sh
run_all "$jobs" "${list[@]}"
