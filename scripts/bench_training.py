"""Training throughput: the learning loop against the env's own steps per second.

    python scripts/bench_training.py [--learner imitation|backends] [--timesteps N]
        [--n-envs K] [--rollout-steps N] [--scenario NAME] [--perception stereo|surrogate]
        [--json FILE] [--out DIR]

``--learner imitation`` (the default) measures the imitation recipe of ``train.py --teacher
planner`` (:mod:`agents.learning.imitation`), surrogate perception by default, ``--n-envs`` env
processes (2): first the recipe's own vector env alone, stepped with the teacher's actions for
``--timesteps`` steps (``raw_env_steps_per_s``: the envs, the teacher's labels and the
observation, no learner), then the recipe itself scaled to the same number of steps (the
demonstrations' and rounds' shares of :class:`~agents.learning.imitation.ImitationConfig`'s
defaults, 40 % and four rounds of 15 %, with the same epochs and betas; set-up, every fit and the
saving included: ``loop_steps_per_s``); ``loop_over_raw_env`` is their ratio. Then one epoch of
the recipe's fit on 4,096 random observations in channels-last layout (as the recipe fits) and in
NCHW, alternately, twice (``fit_channels_last_over_nchw``: the better of each, their ratio).
Then the recipe's second stage, PPO fine-tuning of the policy just trained
(:mod:`agents.learning.finetune`), the same way: its vector env alone (no teacher), stepped with
uniformly drawn action bins for ``--timesteps`` steps (``finetune_raw_env_steps_per_s``), then
``finetune_policy`` for the same number of steps, set-up and saving included
(``finetune_loop_steps_per_s``; ``finetune_loop_over_raw_env``), and over PPO's rollouts and
updates alone, as the env alone is timed without starting its processes
(``finetune_learn_steps_per_s``; ``finetune_learn_over_raw_env``). The difference,
``finetune_setup_s`` (loading the policy, starting the env processes, building PPO, saving), is
paid once per run: a share of a 10,000-step run that the recipe's 240,000 steps make small.
Last, the rollouts' policy forward alone on one batch of the envs' observations, the
fine-tuning's against stable-baselines3's, alternately (``forward_per_s_lean``,
``forward_per_s_sb3``, ``forward_lean_over_sb3``:
:func:`~agents.learning.finetune.rollout_forward_speed`).

``--learner backends`` compares RLlib PPO on 1 and 2 env runners against stable-baselines3 on 1 and
2 envs (docs/rllib.md). All four runs happen in this one process, one after the other, on the env
kwargs that ``scripts/train.py`` builds (``scenario``, ``perception``, ``diagnostics=False``,
``memory=False``) and with :class:`~agents.learning.training.TrainConfig`'s PPO settings (the
rollout of ``rollout_steps`` over all envs or runners, minibatch, epochs, ``net_arch``) but
``eval_freq=0`` and ``checkpoint_freq=0``: ``train_ppo`` (sb3; 2 envs in ``SubprocVecEnv``
processes) and ``train_rllib`` (RLlib's new API stack, an MLP of ``net_arch`` on the flattened
observation; each runner a Ray worker process). Figures per run: ``<run>_steps_per_s`` (env steps
over the wall time of the whole training call, set-up included: Ray start, worker and env creation,
saving), and for RLlib also ``<run>_loop_steps_per_s`` (over the ``algo.train()`` iterations only);
``<run>_over_sb3_1env`` is the first over the sb3 one-env run's. It prints a Markdown table and the
load average before and after (the machine is shared: other processes' load shows in the figures).
"""

from __future__ import annotations

import argparse
import os
import pathlib
import tempfile
import time
from collections.abc import Callable
from typing import Any

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from _figures import print_figures, write_figures

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents.learning.finetune import (
    FinetuneConfig,
    finetune_policy,
    finetune_vector_env,
    rollout_forward_speed,
)
from agents.learning.imitation import (
    ImitationConfig,
    fit_speed,
    train_imitation,
    training_vector_env,
)
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


def _steps_per_s(step: Callable[[], Any], steps: int, n_envs: int) -> tuple[int, float]:
    """Call ``step`` (one step of ``n_envs`` envs) until ``steps`` env steps are taken; the
    steps taken and their rate."""
    t0 = time.perf_counter()
    taken = 0
    while taken < steps:
        step()
        taken += n_envs
    return taken, taken / (time.perf_counter() - t0)


