"""Agents between Python and ghm: ``policy.json`` as NumPy weights, and back.

ghm's policy file holds a deterministic actor: the observation (outputs, previous inputs,
step, weather; :attr:`ghm.Env.observation_names`) standardised by frozen statistics,
``z = clip((obs - mean) / sqrt(var + epsilon), -clip, clip)``, then an MLP
(``hidden`` activation between layers, ``output`` after the last, ``tanh`` for actions in
``[-1, 1]``), whose action moves each input by up to its rate limit, as in
:class:`ghm.Env`. Any actor of that form — trained with Stable-Baselines3 (:func:`from_sb3`),
CleanRL or your own torch code — written with :func:`write_policy` runs in
``ghm policy --agent FILE``, guides ``ghm rlmpc --agent FILE`` and feeds ``ghm value``.
"""

from __future__ import annotations

import json
import os
from typing import Any, Optional, Sequence

import numpy as np

from . import _ghm

__all__ = ["read_policy", "write_policy", "policy_action", "from_sb3"]


def read_policy(path) -> dict:
    """A ghm policy file (or a ``ghm train`` folder) as plain NumPy data: ``layers`` (a list
    of ``(weight, bias)``, weight ``outputs × inputs``), ``hidden``, ``output``, ``mean``,
    ``var``, ``clip``, ``epsilon``, and the ``model``, ``observation_names``,
    ``action_names``, ``episode`` and ``eval_reward`` it records."""
    path = os.fspath(path)
    if os.path.isdir(path):
        path = os.path.join(path, "policy.json")
    with open(path) as f:
        data = json.load(f)
    actor, norm = data["actor"], data["normalizer"]
    layers = [
        (
            np.array(layer["weight"], dtype=np.float64).reshape(layer["outputs"], layer["inputs"]),
            np.array(layer["bias"], dtype=np.float64),
        )
        for layer in actor["layers"]
    ]
    return {
        "model": data["model"],
        "observation_names": list(data["observation_names"]),
        "action_names": list(data.get("action_names", [])),
        "layers": layers,
        "hidden": actor["hidden"],
        "output": actor["output"],
        "mean": np.array(norm["mean"], dtype=np.float64),
        "var": np.array(norm["var"], dtype=np.float64),
        "clip": float(norm["clip"]),
        "epsilon": float(norm["epsilon"]),
        "episode": int(data.get("episode", 0)),
        "eval_reward": data.get("eval_reward"),
    }


def write_policy(
    path,
    model,
    layers: Sequence[tuple[Any, Any]],
    mean=None,
    var=None,
    *,
    hidden: str = "relu",
    output: str = "tanh",
    clip: float = 10.0,
    epsilon: float = 1e-8,
    episode: int = 0,
    eval_reward: Optional[float] = None,
) -> None:
    """Writes a ghm policy file for the model at ``model`` (its observation and action
    names are taken from it). ``layers``: ``(weight, bias)`` pairs, weight ``outputs ×
    inputs`` (as ``torch.nn.Linear.weight``). ``mean``/``var``: the observation statistics
    (``None``: no standardisation). ghm checks the file when it reads it."""
    names = _ghm.RawEnv(os.fspath(model), days=1.0)
    observation_names, action_names = list(names.observation_names), list(names.action_names)
    width = len(observation_names)
    if mean is None and var is None:
        mean, var, epsilon, clip = np.zeros(width), np.ones(width), 0.0, 1e300
    out_layers = []
    for i, (weight, bias) in enumerate(layers):
        weight = np.asarray(weight, dtype=np.float64)
        bias = np.asarray(bias, dtype=np.float64)
        if weight.ndim != 2 or bias.shape != (weight.shape[0],):
            raise ValueError(
                f"layer {i}: weight {weight.shape} and bias {bias.shape} do not make a layer "
                "(weight: outputs × inputs, bias: outputs)"
            )
        out_layers.append(
            {
                "inputs": int(weight.shape[1]),
                "outputs": int(weight.shape[0]),
                "weight": weight.ravel().tolist(),
                "bias": bias.tolist(),
            }
        )
    data = {
        "model": _ghm.load(os.fspath(model))["name"],
        "observation_names": observation_names,
        "action_names": action_names,
        "normalizer": {
            "mean": np.asarray(mean, dtype=np.float64).tolist(),
            "var": np.asarray(var, dtype=np.float64).tolist(),
            "count": 1.0,
            "clip": float(clip),
            "epsilon": float(epsilon),
            "frozen": True,
        },
        "actor": {"layers": out_layers, "hidden": hidden, "output": output},
        "episode": int(episode),
        "eval_reward": None if eval_reward is None else float(eval_reward),
    }
    path = os.fspath(path)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = path + ".partial"
    with open(tmp, "w") as f:
        json.dump(data, f)
        f.write("\n")
    os.replace(tmp, path)


_ACTIVATIONS = {"identity": lambda x: x, "relu": lambda x: np.maximum(x, 0.0), "tanh": np.tanh}


def policy_action(policy: dict, observation) -> np.ndarray:
    """The action in ``[-1, 1]`` of a policy (as :func:`read_policy` returns it) for one
    observation or a batch (rows), in NumPy."""
    obs = np.asarray(observation, dtype=np.float64)
    z = np.clip((obs - policy["mean"]) / np.sqrt(policy["var"] + policy["epsilon"]), -policy["clip"], policy["clip"])
    layers = policy["layers"]
    for i, (weight, bias) in enumerate(layers):
        z = z @ weight.T + bias
        z = _ACTIVATIONS[policy["output" if i == len(layers) - 1 else "hidden"]](z)
    return z


def _numpy(tensor) -> np.ndarray:
    if hasattr(tensor, "detach"):
        tensor = tensor.detach().cpu().numpy()
    return np.asarray(tensor, dtype=np.float64)


def from_sb3(model, vec_normalize=None) -> dict:
    """The deterministic actor of a Stable-Baselines3 SAC (or TD3) model trained on
    :class:`ghm.Env`, as :func:`write_policy`'s arguments: ``layers`` (its ``latent_pi``
    linear layers and ``mu``), ``hidden`` (ReLU, SB3's default) and ``output`` (tanh: SAC
    squashes its mean action), and the observation statistics of ``vec_normalize`` (a
    ``VecNormalize``) if the agent was trained behind one::

        write_policy("agent/policy.json", "models/lettuce.ghm", **from_sb3(sac, vec_norm))
    """
    actor = model.actor
    linear = [m for m in getattr(actor, "latent_pi", []) if hasattr(m, "weight")]
    last = getattr(actor, "mu", None)
    if last is None:  # TD3's actor: one Sequential ending in tanh
        modules = [m for m in actor.mu if hasattr(m, "weight")]
        linear, last = modules[:-1], modules[-1]
    layers = [(_numpy(m.weight), _numpy(m.bias)) for m in [*linear, last]]
    out: dict[str, Any] = {"layers": layers, "hidden": "relu", "output": "tanh"}
    if vec_normalize is not None:
        rms = vec_normalize.obs_rms
        out.update(
            mean=_numpy(rms.mean),
            var=_numpy(rms.var),
            clip=float(vec_normalize.clip_obs),
            epsilon=float(vec_normalize.epsilon),
        )
    return out
