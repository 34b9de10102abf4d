"""Train a policy on StereoNav-v1: by imitation of the planner, or with PPO.

    python scripts/train.py --teacher planner --out DIR [--seed S] [--n-envs K]
        [--perception surrogate|stereo] [--demo-steps N] [--rounds R] [--round-steps N]
        [--epochs E] [--mirror-share S] [--teacher-setting NAME=VALUE ...]
        [--finetune-steps N]

    python scripts/train.py --finetune POLICY --out DIR [--seed S] [--n-envs K]
        [--finetune-steps N] [--torch-threads T] [--contact-anchor W]

    python scripts/train.py --timesteps N --out DIR [--algo ppo|recurrent-ppo] [--n-envs K]
        [--perception stereo|surrogate] [--scenario NAME] [--curriculum [FAMILY ...]]
        [--curriculum-threshold P] [--resume CHECKPOINT] [--eval-freq N] [--checkpoint-freq N]
        [--seed S] [--rollout-steps N] [--batch-size N] [--n-epochs N] [--ent-coef C]
        [--max-minutes M] [--backend sb3|rllib] [--num-env-runners N] [--address RAY]

--teacher planner (or greedy, cautious) runs the imitation recipe of docs/training.md
(:mod:`agents.learning.imitation`): teacher demonstrations on every family of the curriculum,
behaviour cloning, then DAgger rounds in which the student drives and the teacher, its memory
rebuilt along the student's trajectory, labels every state. It writes DIR/policy.pt (evaluate it
as learned:DIR/policy.pt), DIR/record.json and DIR/curve.csv. Its defaults are
:class:`agents.learning.imitation.ImitationConfig`'s; ``--teacher-setting replan_every=1``
sets a field of the teacher's :class:`agents.planning.config.NavigatorConfig` (repeat).
The imitation's policy is then fine-tuned with PPO for ``--finetune-steps`` env steps (240,000;
0: imitation only) under the same rules (:mod:`agents.learning.finetune`): DIR/policy.pt becomes
the fine-tuned policy (the imitation's stays in DIR/checkpoints/), beside DIR/finetune.json and
DIR/finetune_curve.csv. ``--finetune POLICY`` fine-tunes a policy.pt already trained.

--backend rllib trains with Ray RLlib instead (agents.learning.rllib.backend, docs/rllib.md): N env
runner processes, on a local Ray or on the cluster at --address; it writes DIR/checkpoint/
(evaluate it as rllib:DIR/checkpoint), DIR/tb/, DIR/results.jsonl and DIR/rules.json.

Writes DIR/ppo_final.zip, DIR/checkpoints/, DIR/best/, DIR/eval/, DIR/tb/ (TensorBoard),
DIR/curve.csv, DIR/learning_curve.png, DIR/rules.json (the episode rules, those of
evaluate.py) and DIR/summary.json (steps per second, the curriculum's stages). The defaults
(one env per core, 2,048-step rollouts, minibatch 256, 4 epochs, entropy 0.01, 128 x 128,
normalised rewards) are :class:`agents.learning.training.TrainConfig`'s; the logic is in
:mod:`agents.learning.training`.
"""

from __future__ import annotations

import argparse
import os
import pathlib

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from agents.learning.finetune import (
    RECIPE_STEPS,
    FinetuneConfig,
    FinetuneResult,
    append_to_curve,
    finetune_policy,
)
from agents.learning.imitation import ImitationConfig, ImitationResult, train_imitation
from agents.learning.rllib.backend import RLlibOptions, RLlibResult, train_rllib
from agents.learning.training import ALGOS, CURRICULUM, TrainConfig, TrainResult, train_ppo
from modeling.validation import settings_of

TEACHERS = ("planner", "greedy", "cautious")


def teacher_of(argv: list[str] | None = None) -> str | None:
    """The ``--teacher`` of the command line ``argv`` (``None``: PPO)."""
    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--teacher", choices=TEACHERS, default=None)
    args, _ = parser.parse_known_args(argv)
    teacher: str | None = args.teacher
    return teacher


def finetune_of(argv: list[str] | None = None) -> tuple[pathlib.Path | None, int]:
    """The ``--finetune`` policy (``None``: none) and ``--finetune-steps`` of ``argv``."""
    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--finetune", type=pathlib.Path, default=None)
    parser.add_argument("--finetune-steps", type=int, default=RECIPE_STEPS)
    args, _ = parser.parse_known_args(argv)
    policy: pathlib.Path | None = args.finetune
    steps: int = args.finetune_steps
    return policy, steps


