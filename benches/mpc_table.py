#!/usr/bin/env python3
"""Markdown table of the runs written by benches/mpc_seasons.sh."""
import json, pathlib
rows = []
for d in sorted(pathlib.Path("runs/bench").glob("*-*-*h")):
    s = json.loads((d / "summary.json").read_text())
    m, solve = s["metrics"], s["metrics"]["solve"]
    wall = float((d / "wall_s").read_text()) if (d / "wall_s").exists() else float("nan")
    variant, solver, h = d.name.rsplit("-", 2)
    rows.append((variant, solver, int(h[:-1]), solve, m, wall))
print("| variant | solver | H | median ms | p95 ms | max ms | iterations/step | failed | fallbacks | season s | EPI | cum. reward |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
for variant, solver, h, s, m, wall in sorted(rows):
    print(f"| {variant} | {solver} | {h} h | {s['median_ms']:.2f} | {s['p95_ms']:.2f} | {s['max_ms']:.1f} | "
          f"{s['mean_iterations']:.2f} | {s['failed_solves']} | {s['fallbacks']} | {wall:.1f} | {m['epi']:.4f} | {m['cumulative_reward']:.4f} |")
