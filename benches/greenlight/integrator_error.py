#!/usr/bin/env python3
"""How far an open-loop trajectory of the Katzin 2021 greenhouse lies from GreenLight's
tight reference (`tests/greenlight/make_reference.py`: BDF, rtol 1e-8, atol 1e-6): the
largest difference at any 300 s point, per quantity, as issue 34's first criterion states
it (temperatures in °C, vapour pressures in Pa, CO2 in mg m-3, the crop's carbohydrates
relative).

A candidate is either another `openloop.csv` of that script (GreenLight at other
tolerances: `make_reference.py --controls REF/controls.csv --rtol 1e-4 --atol 1e-4`) or a
`trajectory.csv` of `ghm simulate MODEL --inputs REF/controls.csv --no-rate-limit` (its
states are the columns `x_<name>`, row k at 300 k s after the window's start).

Usage: python integrator_error.py REF/openloop.csv CANDIDATE.csv [CANDIDATE.csv ...]
"""

import csv
import sys

TEMPERATURES = ["tAir", "tCan", "tTop", "tPipe", "tCovIn", "tCovE", "tThScr", "tFlr", "tLamp"]
PRESSURES = ["vpAir", "vpTop"]
CO2 = ["co2Air", "co2Top"]
CARBOHYDRATES = ["cBuf", "cFruit", "cLeaf", "cStem"]


def read(path):
    with open(path, encoding="utf-8") as f:
        rows = list(csv.reader(f))
    header = [h[2:] if h.startswith("x_") else h for h in rows[0]]
    # ghm's last row has no inputs (empty cells); only the states are compared.
    return {name: [float(r[i]) if r[i] else float("nan") for r in rows[1:]] for i, name in enumerate(header)}


def largest(ref, cand, names, relative=False):
    n = min(len(ref[names[0]]), len(cand[names[0]]))
    worst = {}
    for name in names:
        diffs = []
        for k in range(n):
            d = abs(cand[name][k] - ref[name][k])
            diffs.append(d / max(abs(ref[name][k]), 1e-12) if relative else d)
        worst[name] = max(diffs)
    return worst, n


def main():
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    ref = read(sys.argv[1])
    for path in sys.argv[2:]:
        cand = read(path)
        temps, n = largest(ref, cand, TEMPERATURES)
        pressures, _ = largest(ref, cand, PRESSURES)
        co2, _ = largest(ref, cand, CO2)
        carbs, _ = largest(ref, cand, CARBOHYDRATES, relative=True)
        hottest = max(temps, key=temps.get)
        print(
            f"{path} ({n} points): tAir {temps['tAir']:.4f} °C, worst temperature {hottest} "
            f"{temps[hottest]:.4f} °C, vpAir {pressures['vpAir']:.3f} Pa, vpTop {pressures['vpTop']:.3f} Pa, "
            f"co2Air {co2['co2Air']:.3f} mg m-3, co2Top {co2['co2Top']:.3f}, "
            f"carbohydrates {max(carbs.values()):.2e} relative ({max(carbs, key=carbs.get)})"
        )


if __name__ == "__main__":
    main()
