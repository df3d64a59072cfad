#!/usr/bin/env python3
"""Tabulates runs/stochastic/ (benches/stochastic_sweep.sh): per controller and horizon, the
mean and the min–max range over the seasons of the cumulative reward and the EPI, and the
failed solves summed over the seasons."""
import glob
import json
import os
import re
import statistics

ROOT = os.path.join(os.path.dirname(__file__), "..", "runs", "stochastic")
LABELS = {"agent": "SAC agent alone", "mpc": "MPC", "rlmpc": "RL-MPC (SAC)"}


def main():
    runs = {}
    for path in glob.glob(os.path.join(ROOT, "*", "summary.json")):
        name = os.path.basename(os.path.dirname(path))
        match = re.fullmatch(r"(.+)-(agent|mpc|rlmpc)(?:-(\d+)h)?-s(\d+)", name)
        if not match:
            continue
        variant, controller, horizon, _ = match.groups()
        with open(path) as f:
            metrics = json.load(f)["metrics"]
        runs.setdefault((variant, controller, int(horizon or 0)), []).append(metrics)
    horizons = sorted({h for (_, c, h) in runs if c != "agent"})
    for variant in sorted({v for v, _, _ in runs}):
        seasons = {len(r) for (v, _, _), r in runs.items() if v == variant}
        print(f"### `{variant}.ghm`, {min(seasons)}–{max(seasons)} seasons per cell\n")
        print("| controller | " + " | ".join(f"{h} h" for h in horizons) + " |")
        print("|---|" + "---|" * len(horizons))
        for controller in ("agent", "mpc", "rlmpc"):
            for what, label in (("cumulative_reward", "reward"), ("epi", "EPI")):
                cells = []
                for h in horizons:
                    r = runs.get((variant, controller, 0 if controller == "agent" else h))
                    if not r:
                        cells.append("–")
                        continue
                    v = [m[what] for m in r]
                    failed = sum(m["solve"]["failed_solves"] for m in r)
                    note = f", {failed} failed" if failed and what == "cumulative_reward" else ""
                    cells.append(f"{statistics.mean(v):.4f} [{min(v):.3f}, {max(v):.3f}]{note}")
                print(f"| {LABELS[controller]} {label} | " + " | ".join(cells) + " |")
        print()


if __name__ == "__main__":
    main()
