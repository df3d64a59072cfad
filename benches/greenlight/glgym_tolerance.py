#!/usr/bin/env python3
"""gl-gym's speed and accuracy at other integrator tolerances, for issue 34's comparison of
`ghm.Env` with gl-gym. gl-gym integrates each 900 s step with CasADi's CVODES at abstol =
reltol = 1e-4; this script runs its environment (through its registered Gymnasium id, its
code never copied; gl-gym is AGPL) with `casadi.integrator` wrapped so that CVODES gets
the tolerances asked for, over the same seeded smooth actions as `env_rate.py --smooth`,
and compares the states after every step with a run at 1e-10.

Usage (in gl-gym's own venv):
  python glgym_tolerance.py [--steps N] [--tolerances 1e-4,1e-6,1e-8]

Prints, per tolerance, steps per second and the largest difference from the 1e-10 run over
the steps: air temperature, any temperature, air vapour pressure, air CO2 and fruit
carbohydrates (relative), the quantities of issue 34's open-loop criterion.
"""

import argparse
import time

import numpy as np

from env_rate import ACTION_SEED, RESET_SEED, SMOOTH_SCALE, make_gl_gym

# gl-gym's state order (its `init_state`): the rows compared.
CO2_AIR, T_AIR, VP_AIR, C_FRUIT = 0, 2, 15, 25
TEMPERATURES = [2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 17, 18, 19, 20]


def run(tolerance, steps):
    """States after each of `steps` smooth steps with CVODES at `tolerance`, and the rate."""
    import casadi

    plain = casadi.integrator

    def with_tolerance(name, plugin, dae, t0, tf, opts):
        return plain(name, plugin, dae, t0, tf, {**opts, "abstol": tolerance, "reltol": tolerance})

    casadi.integrator = with_tolerance
    try:
        env = make_gl_gym()
    finally:
        casadi.integrator = plain
    env.reset(seed=RESET_SEED)
    rng = np.random.default_rng(ACTION_SEED)
    states = []
    start = time.perf_counter()
    for _ in range(steps):
        action = SMOOTH_SCALE * rng.uniform(-1.0, 1.0, size=env.action_space.shape)
        _, _, terminated, truncated, _ = env.step(action)
        states.append(np.array(env.unwrapped.x))
        if terminated or truncated:
            break
    rate = len(states) / (time.perf_counter() - start)
    return np.array(states), rate


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--steps", type=int, default=960)
    p.add_argument("--tolerances", default="1e-4,1e-6,1e-8")
    args = p.parse_args()
    reference, _ = run(1e-10, args.steps)
    for tolerance in [float(t) for t in args.tolerances.split(",")]:
        states, rate = run(tolerance, args.steps)
        n = min(len(states), len(reference))
        d = np.abs(states[:n] - reference[:n])
        fruit = d[:, C_FRUIT] / np.abs(reference[:n, C_FRUIT])
        print(
            f"tolerance {tolerance:g}: {rate:.0f} steps/s; largest difference from 1e-10 over "
            f"{n} steps: tAir {d[:, T_AIR].max():.4f} °C, any temperature "
            f"{d[:, TEMPERATURES].max():.4f} °C, vpAir {d[:, VP_AIR].max():.3f} Pa, "
            f"co2Air {d[:, CO2_AIR].max():.3f} mg m-3, cFruit {fruit.max():.2e} relative"
        )


if __name__ == "__main__":
    main()
