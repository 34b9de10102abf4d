"""PPO training on ``StereoNav-v1`` with Ray RLlib (``scripts/train.py --backend rllib``).

The same environment as :func:`agents.learning.training.train_ppo` (``gym.make(ENV_ID,
**env_kwargs)`` of the :class:`~agents.learning.training.TrainConfig`), scaled out over RLlib env
runners: each runner is a Ray worker process of its own (a fresh interpreter, not a fork, so each
builds its own EGL rendering context), with one torch thread. RLlib's new API stack (RLModule,
Learner, EnvRunner, ConnectorV2) runs PPO; the ``Dict`` observation reaches the default MLP through
two generic env-to-module connectors (:mod:`agents.learning.rllib.connectors`): ``ScaleBytes``
(every ``uint8`` box to ``[0, 1]`` float32, as stable-baselines3 scales images) and RLlib's
``FlattenObservations`` (every component to one vector). Neither names an observation key.

How the :class:`TrainConfig` fields map onto RLlib's ``PPOConfig``: the train batch is
``rollout_steps`` (sb3's rollout over all envs), each runner's rollout ``rollout_steps //
num_env_runners``; ``batch_size`` is the minibatch; ``n_epochs``, ``learning_rate``, ``gamma``,
``ent_coef`` (RLlib's ``entropy_coeff``), ``net_arch`` (the MLP's hidden layers, the policy's and
the value function's), ``seed`` and ``torch_threads`` (the learner's, in the driver) as named.
``curriculum`` and ``algo="recurrent-ppo"`` are refused; ``eval_freq``, ``resume`` and
``normalize_reward`` are the sb3 backend's (``evaluate.py --agent rllib:PATH`` evaluates a
checkpoint; rewards are not normalised).

:func:`train_rllib` writes in ``OUT``:

* ``OUT/checkpoint/``: the final RLlib checkpoint (``Algorithm.save_to_path``); evaluate it with
  ``make_agent("rllib:OUT/checkpoint")`` (:class:`agents.learning.rllib.agent.RLlibAgent`),
* ``OUT/checkpoints/iter_NNNNNN/``: periodic checkpoints (every ``checkpoint_freq`` steps),
* ``OUT/tb/``: TensorBoard scalars of every training iteration,
* ``OUT/results.jsonl``: one line of figures per iteration (steps, returns, steps/s),
* ``OUT/rules.json``: the episode rules, as the sb3 backend writes them.

ray is imported inside the functions, so importing this module is cheap and works without ray.
"""

from __future__ import annotations

import json
import math
import os
import pathlib
import time
from dataclasses import dataclass, field
from typing import Any

from agents.learning.training import ENV_ID, TrainConfig

__all__ = [
    "CHECKPOINT_DIR",
    "RLlibOptions",
    "RLlibResult",
    "make_env",
    "ppo_config",
    "rules_of",
    "train_rllib",
]

CHECKPOINT_DIR = "checkpoint"
"""The final checkpoint's folder under ``OUT``."""

RLLIB_ENV = "stereo-nav-rllib"
"""The name :func:`make_env` is registered under with Ray Tune's env registry."""