def measure_imitation(args: argparse.Namespace, work: pathlib.Path) -> dict[str, float]:
    """The raw env and the imitation loop on ``args.timesteps`` steps each (module docstring)."""
    import numpy as np

    steps = int(args.timesteps)
    recipe = ImitationConfig(out_dir=work / "imitation")
    share = steps / (recipe.demo_steps + recipe.rounds * recipe.round_steps)
    cfg = ImitationConfig(
        out_dir=work / "imitation",
        n_envs=args.n_envs,
        demo_steps=max(1, round(share * recipe.demo_steps)),
        rounds=recipe.rounds,
        round_steps=max(1, round(share * recipe.round_steps)),
        env_kwargs={"perception": args.perception, "diagnostics": False},
        progress=False,
    )
    venv = training_vector_env(cfg)
    state: dict[str, Any] = {}
    try:
        _, state["info"] = venv.reset(seed=list(range(cfg.n_envs)))

        def teacher_step() -> None:  # the vector env of gymnasium: its info carries the labels
            action = np.asarray(state["info"]["teacher_action"], dtype=np.float32)
            state["info"] = venv.step(action)[-1]

        taken, raw = _steps_per_s(teacher_step, steps, cfg.n_envs)
    finally:
        venv.close()
    result = train_imitation(cfg)
    return {
        **_stage_figures("imitation", "", taken, raw, result),
        **measure_finetune(args, work, result.policy_path),
        **fit_speed(cfg),
        "n_envs": float(cfg.n_envs),
        "loop_wall_s": result.minutes * 60.0,
    }


def _stage_figures(
    stage: str, prefix: str, taken: int, raw: float, result: Any
) -> dict[str, float]:
    """A stage's figures (its env alone: ``taken`` steps at ``raw`` steps/s; its loop:
    ``result``, an imitation or fine-tuning result with ``steps`` and ``minutes``), their keys
    starting with ``prefix``; prints the two speeds."""
    loop = result.steps / (result.minutes * 60.0)
    print(f"{stage}: raw env {raw:.1f} steps/s; loop {loop:.1f} steps/s", flush=True)
    return {
        f"{prefix}raw_env_steps": float(taken),
        f"{prefix}raw_env_steps_per_s": raw,
        f"{prefix}loop_steps": float(result.steps),
        f"{prefix}loop_steps_per_s": loop,
        f"{prefix}loop_over_raw_env": loop / raw,
    }


def measure_finetune(
    args: argparse.Namespace, work: pathlib.Path, policy: pathlib.Path
) -> dict[str, float]:
    """The fine-tuning's env alone and the fine-tuning of ``policy``, ``args.timesteps`` steps
    each (module docstring)."""
    import numpy as np

    from agents.learning.imitation import load_policy

    steps = int(args.timesteps)
    cfg = FinetuneConfig(
        out_dir=work / "finetune",
        policy=policy,
        timesteps=steps,
        n_envs=args.n_envs,
        progress=False,
    )
    bundle = load_policy(policy)
    venv = finetune_vector_env(cfg, bundle)
    rng = np.random.default_rng(0)
    try:
        venv.reset()
        taken, raw = _steps_per_s(
            lambda: venv.step(rng.integers(0, venv.action_space.nvec, size=(cfg.n_envs, 3))),
            steps,
            cfg.n_envs,
        )
        forward = rollout_forward_speed(bundle, venv, cfg)
    finally:
        venv.close()
    result = finetune_policy(cfg)
    learn = result.steps / (result.learn_minutes * 60.0)
    print(f"fine-tuning: loop without set-up and saving {learn:.1f} steps/s", flush=True)
    return {
        **_stage_figures("fine-tuning", "finetune_", taken, raw, result),
        "finetune_learn_steps_per_s": learn,
        "finetune_learn_over_raw_env": learn / raw,
        "finetune_setup_s": (result.minutes - result.learn_minutes) * 60.0,
        **forward,
    }


