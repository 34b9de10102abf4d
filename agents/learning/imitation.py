"""Learning from the planner: behaviour cloning, then DAgger rounds (``train.py --teacher``).

The recipe (:func:`train_imitation`, :class:`ImitationConfig`):

1. **Demonstrations.** ``n_envs`` training envs (:func:`agents.learning.wrappers.make_training_env`:
   the surrogate perception by default, every family of the curriculum mixed, the suite's episode
   rules) are driven by the teacher (the expected-cost ``planner``); every state it observes is
   stored with its action.
2. **Cloning.** :class:`EgoPolicyNet` (a small stride-2 CNN over the egocentric map, an MLP over
   the features) is fitted to the stored actions. Each of the three commands is predicted as a
   distribution over ``bins`` values in [-1, 1] (cross-entropy against the target split between
   its two nearest bins), so "left" and "right" around an obstacle stay two modes instead of
   averaging to "straight"; the action is the mean of the most probable bin and its two
   neighbours.
3. **DAgger rounds** (Ross et al., 2011). The student drives (with probability ``beta`` per step
   the teacher's action is sent instead); every state the student reaches is labelled with the
   teacher's action, computed by a teacher whose memory followed the student's trajectory
   (:class:`~agents.learning.wrappers.PlannerTeacher`); the data are aggregated and the
   student is trained again.

The envs step in subprocesses (gymnasium's ``AsyncVectorEnv``, ``forkserver``); the policy acts
on a batch in the main process. ``info`` crosses the pipe without the model objects
(``info_models=False``).

Outputs in ``out_dir``: ``policy.pt`` (the network's weights and its metadata: observation
version and geometry, episode rules, bins, the command line, the record),
``checkpoints/phaseK.pt`` (the policy after phase K: 0 the cloning, K the K-th round),
``record.json`` (per
phase: steps, episodes, success rate of the driving policy, loss, held-out loss and bin accuracy
per command, minutes) and ``curve.csv``
(per finished training episode: env steps so far, length, success, phase, beta: the learning
curve of the driving policy, the teacher's during the demonstrations;
:func:`agents.learning.seeds.plot_seed_curves` draws it).

torch is imported inside the functions that need it.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import pathlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.learning.egomap import (
    CHANNELS,
    OBSERVATION_VERSION,
    STATE_FEATURES,
    EgoMapConfig,
    mirrored,
)
from agents.learning.runtime import keep_freed_memory, pinned_maker
from modeling.validation import with_overrides

__all__ = [
    "ImitationConfig",
    "ImitationResult",
    "PolicyBundle",
    "decode_bins",
    "encode_bins",
    "fit_speed",
    "load_policy",
    "train_imitation",
    "training_vector_env",
]

TRAIN_FAMILIES = ("open", "sparse", "room", "corridor", "cluttered", "office")
"""The whole curriculum (``agents.learning.training.CURRICULUM``)."""
TRAIN_WEIGHTS = (0.5, 0.5, 1.0, 1.0, 1.0, 1.0)
"""Their shares of the training episodes: the standard families twice the easy ones."""


# ---------------------------------------------------------------------------- action coding
def encode_bins(actions: NDArray[np.floating], bins: int) -> NDArray[np.float32]:
    """(n, 3, bins) soft targets: each value split between its two nearest of ``bins`` values
    spread evenly over [-1, 1] (so :func:`decode_bins` of a target gives the value back)."""
    a = np.clip(np.asarray(actions, dtype=np.float64).reshape(-1, 3), -1.0, 1.0)
    pos = (a + 1.0) * 0.5 * (bins - 1)
    lo = np.clip(np.floor(pos).astype(np.int64), 0, bins - 2)
    frac = pos - lo
    out = np.zeros((a.shape[0], 3, bins), dtype=np.float32)
    n, k = np.meshgrid(np.arange(a.shape[0]), np.arange(3), indexing="ij")
    out[n, k, lo] = 1.0 - frac
    out[n, k, lo + 1] += frac
    return out


def decode_bins(probs: NDArray[np.floating]) -> NDArray[np.float32]:
    """(n, 3) actions from (n, 3, bins) probabilities: the probability-weighted mean of the most
    probable bin and its two neighbours (one mode, never the average of two)."""
    p = np.asarray(probs, dtype=np.float64)
    bins = p.shape[-1]
    values = np.linspace(-1.0, 1.0, bins)
    best = p.argmax(axis=-1)
    out = np.zeros(p.shape[:-1])
    weight = np.zeros(p.shape[:-1])
    for d in (-1, 0, 1):
        idx = np.clip(best + d, 0, bins - 1)
        w = np.take_along_axis(p, idx[..., None], axis=-1)[..., 0]
        w = np.where((best + d >= 0) & (best + d < bins), w, 0.0)
        out += w * values[idx]
        weight += w
    return (out / np.maximum(weight, 1e-12)).astype(np.float32)


# ---------------------------------------------------------------------------- the network
def _network(channels: int, size_px: int, state_dim: int, bins: int, width: int) -> Any:
    """The policy network (a ``torch.nn.Module``): map (B, C, S, S) uint8 and state (B, V)
    -> logits (B, 3, bins)."""
    import torch
    from torch import nn

    class EgoPolicyNet(nn.Module):
        """Small stride-2 CNN over the map (S -> S/16), an MLP over the features, three heads."""

        def __init__(self) -> None:
            super().__init__()
            self.encoder = nn.Sequential(
                nn.Conv2d(channels, 16, 3, stride=2, padding=1),
                nn.ReLU(),
                nn.Conv2d(16, 32, 3, stride=2, padding=1),
                nn.ReLU(),
                nn.Conv2d(32, 64, 3, stride=2, padding=1),
                nn.ReLU(),
                nn.Conv2d(64, 64, 3, stride=2, padding=1),
                nn.ReLU(),
                nn.Flatten(),
            )
            flat = 64 * math.ceil(size_px / 16) ** 2
            self.state = nn.Sequential(nn.Linear(state_dim, 64), nn.ReLU())
            self.head = nn.Sequential(
                nn.Linear(flat + 64, width),
                nn.ReLU(),
                nn.Linear(width, width),
                nn.ReLU(),
                nn.Linear(width, 3 * bins),
            )

        def forward(self, image: torch.Tensor, state: torch.Tensor) -> torch.Tensor:
            x = self.encoder(image.float() / 255.0)
            y = self.state(state)
            logits: torch.Tensor = self.head(torch.cat([x, y], dim=1)).view(-1, 3, bins)
            return logits

    return EgoPolicyNet()


@dataclass(slots=True)
class PolicyBundle:
    """A trained policy and what it needs to act.

    Attributes:
        net: The ``torch.nn.Module``.
        egomap: The observation geometry it was trained on.
        bins: Bins per command.
        meta: Everything saved beside the weights (version, rules, command, record).
    """

    net: Any
    egomap: EgoMapConfig
    bins: int
    meta: dict[str, Any]

    def act(self, maps: NDArray[np.uint8], states: NDArray[np.float32]) -> NDArray[np.float32]:
        """(n, 3) actions for a batch of observations."""
        import torch

        with torch.no_grad():
            logits = self.net(torch.from_numpy(np.asarray(maps)), torch.from_numpy(states))
            probs = torch.softmax(logits, dim=-1).numpy()
        return decode_bins(probs)

    def save(self, path: pathlib.Path) -> None:
        """Write the weights and metadata to ``path`` (a ``.pt`` file)."""
        import torch

        path.parent.mkdir(parents=True, exist_ok=True)
        torch.save({"state_dict": self.net.state_dict(), "meta": self.meta}, path)


def _new_bundle(egomap: EgoMapConfig, bins: int, width: int, meta: dict[str, Any]) -> PolicyBundle:
    net = _network(len(CHANNELS), egomap.size_px, len(STATE_FEATURES), bins, width)
    return PolicyBundle(net=net, egomap=egomap, bins=bins, meta=meta)


def load_policy(path: pathlib.Path | str) -> PolicyBundle:
    """The policy saved at ``path`` by :func:`train_imitation`.

    Raises:
        FileNotFoundError: When there is no such file.
        ValueError: When it was trained on another observation version, or holds a network of
            another shape.
    """
    import torch

    path = pathlib.Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no trained policy at {path}")
    saved = torch.load(path, map_location="cpu", weights_only=False)
    meta = dict(saved["meta"])
    version = meta.get("observation_version")
    if version != OBSERVATION_VERSION:
        raise ValueError(
            f"{path} was trained on observation version {version}, this code builds "
            f"version {OBSERVATION_VERSION}"
        )
    egomap = EgoMapConfig.from_dict(meta["egomap"])
    bundle = _new_bundle(egomap, int(meta["bins"]), int(meta["width"]), meta)
    try:
        bundle.net.load_state_dict(saved["state_dict"])
    except RuntimeError as exc:
        raise ValueError(f"{path} holds a network this code does not build: {exc}") from None
    bundle.net.eval()
    return bundle


# ---------------------------------------------------------------------------- the recipe
@dataclass(frozen=True, slots=True, kw_only=True)
class ImitationConfig:
    """What :func:`train_imitation` does.

    Attributes:
        out_dir: Output folder.
        seed: Seed of the network, the envs (env ``i`` resets first with ``seed * 1000 + i``,
            then continues its own stream) and the family draws.
        teacher: The teacher: ``"planner"`` (or ``"greedy"``, ``"cautious"``).
        teacher_settings: Fields of the teacher's
            :class:`~agents.planning.config.NavigatorConfig` (none: its defaults, the
            suite's planner), e.g. ``{"replan_every": 1}``.
        n_envs: Env subprocesses.
        demo_steps: Env steps of teacher demonstrations (over all envs).
        rounds: DAgger rounds.
        round_steps: Env steps per DAgger round.
        betas: Probability per step that the teacher's action is sent, per round (the last
            value repeats).
        epochs: Passes over the aggregated data after the demonstrations and after each round.
        batch_size: Minibatch size.
        learning_rate: Adam step size at the start of each fit.
        final_lr_share: Each fit's step size falls along a cosine from ``learning_rate`` to
            this share of it by its last minibatch (1, the recipe's: constant). Two seeds at
            0.1 ended every phase on a higher training loss (0.92-0.93 after the last round
            against 0.86-0.87 at 1) and drove worse in their last round (docs/training.md):
            the student is under-fitted, not shaken off a minimum by a large step.
        mirror_share: Share of each minibatch replaced by its left-right mirror image
            (:func:`agents.learning.egomap.mirrored`, the turn and pan labels negated): the
            scenes have no preferred side, so the mirror is a sample of the same task (0.5, the
            recipe's since PPO fine-tuning joined it: its three seeds were run mirrored; on
            its own the mirror moved dev success by no more than the spread between seeds).
        validation_share: Share of the samples held out of the fits (drawn per sample as it is
            stored); each phase's record gives the loss and the per-command bin accuracy on
            them, to tell an under-fitted student from one that fits but drives badly.
        bins: Bins per command.
        width: Hidden width of the MLP.
        env_kwargs: Keyword arguments of ``gym.make("StereoNav-v1", ...)`` (the suite's episode
            rules unless they change one; ``perception`` among them).
        families: Scene families of the training episodes, and ``weights`` their shares.
        weights: Shares of ``families``.
        egomap: The observation geometry.
        pin_envs: Pin env process ``i`` to core ``i`` when the env processes fill the machine
            (:func:`~.runtime.pinned_maker`).
        torch_threads: torch's threads in the main process's fits (the student acts on one).
        command: The command line that ran (recorded in the policy).
        progress: Show progress bars.
    """

    out_dir: pathlib.Path
    seed: int = 0
    teacher: str = "planner"
    teacher_settings: dict[str, Any] = field(default_factory=dict)
    n_envs: int = 2
    demo_steps: int = 60_000
    rounds: int = 4
    round_steps: int = 22_500
    betas: tuple[float, ...] = (0.5, 0.3, 0.1, 0.0)
    epochs: int = 3
    batch_size: int = 256
    learning_rate: float = 1e-3
    final_lr_share: float = 1.0
    mirror_share: float = 0.5
    validation_share: float = 0.05
    bins: int = 11
    width: int = 256
    env_kwargs: dict[str, Any] = field(
        default_factory=lambda: {"perception": "surrogate", "diagnostics": False}
    )
    families: tuple[str, ...] = TRAIN_FAMILIES
    weights: tuple[float, ...] = TRAIN_WEIGHTS
    egomap: EgoMapConfig = field(default_factory=EgoMapConfig)
    pin_envs: bool = True
    torch_threads: int = 2
    command: str = ""
    progress: bool = True

    def __post_init__(self) -> None:
        from agents.planning.config import NavigatorConfig, Policy

        if self.teacher not in {p.value for p in Policy}:
            raise ValueError(
                f"teacher must be one of {[p.value for p in Policy]}, got {self.teacher!r}"
            )
        if "policy" in self.teacher_settings:
            raise ValueError("teacher_settings must not set policy (teacher names it)")
        with_overrides(None, NavigatorConfig, self.teacher_settings)  # names a bad field
        for name in ("n_envs", "demo_steps", "batch_size", "bins", "width", "torch_threads"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        for name in ("rounds", "round_steps", "epochs"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ValueError(f"{name} must be a non-negative integer, got {value!r}")
        if self.bins < 3:
            raise ValueError(f"bins must be at least 3, got {self.bins}")
        if not 0.0 < self.final_lr_share <= 1.0:
            raise ValueError(f"final_lr_share must lie in (0, 1], got {self.final_lr_share!r}")
        if not 0.0 <= self.mirror_share <= 1.0:
            raise ValueError(f"mirror_share must lie in [0, 1], got {self.mirror_share!r}")
        if not 0.0 <= self.validation_share < 0.5:
            raise ValueError(
                f"validation_share must lie in [0, 0.5), got {self.validation_share!r}"
            )
        if not self.betas or any(not 0.0 <= b <= 1.0 for b in self.betas):
            raise ValueError(f"betas must be probabilities, got {self.betas!r}")
        if len(self.weights) != len(self.families):
            raise ValueError("weights must give one share per family")
        if "info_models" in self.env_kwargs or "scenario" in self.env_kwargs:
            raise ValueError("env_kwargs must not set info_models or scenario (the recipe does)")

    def rules(self) -> dict[str, Any]:
        """The episode rules of the training envs (``EnvConfig.rules_dict()`` of StereoNav-v1
        with ``env_kwargs``, the env id and the step limit): the suite's when unchanged."""
        import gymnasium as gym

        from agents.evaluation.suite import ENV_ID, env_config

        return {
            "env_id": ENV_ID,
            **env_config(ENV_ID, **self.env_kwargs).rules_dict(),
            "max_episode_steps": gym.spec(ENV_ID).max_episode_steps,
        }

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly dict of the fields."""
        out: dict[str, Any] = {}
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            if isinstance(value, pathlib.Path):
                value = str(value)
            elif isinstance(value, EgoMapConfig):
                value = value.to_dict()
            elif isinstance(value, tuple):
                value = list(value)
            out[name] = value
        return out


@dataclass(frozen=True, slots=True, kw_only=True)
class ImitationResult:
    """What :func:`train_imitation` wrote.

    Attributes:
        policy_path: The trained policy (``policy.pt``).
        record: Per phase: steps, episodes, success rate of the driving policy, loss, the
            held-out loss and per-command bin accuracy, minutes.
        minutes: Wall time of the whole recipe, minutes.
        steps: Env steps collected.
    """

    policy_path: pathlib.Path
    record: list[dict[str, Any]]
    minutes: float
    steps: int


class _Dataset:
    """The aggregated (map, state, teacher action) samples, stored in arrays that grow by
    doubling (``capacity`` first: the recipe reserves its whole run, and pages no sample reached
    are never touched), so that every sample is held once; each sample is held out for
    validation with probability ``validation_share`` when it is stored."""

    def __init__(self, validation_share: float = 0.0, seed: int = 0, capacity: int = 0) -> None:
        self.validation_share = validation_share
        self._rng = np.random.default_rng(seed)
        self._capacity = max(int(capacity), 0)
        self._n = 0
        # maps, states, actions, held-out mask: one row per sample (None before the first)
        self._columns: tuple[NDArray[Any], ...] | None = None

    def add(self, maps: NDArray[np.uint8], states: NDArray[np.float32], actions: Any) -> None:
        actions = np.asarray(actions, dtype=np.float32).reshape(-1, 3)
        k = actions.shape[0]
        rows: tuple[NDArray[Any], ...] = (
            np.asarray(maps, dtype=np.uint8),
            np.asarray(states, dtype=np.float32),
            actions,
            self._rng.random(k) < self.validation_share,
        )
        n = self._n + k
        if self._columns is None or n > self._columns[0].shape[0]:
            size = max(n, self._capacity, 2 * self._n)
            grown = tuple(np.empty((size, *r.shape[1:]), dtype=r.dtype) for r in rows)
            for new, old in zip(grown, self._columns or (), strict=False):
                new[: self._n] = old[: self._n]
            self._columns = grown
        for column, r in zip(self._columns, rows, strict=True):
            column[self._n : n] = r
        self._n = n

    def arrays(
        self,
    ) -> tuple[NDArray[np.uint8], NDArray[np.float32], NDArray[np.float32], NDArray[np.bool_]]:
        """Maps, states, actions and the held-out mask of every sample (views, not copies)."""
        if self._columns is None:
            raise ValueError("the dataset holds no samples yet")
        maps, states, actions, held_out = (c[: self._n] for c in self._columns)
        return maps, states, actions, held_out

    def __len__(self) -> int:
        return self._n


def training_vector_env(cfg: ImitationConfig) -> Any:
    """The recipe's vector env: ``n_envs`` training envs (in subprocesses, pinned to cores as
    ``cfg.pin_envs`` says, when more than one)."""
    import functools

    import gymnasium as gym

    from agents.learning.wrappers import make_training_env

    make = functools.partial(
        make_training_env,
        dict(cfg.env_kwargs),
        families=cfg.families,
        weights=cfg.weights,
        teacher=cfg.teacher,
        teacher_settings=cfg.teacher_settings,
        egomap=cfg.egomap,
    )
    if cfg.n_envs == 1:
        return gym.vector.SyncVectorEnv([make])
    makers: list[Callable[[], Any]] = [make] * cfg.n_envs
    if cfg.pin_envs:
        makers = [pinned_maker(make, i, cfg.n_envs) for i, make in enumerate(makers)]
    return gym.vector.AsyncVectorEnv(makers, context="forkserver")


def _collect(
    venv: Any,
    state: dict[str, Any],
    student: PolicyBundle | None,
    beta: float,
    steps: int,
    data: _Dataset,
    rng: np.random.Generator,
    bar: Any,
) -> list[dict[str, float]]:
    """Drive ``steps`` env steps (teacher with probability ``beta`` per step, else the
    student), storing every non-terminal state with the teacher's label; returns the finished
    episodes (``timesteps``: env steps so far, ``length``, ``success``)."""
    obs, info, done, lengths = state["obs"], state["info"], state["done"], state["lengths"]
    n = len(done)
    episodes: list[dict[str, float]] = []
    taken = 0
    while taken < steps:
        teacher = np.asarray(info["teacher_action"], dtype=np.float32).reshape(n, 3)
        keep = ~done
        if keep.any():
            data.add(obs["map"][keep], obs["state"][keep], teacher[keep])
        action = teacher.copy()
        if student is not None and beta < 1.0:
            own = student.act(obs["map"], obs["state"])
            use_student = rng.random(n) >= beta
            action[use_student] = own[use_student]
        obs, _, terminated, truncated, info = venv.step(action)
        taken += int(keep.sum())
        state["steps"] += int(keep.sum())
        lengths = np.where(keep, lengths + 1, 0)
        done = np.asarray(terminated) | np.asarray(truncated)
        success = np.asarray(info.get("is_success", np.zeros(n)), dtype=bool)
        for i in np.flatnonzero(done):
            episodes.append(
                {
                    "timesteps": float(state["steps"]),
                    "length": float(lengths[i]),
                    "success": float(success[i]),
                }
            )
        bar.update(int(keep.sum()))
    state.update(obs=obs, info=info, done=done, lengths=lengths)
    return episodes


def _bin_loss(logits: Any, targets: Any) -> Any:
    """The fits' loss (a torch scalar): cross-entropy of (n, 3, bins) ``logits`` against the soft
    targets of :func:`encode_bins`, averaged over the samples and the three commands."""
    import torch

    return -(targets * torch.log_softmax(logits, dim=-1)).sum(dim=-1).mean()


_MIRROR_ODD_COMMANDS = slice(1, 3)
"""The commands (forward, turn, pan) that change sign in the mirror image: turn and pan."""


def _minibatch(
    maps: NDArray[np.uint8],
    states: NDArray[np.float32],
    targets: NDArray[np.float32],
    idx: NDArray[np.int64],
    mirror_share: float,
    rng: np.random.Generator,
) -> tuple[NDArray[np.uint8], NDArray[np.float32], NDArray[np.float32]]:
    """The samples ``idx`` (maps, states, soft targets), each replaced by its mirror image with
    probability ``mirror_share``: :func:`mirrored` observation, turn and pan bins reversed (the
    bins are symmetric about 0, so that is the target of the negated command)."""
    image, state, target = maps[idx], states[idx], targets[idx]
    if mirror_share <= 0.0:
        return image, state, target
    flip = rng.random(idx.size) < mirror_share
    if flip.any():
        image[flip], state[flip] = mirrored(image[flip], state[flip])
        target[flip, _MIRROR_ODD_COMMANDS] = target[flip, _MIRROR_ODD_COMMANDS, ::-1]
    return image, state, target


def _fit(
    bundle: PolicyBundle,
    data: _Dataset,
    cfg: ImitationConfig,
    rng: np.random.Generator,
    *,
    channels_last: bool = True,
) -> dict[str, float]:
    """``cfg.epochs`` passes of Adam over the samples not held out; returns ``loss`` (the mean
    of the last pass) and :func:`_validate`'s figures on the held-out ones. ``channels_last``
    False fits in NCHW (the same sums, slower; ``scripts/bench_training.py`` compares them)."""
    import torch

    maps, states, actions, held_out = data.arrays()
    targets = encode_bins(actions, cfg.bins)
    net = bundle.net
    net.train()
    # Channels-last (NHWC) weights and batches: oneDNN's convolutions, most of a fit's time,
    # run faster on them on this CPU than on NCHW (the same sums; docs/training.md). The net
    # goes back to NCHW after the fit, so acting is unchanged.
    layout = torch.channels_last if channels_last else torch.contiguous_format
    net.to(memory_format=layout)
    optimiser = torch.optim.Adam(net.parameters(), lr=cfg.learning_rate)
    train = np.flatnonzero(~held_out)
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(
        optimiser,
        T_max=max(cfg.epochs * math.ceil(train.size / cfg.batch_size), 1),
        eta_min=cfg.learning_rate * cfg.final_lr_share,
    )
    last = math.nan
    for _ in range(cfg.epochs):
        order = rng.permutation(train)
        total = 0.0
        for start in range(0, order.size, cfg.batch_size):
            idx = np.sort(order[start : start + cfg.batch_size])
            batch = _minibatch(maps, states, targets, idx, cfg.mirror_share, rng)
            image = torch.from_numpy(batch[0]).contiguous(memory_format=layout)
            logits = net(image, torch.from_numpy(batch[1]))
            loss = _bin_loss(logits, torch.from_numpy(batch[2]))
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            schedule.step()
            total += float(loss.detach()) * idx.size
        last = total / max(order.size, 1)
    net.to(memory_format=torch.contiguous_format)
    net.eval()
    held = np.flatnonzero(held_out)
    return {"loss": last, **_validate(bundle, maps[held], states[held], actions[held])}


def fit_speed(cfg: ImitationConfig, samples: int = 4096, repeats: int = 2) -> dict[str, float]:
    """Samples per second of one epoch of the recipe's fit (``cfg``'s network, batch size and
    threads) on ``samples`` random observations, channels-last (as :func:`train_imitation`
    fits) and NCHW, alternately ``repeats`` times: the best of each, and their ratio
    (``fit_channels_last_over_nchw``). Printed by ``scripts/bench_training.py``."""
    import torch

    torch.set_num_threads(cfg.torch_threads)
    rng = np.random.default_rng(0)
    s = cfg.egomap.size_px
    data = _Dataset()
    data.add(
        rng.integers(0, 256, size=(samples, len(CHANNELS), s, s), dtype=np.uint8),
        rng.uniform(-1.0, 1.0, size=(samples, len(STATE_FEATURES))).astype(np.float32),
        rng.uniform(-1.0, 1.0, size=(samples, 3)).astype(np.float32),
    )
    one_epoch = dataclasses.replace(cfg, epochs=1)
    best = {True: 0.0, False: 0.0}
    for _ in range(repeats):
        for channels_last in (True, False):
            bundle = _new_bundle(cfg.egomap, cfg.bins, cfg.width, {})
            t0 = time.perf_counter()
            _fit(bundle, data, one_epoch, rng, channels_last=channels_last)
            best[channels_last] = max(best[channels_last], samples / (time.perf_counter() - t0))
    return {
        "fit_samples_per_s_channels_last": best[True],
        "fit_samples_per_s_nchw": best[False],
        "fit_channels_last_over_nchw": best[True] / best[False],
    }


def _validate(
    bundle: PolicyBundle,
    maps: NDArray[np.uint8],
    states: NDArray[np.float32],
    actions: NDArray[np.float32],
) -> dict[str, float]:
    """On held-out samples: ``val_loss`` (the training loss) and, per command, the share whose
    most probable bin is the bin nearest the teacher's value (``val_accuracy_forward``,
    ``..._turn``, ``..._pan``); NaN without samples."""
    import torch

    names = ("forward", "turn", "pan")
    if actions.shape[0] == 0:
        return {"val_loss": math.nan, **{f"val_accuracy_{k}": math.nan for k in names}}
    bins = bundle.bins
    logits = []
    with torch.no_grad():
        for start in range(0, actions.shape[0], 1024):
            part = slice(start, start + 1024)
            logits.append(
                bundle.net(torch.from_numpy(maps[part]), torch.from_numpy(states[part])).numpy()
            )
    z = torch.from_numpy(np.concatenate(logits))
    loss = float(_bin_loss(z, torch.from_numpy(encode_bins(actions, bins))))
    nearest = np.rint((np.clip(actions, -1.0, 1.0) + 1.0) * 0.5 * (bins - 1)).astype(np.int64)
    hit = z.numpy().argmax(axis=-1) == nearest
    return {
        "val_loss": loss,
        **{f"val_accuracy_{k}": float(hit[:, i].mean()) for i, k in enumerate(names)},
    }


def train_imitation(
    cfg: ImitationConfig, on_phase: Callable[[dict[str, Any]], None] | None = None
) -> ImitationResult:
    """Run the recipe (module docstring); ``on_phase`` sees each phase's record.

    Sets this process's ``malloc`` to keep freed memory (:func:`~.runtime.keep_freed_memory`:
    the fits' minibatches otherwise fault their tensors' pages in afresh each time)."""
    import torch
    from tqdm.auto import tqdm

    keep_freed_memory()
    t0 = time.perf_counter()
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    out = pathlib.Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    meta: dict[str, Any] = {
        "observation_version": OBSERVATION_VERSION,
        "egomap": cfg.egomap.to_dict(),
        "bins": cfg.bins,
        "width": cfg.width,
        "rules": cfg.rules(),
        "config": cfg.to_dict(),
        "command": cfg.command,
    }
    bundle = _new_bundle(cfg.egomap, cfg.bins, cfg.width, meta)
    total = cfg.demo_steps + cfg.rounds * cfg.round_steps
    data = _Dataset(cfg.validation_share, cfg.seed, capacity=total + cfg.n_envs)
    record: list[dict[str, Any]] = []  # one row per phase (the demonstrations, each round)
    curve: list[dict[str, Any]] = []  # one row per finished training episode
    venv = training_vector_env(cfg)
    bar = tqdm(total=total, unit="step", desc="imitation", disable=not cfg.progress)
    try:
        obs, info = venv.reset(seed=[cfg.seed * 1000 + i for i in range(cfg.n_envs)])
        state = {
            "obs": obs,
            "info": info,
            "done": np.zeros(cfg.n_envs, dtype=bool),
            "lengths": np.zeros(cfg.n_envs, dtype=np.int64),
            "steps": 0,
        }
        for phase in range(cfg.rounds + 1):
            beta = 1.0 if phase == 0 else cfg.betas[min(phase - 1, len(cfg.betas) - 1)]
            steps = cfg.demo_steps if phase == 0 else cfg.round_steps
            student = None if phase == 0 else bundle
            before = state["steps"]
            # The student acts on a batch of n_envs maps: one thread does it in under a
            # millisecond, where a team of threads waits on its slowest member, 30x longer
            # when other processes hold the cores (docs/training.md, "Training throughput").
            torch.set_num_threads(1)
            finished = _collect(venv, state, student, beta, steps, data, rng, bar)
            name = "demonstrations" if phase == 0 else f"dagger {phase}"
            curve += [{**e, "phase": name, "beta": beta} for e in finished]
            torch.set_num_threads(cfg.torch_threads)
            fit = _fit(bundle, data, cfg, rng)
            successes = [e["success"] for e in finished]
            row: dict[str, Any] = {
                "phase": name,
                "beta": beta,
                "steps": state["steps"] - before,
                "episodes": len(finished),
                "success_rate": float(np.mean(successes)) if successes else math.nan,
                "samples": len(data),
                **fit,
                "minutes": (time.perf_counter() - t0) / 60.0,
            }
            record.append(row)
            bundle.meta["record"] = record
            bundle.save(out / "checkpoints" / f"phase{phase}.pt")
            if on_phase is not None:
                on_phase(row)
    finally:
        bar.close()
        venv.close()
    minutes = (time.perf_counter() - t0) / 60.0
    bundle.meta["record"] = record
    bundle.meta["minutes"] = minutes
    path = out / "policy.pt"
    bundle.save(path)
    (out / "record.json").write_text(json.dumps({"record": record, "minutes": minutes}, indent=2))
    with (out / "curve.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=["timesteps", "length", "success", "phase", "beta"])
        writer.writeheader()
        writer.writerows(curve)
    return ImitationResult(
        policy_path=path, record=record, minutes=minutes, steps=int(sum(r["steps"] for r in record))
    )
