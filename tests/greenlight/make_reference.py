#!/usr/bin/env python3
"""Make GreenLight reference trajectories for the ghm importer of the Katzin 2021 model.

Runs the Python package GreenLight (PyPI `greenlight`, tested with 2.0.5) twice over a
window of its packaged Bleiswijk weather file:

1. closed loop: the model's own rule-based climate control, GreenLight's default solver
   options (BDF, rtol 1e-6, atol 1e-3, max_step 3600 s, weather linearly interpolated).
   The five acting controls sampled every 300 s go to `controls.csv`; states and key
   climate / energy / harvest quantities every 300 s go to `rules.csv`.
2. open loop: the same model with uBoil, uRoof, uThScr, uLamp, uExtCo2 replaced by the
   samples of `controls.csv`, every input held per 300 s row (GreenLight's
   `interpolation = "left"`, which applies to weather and controls alike), BDF with
   rtol 1e-8, atol 1e-6. All 28 states every 300 s go to `openloop.csv`.

`meta.json` records versions, options, window and wall times.

Usage: python make_reference.py [--start-day D] [--days N] [--out DIR]

This script only calls GreenLight through its public class; it contains no GreenLight
code. The weather data are not written to DIR (see README.md for their provenance).
"""

import argparse
import contextlib
import csv
import datetime
import hashlib
import importlib.metadata
import importlib.resources
import json
import math
import os
import platform
import sys
import tempfile
import time
import warnings

import numpy as np
import pandas as pd

import greenlight

STEP = 300.0  # s, the row spacing of the weather file and of every output
CONTROLS = ["uBoil", "uRoof", "uThScr", "uLamp", "uExtCo2"]
# Quantities written next to the states in rules.csv (GreenLight variable names).
RULES_EXTRA = [
    "co2InPpm",  # ppm, CO2 of the main compartment
    "rhIn",  # %, relative humidity of the main compartment
    "hBoilPipe",  # W m-2, boiler heat to the pipe rails (heating power)
    "hBoilGroPipe",  # W m-2, boiler heat to the grow pipes (0: pBoilGro = 0)
    "qLampIn",  # W m-2, electric input of the top lamps
    "qIntLampIn",  # W m-2, electric input of the interlights (0 in this set-up)
    "mcExtAir",  # mg m-2 s-1, CO2 injection
    "mcFruitHar",  # mg{CH2O} m-2 s-1, fruit harvest rate
    "mcOrgAir",  # mg{CH2O} m-2 s-1, maintenance respiration of the crop
    "mvCanAir",  # kg m-2 s-1, transpiration
]


def package_paths():
    root = importlib.resources.files("greenlight") / "models" / "katzin_2021"
    model = str(root / "definition" / "main_katzin_2021.json")
    weather = str(root / "input_data" / "test_data" / "Bleiswijk_from_20091020.csv")
    return model, weather


def read_weather(path):
    """The weather file as strings (three header rows: name, description, unit)."""
    try:
        raw = pd.read_csv(path, dtype=str, encoding="utf-8", header=None)
    except UnicodeDecodeError:
        raw = pd.read_csv(path, dtype=str, encoding="Windows-1252", header=None)
    names = list(raw.iloc[0])
    descriptions = list(raw.iloc[1])
    units = list(raw.iloc[2])
    data = raw.iloc[3:].reset_index(drop=True)
    data.columns = names
    return names, descriptions, units, data


def options_dict(t0, t1, **extra):
    # t_eval = arange(t_start, t_end, output_step); t_end is one second past the window
    # so that the window's last point is included.
    opts = {
        "t_start": repr(float(t0)),
        "t_end": repr(float(t1) + 1.0),
        "t_eval": "True",
        "output_step": repr(STEP),
        "warn_loading": "False",
        "warn_runtime": "False",
    }
    opts.update(extra)
    return {"options": opts}


def time_state_init(start_day):
    # time_state (days) starts from its "init"; set it to the window's start so that
    # time_state == t / 86400 throughout (t in seconds since 2009-10-20 00:00).
    return {"time_state": {"type": "state", "definition": "1/86400", "init": repr(float(start_day)), "unit": "day"}}


def run_greenlight(prompt, log_path):
    """Load and solve quietly; return the model, load and solve wall times."""
    mdl = greenlight.GreenLight(input_prompt=prompt, output_path=os.path.join(tempfile.gettempdir(), "gl_unused.csv"))
    with open(os.devnull, "w") as devnull, contextlib.redirect_stdout(devnull), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t_a = time.perf_counter()
        mdl.load()
        t_b = time.perf_counter()
        mdl.solve()
        t_c = time.perf_counter()
    # Keep GreenLight's log without the Python function it generates from the model.
    kept, skipping = [], False
    for line in mdl.log.splitlines():
        if line.startswith("Model definitions converted to Python function"):
            skipping = True
            kept.append("[generated right-hand-side function left out]")
            continue
        if skipping:
            skipping = line.strip() != "return dy"
            continue
        kept.append(line)
    warning_lines = [line for line in kept if "RuntimeWarning encountered" in line]
    if len(warning_lines) > 100:  # keep the log small: the first 100 warnings only
        drop = set(warning_lines[100:])
        kept = [line for line in kept if line not in drop]
        kept.append(f"[{len(warning_lines) - 100} further runtime warnings left out]")
    with open(log_path, "w", encoding="utf-8") as f:
        f.write("\n".join(kept) + "\n")
    mdl.runtime_warning_count = len(warning_lines)
    if not mdl.states_sol.success:
        raise RuntimeError(f"GreenLight failed: {mdl.states_sol.message}")
    return mdl, t_b - t_a, t_c - t_b