def markdown_imitation(figures: dict[str, float]) -> str:
    """The table of docs/training.md."""
    return "\n".join(
        [
            "| what | env processes | env steps | steps/s |",
            "| --- | ---: | ---: | ---: |",
            f"| the env alone (teacher's actions) | {figures['n_envs']:.0f} "
            f"| {figures['raw_env_steps']:.0f} | {figures['raw_env_steps_per_s']:.1f} |",
            f"| the imitation loop (collect + fit) | {figures['n_envs']:.0f} "
            f"| {figures['loop_steps']:.0f} | {figures['loop_steps_per_s']:.1f} |",
            f"| ratio | | | {figures['loop_over_raw_env']:.2f} |",
            f"| the fine-tuning's env alone (random bins) | {figures['n_envs']:.0f} "
            f"| {figures['finetune_raw_env_steps']:.0f} "
            f"| {figures['finetune_raw_env_steps_per_s']:.1f} |",
            f"| the PPO fine-tuning loop | {figures['n_envs']:.0f} "
            f"| {figures['finetune_loop_steps']:.0f} "
            f"| {figures['finetune_loop_steps_per_s']:.1f} |",
            f"| ratio | | | {figures['finetune_loop_over_raw_env']:.2f} |",
            f"| the same loop without its set-up and saving | {figures['n_envs']:.0f} "
            f"| {figures['finetune_loop_steps']:.0f} "
            f"| {figures['finetune_learn_steps_per_s']:.1f} |",
            f"| ratio | | | {figures['finetune_learn_over_raw_env']:.2f} |",
            "",
            "| the recipe's fit, one epoch of 4,096 samples | samples/s |",
            "| --- | ---: |",
            f"| channels-last (the recipe's) | {figures['fit_samples_per_s_channels_last']:.0f} |",
            f"| NCHW | {figures['fit_samples_per_s_nchw']:.0f} |",
            f"| ratio | {figures['fit_channels_last_over_nchw']:.2f} |",
            "",
            "| the fine-tuning's policy forward, one batch of the envs' observations | calls/s |",
            "| --- | ---: |",
            f"| bins drawn directly (the fine-tuning's) | {figures['forward_per_s_lean']:.0f} |",
            f"| stable-baselines3's forward | {figures['forward_per_s_sb3']:.0f} |",
            f"| ratio | {figures['forward_lean_over_sb3']:.2f} |",
        ]
    )


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
    parser.add_argument(
        "--learner",
        choices=("imitation", "backends"),
        default="imitation",
        help="the imitation loop against its env, or the PPO backends",
    )
    parser.add_argument("--timesteps", type=int, default=None, help="env steps per run")
    parser.add_argument("--n-envs", type=int, default=2, help="imitation: env processes")
    parser.add_argument(
        "--rollout-steps", type=int, default=512, help="PPO rollout steps over all envs"
    )
    parser.add_argument("--scenario", default="open", help="backends: map or scene family")
    parser.add_argument(
        "--perception",
        choices=("stereo", "surrogate"),
        default=None,
        help="env perception (imitation: surrogate, backends: stereo by default)",
    )
    parser.add_argument("--json", type=pathlib.Path, help="write the figures here")
    parser.add_argument("--out", type=pathlib.Path, help="training outputs (default: a temp dir)")
    args = parser.parse_args(argv)
    imitation = args.learner == "imitation"
    if args.timesteps is None:
        args.timesteps = 10_000 if imitation else 1024
    if args.perception is None:
        args.perception = "surrogate" if imitation else "stereo"
    run = measure_imitation if imitation else measure
    load_before = os.getloadavg()
    if args.out is not None:
        figures = run(args, args.out)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            figures = run(args, pathlib.Path(tmp))
    load_after = os.getloadavg()
    figures["cpu_count"] = float(os.cpu_count() or 0)
    figures["load_1min_before"], figures["load_1min_after"] = load_before[0], load_after[0]
    print_figures(figures)
    print()
    print(markdown_imitation(figures) if imitation else markdown(figures))
    print(
        f"\nload average (1, 5, 15 min) before: {load_before[0]:.2f} {load_before[1]:.2f} "
        f"{load_before[2]:.2f}; after: {load_after[0]:.2f} {load_after[1]:.2f} {load_after[2]:.2f}"
    )
    write_figures(figures, args.json)
    return figures


if __name__ == "__main__":
    main()
