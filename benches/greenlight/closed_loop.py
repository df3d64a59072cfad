#!/usr/bin/env python3
"""GreenLight's own closed loop (its rules, default solver options) over the first DAYS of
the Bleiswijk weather: the yardstick ghm's season is timed against, in one run beside it
(docs/benchmarks-history.md, GreenLight's "Before" entry; the command is in
docs/benchmarks.md). Calls GreenLight only through its public class, as
tests/greenlight/make_reference.py does (whose helpers it uses).

Usage: python closed_loop.py [DAYS]      (default 1)
"""

import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "../../tests/greenlight"))
from make_reference import options_dict, package_paths, run_greenlight, time_state_init  # noqa: E402

days = float(sys.argv[1]) if len(sys.argv) > 1 else 1.0
model, weather = package_paths()
prompt = [model, weather, time_state_init(0), options_dict(0.0, days * 86400.0)]
with tempfile.TemporaryDirectory() as tmp:
    _, load_s, solve_s = run_greenlight(prompt, os.path.join(tmp, "greenlight.log"))
print(f"GreenLight closed loop, {days:g} day(s): load {load_s:.1f} s, solve {solve_s:.1f} s")