def write_csv(path, header, columns):
    n = len(columns[0])
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        for i in range(n):
            w.writerow([repr(float(c[i])) for c in columns])


def solver_stats(sol):
    return {k: int(getattr(sol, k)) for k in ("nfev", "njev", "nlu") if hasattr(sol, k)}


def check(name, frame, cols):
    values = frame[cols].to_numpy(dtype=float)
    if not np.all(np.isfinite(values)):
        raise RuntimeError(f"{name}: non-finite values")
    if "tAir" in frame:
        lo, hi = float(frame["tAir"].min()), float(frame["tAir"].max())
        if not (-5.0 < lo and hi < 45.0):
            raise RuntimeError(f"{name}: implausible tAir range {lo}..{hi}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--start-day", type=int, default=0, help="whole days after 2009-10-20 00:00 (default 0)")
    ap.add_argument("--days", type=int, default=10, help="window length in days (default 10)")
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--rtol", default="1e-8", help="relative tolerance of the open-loop run (default 1e-8)")
    ap.add_argument("--atol", default="1e-6", help="absolute tolerance of the open-loop run (default 1e-6)")
    ap.add_argument(
        "--controls",
        help="take the open loop's controls from this controls.csv (of an earlier run of this "
        "script over the same window) instead of running the closed loop; rules.csv is then not written",
    )
    args = ap.parse_args()

    model_path, weather_path = package_paths()
    names, descriptions, units, weather = read_weather(weather_path)
    t_weather = weather["Time"].astype(float).to_numpy()
    t0 = args.start_day * 86400.0
    t1 = (args.start_day + args.days) * 86400.0
    if args.start_day < 0 or args.days <= 0 or t1 > t_weather[-1] + STEP:
        raise SystemExit(f"window {t0}..{t1} s is outside the weather file (0..{t_weather[-1] + STEP} s)")
    os.makedirs(args.out, exist_ok=True)
    grid = t0 + STEP * np.arange(int(round((t1 - t0) / STEP)) + 1)  # t0 .. t1 inclusive

    if args.controls is None:
        # ---- 1. closed loop with GreenLight's own rules, default solver options ----
        rules_opts = options_dict(t0, t1)
        prompt1 = [model_path, weather_path, time_state_init(args.start_day), rules_opts]
        m1, load1, solve1 = run_greenlight(prompt1, os.path.join(args.out, "rules_greenlight.log"))
        sol1 = m1.full_sol
        if not np.allclose(sol1["Time"].to_numpy(dtype=float), grid, rtol=0, atol=1e-6):
            raise RuntimeError("closed-loop output times differ from the 300 s grid")
        states = list(m1.states.keys())
        check("rules", sol1, states + CONTROLS + RULES_EXTRA)
        ctrl_rows = slice(0, len(grid) - 1)  # one control row per 300 s interval
        write_csv(
            os.path.join(args.out, "controls.csv"),
            ["time_s"] + CONTROLS,
            [grid[ctrl_rows]] + [sol1[c].to_numpy(dtype=float)[ctrl_rows] for c in CONTROLS],
        )
        write_csv(
            os.path.join(args.out, "rules.csv"),
            ["time_s"] + states + CONTROLS + RULES_EXTRA,
            [grid] + [sol1[c].to_numpy(dtype=float) for c in states + CONTROLS + RULES_EXTRA],
        )
    else:
        m1, load1, solve1 = None, 0.0, 0.0
        controls_path = os.path.join(args.out, "controls.csv")
        if os.path.abspath(args.controls) != os.path.abspath(controls_path):
            with open(args.controls, encoding="utf-8") as src, open(controls_path, "w", encoding="utf-8") as dst:
                dst.write(src.read())

    # ---- 2. open loop: the five controls fixed from controls.csv, held per row ----
    ctrl = pd.read_csv(os.path.join(args.out, "controls.csv"), dtype=float)
    first = int(np.searchsorted(t_weather, t0))
    last = int(np.searchsorted(t_weather, t1))  # row at t1 if present
    rows = weather.iloc[first : min(last + 1, len(weather))].reset_index(drop=True)
    if not np.allclose(rows["Time"].astype(float).to_numpy()[: len(ctrl)], ctrl["time_s"].to_numpy()):
        raise RuntimeError("weather rows and control rows do not line up")
    combined = rows.copy()
    for c in CONTROLS:
        v = ctrl[c].to_numpy()
        v = np.concatenate([v, np.full(len(rows) - len(v), v[-1])])  # a row at t1 repeats the last control
        combined[c] = [repr(float(x)) for x in v]
    open_opts = options_dict(t0, t1, interpolation="left", rtol=args.rtol, atol=args.atol)
    with tempfile.TemporaryDirectory() as tmp:
        inputs_path = os.path.join(tmp, "openloop_inputs.csv")
        with open(inputs_path, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(names + CONTROLS)
            w.writerow(descriptions + [f"{c} fixed from controls.csv" for c in CONTROLS])
            w.writerow(units + ["-"] * len(CONTROLS))
            for r in combined.itertuples(index=False):
                w.writerow(list(r))
        # interpolation="left" must not be set while a second CSV is merged into the
        # first one (GreenLight's merge code is only exercised for "linear"), so all
        # inputs come in this single file and the option dict comes after it.
        prompt2 = [model_path, inputs_path, time_state_init(args.start_day), open_opts]
        m2, load2, solve2 = run_greenlight(prompt2, os.path.join(args.out, "openloop_greenlight.log"))
    for c in CONTROLS:
        if c not in m2.inputs or c in m2.aux:
            raise RuntimeError(f"{c} was not replaced by data")
    sol2 = m2.full_sol
    if not np.allclose(sol2["Time"].to_numpy(dtype=float), grid, rtol=0, atol=1e-6):
        raise RuntimeError("open-loop output times differ from the 300 s grid")
    states2 = list(m2.states.keys())
    if m1 is None:
        states = states2
    assert states2 == states and len(states) == 28, states2
    check("openloop", sol2, states)
    write_csv(
        os.path.join(args.out, "openloop.csv"),
        ["time_s"] + states,
        [grid] + [sol2[c].to_numpy(dtype=float) for c in states],
    )

    with open(weather_path, "rb") as f:
        weather_sha = hashlib.sha256(f.read()).hexdigest()
    diff = (
        {s: float(np.max(np.abs(sol1[s].to_numpy(dtype=float) - sol2[s].to_numpy(dtype=float)))) for s in states}
        if m1 is not None
        else None
    )
    meta = {
        "created": datetime.datetime.now().isoformat(timespec="seconds"),
        "greenlight_version": importlib.metadata.version("greenlight"),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": importlib.metadata.version("scipy"),
        "pandas": pd.__version__,
        "platform": platform.platform(),
        "model": "greenlight/models/katzin_2021/definition/main_katzin_2021.json",
        "weather": "greenlight/models/katzin_2021/input_data/test_data/Bleiswijk_from_20091020.csv",
        "weather_sha256": weather_sha,
        "weather_epoch": "2009-10-20T00:00 (Time = 0 s in the weather file)",
        "start_day": args.start_day,
        "days": args.days,
        "t_start_s": t0,
        "t_end_s": t1,
        "step_s": STEP,
        "time_state_init_days": float(args.start_day),
        "initial_state": {k: float(m2.init[k]) for k in states},
        "controls_from": args.controls or "the closed-loop run above",
        "controls": CONTROLS,
        "rules_extra": RULES_EXTRA,
        "rules_run": None
        if m1 is None
        else {
            "options": {k: m1.options[k] for k in ("solver", "rtol", "atol", "max_step", "first_step", "interpolation")},
            "load_s": load1,
            "solve_s": solve1,
            "solver_stats": solver_stats(m1.states_sol),
            "distinct_runtime_warnings": m1.runtime_warning_count,
        },
        "openloop_run": {
            "options": {k: m2.options[k] for k in ("solver", "rtol", "atol", "max_step", "first_step", "interpolation")},
            "load_s": load2,
            "solve_s": solve2,
            "solver_stats": solver_stats(m2.states_sol),
            "distinct_runtime_warnings": m2.runtime_warning_count,
        },
        "max_abs_diff_rules_vs_openloop": diff,
        "rows": {"controls": len(grid) - 1, "rules": len(grid), "openloop": len(grid)},
        "notes": [
            "controls.csv row k holds the rule output at time_s[k]; GreenLight's 'left' interpolation "
            "applies it on (time_s[k], time_s[k] + 300] (at exactly time_s[k] the previous row is used).",
            "In the open-loop run every weather input is held per 300 s row as well (the option is global).",
            "Both runs start from the model's default initial state whatever the start day.",
            "GreenLight replaces NaN by 0 and clips to +-1e38 inside its right-hand side; the runtime "
            "warnings (overflow in exp/power, invalid values) it logged are counted above.",
        ],
    }
    with open(os.path.join(args.out, "meta.json"), "w", encoding="utf-8") as f:
        json.dump(meta, f, indent=2)
    if diff is None:
        print(f"done: open loop {solve2:.1f} s (rtol {args.rtol}, atol {args.atol})", file=sys.stderr)
        return
    worst = max(diff, key=diff.get)
    print(
        f"done: rules {solve1:.1f} s, open loop {solve2:.1f} s; "
        f"tAir {sol2['tAir'].min():.2f}..{sol2['tAir'].max():.2f} degC; "
        f"max |rules - openloop| tAir {diff['tAir']:.3f}, worst {worst} {diff[worst]:.3g}",
        file=sys.stderr,
    )


if __name__ == "__main__":
    main()