def finetune_config(argv: list[str] | None = None) -> FinetuneConfig:
    """The :class:`FinetuneConfig` of a ``--finetune POLICY`` command line ``argv``."""
    import shlex
    import sys

    defaults = FinetuneConfig(out_dir=pathlib.Path("."), policy=pathlib.Path("."))
    parser = argparse.ArgumentParser(description="PPO fine-tuning of an imitation policy")
    parser.add_argument("--finetune", type=pathlib.Path, required=True, help="the policy.pt")
    parser.add_argument("--out", type=pathlib.Path, required=True, help="output folder")
    parser.add_argument("--seed", type=int, default=0, help="seed")
    parser.add_argument("--n-envs", type=int, default=defaults.n_envs, help="env processes")
    parser.add_argument(
        "--finetune-steps", type=int, default=defaults.timesteps, help="PPO env steps"
    )
    parser.add_argument(
        "--torch-threads", type=int, default=defaults.torch_threads, help="torch threads"
    )
    parser.add_argument(
        "--contact-anchor",
        type=float,
        default=defaults.contact_anchor,
        help="weight of the KL to the imitation policy on contact states (0: none)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    words = sys.argv[1:] if argv is None else argv
    try:
        return FinetuneConfig(
            out_dir=args.out,
            policy=args.finetune,
            seed=args.seed,
            n_envs=args.n_envs,
            timesteps=args.finetune_steps,
            torch_threads=args.torch_threads,
            contact_anchor=args.contact_anchor,
            command="python scripts/train.py " + shlex.join(words),
            progress=not args.no_progress,
        )
    except ValueError as err:
        parser.error(str(err))


def imitation_config(argv: list[str] | None = None) -> ImitationConfig:
    """The :class:`ImitationConfig` of a ``--teacher`` command line ``argv``."""
    import shlex
    import sys

    defaults = ImitationConfig(out_dir=pathlib.Path("."))
    parser = argparse.ArgumentParser(description="imitation of a model-based teacher")
    parser.add_argument("--teacher", choices=TEACHERS, required=True, help="the teacher")
    parser.add_argument(
        "--teacher-setting",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a field of the teacher's NavigatorConfig, e.g. replan_every=1 (repeat)",
    )
    parser.add_argument("--out", type=pathlib.Path, required=True, help="output folder")
    parser.add_argument("--seed", type=int, default=0, help="seed")
    parser.add_argument("--n-envs", type=int, default=defaults.n_envs, help="env processes")
    parser.add_argument(
        "--perception",
        choices=("surrogate", "stereo"),
        default="surrogate",
        help="the training envs' perception",
    )
    parser.add_argument(
        "--demo-steps", type=int, default=defaults.demo_steps, help="teacher demonstration steps"
    )
    parser.add_argument("--rounds", type=int, default=defaults.rounds, help="DAgger rounds")
    parser.add_argument(
        "--round-steps", type=int, default=defaults.round_steps, help="env steps per round"
    )
    parser.add_argument(
        "--epochs", type=int, default=defaults.epochs, help="passes over the data per phase"
    )
    parser.add_argument(
        "--mirror-share",
        type=float,
        default=defaults.mirror_share,
        help="share of each minibatch replaced by its left-right mirror image",
    )
    parser.add_argument(
        "--torch-threads",
        type=int,
        default=defaults.torch_threads,
        help="torch threads of the fits (1 when other jobs share the cores)",
    )
    parser.add_argument(
        "--finetune-steps",
        type=int,
        default=RECIPE_STEPS,
        help="then fine-tune the policy with PPO for this many env steps (0: imitation only)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    if args.finetune_steps < 0:
        parser.error(f"--finetune-steps must be >= 0, got {args.finetune_steps}")
    words = sys.argv[1:] if argv is None else argv
    try:
        return ImitationConfig(
            out_dir=args.out,
            seed=args.seed,
            teacher=args.teacher,
            teacher_settings=settings_of(args.teacher_setting),
            n_envs=args.n_envs,
            demo_steps=args.demo_steps,
            rounds=args.rounds,
            round_steps=args.round_steps,
            epochs=args.epochs,
            mirror_share=args.mirror_share,
            torch_threads=args.torch_threads,
            env_kwargs={"perception": args.perception, "diagnostics": False},
            command="python scripts/train.py " + shlex.join(words),
            progress=not args.no_progress,
        )
    except ValueError as err:  # a bad setting or value, named
        parser.error(str(err))


def _add_backend_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--backend", choices=("sb3", "rllib"), default="sb3", help="trainer")
    parser.add_argument(
        "--num-env-runners", type=int, default=2, help="rllib: env runner processes"
    )
    parser.add_argument("--address", default=None, help="rllib: Ray cluster to join (HEAD:6379)")


def backend_options(argv: list[str] | None = None) -> tuple[str, RLlibOptions]:
    """The ``--backend`` of the command line ``argv`` and its RLlib options."""
    parser = argparse.ArgumentParser(add_help=False)
    _add_backend_arguments(parser)
    args, _ = parser.parse_known_args(argv)
    return args.backend, RLlibOptions(num_env_runners=args.num_env_runners, address=args.address)


def train_config(argv: list[str] | None = None) -> TrainConfig:
    """The :class:`TrainConfig` of the command line ``argv``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timesteps", type=int, required=True, help="environment steps")
    parser.add_argument("--algo", choices=ALGOS, default="ppo", help="algorithm")
    parser.add_argument(
        "--n-envs", type=int, default=None, help="parallel environments (default: one per core)"
    )
    parser.add_argument(
        "--perception",
        choices=("stereo", "surrogate"),
        default="stereo",
        help="the training envs' perception (surrogate: no rendering, several times faster)",
    )
    parser.add_argument(
        "--curriculum",
        nargs="*",
        default=None,
        metavar="FAMILY",
        help=f"scene families in order (no list: {' '.join(CURRICULUM)})",
    )
    parser.add_argument(
        "--curriculum-threshold", type=float, default=0.8, help="rolling success to advance"
    )
    parser.add_argument("--out", type=pathlib.Path, required=True, help="output folder")
    parser.add_argument("--resume", type=pathlib.Path, help="checkpoint .zip to continue from")
    parser.add_argument("--eval-freq", type=int, default=10_000, help="timesteps between evals")
    parser.add_argument("--eval-episodes", type=int, default=5, help="episodes per evaluation")
    parser.add_argument(
        "--checkpoint-freq", type=int, default=20_000, help="timesteps between saves"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed")
    parser.add_argument("--scenario", default="random", help="map name or scene family")
    parser.add_argument(
        "--rollout-steps", type=int, default=2048, help="PPO rollout steps over all envs"
    )
    parser.add_argument("--batch-size", type=int, default=256, help="PPO minibatch size")
    parser.add_argument("--n-epochs", type=int, default=4, help="PPO epochs per update")
    parser.add_argument("--ent-coef", type=float, default=0.01, help="entropy bonus")
    parser.add_argument(
        "--max-minutes", type=float, default=None, help="wall-clock budget (stops and saves)"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    _add_backend_arguments(parser)
    args = parser.parse_args(argv)
    curriculum = () if args.curriculum is None else tuple(args.curriculum or CURRICULUM)
    extra = {} if args.n_envs is None else {"n_envs": args.n_envs}
    return TrainConfig(
        timesteps=args.timesteps,
        algo=args.algo,
        out_dir=args.out,
        resume=args.resume,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        checkpoint_freq=args.checkpoint_freq,
        seed=args.seed,
        rollout_steps=args.rollout_steps,
        batch_size=args.batch_size,
        n_epochs=args.n_epochs,
        ent_coef=args.ent_coef,
        curriculum=curriculum,
        curriculum_threshold=args.curriculum_threshold,
        env_kwargs={
            "scenario": args.scenario,
            "diagnostics": False,
            "memory": False,
            "perception": args.perception,
        },
        max_minutes=args.max_minutes,
        progress=not args.no_progress,
        **extra,
    )


def _finetune(cfg: FinetuneConfig) -> FinetuneResult:
    result = finetune_policy(cfg)
    print(
        f"fine-tuned policy: {result.policy_path} ({result.steps} env steps, "
        f"{result.episodes} episodes, {result.minutes:.1f} min)"
    )
    print(f"evaluate it: python scripts/evaluate.py --agent learned:{result.policy_path}")
    return result


def main(
    argv: list[str] | None = None,
) -> TrainResult | RLlibResult | ImitationResult | FinetuneResult:
    """Parse the arguments and train; returns what was written."""
    policy, finetune_steps = finetune_of(argv)
    if policy is not None:
        return _finetune(finetune_config(argv))
    if teacher_of(argv) is not None:
        icfg = imitation_config(argv)
        result = train_imitation(icfg)
        print(f"policy: {result.policy_path} ({result.steps} env steps, {result.minutes:.1f} min)")
        if finetune_steps == 0:
            print(f"evaluate it: python scripts/evaluate.py --agent learned:{result.policy_path}")
            return result
        tuned = _finetune(
            FinetuneConfig(
                out_dir=icfg.out_dir,
                policy=result.policy_path,  # overwritten by the fine-tuned one
                seed=icfg.seed,
                n_envs=icfg.n_envs,
                timesteps=finetune_steps,
                torch_threads=icfg.torch_threads,
                command=icfg.command,
                progress=icfg.progress,
            )
        )
        append_to_curve(icfg.out_dir / "curve.csv", icfg.out_dir / "finetune_curve.csv")
        return tuned
    cfg = train_config(argv)
    backend, options = backend_options(argv)
    if backend == "rllib":
        rllib = train_rllib(cfg, options)
        print(
            f"checkpoint: {rllib.checkpoint} ({rllib.timesteps} timesteps, "
            f"{rllib.steps_per_s:.1f} steps/s on {options.num_env_runners} env runners)"
        )
        return rllib
    ppo = train_ppo(cfg)
    print(f"model: {ppo.model_path} ({ppo.timesteps} timesteps, {ppo.episodes} episodes)")
    print(f"learning curve: {ppo.curve_png}")
    summary = ppo.model_path.parent / "summary.json"
    print(f"summary (steps per second, curriculum stages): {summary}")
    return ppo


if __name__ == "__main__":
    main()
