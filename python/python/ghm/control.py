"""ghm's seasons and controllers from Python.

A season here is the season the command with the same settings runs (``ghm simulate``,
``ghm policy``, ``ghm mpc``, ``ghm rlmpc``, ``ghm optimum``), to the last bit, returned
in memory as a :class:`Season`: the columns of ``trajectory.csv`` as NumPy arrays and the
metrics of ``summary.json``.

>>> mpc = ghm.Mpc("models/lettuce.ghm", horizon="6h")
>>> season = mpc.season(weather="venlo.csv", start_row=1394, days=40)
>>> season.metrics["cumulative_reward"], season["u_heating"]

A controller also decides one step at a time (keeping its warm start between calls), for
use inside your own loop or against a real plant::

    u, record = mpc.decide(step, state, previous_input, forecast)

Settings are checked by ghm: a misspelt option, a missing agent or a bad model raises
``ValueError`` (:class:`ghm.ModelError` for a model) with ghm's message.
"""

from __future__ import annotations

import json
import os
from typing import Any, Optional

import numpy as np

from . import _ghm

__all__ = ["Season", "Controller", "Mpc", "RlMpc", "Policy", "Expert", "Rules", "simulate", "optimum", "defaults"]


class Season:
    """One season: ``columns`` (name → array, as ``trajectory.csv``; ``status``,
    ``fallback`` and ``terminal_region`` as lists of strings) and ``metrics`` (as
    ``summary.json``'s: ``epi``, ``cumulative_reward``, ``bands``, ``solve``, ...)."""

    def __init__(self, names, data, texts, metrics_json: str):
        self.columns: dict[str, Any] = {name: data[:, i] for i, name in enumerate(names)}
        for name, values in zip(("status", "fallback", "terminal_region"), texts):
            self.columns[name] = values
        self.metrics: dict[str, Any] = json.loads(metrics_json)

    def __getitem__(self, name: str):
        return self.columns[name]

    def __len__(self) -> int:
        return len(self.columns["k"])

    def __repr__(self) -> str:
        return (
            f"Season({len(self)} steps, cumulative reward "
            f"{self.metrics.get('cumulative_reward')}, EPI {self.metrics.get('epi')})"
        )


def defaults(kind: str) -> dict:
    """The settings of a controller of ``kind`` (``"mpc"``, ``"rlmpc"``, ``"optimum"``,
    ``"inputs"``, ``"policy"``, ``"expert"``) at ghm's defaults, those of its command:
    ``ghm.defaults("mpc")["horizon"] == "3h"``. A setting left out (``None``) in the
    classes below takes this default."""
    return json.loads(_ghm.controller_defaults(kind))


def _plain(value):
    """A setting as JSON holds it: paths as strings."""
    return os.fspath(value) if isinstance(value, os.PathLike) else value


def _settings(kind: str, given: dict) -> dict:
    """ghm's defaults for ``kind`` with the settings given (those not ``None``) over them;
    a misspelt one is refused by ghm."""
    settings = defaults(kind)
    settings.update({key: _plain(value) for key, value in given.items() if value is not None})
    return settings


_WEATHER = ("weather", "knmi", "start_row", "weather_seed", "days", "steps", "knmi_co2")
_PLANT = ("uncertainty", "seed")


def _spec(model, controller: dict, **season) -> str:
    """The job spec of a season: ``season`` holds the weather options (``weather``,
    ``knmi``, ``start_row``, ``weather_seed``, ``days`` or ``steps``, ``knmi_co2``) and
    the plant's (``uncertainty``, ``seed``); those left out take ghm's defaults (40 days of
    the built-in weather, the nominal plant)."""
    unknown = sorted(set(season) - set(_WEATHER) - set(_PLANT))
    if unknown:
        raise ValueError(f"unknown season option(s) {unknown}; expected some of {sorted(_WEATHER + _PLANT)}")
    pick = lambda names: {k: _plain(season[k]) for k in names if season.get(k) is not None}
    return json.dumps({"model": os.fspath(model), "weather": pick(_WEATHER), "plant": pick(_PLANT), "controller": controller})


def _season(model, controller: dict, **season) -> Season:
    return Season(*_ghm.season(_spec(model, controller, **season)))


