"""Agents between Python and ghm: a policy file read into NumPy and written back runs the
same season; the NumPy actor is ghm's; an SB3-shaped actor is carried over layer by
layer."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import ghm

ROOT = Path(__file__).resolve().parents[2]
LETTUCE = ROOT / "models" / "lettuce.ghm"
SHIPPED = ROOT / "models" / "agents" / "lettuce" / "builtin" / "policy.json"


def test_a_policy_read_and_written_back_runs_the_same_season(tmp_path):
    policy = ghm.read_policy(SHIPPED)
    assert policy["layers"][0][0].shape == (128, len(policy["observation_names"]))
    path = tmp_path / "agent" / "policy.json"
    ghm.write_policy(
        path,
        LETTUCE,
        policy["layers"],
        policy["mean"],
        policy["var"],
        hidden=policy["hidden"],
        output=policy["output"],
        clip=policy["clip"],
        epsilon=policy["epsilon"],
    )
    shipped = ghm.Policy(LETTUCE).season(steps=48)
    written = ghm.Policy(LETTUCE, agent=path.parent).season(steps=48)
    for name in ("u_heating", "u_ventilation", "u_co2_supply", "cumulative_reward"):
        np.testing.assert_array_equal(written[name], shipped[name], err_msg=name)


def test_the_numpy_actor_is_the_one_ghm_runs():
    policy = ghm.read_policy(SHIPPED)
    env = ghm.Env(LETTUCE, days=1)
    obs, _ = env.reset(seed=0)
    season = ghm.Policy(LETTUCE).season(days=1)
    inputs = np.column_stack([season[f"u_{n}"] for n in env.action_names])
    previous = [env.observation_names.index(f"prev_{n}") for n in env.action_names]
    for k in range(20):
        action = ghm.policy_action(policy, obs)
        assert np.all(np.abs(action) <= 1.0)
        obs, _, _, _, _ = env.step(action)
        # The environment applies the action as ghm's policy controller does: the inputs
        # it applied are the season's (to the rounding of a different summation order).
        np.testing.assert_allclose(obs[previous], inputs[k], rtol=1e-7, err_msg=f"step {k}")


class _Linear:
    def __init__(self, weight, bias):
        self.weight, self.bias = weight, bias


class _ReLU:
    pass


def test_an_sb3_shaped_actor_is_carried_over_layer_by_layer(tmp_path):
    policy = ghm.read_policy(SHIPPED)
    *hidden, last = [_Linear(w, b) for w, b in policy["layers"]]
    sequential = []
    for layer in hidden:
        sequential += [layer, _ReLU()]

    class Actor:
        latent_pi = sequential
        mu = last

    class Sac:
        actor = Actor()

    class Rms:
        mean, var = policy["mean"], policy["var"]

    class VecNormalize:
        obs_rms, clip_obs, epsilon = Rms(), policy["clip"], policy["epsilon"]

    path = tmp_path / "sb3.json"
    ghm.write_policy(path, LETTUCE, **ghm.from_sb3(Sac(), VecNormalize()))
    again = ghm.read_policy(path)
    for (w, b), (w2, b2) in zip(policy["layers"], again["layers"]):
        np.testing.assert_array_equal(w, w2)
        np.testing.assert_array_equal(b, b2)
    obs = np.linspace(-1.0, 500.0, len(policy["observation_names"]))
    np.testing.assert_array_equal(ghm.policy_action(again, obs), ghm.policy_action(policy, obs))


def test_a_bad_policy_is_refused_by_ghm(tmp_path):
    path = tmp_path / "bad.json"
    with pytest.raises(ValueError, match="layer 0"):
        ghm.write_policy(path, LETTUCE, [(np.zeros((3, 12)), np.zeros(2))])
    ghm.write_policy(path, LETTUCE, [(np.zeros((3, 11)), np.zeros(3))])
    with pytest.raises(ValueError, match="inputs"):
        ghm.Policy(LETTUCE, agent=path)
    data = json.loads(path.read_text())
    assert data["observation_names"][0] == "crop"
