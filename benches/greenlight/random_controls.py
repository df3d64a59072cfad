#!/usr/bin/env python3
"""GreenLight's five controls as a random walk, one row per step, for timing `ghm simulate`
under the controls an untrained agent gives (`docs/benchmarks.md`, "Fewer exact Newton
matrices"): each input starts at 0.5 and moves each step by a uniform draw in
[-SCALE, SCALE], held in [0, 1]. SCALE 1 is gl-gym's and `benches/greenlight/env_rate.py`'s
random actions (a move of up to the input's whole range); 0.1 their smooth ones.

Usage: python random_controls.py STEPS SCALE SEED > controls.csv
"""

import random
import sys


def main():
    steps, scale, seed = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
    rng = random.Random(seed)
    names = ["uBoil", "uRoof", "uExtCo2", "uThScr", "uLamp"]
    u = [0.5] * len(names)
    print(",".join(names))
    for _ in range(steps):
        u = [min(1.0, max(0.0, v + rng.uniform(-scale, scale))) for v in u]
        print(",".join(f"{v:.4f}" for v in u))


if __name__ == "__main__":
    main()
