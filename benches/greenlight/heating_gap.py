#!/usr/bin/env python3
"""GreenLight's 10-day closed loop (Katzin 2021, its own rules) under variants of its solver
options, printing the mean heating power over the 2 880 points of 300 s that
`tests/greenlight_openloop.rs` compares with ghm's (12.992 W m⁻² with GreenLight's defaults:
weather interpolated linearly, BDF rtol 1e-6, atol 1e-3).

Measured 2026-12-04 (mean heating over all 2 880 points, W m⁻²): GreenLight's defaults
12.992; weather held per row 13.090; held, rtol 1e-8 atol 1e-6 13.355 (697 s of solve);
linear, rtol 1e-8 atol 1e-6 13.175 (344 s). ghm: 12.693 (4 sub-steps), 12.988 (16),
13.171 (64). The spread is ten samples at midnight where GreenLight's rules are not
defined for an instant (docs/import.md); over the other 2 870 points ghm and GreenLight
agree to 0.1 %. The tight-tolerance variants take several minutes each on one core.

Usage: python benches/greenlight/heating_gap.py   (in a venv with greenlight==2.0.5)
Only GreenLight's public class is called (through tests/greenlight/make_reference.py).
"""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tests", "greenlight"))
import make_reference as mr  # noqa: E402

VARIANTS = [
    ("weather held per row", {"interpolation": "left"}),
    ("weather held, rtol 1e-8 atol 1e-6", {"interpolation": "left", "rtol": "1e-8", "atol": "1e-6"}),
    ("weather linear, rtol 1e-8 atol 1e-6", {"rtol": "1e-8", "atol": "1e-6"}),
]


def main():
    model_path, weather_path = mr.package_paths()
    points = 2880
    for name, extra in VARIANTS:
        opts = mr.options_dict(0.0, 10 * 86400.0, **extra)
        prompt = [model_path, weather_path, mr.time_state_init(0), opts]
        m, _, solve_s = mr.run_greenlight(prompt, os.devnull)
        sol = m.full_sol
        heat = (sol["hBoilPipe"].to_numpy(dtype=float) + sol["hBoilGroPipe"].to_numpy(dtype=float))[:points]
        print(f"{name}: mean heating {heat.mean():.4f} W m-2 (solve {solve_s:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