WORKER_ENV_VARS = {"PYOPENGL_PLATFORM": "egl", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
"""Environment of every Ray worker: headless EGL rendering, one torch (OpenMP) thread."""


@dataclass(frozen=True, slots=True, kw_only=True)
class RLlibOptions:
    """What the RLlib backend adds to a :class:`TrainConfig`.

    Attributes:
        num_env_runners: Env runner processes (0: sample in the driver process).
        address: A running Ray cluster to join (``ray.init(address=...)``, e.g. ``HEAD:6379``);
            ``None``: start a local Ray sized to the runners.
        log_to_driver: Forward the workers' output to this process.
    """

    num_env_runners: int = 2
    address: str | None = None
    log_to_driver: bool = True

    def __post_init__(self) -> None:
        n = self.num_env_runners
        if isinstance(n, bool) or not isinstance(n, int) or n < 0:
            raise ValueError(f"num_env_runners must be a non-negative integer, got {n!r}")
        if self.address is not None and (not isinstance(self.address, str) or not self.address):
            raise ValueError(f"address must be a non-empty string, got {self.address!r}")


@dataclass(frozen=True, slots=True, kw_only=True)
class RLlibResult:
    """What :func:`train_rllib` wrote and measured.

    Attributes:
        checkpoint: The final checkpoint folder.
        timesteps: Environment steps sampled in all.
        iterations: Training iterations.
        episodes: Episodes finished in all.
        wall_s: Seconds of training (``algo.train`` calls, set-up excluded).
        steps_per_s: ``timesteps / wall_s``.
        runner_pids: Process ids of the env runners (the driver's when ``num_env_runners == 0``).
        runner_torch_threads: ``torch.get_num_threads()`` in each of those processes.
    """

    checkpoint: pathlib.Path
    timesteps: int
    iterations: int
    episodes: int
    wall_s: float
    steps_per_s: float
    runner_pids: tuple[int, ...]
    runner_torch_threads: tuple[int, ...]


def make_env(env_config: dict[str, Any]) -> Any:
    """The env of one env runner: ``gym.make(ENV_ID, **env_config)`` (RLlib's env creator).

    Runs inside each runner process: it registers the ids there and keeps torch to one thread.
    RLlib passes an ``EnvContext`` (a ``dict`` with the runner index); only its items are used.
    """
    import gymnasium as gym
    import torch

    import stereo_nav_env  # noqa: F401  (registers the ids)

    torch.set_num_threads(1)
    return gym.make(ENV_ID, **dict(env_config))


def ppo_config(cfg: TrainConfig, options: RLlibOptions) -> Any:
    """RLlib's ``PPOConfig`` (new API stack) for ``cfg`` and ``options``."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
    from ray.tune.registry import register_env

    from agents.learning.rllib.connectors import env_to_module

    register_env(RLLIB_ENV, make_env)

    runners = options.num_env_runners
    train_batch = cfg.rollout_steps
    return (
        PPOConfig()
        .api_stack(enable_rl_module_and_learner=True, enable_env_runner_and_connector_v2=True)
        .framework("torch")
        .environment(env=RLLIB_ENV, env_config=cfg.gym_kwargs)
        .env_runners(
            num_env_runners=runners,
            num_envs_per_env_runner=1,
            num_cpus_per_env_runner=1,
            rollout_fragment_length=max(1, train_batch // max(1, runners)),
            env_to_module_connector=env_to_module,
        )
        .learners(num_learners=0)
        .training(
            train_batch_size_per_learner=train_batch,
            minibatch_size=min(cfg.batch_size, train_batch),
            num_epochs=cfg.n_epochs,
            lr=cfg.learning_rate,
            gamma=cfg.gamma,
            entropy_coeff=cfg.ent_coef,
        )
        .rl_module(
            model_config=DefaultModelConfig(
                fcnet_hiddens=list(cfg.net_arch), fcnet_activation="tanh", vf_share_layers=False
            )
        )
        .debugging(seed=cfg.seed, log_level="ERROR")
    )


def rules_of(cfg: TrainConfig) -> dict[str, Any]:
    """The episode rules of ``cfg``'s env (what both backends write to ``rules.json``)."""
    import gymnasium as gym

    import stereo_nav_env  # noqa: F401  (registers the ids)

    steps = cfg.gym_kwargs.get("max_episode_steps", gym.spec(ENV_ID).max_episode_steps)
    return {"env_id": ENV_ID, **cfg.env_config().rules_dict(), "max_episode_steps": steps}


def _init_ray(options: RLlibOptions) -> bool:
    """Start or join Ray; ``True`` when this call started it (and so must shut it down)."""
    import ray

    if ray.is_initialized():
        return False
    runtime_env = {"env_vars": dict(WORKER_ENV_VARS)}
    if options.address is not None:
        ray.init(
            address=options.address, runtime_env=runtime_env, log_to_driver=options.log_to_driver
        )
    else:
        ray.init(
            num_cpus=options.num_env_runners + 1,
            include_dashboard=False,
            log_to_driver=options.log_to_driver,
            runtime_env=runtime_env,
        )
    return True


def _scalars(result: dict[str, Any], prefix: str = "") -> dict[str, float]:
    """The finite numbers of a nested result dict, keyed by ``/``-joined paths."""
    out: dict[str, float] = {}
    for key, value in result.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(_scalars(value, name + "/"))
        elif isinstance(value, int | float) and not isinstance(value, bool):
            if math.isfinite(float(value)):
                out[name] = float(value)
    return out


@dataclass(slots=True)
class _Log:
    """``results.jsonl`` and the TensorBoard writer of one run."""

    out: pathlib.Path
    writer: Any = None
    rows: list[dict[str, float]] = field(default_factory=list)

    def __post_init__(self) -> None:
        from tensorboardX import SummaryWriter

        self.writer = SummaryWriter(str(self.out / "tb"))
        (self.out / "results.jsonl").write_text("")

    def add(self, result: dict[str, Any], row: dict[str, float]) -> None:
        step = int(row["timesteps"])
        for name, value in _scalars(result).items():
            self.writer.add_scalar(name, value, step)
        for name, value in _scalars(row).items():
            self.writer.add_scalar(f"stereo_nav/{name}", value, step)
        finite = {k: (v if math.isfinite(v) else None) for k, v in row.items()}
        with (self.out / "results.jsonl").open("a") as fh:  # null: no episode ended yet
            fh.write(json.dumps(finite, allow_nan=False) + "\n")
        self.rows.append(row)

    def close(self) -> None:
        self.writer.close()


def _row(result: dict[str, Any], wall_s: float, start_steps: int) -> dict[str, float]:
    from ray.rllib.utils.metrics import (
        ENV_RUNNER_RESULTS,
        EPISODE_LEN_MEAN,
        EPISODE_RETURN_MEAN,
        NUM_ENV_STEPS_SAMPLED_LIFETIME,
        NUM_EPISODES_LIFETIME,
    )

    runners = result.get(ENV_RUNNER_RESULTS, {})
    steps = int(runners.get(NUM_ENV_STEPS_SAMPLED_LIFETIME, 0))
    return {
        "iteration": float(result.get("training_iteration", 0)),
        "timesteps": float(steps),
        "episodes": float(runners.get(NUM_EPISODES_LIFETIME, 0)),
        "episode_return_mean": float(runners.get(EPISODE_RETURN_MEAN, math.nan)),
        "episode_len_mean": float(runners.get(EPISODE_LEN_MEAN, math.nan)),
        "wall_s": wall_s,
        "steps_per_s": (steps - start_steps) / wall_s if wall_s > 0 else 0.0,
    }


def _process_facts(runner: Any = None) -> tuple[int, int]:
    """``(pid, torch threads)`` of the calling process."""
    import torch

    return os.getpid(), int(torch.get_num_threads())


def _runner_facts(algo: Any) -> list[tuple[int, int]]:
    """:func:`_process_facts` of every process that samples (the env runners)."""
    group = algo.env_runner_group
    if group.num_remote_env_runners() == 0:
        return [_process_facts()]
    return list(group.foreach_env_runner(_process_facts, local_env_runner=False))


def train_rllib(cfg: TrainConfig, options: RLlibOptions | None = None) -> RLlibResult:
    """Train PPO with RLlib as ``cfg`` and ``options`` say; see the module docstring.

    Training runs whole iterations (about ``rollout_steps`` steps each) until
    ``cfg.timesteps`` steps are sampled or ``cfg.max_minutes`` have passed.

    Raises:
        ValueError: When ``cfg`` asks for what only the sb3 backend does (``resume``,
            ``curriculum``, ``algo="recurrent-ppo"``), naming the field.
    """
    import torch

    options = options or RLlibOptions()
    if cfg.resume is not None:
        raise ValueError("resume is for the sb3 backend; the rllib backend starts afresh")
    if cfg.curriculum:
        raise ValueError("curriculum is for the sb3 backend; give the rllib backend a --scenario")
    if cfg.algo != "ppo":
        raise ValueError(f"algo must be 'ppo' for the rllib backend, got {cfg.algo!r}")
    torch.set_num_threads(cfg.torch_threads)
    out = cfg.out_dir
    out.mkdir(parents=True, exist_ok=True)
    (out / "rules.json").write_text(json.dumps(rules_of(cfg), indent=2) + "\n")
    started = _init_ray(options)
    algo = None
    log = _Log(out)
    try:
        import ray

        algo = ppo_config(cfg, options).build_algo()
        facts = _runner_facts(algo)
        bar = None
        if cfg.progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=cfg.timesteps, unit="step", desc="PPO (RLlib)", dynamic_ncols=True)
        deadline = math.inf if cfg.max_minutes is None else time.monotonic() + 60 * cfg.max_minutes
        steps, wall, next_save = 0, 0.0, cfg.checkpoint_freq or math.inf
        while steps < cfg.timesteps and time.monotonic() < deadline:
            t0 = time.perf_counter()
            result = algo.train()
            wall += time.perf_counter() - t0
            row = _row(result, wall, 0)
            log.add(result, row)
            if bar is not None:
                bar.update(int(row["timesteps"]) - steps)
                bar.set_postfix(ret=f"{row['episode_return_mean']:.2f}")
            steps = int(row["timesteps"])
            if steps >= next_save and steps < cfg.timesteps:
                algo.save_to_path(str(out / "checkpoints" / f"iter_{int(row['iteration']):06d}"))
                next_save += cfg.checkpoint_freq
        if bar is not None:
            bar.close()
        checkpoint = out / CHECKPOINT_DIR
        algo.save_to_path(str(checkpoint))
        episodes = int(log.rows[-1]["episodes"]) if log.rows else 0
        del ray
    finally:
        log.close()
        if algo is not None:
            algo.stop()
        if started:
            import ray

            ray.shutdown()
    return RLlibResult(
        checkpoint=checkpoint,
        timesteps=steps,
        iterations=len(log.rows),
        episodes=episodes,
        wall_s=wall,
        steps_per_s=steps / wall if wall > 0 else 0.0,
        runner_pids=tuple(pid for pid, _ in facts),
        runner_torch_threads=tuple(threads for _, threads in facts),
    )
