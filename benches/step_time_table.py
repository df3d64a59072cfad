#!/usr/bin/env python3
"""Tabulates runs/step-time/ (benches/rlmpc_step_time.sh): per variant and horizon, the
median over repeated seasons of each season's median / p95 / max solve time per step, for
MPC and RL-MPC, and the ratio of the medians."""
import glob
import json
import os
import re
import statistics

ROOT = os.path.join(os.path.dirname(__file__), "..", "runs", "step-time")


def main():
    cells = {}
    for path in glob.glob(os.path.join(ROOT, "*", "summary.json")):
        name = os.path.basename(os.path.dirname(path))
        match = re.fullmatch(r"(.+)-(mpc|rlmpc)-(\d+)h-r(\d+)", name)
        if not match:
            continue
        variant, controller, horizon, _ = match.groups()
        with open(path) as f:
            solve = json.load(f)["metrics"]["solve"]
        cells.setdefault((variant, int(horizon), controller), []).append(solve)
    print("| variant | horizon | MPC ms (median / p95 / max) | RL-MPC ms (median / p95 / max) "
          "| RL-MPC / MPC (median) | seasons |")
    print("|---|---|---|---|---|---|")
    for variant, horizon in sorted({(v, h) for v, h, _ in cells}, key=lambda k: (k[0] != "lettuce-thesis", k[1])):
        row = {}
        for controller in ("mpc", "rlmpc"):
            runs = cells.get((variant, horizon, controller), [])
            if runs:
                row[controller] = [statistics.median(r[k] for r in runs)
                                   for k in ("median_ms", "p95_ms", "max_ms")] + [len(runs)]
        if len(row) < 2:
            continue
        fmt = lambda v: f"{v[0]:.3f} / {v[1]:.2f} / {v[2]:.1f}"
        ratio = row["rlmpc"][0] / row["mpc"][0]
        print(f"| {variant} | {horizon} h | {fmt(row['mpc'])} | {fmt(row['rlmpc'])} | "
              f"{ratio:.2f} × | {min(row['mpc'][3], row['rlmpc'][3])} |")


if __name__ == "__main__":
    main()
