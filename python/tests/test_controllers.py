"""ghm's seasons and controllers from Python: the same seasons as the commands, to the
last bit, and the same decisions step by step as inside a season."""

from __future__ import annotations

import csv
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import ghm

ROOT = Path(__file__).resolve().parents[2]
LETTUCE = ROOT / "models" / "lettuce.ghm"
LAMP_CLOCK = ROOT / "models" / "lamp-clock.ghm"
GHM_BIN = Path(os.environ.get("GHM_BIN", ROOT / "target" / "debug" / "ghm"))


def command_season(tmp_path, *args):
    """trajectory.csv of `ghm ARGS --out tmp` as column → array (text columns as lists)."""
    assert GHM_BIN.exists(), f"{GHM_BIN} is missing: run `cargo build` first (or set GHM_BIN)"
    out = tmp_path / "run"
    subprocess.run(
        [str(GHM_BIN), *map(str, args), "--out", str(out)],
        check=True,
        capture_output=True,
        cwd=ROOT,
    )
    with open(out / "trajectory.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    columns = {}
    for name in rows[0]:
        values = [r[name] for r in rows]
        try:
            columns[name] = np.array([float(v) for v in values])
        except ValueError:
            columns[name] = values
    return columns


def assert_same_season(season, columns, skip=("solve_ms",)):
    for name, values in columns.items():
        if name in skip:
            continue
        got = season[name]
        if isinstance(values, list):
            assert list(got) == values, name
        else:
            # trajectory.csv prints each number in its shortest exact form.
            np.testing.assert_array_equal(got, values, err_msg=name)


def test_mpc_from_python_is_the_season_of_ghm_mpc(tmp_path):
    season = ghm.Mpc(LETTUCE, horizon="2h").season(days=1)
    columns = command_season(tmp_path, "mpc", LETTUCE, "--horizon", "2h", "--days", "1")
    assert len(season) == 48
    assert_same_season(season, columns)
    assert season.metrics["cumulative_reward"] == pytest.approx(columns["cumulative_reward"][-1], abs=0)
    assert season.metrics["solve"]["failed_solves"] == 0


def test_rlmpc_policy_and_fixed_inputs_match_their_commands(tmp_path):
    cases = [
        (ghm.RlMpc(LETTUCE, horizon="1h").season(steps=12, uncertainty=0.05, seed=3),
         ["rlmpc", LETTUCE, "--horizon", "1h", "--steps", "12", "--uncertainty", "0.05", "--seed", "3"]),
        (ghm.Policy(LETTUCE).season(steps=20), ["policy", LETTUCE, "--steps", "20"]),
        (ghm.Expert(LETTUCE).season(steps=20), ["policy", LETTUCE, "--expert", "--steps", "20"]),
        (ghm.Rules(LAMP_CLOCK).season(steps=40), ["simulate", LAMP_CLOCK, "--rules", "--steps", "40"]),
        (ghm.simulate(LETTUCE, "const:0.6,1,40", enforce_limits=False, steps=20),
         ["simulate", LETTUCE, "--inputs", "const:0.6,1,40", "--no-rate-limit", "--steps", "20"]),
    ]
    for i, (season, args) in enumerate(cases):
        assert_same_season(season, command_season(tmp_path / str(i), *args))


def test_decisions_step_by_step_are_the_seasons_decisions():
    mpc = ghm.Mpc(LETTUCE, horizon="2h")
    season = mpc.season(days=1)
    model = ghm.load(LETTUCE)
    x_names = [f"x_{s['name']}" for s in model["states"]]
    u_names = [f"u_{u['name']}" for u in model["inputs"]]
    d_names = [f"d_{d['name']}" for d in model["disturbances"]]
    states = np.column_stack([season[n] for n in x_names])
    inputs = np.column_stack([season[n] for n in u_names])
    weather = np.column_stack([season[n] for n in d_names])
    start = np.array([u["start"] for u in model["inputs"]])
    assert mpc.forecast_rows == 4
    for k in range(40):
        previous = start if k == 0 else inputs[k - 1]
        u, record = mpc.decide(k, states[k], previous, weather[k:])
        np.testing.assert_array_equal(u, inputs[k], err_msg=f"step {k}")
        assert record["status"] == season["status"][k]
    mpc.reset()
    u, _ = mpc.decide(0, states[0], start, weather)
    np.testing.assert_array_equal(u, inputs[0])


def test_settings_left_out_take_the_defaults_ghm_states(tmp_path):
    assert ghm.defaults("mpc") == {"kind": "mpc", "horizon": "3h", "solver": "ipm", "bands": "auto"}
    rlmpc = ghm.defaults("rlmpc")
    assert rlmpc["horizon"] == "1h" and rlmpc["guide"] == "sac" and rlmpc["epsilon"] == 0.05
    assert ghm.Mpc(LETTUCE).settings == ghm.defaults("mpc")
    mpc = ghm.Mpc(LETTUCE, horizon="2h", warm_start="primal-dual", bands=None)
    assert mpc.settings["warm_start"] == "primal-dual" and mpc.settings["bands"] == "auto"
    guided = ghm.RlMpc(LETTUCE, guide="expert", agent=tmp_path, terminal_cost="none")
    assert guided.settings["horizon"] == "1h" and guided.settings["agent"] == str(tmp_path)
    with pytest.raises(ValueError, match="no controller kind `mcp`"):
        ghm.defaults("mcp")
    with pytest.raises(ValueError, match="warmstart"):
        ghm.Mpc(LETTUCE, warmstart="primal")
    with pytest.raises(ValueError, match="unknown season option"):
        ghm.Mpc(LETTUCE).season(day=1)


def test_bad_settings_and_arguments_raise_with_ghm_messages(tmp_path):
    with pytest.raises(ValueError, match="solvr"):
        ghm.Controller(LETTUCE, {"kind": "mpc", "horizon": "1h", "solvr": "sqp"})
    with pytest.raises(ValueError, match="`horizon` = 45min"):
        ghm.Mpc(LETTUCE, horizon="45min")
    with pytest.raises(ValueError, match="no policy"):
        ghm.Policy(LETTUCE, agent=tmp_path)
    bad = tmp_path / "bad.ghm"
    bad.write_text("model bad\nstate x [m] = 1 +\n")
    with pytest.raises(ghm.ModelError, match=r"bad\.ghm:3:1"):
        ghm.Mpc(bad)
    mpc = ghm.Mpc(LETTUCE, horizon="1h")
    with pytest.raises(ValueError, match="state has 3 numbers; the model has 4"):
        mpc.decide(0, [1.0, 2.0, 3.0], [0, 0, 0], np.zeros((2, 4)))
    with pytest.raises(ValueError, match="finite"):
        mpc.decide(0, [np.nan, 1, 1, 1], [0, 0, 0], np.zeros((2, 4)))
    with pytest.raises(ValueError, match="optimum"):
        ghm.Controller(LETTUCE, {"kind": "optimum"})
