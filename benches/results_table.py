#!/usr/bin/env python3
"""Tabulates runs/results/ (benches/rlmpc_sweep.sh) as the Markdown tables of docs/results.md:
EPI and cumulative reward per controller and horizon with the gap to the season optimum,
and per-step solve times of RL-MPC beside MPC's. With `--svg DIR` it also draws cumulative
reward against horizon per variant (DIR/results-<variant>.svg, plain SVG, no plotting
library needed)."""
import json
import os
import sys

ROOT = os.path.join(os.path.dirname(__file__), "..", "runs", "results")
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


def optimum(variant):
    """(EPI, cumulative reward) of the season optimum, from the sweep's `ghm optimum` run."""
    m = load(f"{variant}-optimum")
    if m is None:
        sys.exit(f"no {ROOT}/{variant}-optimum/summary.json: run benches/rlmpc_sweep.sh first")
    return m["epi"], m["cumulative_reward"]


COLOURS = {"mpc": "#1f77b4", "rlmpc-sac": "#d62728", "rlmpc-expert": "#2ca02c",
           "vfo-sac": "#9467bd"}


def svg_plot(variant, horizons, path):
    """Cumulative reward against horizon as the paper draws it: MPC, RL-MPC and RL-MPC-VFO
    (SAC guide) as lines, the agent alone and the season optimum as dashed levels (the
    expert rows, far below, are in the tables)."""
    series = []
    for key, label in CONTROLLERS:
        if key == "rlmpc-expert":
            continue
        points = [(h, load(f"{variant}-{key}-{h}h")) for h in horizons]
        points = [(h, m["cumulative_reward"]) for h, m in points if m]
        if points:
            series.append((label, COLOURS[key], points))
    levels = [("optimum", "#000000", optimum(variant)[1])]
    for alone, label, colour in [("agent", "SAC agent alone", "#d62728")]:
        m = load(f"{variant}-{alone}")
        if m:
            levels.append((label, colour, m["cumulative_reward"]))
    values = [v for _, _, pts in series for _, v in pts] + [v for _, _, v in levels]
    lo, hi = min(values), max(values)
    pad = 0.05 * (hi - lo or 1.0)
    lo, hi = lo - pad, hi + pad
    width, height, left, right, top, bottom = 720, 420, 70, 200, 40, 50
    pw, ph = width - left - right, height - top - bottom
    x_of = lambda h: left + pw * (h - horizons[0]) / max(horizons[-1] - horizons[0], 1)
    y_of = lambda v: top + ph * (hi - v) / (hi - lo)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           'font-family="sans-serif" font-size="12">',
           f'<rect width="{width}" height="{height}" fill="white"/>',
           f'<text x="{left}" y="22" font-size="14">{NAMES[variant].replace("`", "")}: cumulative reward '
           '(€/m²) against prediction horizon</text>',
           f'<rect x="{left}" y="{top}" width="{pw}" height="{ph}" fill="none" stroke="#888"/>']
    for i in range(6):
        v = lo + (hi - lo) * i / 5
        out.append(f'<line x1="{left}" x2="{left + pw}" y1="{y_of(v):.1f}" y2="{y_of(v):.1f}" '
                   'stroke="#eee"/>')
        out.append(f'<text x="{left - 6}" y="{y_of(v) + 4:.1f}" text-anchor="end">{v:.2f}</text>')
    for h in horizons:
        out.append(f'<text x="{x_of(h):.1f}" y="{top + ph + 18}" text-anchor="middle">{h} h</text>')
    legend = []
    for label, colour, v in levels:
        out.append(f'<line x1="{left}" x2="{left + pw}" y1="{y_of(v):.1f}" y2="{y_of(v):.1f}" '
                   f'stroke="{colour}" stroke-dasharray="6 4"/>')
        legend.append((label, colour, True))
    for label, colour, points in series:
        path_d = " ".join(f"{'M' if i == 0 else 'L'}{x_of(h):.1f},{y_of(v):.1f}"
                          for i, (h, v) in enumerate(points))
        out.append(f'<path d="{path_d}" fill="none" stroke="{colour}" stroke-width="2"/>')
        out += [f'<circle cx="{x_of(h):.1f}" cy="{y_of(v):.1f}" r="3" fill="{colour}"/>'
                for h, v in points]
        legend.append((label, colour, False))
    for i, (label, colour, dashed) in enumerate(legend):
        y = top + 10 + 20 * i
        dash = ' stroke-dasharray="6 4"' if dashed else ' stroke-width="2"'
        out.append(f'<line x1="{left + pw + 12}" x2="{left + pw + 40}" y1="{y}" y2="{y}" '
                   f'stroke="{colour}"{dash}/>')
        out.append(f'<text x="{left + pw + 46}" y="{y + 4}">{label}</text>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def main():
    args = sys.argv[1:]
    svg_dir = None
    if "--svg" in args:
        i = args.index("--svg")
        svg_dir = args[i + 1]
        del args[i:i + 2]
    horizons = [int(h) for h in (args or ["1", "2", "3", "4", "5", "6"])]
    if svg_dir:
        for variant in NAMES:
            svg_plot(variant, horizons, os.path.join(svg_dir, f"results-{variant}.svg"))
    for variant, title in NAMES.items():
        opt_epi, opt_reward = optimum(variant)
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
