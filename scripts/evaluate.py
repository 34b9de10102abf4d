"""Evaluate agents on the fixed, seeded scene suite; print a Markdown table; write JSON, a plot.

    python scripts/evaluate.py --agent NAME [--agent NAME ...] [--episodes N] [--split dev|test]
        [--seed S]
        [--json FILE] [--markdown FILE] [--plot FILE] [--details FILE] [--scenario FAMILY]
        [--families F [F ...]] [--max-steps N] [--workers K] [--terminate-on-collision]
        [--perception P] [--tilt RAD] [--fused-range M] [--ground-lines] [--surface-detail]
        [--navigator-setting NAME=VALUE ...]

``--split dev`` (the default: seed 0 unless ``--seed``) runs suite seeds for tuning and diagnosis;
``--split test`` (seed 900000 unless ``--seed``) runs the seeds reserved for reported figures,
which nothing is tuned on (docs/evaluation.md). A ``--seed`` of the other split is refused.
The Markdown table is always printed; each file option writes its file, none by default. The suite
runs under the StereoNav-v1 rules; each agent's JSON entry records them ("rules") and
carries 95 % bootstrap intervals of its rates (keys ending in "_ci").

``--navigator-setting replan_every=1`` sets a field of the model-based agents' (greedy, cautious,
planner) :class:`agents.planning.config.NavigatorConfig` (repeat); the JSON records them.

Agent names: random, greedy, cautious, planner, oracle, learned (the shipped policy),
learned-fixed-head, learned:PATH, learned-fixed-head:PATH, ppo:PATH, rllib:PATH. The logic is in
:mod:`agents.evaluation.suite`.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
from typing import Any

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from agents.evaluation.suite import (
    EpisodeSpec,
    Split,
    SuiteConfig,
    default_seed,
    episode_records,
    evaluate,
    markdown_table,
    plot_summary,
    split_of,
    suite_episodes,
    suite_rules,
    summarize,
)
from agents.planning.config import NavigatorConfig
from modeling.validation import settings_of, with_overrides
from stereo_nav_env.perception.base import PerceptionName


def add_suite_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the suite's options to ``parser``: ``--episodes``, ``--split``, ``--seed``,
    ``--scenario``, ``--families``, ``--max-steps``, ``--workers`` and ``--no-progress``
    (:func:`suite_of` reads them)."""
    parser.add_argument("--episodes", type=int, default=32, help="episodes per agent")
    parser.add_argument(
        "--split",
        choices=[s.value for s in Split],
        default=Split.DEV.value,
        help="dev (tuning, the default) or test (reported figures only)",
    )
    parser.add_argument("--seed", type=int, default=None, help="suite seed (within the split)")
    parser.add_argument("--scenario", default=None, help="run the suite on this family only")
    parser.add_argument(
        "--families", nargs="+", default=None, help="scene families (default: the standard four)"
    )
    parser.add_argument("--max-steps", type=int, default=500, help="steps at most per episode")
    parser.add_argument("--workers", type=int, default=1, help="parallel processes")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def add_trace_arguments(parser: argparse.ArgumentParser, *, json_help: str) -> None:
    """Add the options of the scripts that trace suite episodes one by one (``stall_report.py``,
    ``student_report.py``): ``--only`` (episode indices), ``--perception`` (stereo by default)
    and ``--json`` (``json_help`` says what it holds)."""
    parser.add_argument("--only", type=int, nargs="+", default=None, help="episode indices")
    parser.add_argument("--perception", default="stereo", help="the env's perception")
    parser.add_argument("--json", type=pathlib.Path, help=json_help)


def add_navigator_settings(parser: argparse.ArgumentParser, flag: str, whose: str) -> None:
    """Add ``flag`` (repeatable ``NAME=VALUE``): a field of ``whose`` ``NavigatorConfig``."""
    parser.add_argument(
        flag,
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help=f"a field of {whose} NavigatorConfig, e.g. replan_every=1 (repeat)",
    )


def navigator_settings(parser: argparse.ArgumentParser, words: list[str]) -> dict[str, Any]:
    """``{name: value}`` of the words of an option of :func:`add_navigator_settings`; a word
    that is not ``NAME=VALUE``, an unknown field or a bad value is a ``parser.error``."""
    try:
        settings = settings_of(words)
        with_overrides(None, NavigatorConfig, settings)  # names a bad field or value
    except ValueError as err:
        parser.error(str(err))
    return settings


def chosen_episodes(cfg: SuiteConfig, only: list[int] | None) -> list[EpisodeSpec]:
    """The episodes of ``cfg``'s suite, only those of the indices ``only`` unless it is None."""
    return [spec for spec in suite_episodes(cfg) if only is None or spec.index in only]


