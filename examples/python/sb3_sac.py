"""SAC from Stable-Baselines3 on a ghm model, its agent brought back to ghm.

Trains SAC on ``ghm.Env`` (the lettuce season by default), writes the actor and its
observation statistics as a ghm policy file (``ghm.from_sb3`` and ``ghm.write_policy``),
and prints the commands that run it in ghm: the agent alone, a value network fitted to
its roll-outs, and RL-guided MPC with it.

    pip install stable-baselines3 torch       # not needed by ghm itself, nor by its tests
    python3 examples/python/sb3_sac.py models/lettuce.ghm --timesteps 200000 --out runs/sb3

Not run by CI (torch is large); docs/results.md, "An agent trained in Python", has the
figures of a 192 000-step run.
"""

import argparse
import os

import ghm


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", help="the .ghm model file")
    parser.add_argument("--weather", help="weather CSV in the model's units")
    parser.add_argument("--start-row", type=int, default=0)
    parser.add_argument("--days", type=float, default=40.0)
    parser.add_argument("--timesteps", type=int, default=200_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="runs/sb3", help="folder of the policy file")
    args = parser.parse_args()

    from stable_baselines3 import SAC
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    def make():
        return ghm.Env(
            args.model,
            weather=args.weather,
            start_row=args.start_row,
            days=args.days,
            seed=args.seed,
        )

    env = VecNormalize(DummyVecEnv([make]), norm_obs=True, norm_reward=False)
    model = SAC("MlpPolicy", env, seed=args.seed, verbose=1)
    model.learn(total_timesteps=args.timesteps)

    os.makedirs(args.out, exist_ok=True)
    policy = os.path.join(args.out, "policy.json")
    ghm.write_policy(policy, args.model, **ghm.from_sb3(model, env))
    print(f"wrote {policy}")
    weather = f" --weather {args.weather} --start-row {args.start_row}" if args.weather else ""
    print("In ghm:")
    print(f"  ghm policy {args.model} --agent {args.out}{weather}")
    print(f"  ghm value {args.model} --agent {args.out}{weather} --out {args.out}/value")
    print(
        f"  ghm rlmpc {args.model} --agent {args.out} --value {args.out}/value"
        f" --horizon 1h{weather}"
    )


if __name__ == "__main__":
    main()
