"""Types of ghm's compiled module (`python/src`, PyO3). The Gymnasium classes, controllers
and seasons of `ghm` are built on it; use those (`ghm.Env`, `ghm.Mpc`, `ghm.simulate`)."""

from os import PathLike
from typing import Any, Optional, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike[str]]
_Floats = npt.NDArray[np.float64]

class ModelError(ValueError):
    """A .ghm model that does not check; the message holds ghm's diagnostics."""

class DivergedError(RuntimeError):
    """A step whose state is no longer a finite number: the episode is over."""

def load(path: _Path) -> dict[str, Any]:
    """A model's declarations: `name`, `sample_period_s`, and `states`, `inputs`,
    `disturbances`, `outputs`, `params` (lists of dictionaries)."""

class RawEnv:
    def __init__(
        self,
        model: _Path,
        weather: Optional[_Path] = None,
        start_row: int = 0,
        days: float = 40.0,
        uncertainty: float = 0.0,
        seed: int = 0,
        weather_seed: int = 2014,
        forecast_rows: int = 0,
    ) -> None: ...
    def reseed(self, seed: int) -> None: ...
    def reset(self) -> _Floats: ...
    def step(self, action: _Floats) -> tuple[_Floats, float, float, bool, _Floats]:
        """`(observation, reward, economic, done, input)`."""
    @property
    def observation_names(self) -> list[str]: ...
    @property
    def action_names(self) -> list[str]: ...
    @property
    def episode_len(self) -> int: ...
    @property
    def state(self) -> _Floats: ...
    @property
    def step_index(self) -> int: ...

class RawVecEnv:
    def __init__(
        self,
        model: _Path,
        count: int,
        weather: Optional[_Path] = None,
        start_row: int = 0,
        days: float = 40.0,
        uncertainty: float = 0.0,
        seed: int = 0,
        weather_seed: int = 2014,
        forecast_rows: int = 0,
    ) -> None: ...
    def reseed(self, seed: int) -> None: ...
    def reset(self) -> _Floats: ...
    def step(self, actions: _Floats) -> tuple[_Floats, _Floats, npt.NDArray[np.bool_]]:
        """`(observations, rewards, dones)`, one row per environment."""
    @property
    def count(self) -> int: ...

class RawController:
    def __init__(self, spec: str) -> None: ...
    def reset(self) -> None: ...
    def forecast_rows(self) -> int: ...
    def name(self) -> str: ...
    def decide(
        self, step: int, state: _Floats, previous_input: _Floats, forecast: _Floats
    ) -> tuple[_Floats, dict[str, Any]]: ...

def season(spec: str) -> tuple[list[str], _Floats, list[list[str]], str]:
    """`(columns, values, text columns, metrics JSON)` of one season."""

def controller_defaults(kind: str) -> str:
    """A controller kind's defaults, as the spec's JSON."""