def suite_of(
    parser: argparse.ArgumentParser,
    args: argparse.Namespace,
    env_kwargs: dict[str, Any],
    navigator: dict[str, Any] | None = None,
) -> SuiteConfig:
    """The :class:`SuiteConfig` of the options of :func:`add_suite_arguments` in ``args``, with
    ``env_kwargs`` and ``navigator``: the split's seed unless ``--seed`` (a seed of the other
    split is a ``parser.error``, as is a value the suite refuses), ``--scenario`` or
    ``--families``."""
    seed = default_seed(args.split) if args.seed is None else args.seed
    if seed >= 0 and split_of(seed).value != args.split:
        parser.error(f"--seed {seed} is a {split_of(seed).value} seed, not of --split {args.split}")
    families = [args.scenario] if args.scenario is not None else args.families
    kw = {} if families is None else {"families": tuple(families)}
    try:
        return SuiteConfig(
            episodes=args.episodes,
            seed=seed,
            max_steps=args.max_steps,
            env_kwargs=env_kwargs,
            navigator={} if navigator is None else navigator,
            **kw,
        )
    except ValueError as err:  # a bad count, family or navigator setting, named
        parser.error(str(err))


def _arguments(argv: list[str] | None) -> tuple[argparse.Namespace, SuiteConfig]:
    """The parsed command line and its suite."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent", action="append", required=True, help="agent name (repeat)")
    add_suite_arguments(parser)
    parser.add_argument("--json", type=pathlib.Path, help="summary JSON file (default: none)")
    parser.add_argument("--markdown", type=pathlib.Path, help="Markdown table file")
    parser.add_argument("--plot", type=pathlib.Path, help="bar plot (PNG)")
    parser.add_argument("--details", type=pathlib.Path, help="per-episode JSON file")
    parser.add_argument(
        "--terminate-on-collision",
        action="store_true",
        help="end an episode at its first collision (the env's default task)",
    )
    parser.add_argument(
        "--perception",
        choices=[p.value for p in PerceptionName],
        default=PerceptionName.STEREO.value,
        help="the env's perception (stereo_nav_env.perception: surrogate and truth render "
        "nothing; stereo_means, dense and truth are issue 43's ablation)",
    )
    parser.add_argument(
        "--tilt",
        type=float,
        default=None,
        help="head tilt below the horizon, radians (the camera's tilt_rad; default: the env's)",
    )
    parser.add_argument(
        "--fused-range",
        type=float,
        default=0.0,
        help="the model-based agents add the env's fused memory's obstacles within this many "
        "metres (NavigatorConfig.fused_range_m; turns the env's memory on; default 0: off)",
    )
    parser.add_argument(
        "--ground-lines",
        action="store_true",
        help="the env's lowest near-horizontal image lines enter as floor segments "
        "(EnvConfig.ground_lines, modeling.stereo.ground_lines; perceptions stereo, "
        "stereo_means and surrogate)",
    )
    parser.add_argument(
        "--surface-detail",
        action="store_true",
        help="the scenes' faces carry surface detail: seams, door frames, fronts, book spines "
        "(EnvConfig.surface_detail, stereo_nav_env.sim.scenes.surface; default: plain faces)",
    )
    add_navigator_settings(parser, "--navigator-setting", "the model-based agents'")
    args = parser.parse_args(argv)
    navigator = navigator_settings(parser, args.navigator_setting)
    if args.fused_range > 0.0:
        navigator["fused_range_m"] = args.fused_range
    cfg = suite_of(
        parser,
        args,
        env_kwargs={
            "diagnostics": False,
            "memory": args.fused_range > 0.0,
            "perception": args.perception,
        }
        | ({"terminate_on_collision": True} if args.terminate_on_collision else {})
        | ({"ground_lines": True} if args.ground_lines else {})
        | ({"surface_detail": True} if args.surface_detail else {})
        | ({"camera": {"tilt_rad": args.tilt}} if args.tilt is not None else {}),
        navigator=navigator,
    )
    return args, cfg


def suite_config(argv: list[str] | None = None) -> SuiteConfig:
    """The :class:`SuiteConfig` of the command line ``argv``."""
    return _arguments(argv)[1]


def main(argv: list[str] | None = None) -> dict[str, dict[str, Any]]:
    """Parse the arguments, run the suite, print its table, write the files asked for; returns
    the summary."""
    args, cfg = _arguments(argv)
    results = evaluate(args.agent, cfg, workers=args.workers, progress=not args.no_progress)
    summary = summarize(dict(results))
    rules = suite_rules(cfg)
    for figures in summary.values():
        figures["rules"] = rules
        figures["split"] = split_of(cfg.seed).value
        figures["suite_seed"] = cfg.seed
        figures["navigator"] = dict(cfg.navigator)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(summary, indent=2) + "\n")
    table = markdown_table(summary)
    print(table)
    if args.markdown is not None:
        args.markdown.parent.mkdir(parents=True, exist_ok=True)
        args.markdown.write_text(table)
    if args.plot is not None:
        plot_summary(summary, args.plot)
    if args.details is not None:
        args.details.parent.mkdir(parents=True, exist_ok=True)
        args.details.write_text(json.dumps(episode_records(dict(results)), indent=1) + "\n")
    return summary


if __name__ == "__main__":
    main()
