#!/usr/bin/env bash
# The results of docs/results.md: the 40-day Venlo season for H = 1..6 h, both model
# variants, under plain MPC, RL-MPC with the SAC and the expert guide, and RL-MPC-VFO
# (SAC guide), plus the agent and the expert alone and the season optimum (`ghm optimum`); all with the agents and value networks
# shipped under models/agents/. Each run writes runs/results/<variant>-<controller>[-<H>h]/
# summary.json; finished runs are kept, so the script resumes where it stopped. JOBS runs
# in parallel (default 2). Tabulate with benches/results_table.py. Needs ../shared.
set -euo pipefail
cd "$(dirname "$0")/.."
ghm=${GHM:-target/release/ghm}
jobs=${JOBS:-2}
weather="--weather ../shared/data/venlo2014_30min_model_units.csv --start-row 1394"
horizons=${HORIZONS:-"1 2 3 4 5 6"}
list=()
for variant in lettuce-thesis lettuce; do
  list+=("$variant-optimum|optimum models/$variant.ghm")
  list+=("$variant-agent|policy models/$variant.ghm")
  list+=("$variant-expert|policy models/$variant.ghm --expert")
  for h in $horizons; do
    list+=("$variant-mpc-${h}h|mpc models/$variant.ghm --horizon ${h}h")
    list+=("$variant-rlmpc-sac-${h}h|rlmpc models/$variant.ghm --horizon ${h}h --guide sac")
    list+=("$variant-rlmpc-expert-${h}h|rlmpc models/$variant.ghm --horizon ${h}h --guide expert")
    list+=("$variant-vfo-sac-${h}h|rlmpc models/$variant.ghm --horizon ${h}h --guide sac --variant vfo")
  done
done
SWEEP_ROOT=runs/results
# shellcheck source=benches/sweep_lib.sh
source benches/sweep_lib.sh
run_all "$jobs" "${list[@]}"
