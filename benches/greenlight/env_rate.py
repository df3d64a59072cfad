#!/usr/bin/env python3
"""Steps per second of a GreenLight tomato environment at a 900 s step, for issue 34's
comparison of `ghm.Env` with gl-gym, each run by the Python that has it installed (gl-gym
is AGPL: installed in a venv of its own and called only through its registered Gymnasium
id, never copied). Three rounds of STEPS steps after a reset; random actions in [-1, 1]
(each a move of up to the input's whole range per step, as an untrained agent's), or,
with `--smooth`, actions that move each input by at most a tenth of its range a step.

Usage:
  python env_rate.py ghm MODEL.ghm WEATHER.csv [--steps N] [--smooth]
  python env_rate.py gl_gym [--steps N] [--smooth]

The ghm model at 900 s comes from `ghm import greenlight … --step 900 --out DIR`
(DIR/katzin_2021.ghm and DIR/weather.csv, one row per 900 s).
"""

import argparse
import time

import numpy as np

# The seeds of the reset and of the actions, and the largest move of a smooth action as a
# fraction of the input's range: `glgym_tolerance.py` steps through the same actions.
RESET_SEED = 1
ACTION_SEED = 0
SMOOTH_SCALE = 0.1


def make_gl_gym():
    """gl-gym's tomato environment, through its registered Gymnasium id."""
    import gymnasium
    import gl_gym  # noqa: F401  (registers its environment)

    return gymnasium.make("gl_gym/GreenLightTomato-v0")


def make(args):
    if args.package == "ghm":
        import ghm

        return ghm.Env(args.model, weather=args.weather, days=60)
    return make_gl_gym()


def main():
    p = argparse.ArgumentParser()
    p.add_argument("package", choices=["ghm", "gl_gym"])
    p.add_argument("model", nargs="?")
    p.add_argument("weather", nargs="?")
    p.add_argument("--steps", type=int, default=2000)
    p.add_argument("--smooth", action="store_true")
    args = p.parse_args()
    env = make(args)
    env.reset(seed=RESET_SEED)
    rng = np.random.default_rng(ACTION_SEED)
    shape = env.action_space.shape
    scale = SMOOTH_SCALE if args.smooth else 1.0
    rates = []
    for _ in range(3):
        start = time.perf_counter()
        for _ in range(args.steps):
            action = scale * rng.uniform(-1.0, 1.0, size=shape)
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        rates.append(args.steps / (time.perf_counter() - start))
    label = f"{args.package}, {'smooth' if args.smooth else 'random'} actions"
    print(f"{label}: {', '.join(f'{r:.0f}' for r in rates)} steps/s (median {np.median(rates):.0f})")


if __name__ == "__main__":
    main()
