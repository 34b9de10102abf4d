"""The evaluation suite: named agents on a fixed, seeded set of generated scenes.

Episode ``i`` of a suite with seed ``S`` runs in a scene of family ``families[i % len(families)]``
drawn by ``env.reset(seed=S * 100_000 + i)``: every agent meets exactly the same scenes, and the
same suite is drawn again for the same ``--episodes`` and ``--seed``.

Per episode (:class:`EpisodeResult`): success (the robot's centre within the goal radius before
``max_steps``), whether it collided at least once and in how many steps, steps, looks (steps whose
head pan target is off straight ahead, :func:`agents.base.is_look`), the path length driven, the
reference length and the episode's wall time. The reference length is the true shortest route of
the robot (:func:`agents.baselines.true_shortest_route`, on the ground-truth outlines) less the goal
radius (the distance to the success region); SPL (Anderson et al., 2018) is
``mean(S_i * l_i / max(p_i, l_i))``.

The suite runs ``StereoNav-v1``: its rules (:func:`suite_rules`, written into every result by
``evaluate.py``) let collisions not end an episode: the robot stops at the obstacle, the
collision is counted, and the agent may recover. The collision
rate is the fraction of episodes with at least one collision; ``mean_collisions`` is the number of
steps that ended in a collision, per episode (it tells a graze from a robot that keeps hitting).

The summary per agent (:func:`summarize`) is the JSON contract of ARCHITECTURE.md::

    {"planner": {"episodes": 32, "success_rate": ..., "collision_rate": ...,
                 "mean_collisions": ..., "spl": ..., "mean_steps": ..., "mean_looks": ...,
                 "mean_episode_time_s": ...}, ...}
"""

from __future__ import annotations

import dataclasses
import math
import multiprocessing
import os
import pathlib
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np

__all__ = [
    "CI_KEYS",
    "EPISODE_STRIDE",
    "SUMMARY_KEYS",
    "TEST_SEED_START",
    "EpisodeResult",
    "EpisodeSpec",
    "Split",
    "SuiteConfig",
    "bootstrap_ci",
    "default_seed",
    "env_config",
    "episode_records",
    "evaluate",
    "markdown_table",
    "plot_summary",
    "reference_length_m",
    "run_episode",
    "split_of",
    "suite_env_config",
    "suite_episodes",
    "suite_rules",
    "summarize",
]

ENV_ID = "StereoNav-v1"
SUMMARY_KEYS = (
    "episodes",
    "success_rate",
    "collision_rate",
    "mean_collisions",
    "spl",
    "mean_steps",
    "mean_looks",
    "mean_episode_time_s",
)
CI_KEYS = ("success_rate_ci", "spl_ci", "collision_rate_ci")
"""The 95 % bootstrap intervals ``[lo, hi]`` of the summary (:func:`bootstrap_ci`)."""


def bootstrap_ci(
    values: Sequence[float], *, confidence: float = 0.95, resamples: int = 10_000, seed: int = 0
) -> list[float]:
    """The percentile bootstrap interval ``[lo, hi]`` of the mean of ``values``.

    ``scipy.stats.bootstrap`` (percentile method) with a fixed seed: the same values give the same
    interval. A constant sample (all successes, say) gives ``[v, v]``; an empty one ``[0, 0]``.
    """
    from scipy.stats import bootstrap

    data = np.asarray(values, dtype=np.float64)
    if data.size == 0:
        return [0.0, 0.0]
    if np.all(data == data[0]):
        return [float(data[0]), float(data[0])]
    res = bootstrap(
        (data,),
        np.mean,
        confidence_level=confidence,
        n_resamples=resamples,
        method="percentile",
        rng=np.random.default_rng(seed),
    )
    return [float(res.confidence_interval.low), float(res.confidence_interval.high)]


class Split(str, Enum):
    """Which suite seeds an evaluation may use (docs/evaluation.md, "Dev and test splits").

    ``dev`` seeds (below :data:`TEST_SEED_START`) are for tuning and diagnosis; ``test`` seeds
    (from it on) are reserved for the figures a report gives, and nothing is tuned on them. With
    at most :data:`EPISODE_STRIDE` episodes per suite seed, the two splits' episodes (reset seeds
    ``seed * EPISODE_STRIDE + i``) never meet.
    """

    DEV = "dev"
    TEST = "test"


EPISODE_STRIDE = 100_000
"""Episode ``i`` of suite seed ``S`` resets with ``S * EPISODE_STRIDE + i`` (``i`` below it)."""
TEST_SEED_START = 900_000
"""The first suite seed of the test split; every smaller one is a dev seed."""


def split_of(seed: int) -> Split:
    """The split suite seed ``seed`` belongs to."""
    return Split.TEST if seed >= TEST_SEED_START else Split.DEV


