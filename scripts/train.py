"""Train PPO (stable-baselines3, MultiInputPolicy) on StereoNav-v1.

    python scripts/train.py --timesteps N [--n-envs K] --out DIR [--resume CHECKPOINT]
        [--eval-freq N] [--checkpoint-freq N] [--seed S] [--scenario NAME] [--n-steps N]
        [--batch-size N] [--max-minutes M]

Writes DIR/ppo_final.zip, DIR/checkpoints/, DIR/best/, DIR/eval/, DIR/tb/ (TensorBoard),
DIR/curve.csv, DIR/learning_curve.png and DIR/rules.json (the episode rules, those of
evaluate.py). The logic is in :mod:`agents.training`.
"""

from __future__ import annotations

import argparse
import os
import pathlib

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from agents.training import TrainConfig, TrainResult, train_ppo


def train_config(argv: list[str] | None = None) -> TrainConfig:
    """The :class:`TrainConfig` of the command line ``argv``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timesteps", type=int, required=True, help="environment steps")
    parser.add_argument("--n-envs", type=int, default=1, help="parallel environments")
    parser.add_argument("--out", type=pathlib.Path, required=True, help="output folder")
    parser.add_argument("--resume", type=pathlib.Path, help="checkpoint .zip to continue from")
    parser.add_argument("--eval-freq", type=int, default=10_000, help="timesteps between evals")
    parser.add_argument("--eval-episodes", type=int, default=5, help="episodes per evaluation")
    parser.add_argument(
        "--checkpoint-freq", type=int, default=20_000, help="timesteps between saves"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed")
    parser.add_argument("--scenario", default="random", help="map name or scene family")
    parser.add_argument("--n-steps", type=int, default=512, help="PPO rollout steps per env")
    parser.add_argument("--batch-size", type=int, default=64, help="PPO minibatch size")
    parser.add_argument(
        "--max-minutes", type=float, default=None, help="wall-clock budget (stops and saves)"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    return TrainConfig(
        timesteps=args.timesteps,
        n_envs=args.n_envs,
        out_dir=args.out,
        resume=args.resume,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        checkpoint_freq=args.checkpoint_freq,
        seed=args.seed,
        n_steps=args.n_steps,
        batch_size=args.batch_size,
        env_kwargs={"scenario": args.scenario, "diagnostics": False},
        max_minutes=args.max_minutes,
        progress=not args.no_progress,
    )


def main(argv: list[str] | None = None) -> TrainResult:
    """Parse the arguments and train; returns what was written."""
    result = train_ppo(train_config(argv))
    print(f"model: {result.model_path} ({result.timesteps} timesteps, {result.episodes} episodes)")
    print(f"learning curve: {result.curve_png}")
    return result


if __name__ == "__main__":
    main()
