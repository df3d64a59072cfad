"""ghm from Python: any ``.ghm`` model as a Gymnasium environment.

``ghm.Env`` is a :class:`gymnasium.Env` over ghm's Rust environment (the one ``ghm train``
trains on): the same observation, action and reward, bit for bit.

* observation ``[y(x(k)), u(k-1), k, d(k)]`` in model units (``float64``);
* action in ``[-1, 1]`` per input, mapped to ``u(k) = clip(u(k-1) + a * du, lower, upper)``
  (``du`` the input's rate limit, or its range);
* reward: the model's economic reward of the step minus its soft-band penalties.

The season ends after ``days`` days; the step index is part of the observation, so the
end is part of the problem and is reported as ``terminated``. A step whose state is no
longer a finite number (an action that drove the plant outside what its model can
integrate) ends the episode too: ``terminated``, reward 0, the last finite observation,
and ``info["diverged"]`` with ghm's message, as ghm's own trainer ends such an episode.

``ghm.VecEnv`` steps many environments of one model inside Rust with one call per batch;
``ghm.load`` returns a model's declarations (names, units, bounds). ``ghm.Mpc``,
``ghm.RlMpc``, ``ghm.Policy``, ``ghm.Expert``, ``ghm.simulate`` and ``ghm.optimum`` run
ghm's seasons and controllers (:mod:`ghm.control`); ``ghm.read_policy``,
``ghm.write_policy`` and ``ghm.from_sb3`` carry agents between Python and ghm
(:mod:`ghm.policy`). A model that does not
check raises :class:`ghm.ModelError` with ghm's diagnostics (file, line and column).
"""

from __future__ import annotations

import os
from typing import Any, Optional

import gymnasium
import numpy as np
from gymnasium import spaces

from . import _ghm
from ._ghm import DivergedError, ModelError, load
from .control import Controller, Expert, Mpc, Policy, RlMpc, Rules, Season, defaults, optimum, simulate
from .policy import from_sb3, policy_action, read_policy, write_policy

__all__ = [
    "Env",
    "VecEnv",
    "ModelError",
    "DivergedError",
    "load",
    "Season",
    "Controller",
    "Mpc",
    "RlMpc",
    "Policy",
    "Expert",
    "Rules",
    "simulate",
    "optimum",
    "defaults",
    "read_policy",
    "write_policy",
    "policy_action",
    "from_sb3",
]


def _path(value: Optional[os.PathLike | str]) -> Optional[str]:
    return None if value is None else os.fspath(value)


class Env(gymnasium.Env):
    """A season of a ``.ghm`` model as a Gymnasium environment.

    Parameters
    ----------
    model: path of the ``.ghm`` file.
    weather: a weather CSV in the model's units (columns named as the model's
        disturbances), or ``None`` for ghm's built-in Dutch late-winter season.
    start_row: the weather row of step 0.
    days: the season length (at the model's sample period).
    uncertainty: relative spread of the model's uncertain parameters, drawn afresh each
        episode (0: the nominal plant).
    seed: seed of the parameter draws (``reset(seed=...)`` restarts them).
    forecast_rows: rows of the weather forecast observed after the current weather
        (observation version 2, as a guide of ``ghm distill --forecast-rows`` observes;
        0: the current weather only, version 1). A row past the weather's end repeats
        the last.
    """

    metadata = {"render_modes": []}

    def __init__(
        self,
        model: os.PathLike | str,
        weather: Optional[os.PathLike | str] = None,
        start_row: int = 0,
        days: float = 40.0,
        uncertainty: float = 0.0,
        seed: Optional[int] = None,
        forecast_rows: int = 0,
    ):
        self._raw = _ghm.RawEnv(
            os.fspath(model),
            weather=_path(weather),
            start_row=start_row,
            days=float(days),
            uncertainty=float(uncertainty),
            seed=0 if seed is None else int(seed),
            forecast_rows=int(forecast_rows),
        )
        self.observation_names = list(self._raw.observation_names)
        self.action_names = list(self._raw.action_names)
        self.observation_space = spaces.Box(
            -np.inf, np.inf, shape=(len(self.observation_names),), dtype=np.float64
        )
        self.action_space = spaces.Box(
            -1.0, 1.0, shape=(len(self.action_names),), dtype=np.float64
        )
        self.episode_len = self._raw.episode_len

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        super().reset(seed=seed)
        if seed is not None:
            self._raw.reseed(int(seed))
        observation = self._raw.reset()
        self._last_observation = observation
        return observation, {"step": 0}

    def step(self, action):
        action = np.asarray(action, dtype=np.float64).reshape(-1)
        try:
            observation, reward, economic, done, applied = self._raw.step(action)
        except DivergedError as diverged:
            info = {"diverged": str(diverged), "step": self._raw.step_index}
            return self._last_observation, 0.0, True, False, info
        self._last_observation = observation
        info: dict[str, Any] = {
            "economic": economic,
            "input": applied,
            "step": self._raw.step_index,
        }
        return observation, reward, done, False, info

    @property
    def state(self) -> np.ndarray:
        """The plant's state ``x(k)`` (model units)."""
        return self._raw.state


class VecEnv:
    """``count`` environments of one model stepped together inside Rust.

    ``step(actions)`` takes an array of shape ``(count, inputs)`` and returns
    ``(observations, rewards, dones)``; an environment whose season ended, or whose state
    diverged (reward 0 for that step), is reset in the same call (its row of
    ``observations`` is the new season's first). Environment ``i``
    draws its parameters from ``seed + i``. ``forecast_rows`` as for ``Env``.
    """

    def __init__(
        self,
        model: os.PathLike | str,
        count: int,
        weather: Optional[os.PathLike | str] = None,
        start_row: int = 0,
        days: float = 40.0,
        uncertainty: float = 0.0,
        seed: int = 0,
        forecast_rows: int = 0,
    ):
        self._raw = _ghm.RawVecEnv(
            os.fspath(model),
            int(count),
            weather=_path(weather),
            start_row=start_row,
            days=float(days),
            uncertainty=float(uncertainty),
            seed=int(seed),
            forecast_rows=int(forecast_rows),
        )
        self.count = self._raw.count

    def reset(self, seed: Optional[int] = None) -> np.ndarray:
        if seed is not None:
            self._raw.reseed(int(seed))
        return self._raw.reset()

    def step(self, actions):
        actions = np.ascontiguousarray(actions, dtype=np.float64)
        return self._raw.step(actions)


gymnasium.register(id="ghm/Model-v0", entry_point="ghm:Env")


def __dir__() -> list[str]:
    """The package's API only (PEP 562), not the modules it imports (``np``, ``os``, ...)."""
    return sorted(__all__)
