"""The Python package against ghm itself: Gymnasium's checker on every shipped model, an
episode equal to the Rust season loop's to the last bit, the vectorised form equal to the
single one, and errors as exceptions with ghm's diagnostics."""

import csv
import os
import subprocess
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import ghm

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
# The ghm binary that `cargo test` (or `cargo build`) left; GHM_BIN overrides it.
GHM_BIN = Path(os.environ.get("GHM_BIN", ROOT / "target" / "debug" / "ghm"))


@pytest.mark.parametrize("model", ["lettuce.ghm", "lettuce-thesis.ghm", "cstr.ghm", "bioreactor.ghm"])
def test_check_env_passes_on_every_shipped_model(model):
    env = ghm.Env(MODELS / model, days=1)
    check_env(env, skip_render_check=True)
    assert env.observation_space.shape == (len(env.observation_names),)
    assert env.action_space.shape == (len(env.action_names),)


def test_gymnasium_make_builds_the_registered_environment():
    env = gymnasium.make("ghm/Model-v0", model=str(MODELS / "lettuce.ghm"), days=1)
    observation, _ = env.reset(seed=3)
    assert observation.shape == (12,)


def test_an_environment_observes_the_forecast_as_a_distilled_guide_does():
    rows = 3
    env = ghm.Env(MODELS / "lettuce.ghm", days=1, forecast_rows=rows)
    plain = ghm.Env(MODELS / "lettuce.ghm", days=1)
    weather = ["radiation", "co2_out", "temp_out", "hum_out"]
    names = env.observation_names
    assert names[: len(plain.observation_names)] == plain.observation_names
    assert names[len(plain.observation_names) :] == [
        f"{d}[k+{j}]" for j in range(1, rows + 1) for d in weather
    ]
    check_env(env, skip_render_check=True)
    # Row j of the forecast at step k is the current weather at step k + j; the last
    # steps read rows past the season's end, loaded as a season of the job layer loads them.
    now = [names.index(d) for d in weather]
    ahead = [names.index(f"{d}[k+1]") for d in weather]
    observations = [env.reset(seed=2)[0]]
    done = False
    while not done:
        observation, _, done, _, _ = env.step(np.zeros(env.action_space.shape))
        observations.append(observation)
    for before, after in zip(observations, observations[1:]):
        assert np.array_equal(before[ahead], after[now])
    with pytest.raises(ValueError, match="forecast_rows = 400"):
        ghm.Env(MODELS / "lettuce.ghm", days=1, forecast_rows=400)


def random_episode(env, seed):
    rng = np.random.default_rng(seed)
    observation, _ = env.reset(seed=seed)
    rewards, inputs, states = [], [], [env.state.copy()]
    done = False
    while not done:
        action = rng.uniform(-1.0, 1.0, size=env.action_space.shape)
        observation, reward, done, truncated, info = env.step(action)
        assert not truncated
        rewards.append(reward)
        inputs.append(info["input"])
        states.append(env.state.copy())
    return np.array(rewards), np.array(inputs), np.array(states)


