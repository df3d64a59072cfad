#!/usr/bin/env python3
"""Tabulates runs/results/ (benches/rlmpc_sweep.sh) as the Markdown tables of docs/results.md:
EPI and cumulative reward per controller and horizon with the gap to the season optimum,
and per-step solve times of RL-MPC beside MPC's."""
import json
import os
import sys

ROOT = os.path.join(os.path.dirname(__file__), "..", "runs", "results")
# `ghm optimum ... --solver ipopt` on the same season (docs/benchmarks.md).
OPTIMUM = {"lettuce-thesis": (5.1772, 4.7634), "lettuce": (3.8512, 3.3849)}
NAMES = {"lettuce-thesis": "thesis-code variant (`lettuce-thesis.ghm`)",
         "lettuce": "paper variant (`lettuce.ghm`)"}
CONTROLLERS = [("mpc", "MPC"), ("rlmpc-sac", "RL-MPC (SAC)"),
               ("rlmpc-expert", "RL-MPC (expert)"), ("vfo-sac", "RL-MPC-VFO (SAC)")]


def load(name):
    path = os.path.join(ROOT, name, "summary.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)["metrics"]


def main():
    horizons = [int(h) for h in (sys.argv[1:] or ["1", "2", "3", "4", "5", "6"])]
    for variant, title in NAMES.items():
        opt_epi, opt_reward = OPTIMUM[variant]
        print(f"### {title}\n")
        print(f"Season optimum: EPI {opt_epi:.4f}, cumulative reward {opt_reward:.4f} €/m².\n")
        for alone, label in [("agent", "SAC agent alone"), ("expert", "expert alone")]:
            m = load(f"{variant}-{alone}")
            if m:
                print(f"- {label}: EPI {m['epi']:.4f}, cumulative reward "
                      f"{m['cumulative_reward']:.4f} (gap {opt_reward - m['cumulative_reward']:.4f})")
        print()
        header = "| controller | " + " | ".join(f"{h} h" for h in horizons) + " |"
        print(header)
        print("|---|" + "---|" * len(horizons))
        for key, label in CONTROLLERS:
            for what in ("cumulative_reward", "epi"):
                cells = []
                for h in horizons:
                    m = load(f"{variant}-{key}-{h}h")
                    if m is None:
                        cells.append("–")
                        continue
                    v = m[what]
                    gap = (opt_reward if what == "cumulative_reward" else opt_epi) - v
                    failed = m["solve"]["failed_solves"]
                    note = f" ({failed} failed)" if failed and what == "cumulative_reward" else ""
                    cells.append(f"{v:.4f} (−{gap:.3f}){note}" if gap >= 0 else f"{v:.4f} (+{-gap:.3f}){note}")
                kind = "reward" if what == "cumulative_reward" else "EPI"
                print(f"| {label} {kind} | " + " | ".join(cells) + " |")
        print()
        print("Per-step solve time, ms (median / p95 / max):\n")
        print(header)
        print("|---|" + "---|" * len(horizons))
        for key, label in CONTROLLERS:
            cells = []
            for h in horizons:
                m = load(f"{variant}-{key}-{h}h")
                if m is None:
                    cells.append("–")
                    continue
                s = m["solve"]
                cells.append(f"{s['median_ms']:.2f} / {s['p95_ms']:.1f} / {s['max_ms']:.0f}")
            print(f"| {label} | " + " | ".join(cells) + " |")
        print()


if __name__ == "__main__":
    main()