def simulate(model, inputs: Optional[str] = None, *, enforce_limits: Optional[bool] = None, **season) -> Season:
    """A season with fixed inputs (``ghm simulate``): ``inputs`` is ``"const:u1,u2,..."``,
    a CSV file, or ``None`` for the model's start input. ``season``: ``weather``,
    ``start_row``, ``days`` or ``steps``, ``uncertainty``, ``seed``, ``weather_seed``."""
    return _season(model, _settings("inputs", {"inputs": inputs, "enforce_limits": enforce_limits}), **season)


def optimum(
    model,
    *,
    init_horizon: Optional[str] = None,
    solver: Optional[str] = None,
    max_iterations: Optional[int] = None,
    **season,
) -> Season:
    """The season as one NLP with perfect foresight (``ghm optimum``), on the nominal plant.
    Settings left out take ghm's defaults (``ghm.defaults("optimum")``)."""
    given = {"init_horizon": init_horizon, "solver": solver, "max_iterations": max_iterations}
    return _season(model, _settings("optimum", given), **season)


class Controller:
    """A controller of ghm: a season of it, or its decisions one step at a time."""

    def __init__(self, model, controller: dict):
        self.model = os.fspath(model)
        self.settings = dict(controller)
        self._raw: Optional[Any] = None
        # Checked now, so that a bad setting fails where it is written.
        self._stepper()

    def season(self, **season) -> Season:
        """The season the command with these settings runs: ``weather``, ``start_row``,
        ``days`` or ``steps``, ``uncertainty``, ``seed``, ``weather_seed``."""
        return _season(self.model, self.settings, **season)

    def _stepper(self, uncertainty: float = 0.0):
        if self._raw is None:
            self._raw = _ghm.RawController(_spec(self.model, self.settings, uncertainty=uncertainty))
        return self._raw

    @property
    def forecast_rows(self) -> int:
        """Rows of weather forecast a decision reads (the horizon; 0 for a policy)."""
        return self._stepper().forecast_rows()

    def decide(self, step: int, state, previous_input, forecast):
        """The input for step ``step`` at ``state`` after ``previous_input``, with the
        weather ``forecast`` (rows × disturbances, row 0 = now; MPC reads
        ``forecast_rows`` rows and repeats the last where fewer are given), and a record
        of how it was found (``solve_ms``, ``iterations``, ``status``, ``fallback``, ...).
        The input is clipped to its bounds and rate limits as a season clips it (every door
        of ghm decides through the same stepper)."""
        as_array = lambda v: np.ascontiguousarray(v, dtype=np.float64)
        forecast = np.atleast_2d(as_array(forecast))
        return self._stepper().decide(int(step), as_array(state), as_array(previous_input), forecast)

    def reset(self) -> None:
        """Forget the past (warm starts, plans)."""
        self._stepper().reset()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.model!r}, {self.settings!r})"


class Mpc(Controller):
    """Economic MPC (``ghm mpc``). ``settings``: ``solver``, ``warm_start``, ``bands``;
    each left out takes ghm's default (``ghm.defaults("mpc")``: a 3 h horizon, ``ipm``)."""

    def __init__(self, model, horizon: Optional[str] = None, **settings):
        super().__init__(model, _settings("mpc", {"horizon": horizon, **settings}))


class RlMpc(Controller):
    """RL-guided MPC (``ghm rlmpc``): the guide's terminal cost, region and warm start.
    ``settings``: ``guide``, ``agent``, ``value``, ``variant``, ``epsilon``,
    ``terminal_cost`` and MPC's ``solver``, ``warm_start``, ``bands``; each left out takes
    ghm's default (``ghm.defaults("rlmpc")``: a 1 h horizon, the shipped SAC guide)."""

    def __init__(self, model, horizon: Optional[str] = None, **settings):
        super().__init__(model, _settings("rlmpc", {"horizon": horizon, **settings}))


class Policy(Controller):
    """A trained policy (``ghm policy``): a ``ghm train`` folder or policy file, or the
    agent shipped for the model."""

    def __init__(self, model, agent=None):
        super().__init__(model, _settings("policy", {"agent": agent}))


class Rules(Controller):
    """The model's own rules (``ghm simulate --rules``): each input set by its ``rule``
    at the step's state and weather, as a model imported from GreenLight carries
    GreenLight's climate control."""

    def __init__(self, model):
        super().__init__(model, _settings("rules", {}))


class Expert(Controller):
    """The rule-based expert (``ghm policy --expert``)."""

    def __init__(self, model):
        super().__init__(model, _settings("expert", {}))
