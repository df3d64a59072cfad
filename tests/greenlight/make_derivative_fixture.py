#!/usr/bin/env python3
"""GreenLight's own state derivatives of the Katzin 2021 model at its initial state, for
`tests/import_greenlight.rs` (the check of `ghm import greenlight`).

The point: t = 0, the default initial state (`init` of main_katzin_2021.json), the first
row of the packaged Bleiswijk weather file (GreenLight's linear interpolation returns row 0
at t = 0), and the five acting controls uBoil, uRoof, uThScr, uLamp, uExtCo2 at 0 (given
as data columns, as GreenLight replaces a variable by a CSV column of its name).

It calls the public `greenlight.GreenLight` class (load, solve) and captures the right-hand
side GreenLight hands to scipy's `solve_ivp`, evaluating it once; it contains no GreenLight
code. The output is numbers and GreenLight's state names only (no weather data):

    python make_derivative_fixture.py [--out tests/greenlight/katzin_2021_derivatives.json]
"""

import argparse
import contextlib
import csv
import importlib.metadata
import json
import os
import tempfile
import warnings

import numpy as np

import greenlight
import greenlight._solve._solve_ivp_from_str as from_str

CONTROLS = ["uBoil", "uRoof", "uThScr", "uLamp", "uExtCo2"]


class Captured(Exception):
    pass


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--out", default=os.path.join(here, "katzin_2021_derivatives.json"))
    args = ap.parse_args()

    models = os.path.join(os.path.dirname(greenlight.__file__), "models")
    model_json = os.path.join(models, "katzin_2021", "definition", "main_katzin_2021.json")
    weather = os.path.join(models, "katzin_2021", "input_data", "test_data", "Bleiswijk_from_20091020.csv")

    # The first data rows of the weather, with the controls as extra columns at 0.
    with open(weather, encoding="cp1252", newline="") as f:
        rows = list(csv.reader(f))
    header, data = rows[:3], rows[3:6]
    tmp = tempfile.mkdtemp()
    combined = os.path.join(tmp, "weather_controls.csv")
    with open(combined, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(header[0] + CONTROLS)
        w.writerow(header[1] + ["control"] * len(CONTROLS))
        w.writerow(header[2] + ["-"] * len(CONTROLS))
        for r in data:
            w.writerow(r + ["0"] * len(CONTROLS))

    captured = {}

    def fake_solve_ivp(fun, t_span, y0, method, args=(), **kwargs):
        captured["y0"] = np.array(y0, dtype=float)
        captured["dy"] = np.array(fun(t_span[0], np.array(y0, dtype=float), *args), dtype=float)
        raise Captured()

    from_str.solve_ivp = fake_solve_ivp
    warnings.filterwarnings("ignore")
    opts = {"options": {"t_start": "0", "t_end": "600"}}
    m = greenlight.GreenLight(input_prompt=[model_json, combined, opts], output_path=os.path.join(tmp, "unused.csv"))
    with open(os.devnull, "w") as dn, contextlib.redirect_stdout(dn):
        m.load()
        try:
            m.solve()
        except Captured:
            pass
    if "dy" not in captured:
        raise SystemExit("GreenLight did not call solve_ivp; is this GreenLight 2.0.5?")
    inputs = list(m.inputs.keys())
    missing = [c for c in CONTROLS if c not in inputs]
    if missing:
        raise SystemExit(f"controls not replaced by data: {missing}")
    states = list(m.states.keys())
    out = {
        "about": "GreenLight's derivatives of the Katzin 2021 states at t = 0, initial state, weather row 0, controls 0 (tests/greenlight/make_derivative_fixture.py)",
        "greenlight": importlib.metadata.version("greenlight"),
        "numpy": np.__version__,
        "states": states,
        "initial": [float(v) for v in captured["y0"]],
        "derivative": [float(v) for v in captured["dy"]],
    }
    with open(args.out, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    print(f"wrote {args.out}: {len(states)} states")


if __name__ == "__main__":
    main()