def default_seed(split: Split | str) -> int:
    """The suite seed a split runs when none is given: 0 (dev), :data:`TEST_SEED_START` (test)."""
    return TEST_SEED_START if Split(split) is Split.TEST else 0


@dataclass(frozen=True, slots=True, kw_only=True)
class SuiteConfig:
    """The evaluation suite.

    Attributes:
        episodes: Episodes per agent.
        seed: Suite seed (episode ``i`` resets with ``seed * 100_000 + i``); below
            :data:`TEST_SEED_START` for the dev split, from it on for the test split.
        families: Scene families, cycled (see ``stereo_nav_env.sim.scenes.FAMILIES``).
        max_steps: Steps at most per episode.
        env_kwargs: Keyword arguments of ``gym.make(ENV_ID, ...)`` besides ``scenario``.
        navigator: Fields of :class:`~agents.planning.config.NavigatorConfig` for the model-based
            agents (``greedy``, ``cautious``, ``planner``; the others take none), e.g.
            ``{"fused_range_m": 1.8}``.
    """

    episodes: int = 32
    seed: int = 0
    families: tuple[str, ...] = ("room", "corridor", "cluttered", "office")
    max_steps: int = 500
    env_kwargs: dict[str, Any] = field(default_factory=lambda: {"diagnostics": False})
    navigator: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from agents.planning.config import NavigatorConfig
        from modeling.validation import with_overrides
        from stereo_nav_env.sim.scenes import FAMILIES

        with_overrides(None, NavigatorConfig, self.navigator)  # names a bad field or value
        if "policy" in self.navigator:
            raise ValueError("navigator must not set policy (each agent's name does)")

        for name in ("episodes", "max_steps"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"seed must be a non-negative integer, got {self.seed!r}")
        if self.episodes > EPISODE_STRIDE:
            raise ValueError(f"episodes must be at most {EPISODE_STRIDE}, got {self.episodes}")
        fams = tuple(self.families)
        if not fams or any(f not in FAMILIES for f in fams):
            raise ValueError(f"families must be a non-empty subset of {list(FAMILIES)}, got {fams}")
        object.__setattr__(self, "families", fams)
        if "scenario" in self.env_kwargs:
            raise ValueError("env_kwargs must not hold 'scenario' (the suite sets it)")


@dataclass(frozen=True, slots=True, kw_only=True)
class EpisodeSpec:
    """One episode of the suite.

    Attributes:
        index: Position in the suite.
        family: Scene family (the env's ``scenario``).
        seed: ``env.reset`` seed (also the agent's).
    """

    index: int
    family: str
    seed: int


@dataclass(frozen=True, slots=True, kw_only=True)
class EpisodeResult:
    """What happened in one episode.

    Attributes:
        agent: Agent name.
        index: Episode index in the suite.
        family: Scene family.
        scene: Scene name.
        seed: Reset seed.
        success: Reached the goal.
        collided: Touched an obstacle at least once.
        collision_steps: Steps with a contact.
        steps: Steps taken.
        looks: Look steps.
        path_length_m: Distance driven by the robot's centre, metres.
        reference_m: True shortest route length to the goal region, metres (nan if none).
        spl: ``success * reference / max(path, reference)``.
        time_s: Wall time of the episode (agent and environment), seconds.
    """

    agent: str
    index: int
    family: str
    scene: str
    seed: int
    success: bool
    collided: bool
    collision_steps: int
    steps: int
    looks: int
    path_length_m: float
    reference_m: float
    spl: float
    time_s: float


def env_config(env_id: str, **kwargs: Any) -> Any:
    """The ``EnvConfig`` that ``gym.make(env_id, **kwargs)`` builds (its registered keywords
    first), without building the env: training and evaluation compare theirs with it."""
    import gymnasium as gym

    import stereo_nav_env  # noqa: F401  (registers the ids)
    from stereo_nav_env.config import EnvConfig

    return EnvConfig.from_kwargs(**{**gym.spec(env_id).kwargs, **kwargs})


def suite_env_config(cfg: SuiteConfig, family: str) -> Any:
    """The ``EnvConfig`` of the suite's episodes of ``family``."""
    return env_config(ENV_ID, **cfg.env_kwargs, scenario=family)


def suite_rules(cfg: SuiteConfig) -> dict[str, Any]:
    """The episode rules the suite runs under (``EnvConfig.rules_dict()`` of its env, the env id
    and the step limit): what every result records."""
    return {
        "env_id": ENV_ID,
        **suite_env_config(cfg, cfg.families[0]).rules_dict(),
        "max_episode_steps": cfg.max_steps,
    }


