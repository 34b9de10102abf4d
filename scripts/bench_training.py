"""Training throughput: RLlib PPO on 1 and 2 env runners against stable-baselines3 on 1 and 2 envs.

    python scripts/bench_training.py [--timesteps N] [--rollout-steps N] [--scenario NAME]
        [--perception stereo|surrogate] [--json FILE] [--out DIR]

All four runs happen in this one process, one after the other, on the env kwargs that
``scripts/train.py`` builds (``scenario``, ``perception``, ``diagnostics=False``,
``memory=False``) and with :class:`~agents.learning.training.TrainConfig`'s PPO settings (the
rollout of ``rollout_steps`` over all envs or runners, minibatch, epochs, ``net_arch``) but
``eval_freq=0`` and ``checkpoint_freq=0``: ``train_ppo`` (sb3; 2 envs in ``SubprocVecEnv``
processes) and ``train_rllib`` (RLlib's new API stack, an MLP of ``net_arch`` on the flattened
observation; each runner a Ray worker process).

Figures per run: ``<run>_steps_per_s`` (env steps over the wall time of the whole training call,
set-up included: Ray start, worker and env creation, saving), and for RLlib also
``<run>_loop_steps_per_s`` (over the ``algo.train()`` iterations only); ``<run>_over_sb3_1env``
is the first over the sb3 one-env run's. It prints a Markdown table and the load average before
and after (the machine is shared: other processes' load shows in the figures).
"""

from __future__ import annotations

import argparse
import os
import pathlib
import tempfile
import time

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from _figures import print_figures, write_figures

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents.learning.rllib.backend import RLlibOptions, train_rllib
from agents.learning.training import TrainConfig, train_ppo

RUNS = (("sb3", 1), ("sb3", 2), ("rllib", 1), ("rllib", 2))
"""(backend, envs or env runners) of each run, in order."""


def _config(args: argparse.Namespace, out: pathlib.Path, n_envs: int) -> TrainConfig:
    env_kwargs = {
        "scenario": args.scenario,
        "diagnostics": False,
        "memory": False,
        "perception": args.perception,
    }
    return TrainConfig(
        timesteps=args.timesteps,
        out_dir=out,
        n_envs=n_envs,
        rollout_steps=args.rollout_steps,
        eval_freq=0,
        checkpoint_freq=0,
        env_kwargs=env_kwargs,
        progress=False,
    )


def measure(args: argparse.Namespace, work: pathlib.Path) -> dict[str, float]:
    """The figures of the four runs (module docstring), trained under ``work``."""
    figures: dict[str, float] = {}
    for backend, n in RUNS:
        name = f"{backend}_{n}{'env' if backend == 'sb3' else 'runner'}"
        out = work / name
        t0 = time.perf_counter()
        if backend == "sb3":
            steps = train_ppo(_config(args, out, n)).timesteps
        else:
            result = train_rllib(
                _config(args, out, 1), RLlibOptions(num_env_runners=n, log_to_driver=False)
            )
            steps = result.timesteps
            figures[f"{name}_loop_steps_per_s"] = result.steps_per_s
        wall = time.perf_counter() - t0
        figures[f"{name}_steps"] = float(steps)
        figures[f"{name}_wall_s"] = wall
        figures[f"{name}_steps_per_s"] = steps / wall
        print(f"{name}: {steps} steps in {wall:.1f} s", flush=True)
    base = figures["sb3_1env_steps_per_s"]
    for backend, n in RUNS:
        name = f"{backend}_{n}{'env' if backend == 'sb3' else 'runner'}"
        figures[f"{name}_over_sb3_1env"] = figures[f"{name}_steps_per_s"] / base
    return figures


def markdown(figures: dict[str, float]) -> str:
    """The table of docs/rllib.md."""
    lines = [
        "| trainer | parallel envs | env steps | wall s | steps/s (all) | steps/s (loop) "
        "| vs sb3 1 env |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for backend, n in RUNS:
        name = f"{backend}_{n}{'env' if backend == 'sb3' else 'runner'}"
        loop = figures.get(f"{name}_loop_steps_per_s")
        lines.append(
            f"| {'stable-baselines3' if backend == 'sb3' else 'RLlib'} | {n} "
            f"| {figures[f'{name}_steps']:.0f} | {figures[f'{name}_wall_s']:.1f} "
            f"| {figures[f'{name}_steps_per_s']:.1f} "
            f"| {'' if loop is None else f'{loop:.1f}'} "
            f"| {figures[f'{name}_over_sb3_1env']:.2f} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict[str, float]:
    """Parse the arguments, measure, print (and write) the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timesteps", type=int, default=1024, help="env steps per run")
    parser.add_argument(
        "--rollout-steps", type=int, default=512, help="PPO rollout steps over all envs"
    )
    parser.add_argument("--scenario", default="open", help="map name or scene family")
    parser.add_argument(
        "--perception", choices=("stereo", "surrogate"), default="stereo", help="env perception"
    )
    parser.add_argument("--json", type=pathlib.Path, help="write the figures here")
    parser.add_argument("--out", type=pathlib.Path, help="training outputs (default: a temp dir)")
    args = parser.parse_args(argv)
    load_before = os.getloadavg()
    if args.out is not None:
        figures = measure(args, args.out)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            figures = measure(args, pathlib.Path(tmp))
    load_after = os.getloadavg()
    figures["cpu_count"] = float(os.cpu_count() or 0)
    figures["load_1min_before"], figures["load_1min_after"] = load_before[0], load_after[0]
    print_figures(figures)
    print()
    print(markdown(figures))
    print(
        f"\nload average (1, 5, 15 min) before: {load_before[0]:.2f} {load_before[1]:.2f} "
        f"{load_before[2]:.2f}; after: {load_after[0]:.2f} {load_after[1]:.2f} {load_after[2]:.2f}"
    )
    write_figures(figures, args.json)
    return figures


if __name__ == "__main__":
    main()
