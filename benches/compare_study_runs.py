#!/usr/bin/env python3
"""Two runs of the same study, season by season: the tail of the solver's iterations and
the rewards, from each season's trajectory.csv (iterations are not noisy; wall times are).

    python3 benches/compare_study_runs.py runs/paper-before runs/paper-after

Seasons found in both runs are compared (the agent-only seasons, which solve nothing, are
skipped). Printed: rewards that moved by more than 1e-9, the worst ratio of a season's
longest step to its median (iterations) in each run, the seasons over 8.1x and 10x, the
seasons whose longest step changed, steps that did not end optimal or acceptable, and the
mean iterations per step.
"""
import csv
import statistics
import sys
from pathlib import Path


def read(path):
    """Iterations per step, the final cumulative reward and the unsuccessful steps."""
    rows = list(csv.DictReader(path.open()))
    iterations = [int(r["iterations"]) for r in rows if r["iterations"]]
    unsuccessful = sum(r["status"] not in ("optimal", "acceptable") for r in rows)
    return iterations, float(rows[-1]["cumulative_reward"]), unsuccessful


def main(before, after):
    seasons = []
    for path in sorted(after.glob("*/*/*/*/trajectory.csv")):
        relative = path.relative_to(after)
        other = before / relative
        if not other.exists():
            continue
        old, old_reward, _ = read(other)
        new, new_reward, unsuccessful = read(path)
        if not old or not new:
            continue
        seasons.append((str(relative.parent), old, new, old_reward, new_reward, unsuccessful))
    print(f"{len(seasons)} seasons compared")
    moved = [s for s in seasons if abs(s[3] - s[4]) > 1e-9]
    print(f"rewards the same to 1e-9: {len(seasons) - len(moved)}")
    for name, _, _, a, b, _ in moved:
        print(f"  reward moved: {name} {a:.10f} -> {b:.10f} ({b - a:+.1e})")
    for label, index in (("before", 1), ("after", 2)):
        ratios = sorted((max(s[index]) / statistics.median(s[index]), s[0], max(s[index]),
                         statistics.median(s[index])) for s in seasons)
        ratio, name, longest, median = ratios[-1]
        over8 = sum(r[0] > 8.1 for r in ratios)
        over10 = sum(r[0] > 10 for r in ratios)
        print(f"{label}: worst {ratio:.1f}x ({longest} / {median:g}, {name}); "
              f"over 8.1x: {over8}, over 10x: {over10}")
    changed = [s for s in seasons if max(s[1]) != max(s[2])]
    print(f"seasons whose longest step changed: {len(changed)}")
    for name, old, new, _, _, _ in changed:
        print(f"  {name}: {max(old)} -> {max(new)}")
    print(f"steps not optimal or acceptable (after): {sum(s[5] for s in seasons)}")
    for label, index in (("before", 1), ("after", 2)):
        mean = statistics.mean(statistics.mean(s[index]) for s in seasons)
        print(f"mean iterations per step ({label}): {mean:.5f}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: compare_study_runs.py BEFORE AFTER (two folders of one study)")
    main(Path(sys.argv[1]), Path(sys.argv[2]))
