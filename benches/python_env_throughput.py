#!/usr/bin/env python3
"""Environment steps per second from Python: ghm.Env (one step per call), ghm.VecEnv (a
batch per call) and, as the paper's kind of Python environment, a step loop over the peers'
CasADi model (../shared/peers/greenhouse.py: RK4 step, outputs, reward and penalties).

    python3 benches/python_env_throughput.py      # needs the ghm wheel (release) and casadi
"""
import sys
import time
from pathlib import Path

import numpy as np

import ghm

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "lettuce.ghm"


def best_of(runs, work):
    """The fastest of `runs` timings of `work()` (seconds)."""
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        work()
        times.append(time.perf_counter() - start)
    return min(times), sorted(times)[len(times) // 2]


def single():
    env = ghm.Env(MODEL, days=40)
    actions = np.random.default_rng(0).uniform(-1, 1, size=(env.episode_len, 3))

    def episode():
        env.reset(seed=0)
        for a in actions:
            env.step(a)

    best, median = best_of(5, episode)
    return env.episode_len / median, env.episode_len / best


def vectorised(count):
    vec = ghm.VecEnv(MODEL, count, days=40)
    steps = 1920
    actions = np.random.default_rng(0).uniform(-1, 1, size=(steps, count, 3))

    def episode():
        vec.reset()
        for a in actions:
            vec.step(a)

    best, median = best_of(3, episode)
    return steps * count / median, steps * count / best


def casadi_peer():
    sys.path.insert(0, str(ROOT.parent / "shared" / "peers"))
    import greenhouse as gh  # noqa: E402

    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, size=(1920, 3))
    d = np.array([50.0, 7e-4, 5.0, 5e-3])

    def episode():
        x = np.array([0.0035, 0.001, 15.0, 0.008])
        u = np.zeros(3)
        for a in actions:
            u = np.clip(u + a * gh.DU_MAX, gh.U_MIN, gh.U_MAX)
            xn = gh.step(x, u, d)
            _ = gh.economic_reward(x, u, xn) - gh.penalty(gh.y_of(xn))
            x = xn

    best, median = best_of(3, episode)
    return 1920 / median, 1920 / best


if __name__ == "__main__":
    print(f"ghm.Env (one step per call):      median {single()[0]:>12,.0f} steps/s")
    for count in (1, 64):
        print(f"ghm.VecEnv, {count:>3} environments:     median {vectorised(count)[0]:>12,.0f} steps/s")
    try:
        print(f"CasADi peer step loop (Python):   median {casadi_peer()[0]:>12,.0f} steps/s")
    except ImportError as error:
        print(f"CasADi peer skipped: {error}")
