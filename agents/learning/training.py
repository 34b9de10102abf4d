"""PPO training on ``StereoNav-v1`` with stable-baselines3 (what ``scripts/train.py`` runs).

The training envs run under the rules of the evaluation suite (``StereoNav-v1``, its
``"policy"`` observation).

:func:`train_ppo` trains PPO's ``MultiInputPolicy`` or (``algo="recurrent-ppo"``) sb3-contrib's
``RecurrentPPO`` with ``MultiInputLstmPolicy`` (the observation is a ``Dict``) on ``n_envs``
environments in subprocesses (``SubprocVecEnv`` with the ``forkserver`` start method by default,
safe with the EGL renderer; one environment runs in-process; by default one per core), with
defaults that work on a small machine (2,048-step rollouts over all envs, minibatch 256, 4
epochs, entropy bonus 0.01, a 128 x 128 network, rewards normalised by ``VecNormalize``, torch
on one thread), and

* a curriculum (``curriculum``: scene families in order; the next once the rolling success
  rate over ``curriculum_window`` episodes of the stage reaches ``curriculum_threshold``; every
  env, the evaluation env too, switches through ``set_scenario``; the stages reached in
  ``OUT/summary.json``),

* a tqdm progress bar over the timesteps,
* TensorBoard logs in ``OUT/tb``,
* periodic checkpoints in ``OUT/checkpoints`` (``CheckpointCallback``),
* periodic evaluation on separate environments (``EvalCallback``; best model in ``OUT/best``,
  results in ``OUT/eval/evaluations.npz``),
* the learning curve: every finished training episode in ``OUT/curve.csv`` (timesteps, return,
  length, success) and ``OUT/learning_curve.png`` (rolling return and success rate, evaluation
  returns),
* the episode rules ``OUT/rules.json`` (:meth:`TrainConfig.env_config`'s ``rules_dict()``,
  the env id and the step limit),
* the final model ``OUT/ppo_final.zip`` (load it with ``make_agent("ppo:OUT/ppo_final.zip")``),
* ``OUT/summary.json``: the algorithm, timesteps, wall time, steps per second, the curriculum's
  stages (the timestep each began), the configuration.

``resume`` continues from a saved checkpoint (its timestep counter too).

torch and stable-baselines3 are imported inside the functions, so importing this module is cheap.
"""

from __future__ import annotations

import csv
import pathlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from agents.learning.runtime import keep_freed_memory
from modeling.validation import number

__all__ = [
    "ALGOS",
    "CURRICULUM",
    "TrainConfig",
    "TrainResult",
    "finished_episode",
    "plot_learning_curve",
    "train_ppo",
]

ENV_ID = "StereoNav-v1"
ALGOS = ("ppo", "recurrent-ppo")
"""The algorithms: stable-baselines3's PPO and sb3-contrib's RecurrentPPO (an LSTM policy)."""
CURRICULUM = ("open", "sparse", "room", "corridor", "cluttered", "office")
"""The curriculum's families, easiest first (``--curriculum`` without a list)."""


def _cores() -> int:
    """The machine's cores (one env process per core)."""
    import os

    return max(1, os.cpu_count() or 1)