def test_an_episode_equals_the_rust_season_loop_to_the_last_bit(tmp_path):
    assert GHM_BIN.exists(), f"{GHM_BIN} is missing: run `cargo build` first (or set GHM_BIN)"
    env = ghm.Env(MODELS / "lettuce.ghm", days=1)
    rewards, inputs, states = random_episode(env, seed=11)
    assert len(rewards) == 48
    # The inputs the actions mapped to, replayed by `ghm simulate` on the same built-in
    # weather: every reward and state as Rust's season loop computes them.
    table = tmp_path / "inputs.csv"
    with table.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(env.action_names)
        for row in inputs:
            writer.writerow([repr(float(v)) for v in row])
    out = tmp_path / "run"
    subprocess.run(
        [GHM_BIN, "simulate", MODELS / "lettuce.ghm", "--days", "1", "--inputs", table, "--out", out],
        check=True,
        capture_output=True,
    )
    with (out / "trajectory.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 48
    season_rewards = np.array([float(r["reward"]) for r in rows])
    assert np.array_equal(season_rewards, rewards), np.max(np.abs(season_rewards - rewards))
    state_columns = [c for c in rows[0] if c.startswith("x_")]
    season_states = np.array([[float(r[c]) for c in state_columns] for r in rows])
    assert np.array_equal(season_states, states[:-1])


def test_the_same_seed_gives_the_same_uncertain_episode_and_another_seed_another():
    env = ghm.Env(MODELS / "lettuce.ghm", days=1, uncertainty=0.2)
    first = random_episode(env, seed=5)[0]
    again = random_episode(env, seed=5)[0]
    other = random_episode(env, seed=6)[0]
    assert np.array_equal(first, again)
    assert not np.array_equal(first, other)


def test_the_vectorised_form_steps_each_environment_as_a_single_one_would():
    count, days = 4, 0.5
    vec = ghm.VecEnv(MODELS / "lettuce.ghm", count, days=days, uncertainty=0.1, seed=20)
    singles = [ghm.Env(MODELS / "lettuce.ghm", days=days, uncertainty=0.1, seed=20 + i) for i in range(count)]
    observations = vec.reset()
    for i, env in enumerate(singles):
        first, _ = env.reset()
        assert np.array_equal(observations[i], first)
    rng = np.random.default_rng(0)
    for step in range(singles[0].episode_len):
        actions = rng.uniform(-1, 1, size=(count, 3))
        observations, rewards, dones = vec.step(actions)
        for i, env in enumerate(singles):
            observation, reward, done, _, _ = env.step(actions[i])
            assert reward == rewards[i]
            assert done == dones[i]
            if done:
                # The vectorised form starts the next season at once.
                observation, _ = env.reset()
            assert np.array_equal(observation, observations[i])
    assert dones.all()


def test_load_returns_the_declarations_with_units():
    model = ghm.load(MODELS / "lettuce.ghm")
    assert [s["name"] for s in model["states"]] == ["dry_weight", "co2_air", "temp_air", "hum_air"]
    assert all("unit" in u and "lower" in u and "upper" in u for u in model["inputs"])
    assert model["sample_period_s"] == 1800.0


def test_a_bad_model_raises_model_error_with_file_line_and_column(tmp_path):
    bad = tmp_path / "bad.ghm"
    bad.write_text("model m\nstate x [kg] = 1\nder x = y + 1\n")
    with pytest.raises(ghm.ModelError) as error:
        ghm.Env(bad, days=1)
    assert "bad.ghm:3:" in str(error.value)


def test_bad_arguments_and_actions_are_exceptions_not_crashes():
    with pytest.raises(ValueError, match="days"):
        ghm.Env(MODELS / "lettuce.ghm", days=1e20)
    with pytest.raises(ValueError, match="uncertainty"):
        ghm.Env(MODELS / "lettuce.ghm", uncertainty=1.5)
    with pytest.raises(ValueError):
        ghm.Env(MODELS / "lettuce.ghm", weather="/no/such/file.csv")
    env = ghm.Env(MODELS / "lettuce.ghm", days=1)
    env.reset()
    with pytest.raises(ValueError):
        env.step([0.0, 0.0])
    with pytest.raises(ValueError):
        env.step([float("nan"), 0.0, 0.0])
    with pytest.raises(ValueError):
        ghm.VecEnv(MODELS / "lettuce.ghm", 2, days=1).step(np.zeros((3, 3)))


BLOWUP = """model blowup "a state that leaves the numbers under a large input"
sample 1 [s] integrator rk4 substeps 1
state x [m] = 1 "grows as x squared times the drive"
input u [m s^-1] in [0, 1e6] start 0 "drive"
der x = u * x * x
output y [m] = x
cost drive [EUR] = -0.001 * u
"""


def test_a_diverged_step_ends_the_episode_instead_of_raising(tmp_path):
    model = tmp_path / "blowup.ghm"
    model.write_text(BLOWUP)
    env = ghm.Env(model, days=0.01)
    previous, _ = env.reset(seed=1)
    # Full drive: x reaches 4e85 after one step, overflows in the second.
    for _ in range(5):
        observation, reward, terminated, truncated, info = env.step(np.ones(1))
        if terminated:
            break
        previous = observation
    assert terminated and not truncated
    assert reward == 0.0
    assert "`x`" in info["diverged"] and "inf" in info["diverged"], info
    np.testing.assert_array_equal(observation, previous)
    # The raw step says why, as its own exception (a RuntimeError).
    assert issubclass(ghm.DivergedError, RuntimeError)
    # Batched: the diverged environment is done, rewarded 0 and reset; the other goes on.
    vec = ghm.VecEnv(model, 2, days=0.01)
    first = vec.reset()[0]
    actions = np.array([[1.0], [-1.0]])
    _, _, dones = vec.step(actions)
    assert list(dones) == [False, False]
    observations, rewards, dones = vec.step(actions)
    assert list(dones) == [True, False]
    assert rewards[0] == 0.0
    np.testing.assert_array_equal(observations[0], first)