def suite_episodes(cfg: SuiteConfig) -> list[EpisodeSpec]:
    """The episodes of the suite, in order."""
    return [
        EpisodeSpec(
            index=i,
            family=cfg.families[i % len(cfg.families)],
            seed=cfg.seed * EPISODE_STRIDE + i,
        )
        for i in range(cfg.episodes)
    ]


_AGENTS: dict[tuple[str, tuple[tuple[str, Any], ...]], Any] = {}


def _agent(name: str, navigator: Mapping[str, Any]) -> Any:
    """One agent per name (and navigator settings) and process (a PPO model is loaded once)."""
    from agents import make_agent
    from agents.planning.config import NavigatorConfig, Policy

    key = (name, tuple(sorted(navigator.items())))
    if key not in _AGENTS:
        model_based = name in {p.value for p in Policy}  # greedy, cautious, planner
        kwargs = {"config": NavigatorConfig(**navigator)} if model_based else {}
        _AGENTS[key] = make_agent(name, **kwargs)
    return _AGENTS[key]


def reference_length_m(env: Any) -> float:
    """The episode's reference length for SPL, right after its reset: the robot's true shortest
    route less the goal radius (NaN when there is none)."""
    from agents.base import control_limits
    from agents.baselines import true_shortest_route

    route = true_shortest_route(env)
    radius = control_limits(env).goal_radius_m
    return math.nan if route is None else max(route.length_m - radius, 1e-6)


def run_episode(agent_name: str, spec: EpisodeSpec, cfg: SuiteConfig) -> EpisodeResult:
    """Run ``agent_name`` for one episode of the suite."""
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    import gymnasium as gym

    import stereo_nav_env  # noqa: F401  (registers the ids)
    from agents.base import robot_pose

    env = gym.make(ENV_ID, scenario=spec.family, **cfg.env_kwargs)
    agent = _agent(agent_name, cfg.navigator)
    t0 = time.perf_counter()
    try:
        obs, info = env.reset(seed=spec.seed)
        reference = reference_length_m(env)
        agent.reset(env, seed=spec.seed)
        x, y, _, _ = robot_pose(env)
        last = np.array([x, y])
        path = 0.0
        success = False
        collision_steps = 0
        steps = 0
        for steps in range(1, cfg.max_steps + 1):  # noqa: B007 (steps is read after the loop)
            action = agent.act(obs, info)
            obs, _, terminated, truncated, info = env.step(action)
            x, y, _, _ = robot_pose(env)
            here = np.array([x, y])
            path += float(np.hypot(*(here - last)))
            last = here
            collision_steps += int(bool(info.get("collision", False)))
            success = bool(info.get("is_success", False))
            if terminated or truncated:
                break
        base: Any = env.unwrapped
        scene = str(base.scene.name)
    finally:
        agent.close()
        env.close()
    spl = float(reference / max(path, reference)) if success and math.isfinite(reference) else 0.0
    return EpisodeResult(
        agent=agent_name,
        index=spec.index,
        family=spec.family,
        scene=scene,
        seed=spec.seed,
        success=success,
        collided=collision_steps > 0,
        collision_steps=collision_steps,
        steps=steps,
        looks=int(agent.looks),
        path_length_m=path,
        reference_m=float(reference),
        spl=spl,
        time_s=time.perf_counter() - t0,
    )


def _job(args: tuple[str, EpisodeSpec, SuiteConfig]) -> EpisodeResult:
    return run_episode(*args)


def evaluate(
    agent_names: Sequence[str],
    cfg: SuiteConfig,
    *,
    workers: int = 1,
    progress: bool = True,
) -> dict[str, list[EpisodeResult]]:
    """Run every agent on every episode of the suite.

    Args:
        agent_names: Registry names (``"planner"``, ``"ppo:out/ppo/ppo_final.zip"``, ...).
        cfg: The suite.
        workers: Parallel processes (``forkserver``); 1 runs in this process.
        progress: Show a tqdm bar over all episodes.

    Returns:
        ``{agent name: [EpisodeResult, ...]}`` in suite order.
    """
    from tqdm.auto import tqdm

    from agents import make_agent

    names = list(dict.fromkeys(agent_names))
    if not names:
        raise ValueError("agent_names must name at least one agent")
    for name in names:  # fail fast on bad names, before any episode runs
        if not name.startswith("ppo:"):
            make_agent(name)
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers!r}")
    jobs = [(name, spec, cfg) for spec in suite_episodes(cfg) for name in names]
    out: dict[str, list[EpisodeResult]] = {name: [] for name in names}
    bar = tqdm(total=len(jobs), unit="episode", desc="evaluate", disable=not progress)
    try:
        if workers == 1:
            for job in jobs:
                _record(out, _job(job), bar)
        else:
            ctx = multiprocessing.get_context("forkserver")
            with ctx.Pool(workers, maxtasksperchild=20) as pool:
                for result in pool.imap_unordered(_job, jobs):
                    _record(out, result, bar)
    finally:
        bar.close()
    for name in names:
        out[name].sort(key=lambda r: r.index)
    return out