@dataclass(frozen=True, slots=True, kw_only=True)
class TrainConfig:
    """What :func:`train_ppo` does.

    Attributes:
        timesteps: Environment steps to train for (in addition to a resumed model's).
        out_dir: Output folder.
        algo: One of :data:`ALGOS`.
        n_envs: Parallel environments (subprocesses when > 1; default one per core).
        seed: Seed of the policy and of the environments (env ``i`` gets ``seed + i``).
        resume: A checkpoint ``.zip`` to continue from (the reward normaliser starts afresh).
        eval_freq: Evaluate every this many timesteps (0: never), under the training rules.
        eval_episodes: Episodes per evaluation.
        checkpoint_freq: Save a checkpoint every this many timesteps (0: never).
        rollout_steps: Steps per PPO rollout over all envs (``n_steps`` each).
        batch_size: PPO minibatch size.
        n_epochs: PPO epochs per update.
        learning_rate: Adam step size.
        gamma: Discount factor.
        ent_coef: Entropy bonus.
        net_arch: Hidden layers of the policy and value networks.
        normalize_reward: Scale rewards by a running estimate of the return's deviation
            (``VecNormalize``; observations are not normalised: they are bounded already).
        torch_threads: torch's intra-op threads in the training process.
        curriculum: Scene families in order (each in :data:`CURRICULUM` or another family);
            empty: train on ``env_kwargs["scenario"]`` only.
        curriculum_threshold: Rolling success rate that advances the curriculum, in (0, 1].
        curriculum_window: Episodes of a stage that the rolling success rate covers.
        env_kwargs: Keyword arguments of ``gym.make(ENV_ID, ...)`` (the curriculum's first
            family replaces ``scenario``).
        start_method: ``multiprocessing`` start method of the subprocesses.
        max_minutes: Wall-clock budget: past it training stops (the rollout under way is
            dropped) and everything is saved as at the end; ``None``: only ``timesteps``.
        progress: Show a progress bar.
        verbose: stable-baselines3 verbosity.
    """

    timesteps: int
    out_dir: pathlib.Path
    algo: str = "ppo"
    n_envs: int = field(default_factory=_cores)
    seed: int = 0
    resume: pathlib.Path | None = None
    eval_freq: int = 10_000
    eval_episodes: int = 5
    checkpoint_freq: int = 20_000
    rollout_steps: int = 2048
    batch_size: int = 256
    n_epochs: int = 4
    learning_rate: float = 3e-4
    gamma: float = 0.99
    ent_coef: float = 0.01
    net_arch: tuple[int, ...] = (128, 128)
    normalize_reward: bool = True
    torch_threads: int = 1
    curriculum: tuple[str, ...] = ()
    curriculum_threshold: float = 0.8
    curriculum_window: int = 50
    env_kwargs: dict[str, Any] = field(
        default_factory=lambda: {"scenario": "random", "diagnostics": False, "memory": False}
    )
    start_method: str = "forkserver"
    max_minutes: float | None = None
    progress: bool = True
    verbose: int = 0

    @property
    def n_steps(self) -> int:
        """Rollout steps per env (``rollout_steps // n_envs``)."""
        return max(1, self.rollout_steps // self.n_envs)

    @property
    def gym_kwargs(self) -> dict[str, Any]:
        """``env_kwargs`` with the curriculum's first family as the scenario."""
        kwargs = dict(self.env_kwargs)
        if self.curriculum:
            kwargs["scenario"] = self.curriculum[0]
        return kwargs

    def env_config(self) -> Any:
        """The ``EnvConfig`` of the training envs (``gym.make(ENV_ID, **env_kwargs)``'s)."""
        from agents.evaluation.suite import env_config

        kwargs = {k: v for k, v in self.gym_kwargs.items() if k != "max_episode_steps"}
        return env_config(ENV_ID, **kwargs)

    def __post_init__(self) -> None:
        if self.algo not in ALGOS:
            raise ValueError(f"algo must be one of {list(ALGOS)}, got {self.algo!r}")
        for name in (
            "timesteps",
            "n_envs",
            "rollout_steps",
            "batch_size",
            "n_epochs",
            "torch_threads",
            "curriculum_window",
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        for name in ("eval_freq", "checkpoint_freq", "eval_episodes", "seed"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ValueError(f"{name} must be a non-negative integer, got {value!r}")
        if self.max_minutes is not None and not (
            isinstance(self.max_minutes, int | float)
            and not isinstance(self.max_minutes, bool)
            and self.max_minutes > 0
        ):
            raise ValueError(f"max_minutes must be a positive number, got {self.max_minutes!r}")
        number(self.ent_coef, "ent_coef", low=0.0, strict=False)
        arch = tuple(self.net_arch)
        if not arch or not all(isinstance(n, int) and n >= 1 for n in arch):
            raise ValueError(f"net_arch must be positive layer sizes, got {self.net_arch!r}")
        object.__setattr__(self, "net_arch", arch)
        if number(self.curriculum_threshold, "curriculum_threshold", low=0.0) > 1.0:
            raise ValueError(
                f"curriculum_threshold must be in (0, 1], got {self.curriculum_threshold!r}"
            )
        from stereo_nav_env.sim.scenes import FAMILIES

        curriculum = tuple(self.curriculum)
        for family in curriculum:
            if family not in FAMILIES:
                raise ValueError(
                    f"curriculum must name families of {list(FAMILIES)}, got {family!r}"
                )
        object.__setattr__(self, "curriculum", curriculum)
        object.__setattr__(self, "out_dir", pathlib.Path(self.out_dir))
        if self.resume is not None:
            resume = pathlib.Path(self.resume)
            if not resume.is_file():
                raise ValueError(f"resume must name an existing checkpoint, got {str(resume)!r}")
            object.__setattr__(self, "resume", resume)


@dataclass(frozen=True, slots=True, kw_only=True)
class TrainResult:
    """What :func:`train_ppo` wrote.

    Attributes:
        model_path: The final model (``.zip``).
        curve_csv: One row per finished training episode.
        curve_png: The learning-curve plot.
        timesteps: Total timesteps of the final model.
        episodes: Training episodes finished in this run.
    """

    model_path: pathlib.Path
    curve_csv: pathlib.Path
    curve_png: pathlib.Path
    timesteps: int
    episodes: int


def _env_factory(kwargs: dict[str, Any], seed: int) -> Callable[[], Any]:
    def make() -> Any:
        import gymnasium as gym
        from stable_baselines3.common.monitor import Monitor

        import stereo_nav_env  # noqa: F401  (registers the ids)

        env: Any = Monitor(gym.make(ENV_ID, **kwargs), info_keywords=("is_success",))
        env.reset(seed=seed)
        env.action_space.seed(seed)
        return env

    return make


def _vec_env(cfg: TrainConfig, n: int, seed: int) -> Any:
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    fns = [_env_factory(cfg.gym_kwargs, seed + i) for i in range(n)]
    if n == 1:
        return DummyVecEnv(fns)
    return SubprocVecEnv(fns, start_method=cfg.start_method)


def finished_episode(info: dict[str, Any], timesteps: int) -> dict[str, float] | None:
    """The learning-curve row of an episode that ended in the step of ``info`` (Monitor's
    ``info["episode"]``): env steps so far, return, length, success; ``None`` mid-episode."""
    episode = info.get("episode")
    if episode is None:
        return None
    return {
        "timesteps": float(timesteps),
        "return": float(episode["r"]),
        "length": float(episode["l"]),
        "success": float(bool(info.get("is_success", False))),
    }


def _callbacks(
    cfg: TrainConfig, rows: list[dict[str, float]], stages: list[dict[str, Any]], eval_env: Any
) -> list[Any]:
    from collections import deque

    from stable_baselines3.common.callbacks import BaseCallback

    class CurriculumCallback(BaseCallback):
        """Advances ``cfg.curriculum`` when the stage's rolling success rate passes the bar."""

        def _on_training_start(self) -> None:
            self._recent: deque[float] = deque(maxlen=cfg.curriculum_window)
            stages.append({"scenario": cfg.curriculum[0], "timesteps": int(self.num_timesteps)})

        def _on_step(self) -> bool:
            for info in self.locals.get("infos", ()):
                if info.get("episode") is not None:
                    self._recent.append(float(bool(info.get("is_success", False))))
            stage = len(stages) - 1
            full = len(self._recent) == cfg.curriculum_window
            if stage + 1 < len(cfg.curriculum) and full:
                rate = float(np.mean(self._recent))
                if rate >= cfg.curriculum_threshold:
                    family = cfg.curriculum[stage + 1]
                    self.training_env.env_method("set_scenario", family)
                    if eval_env is not None:
                        eval_env.env_method("set_scenario", family)
                    stages[-1]["success_rate_at_end"] = rate
                    stages.append({"scenario": family, "timesteps": int(self.num_timesteps)})
                    self._recent.clear()
            return True

    class CurveCallback(BaseCallback):
        """Records every finished episode (Monitor's ``info["episode"]``)."""

        def _on_step(self) -> bool:
            for info in self.locals.get("infos", ()):
                row = finished_episode(info, self.num_timesteps)
                if row is not None:
                    rows.append(row)
            return True

    class TqdmCallback(BaseCallback):
        """A tqdm bar over the timesteps of this run."""

        def _on_training_start(self) -> None:
            from tqdm.auto import tqdm

            self._bar = tqdm(total=cfg.timesteps, unit="step", desc="PPO", dynamic_ncols=True)
            self._start = self.num_timesteps

        def _on_step(self) -> bool:
            done = self.num_timesteps - self._start
            self._bar.update(max(0, done - self._bar.n))
            if rows:
                recent = rows[-20:]
                self._bar.set_postfix(
                    ret=f"{np.mean([r['return'] for r in recent]):.2f}",
                    succ=f"{np.mean([r['success'] for r in recent]):.2f}",
                )
            return True

        def _on_training_end(self) -> None:
            self._bar.close()

    class BudgetCallback(BaseCallback):
        """Stops training once ``cfg.max_minutes`` have passed (the partial rollout is dropped)."""

        def _on_training_start(self) -> None:
            self._deadline = time.monotonic() + 60.0 * float(cfg.max_minutes or 0.0)

        def _on_step(self) -> bool:
            return time.monotonic() < self._deadline

    callbacks: list[Any] = [CurveCallback()]
    if cfg.curriculum:
        callbacks.append(CurriculumCallback())
    if cfg.max_minutes is not None:
        callbacks.append(BudgetCallback())
    if cfg.progress:
        callbacks.append(TqdmCallback())
    return callbacks


def _algorithm(cfg: TrainConfig) -> tuple[Any, str]:
    """The stable-baselines3 class of ``cfg.algo`` and its policy name."""
    if cfg.algo == "recurrent-ppo":
        from sb3_contrib import RecurrentPPO

        return RecurrentPPO, "MultiInputLstmPolicy"
    from stable_baselines3 import PPO

    return PPO, "MultiInputPolicy"


def _normalised(env: Any, cfg: TrainConfig, *, training: bool) -> Any:
    """``env`` under ``VecNormalize`` (rewards only) when ``cfg.normalize_reward``."""
    if not cfg.normalize_reward:
        return env
    from stable_baselines3.common.vec_env import VecNormalize

    return VecNormalize(
        env, training=training, norm_obs=False, norm_reward=training, gamma=cfg.gamma
    )


def train_ppo(cfg: TrainConfig) -> TrainResult:
    """Train (or resume) PPO as :class:`TrainConfig` says; see the module docstring for outputs.

    Sets this process's ``malloc`` to keep freed memory (:func:`~.runtime.keep_freed_memory`)."""
    import json

    import gymnasium as gym
    import torch
    from stable_baselines3.common.callbacks import CheckpointCallback, EvalCallback

    import stereo_nav_env  # noqa: F401  (registers ENV_ID, looked up below)

    keep_freed_memory()
    torch.set_num_threads(cfg.torch_threads)
    out = cfg.out_dir
    out.mkdir(parents=True, exist_ok=True)
    steps = cfg.env_kwargs.get("max_episode_steps", gym.spec(ENV_ID).max_episode_steps)
    rules = {"env_id": ENV_ID, **cfg.env_config().rules_dict(), "max_episode_steps": steps}
    (out / "rules.json").write_text(json.dumps(rules, indent=2) + "\n")
    env = _normalised(_vec_env(cfg, cfg.n_envs, cfg.seed), cfg, training=True)
    eval_env = None
    rows: list[dict[str, float]] = []
    stages: list[dict[str, Any]] = []
    algo, policy = _algorithm(cfg)
    started = time.monotonic()
    try:
        if cfg.resume is not None:
            model = algo.load(
                str(cfg.resume), env=env, device="cpu", tensorboard_log=str(out / "tb")
            )
        else:
            model = algo(
                policy,
                env,
                n_steps=cfg.n_steps,
                batch_size=cfg.batch_size,
                n_epochs=cfg.n_epochs,
                learning_rate=cfg.learning_rate,
                gamma=cfg.gamma,
                ent_coef=cfg.ent_coef,
                policy_kwargs={"net_arch": list(cfg.net_arch)},
                seed=cfg.seed,
                device="cpu",
                tensorboard_log=str(out / "tb"),
                verbose=cfg.verbose,
            )
        if cfg.eval_freq:
            from stable_baselines3.common.vec_env import VecTransposeImage

            eval_env = _normalised(_vec_env(cfg, 1, cfg.seed + 10_000), cfg, training=False)
            if isinstance(model.get_env(), VecTransposeImage):  # as PPO wrapped the training env
                eval_env = VecTransposeImage(eval_env)
        callbacks = _callbacks(cfg, rows, stages, eval_env)
        if cfg.checkpoint_freq:
            callbacks.append(
                CheckpointCallback(
                    save_freq=max(1, cfg.checkpoint_freq // cfg.n_envs),
                    save_path=str(out / "checkpoints"),
                    name_prefix="ppo",
                )
            )
        if eval_env is not None:
            callbacks.append(
                EvalCallback(
                    eval_env,
                    n_eval_episodes=cfg.eval_episodes,
                    eval_freq=max(1, cfg.eval_freq // cfg.n_envs),
                    best_model_save_path=str(out / "best"),
                    log_path=str(out / "eval"),
                    deterministic=True,
                    verbose=cfg.verbose,
                )
            )
        start_steps = int(model.num_timesteps) if cfg.resume is not None else 0
        model.learn(
            total_timesteps=cfg.timesteps,
            callback=callbacks,
            reset_num_timesteps=cfg.resume is None,
            tb_log_name=cfg.algo,
        )
        model_path = out / "ppo_final.zip"
        model.save(str(model_path))
        timesteps = int(model.num_timesteps)
    finally:
        env.close()
        if eval_env is not None:
            eval_env.close()
    wall_s = time.monotonic() - started
    curve_csv = out / "curve.csv"
    _append_curve(curve_csv, rows, fresh=cfg.resume is None)
    curve_png = plot_learning_curve(curve_csv, out / "learning_curve.png", out / "eval")
    summary = {
        "algo": cfg.algo,
        "timesteps": timesteps,
        "wall_s": round(wall_s, 1),
        "steps_per_s": round((timesteps - start_steps) / max(wall_s, 1e-9), 1),
        "episodes": len(rows),
        "curriculum": stages,
        "n_envs": cfg.n_envs,
        "env_kwargs": cfg.gym_kwargs,
        "seed": cfg.seed,
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=str) + "\n")
    return TrainResult(
        model_path=model_path,
        curve_csv=curve_csv,
        curve_png=curve_png,
        timesteps=timesteps,
        episodes=len(rows),
    )


_FIELDS = ("timesteps", "return", "length", "success")


def _append_curve(path: pathlib.Path, rows: list[dict[str, float]], *, fresh: bool) -> None:
    new = fresh or not path.exists()
    with path.open("w" if new else "a", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=_FIELDS)
        if new:
            writer.writeheader()
        writer.writerows(rows)


def plot_learning_curve(
    curve_csv: pathlib.Path, out_png: pathlib.Path, eval_dir: pathlib.Path | None = None
) -> pathlib.Path:
    """Plot the training returns and success rate (rolling means) and the evaluation returns.

    Args:
        curve_csv: The CSV written by :func:`train_ppo`.
        out_png: Where to write the figure.
        eval_dir: Folder holding ``evaluations.npz`` of ``EvalCallback`` (optional).

    Returns:
        ``out_png``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, ret, succ = [], [], []
    if curve_csv.exists():
        with curve_csv.open() as fh:
            for row in csv.DictReader(fh):
                t.append(float(row["timesteps"]))
                ret.append(float(row["return"]))
                succ.append(float(row["success"]))
    fig, (ax_r, ax_s) = plt.subplots(1, 2, figsize=(11, 4))
    if t:
        window = max(1, min(50, len(t) // 5 or 1))
        kernel = np.ones(window) / window
        smooth_r = np.convolve(ret, kernel, mode="valid")
        smooth_s = np.convolve(succ, kernel, mode="valid")
        tt = np.asarray(t)[window - 1 :]
        ax_r.plot(t, ret, ".", color="0.75", ms=3, label="episode")
        ax_r.plot(tt, smooth_r, color="tab:blue", label=f"mean of {window}")
        ax_s.plot(tt, smooth_s, color="tab:green", label=f"success, mean of {window}")
    if eval_dir is not None and (eval_dir / "evaluations.npz").exists():
        data = np.load(eval_dir / "evaluations.npz")
        ax_r.errorbar(
            data["timesteps"],
            data["results"].mean(axis=1),
            yerr=data["results"].std(axis=1),
            fmt="o-",
            color="tab:red",
            label="evaluation",
        )
        if "successes" in data and data["successes"].size:
            ax_s.plot(
                data["timesteps"],
                data["successes"].mean(axis=1),
                "o-",
                color="tab:red",
                label="evaluation",
            )
    ax_r.set_xlabel("timesteps")
    ax_r.set_ylabel("episode return")
    ax_s.set_xlabel("timesteps")
    ax_s.set_ylabel("success rate")
    ax_s.set_ylim(-0.05, 1.05)
    for ax in (ax_r, ax_s):
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    fig.suptitle(f"PPO on {ENV_ID}")
    fig.tight_layout()
    out_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=100)
    plt.close(fig)
    return out_png
