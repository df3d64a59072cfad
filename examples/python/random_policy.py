"""A Gymnasium loop on a ghm model: random actions for a season, then the season's return.

Any ``.ghm`` file is an environment (``gymnasium.make("ghm/Model-v0", model=...)``): the
observation and action spaces come from the model, the reward is the one it declares.

    python3 examples/python/random_policy.py models/lettuce.ghm --days 40 --episodes 3

Runs without ``../shared`` (ghm's built-in weather) unless ``--weather`` names a CSV.
"""

import argparse
import time

import gymnasium
import numpy as np

import ghm  # noqa: F401  (registers "ghm/Model-v0")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", help="the .ghm model file")
    parser.add_argument("--weather", help="weather CSV in the model's units")
    parser.add_argument("--start-row", type=int, default=0)
    parser.add_argument("--days", type=float, default=40.0)
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    env = gymnasium.make(
        "ghm/Model-v0",
        model=args.model,
        weather=args.weather,
        start_row=args.start_row,
        days=args.days,
    )
    env.action_space.seed(args.seed)
    returns = []
    clock = time.perf_counter()
    steps = 0
    for episode in range(args.episodes):
        observation, info = env.reset(seed=args.seed + episode)
        total, done = 0.0, False
        while not done:
            action = env.action_space.sample()
            observation, reward, terminated, truncated, info = env.step(action)
            total += reward
            steps += 1
            done = terminated or truncated
        if "diverged" in info:
            # A plant driven out of its range by random inputs (a runaway CSTR, say): ghm
            # ends the episode at the first number that is not finite, and says where.
            print(f"episode {episode}: stopped: {info['diverged']}")
            continue
        returns.append(total)
        print(f"episode {episode}: return {total:+.4f} over {info['step']} steps")
    seconds = time.perf_counter() - clock
    mean = f"{np.mean(returns):+.4f}" if returns else "none (every episode stopped)"
    print(
        f"mean return {mean}; "
        f"{steps} steps in {seconds:.2f} s ({steps / seconds:,.0f} steps per second)"
    )


if __name__ == "__main__":
    main()