def _record(out: dict[str, list[EpisodeResult]], result: EpisodeResult, bar: Any) -> None:
    out[result.agent].append(result)
    bar.update(1)
    bar.set_postfix_str(
        f"{result.agent} {result.scene} {'ok' if result.success else 'fail'}", refresh=False
    )


def summarize(results: Mapping[str, Iterable[EpisodeResult]]) -> dict[str, dict[str, Any]]:
    """The JSON figures of ARCHITECTURE.md for each agent (keys :data:`SUMMARY_KEYS`, then the
    95 % bootstrap intervals :data:`CI_KEYS`)."""
    summary: dict[str, dict[str, Any]] = {}
    for name, episodes in results.items():
        eps = list(episodes)
        n = len(eps)

        def mean(values: list[float]) -> float:
            return float(np.mean(values)) if values else 0.0

        summary[name] = {
            "episodes": n,
            "success_rate": mean([float(e.success) for e in eps]),
            "collision_rate": mean([float(e.collided) for e in eps]),
            "mean_collisions": mean([float(e.collision_steps) for e in eps]),
            "spl": mean([e.spl for e in eps]),
            "mean_steps": mean([float(e.steps) for e in eps]),
            "mean_looks": mean([float(e.looks) for e in eps]),
            "mean_episode_time_s": mean([e.time_s for e in eps]),
            "success_rate_ci": bootstrap_ci([float(e.success) for e in eps]),
            "spl_ci": bootstrap_ci([e.spl for e in eps]),
            "collision_rate_ci": bootstrap_ci([float(e.collided) for e in eps]),
        }
    return summary


def episode_records(results: Mapping[str, Iterable[EpisodeResult]]) -> list[dict[str, Any]]:
    """Every episode as a JSON-friendly dict (for a details file)."""
    return [dataclasses.asdict(e) for eps in results.values() for e in eps]


def _with_ci(s: Mapping[str, Any], key: str, digits: int) -> str:
    """``value [lo, hi]`` of a summary figure and its interval (the value alone without one)."""
    text = f"{float(s[key]):.{digits}f}"
    ci = s.get(f"{key}_ci")
    return text if ci is None else f"{text} [{ci[0]:.{digits}f}, {ci[1]:.{digits}f}]"


def markdown_table(summary: Mapping[str, Mapping[str, Any]]) -> str:
    """A Markdown table of the summary, one row per agent (rates with their 95 % intervals)."""
    header = (
        "| agent | episodes | success | collision | collisions / episode | SPL | mean steps | "
        "mean looks | mean episode time (s) |\n|---|---|---|---|---|---|---|---|---|\n"
    )
    rows = [
        f"| {name} | {s['episodes']} | {_with_ci(s, 'success_rate', 2)} | "
        f"{_with_ci(s, 'collision_rate', 2)} | "
        f"{s['mean_collisions']:.2f} | {_with_ci(s, 'spl', 3)} | {s['mean_steps']:.1f} | "
        f"{s['mean_looks']:.1f} | {s['mean_episode_time_s']:.1f} |"
        for name, s in summary.items()
    ]
    return header + "\n".join(rows) + "\n"


def plot_summary(
    summary: Mapping[str, Mapping[str, Any]], path: str | pathlib.Path
) -> pathlib.Path:
    """Bar plot of success rate, collision rate and SPL per agent, written to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(summary)
    metrics = (("success_rate", "success"), ("collision_rate", "collision"), ("spl", "SPL"))
    x = np.arange(len(names))
    width = 0.8 / len(metrics)
    fig, ax = plt.subplots(figsize=(max(5.0, 1.4 * len(names) + 2), 3.8))
    for k, (key, label) in enumerate(metrics):
        values = [float(summary[n][key]) for n in names]
        bars = ax.bar(x + (k - 1) * width, values, width, label=label)
        ax.bar_label(bars, fmt="%.2f", fontsize=7, padding=1)
    ax.set_xticks(x, [n if len(n) <= 18 else n[:15] + "..." for n in names])
    ax.set_ylim(0, 1.12)
    ax.set_ylabel("rate")
    episodes = {int(summary[n]["episodes"]) for n in names}
    ax.set_title(f"StereoNav evaluation ({'/'.join(map(str, sorted(episodes)))} episodes/agent)")
    ax.legend(ncols=3, fontsize=8, loc="upper center")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    out = pathlib.Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
