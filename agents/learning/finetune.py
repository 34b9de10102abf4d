"""PPO fine-tuning of an imitation policy under the suite's rules (``train.py --finetune``).

The student of :mod:`agents.learning.imitation` predicts each command (forward, turn, pan) as a
distribution over ``bins`` values in [-1, 1]; that is a policy over the ``MultiDiscrete([bins] *
3)`` actions of :class:`BinActions`, so stable-baselines3's PPO can go on training it with the
env's own reward (:mod:`stereo_nav_env.rewards`: geodesic progress, goal, contact and time
terms) in the imitation's training envs (:func:`agents.learning.wrappers.make_training_env`, the
same families, perception and episode rules, no teacher).

:func:`finetune_policy`:

1. builds a PPO actor-critic (:class:`EgoFeatures`: the imitation network's encoder and feature
   MLP; its two hidden layers; its output layer as the action net) and copies the imitation
   weights into it, so that before any update PPO's action distribution *is* the imitation
   policy's (``tests/agents/learning/test_finetune.py`` checks the logits); in rollouts it
   draws the action bins from the logits directly (:func:`sample_bins`: the draws of
   stable-baselines3's distribution, in a forward that costs about 0.6 of its own); the critic reads
   the actor's encoder and feature MLP through a stop-gradient (``critic_encoder="actor"``;
   ``"own"`` gives it its own copy of the encoder, trained by the value loss: twice the
   convolutions) and starts from copies of the hidden layers with a fresh value output;
2. trains the critic alone for ``critic_warmup_rollouts`` rollouts (the actor's parameters
   frozen), so that the first policy updates use advantages of a critic that knows the returns,
   not of a random one that would pull the actor away from what it imitated;
3. runs PPO with a small step and clip range, and stops early within an update once the
   approximate KL to the rollout's policy passes 1.5 x ``target_kl`` (stable-baselines3's rule);
   ``contact_anchor`` > 0 then pulls the actor back towards the imitation on each rollout's
   contact states (:class:`ContactAnchor`; off in the recipe: on the dev split it cut the
   contact tail and cost success, docs/training.md);
4. copies the actor back into the imitation network and saves it as a
   :class:`~agents.learning.imitation.PolicyBundle` (``policy.pt``: the same file format, so
   ``evaluate.py --agent learned:PATH`` and ``make_agent("learned:PATH")`` use it as they are),
   its metadata the imitation's plus ``finetune`` (this config and the run's figures).

Outputs in ``out_dir``: ``policy.pt``, ``finetune_curve.csv`` (per finished training episode:
env steps since the fine-tuning started, return, length, success, whether the actor was
training) and ``finetune.json`` (config, steps, minutes, episodes).

It is the recipe's second stage (``train.py --teacher planner`` runs it after the imitation): on
the dev split it took three seeds' mirrored students from 0.75, 0.69 and 0.78 success to 0.92,
0.92 and 0.83 in 240,000 steps (with a critic on its own encoder 0.89, 0.89 and 0.91, in 30-31
minutes instead of 25), after an imitation of 22.5 minutes on 2 cores (docs/training.md).

torch and stable-baselines3 are imported inside the functions that need them.
"""

from __future__ import annotations

import copy
import csv
import json
import math
import pathlib
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from agents.learning.runtime import keep_freed_memory, pinned_maker
from modeling.validation import number

__all__ = [
    "PHASE",
    "RECIPE_STEPS",
    "BinActions",
    "ContactAnchor",
    "FinetuneConfig",
    "FinetuneResult",
    "actor_critic",
    "append_to_curve",
    "copy_actor_back",
    "finetune_policy",
    "finetune_vector_env",
    "rollout_forward_speed",
    "sample_bins",
]

PHASE = "ppo fine-tuning"
"""The phase name of the fine-tuning's episodes in an imitation run's ``curve.csv``."""
RECIPE_STEPS = 240_000
"""The recipe's fine-tuning length, env steps (``FinetuneConfig.timesteps``'s default and
``train.py --finetune-steps``')."""
CRITIC_ENCODERS = ("own", "actor")
"""The values of ``FinetuneConfig.critic_encoder``."""
RESET_SEED_OFFSET = 500
"""Env ``i`` of a fine-tuning with seed ``s`` first resets with ``s * 1000 + 500 + i``: apart
from the imitation's ``s * 1000 + i`` (and every suite seed, which runs in the hundred
thousands)."""


class BinActions(gym.ActionWrapper[Any, Any, Any]):
    """The env with ``MultiDiscrete([bins] * 3)`` actions: bin ``k`` of a command is the value
    ``-1 + 2 k / (bins - 1)``, the values the imitation's bins stand for.

    Raises:
        ValueError: When ``bins`` < 2.
    """

    def __init__(self, env: gym.Env[Any, Any], bins: int) -> None:
        super().__init__(env)
        if isinstance(bins, bool) or not isinstance(bins, int) or bins < 2:
            raise ValueError(f"bins must be an integer >= 2, got {bins!r}")
        self.values = np.linspace(-1.0, 1.0, bins).astype(np.float32)
        self.action_space = gym.spaces.MultiDiscrete([bins] * 3)

    def action(self, action: Any) -> NDArray[np.float32]:
        index = np.asarray(action, dtype=np.int64).reshape(3)
        return self.values[index]


@dataclass(frozen=True, slots=True, kw_only=True)
class FinetuneConfig:
    """What :func:`finetune_policy` does.

    Attributes:
        out_dir: Output folder.
        policy: The imitation's ``policy.pt`` to start from (its metadata names the training
            envs: perception, families and their shares, episode rules).
        seed: Seed of PPO and of the envs (env ``i`` first resets with ``seed * 1000 + 500 +
            i``).
        timesteps: Env steps of fine-tuning (the run also stops after ``max_minutes``).
        max_minutes: Wall-time budget, minutes (``None``: none); the rollout under way when it
            runs out is dropped.
        n_envs: Env subprocesses.
        n_steps: Steps per env per rollout.
        batch_size: PPO minibatch size.
        n_epochs: Passes over each rollout.
        learning_rate: Adam step size (small: the policy starts good).
        clip_range: PPO's ratio clip.
        target_kl: An update stops once the approximate KL to the rollout's policy passes
            1.5 x this (``None``: never).
        ent_coef: Entropy bonus.
        gamma: Discount.
        gae_lambda: GAE's lambda.
        critic_warmup_rollouts: Rollouts at the start in which only the critic trains.
        critic_encoder: ``"own"``: the critic convolves the maps with its own copy of the
            imitation's encoder, trained by the value loss; ``"actor"``: it reads the actor's
            encoder and feature MLP through a stop-gradient (its hidden layers and output train,
            the value loss never reaches the actor), which halves the convolutions of every
            rollout step and update.
        normalize_reward: Scale rewards by a running estimate of the return's spread
            (``VecNormalize``, rewards only).
        contact_anchor: Weight of the contact anchor (0: none): after each update, ``n_epochs``
            passes over the rollout's contact states (state feature ``contact`` = 1) pull the
            actor's distribution towards that of ``policy`` (the imitation's, in the recipe),
            minimising their KL divergence (``policy`` to actor) times this weight
            (:class:`ContactAnchor`).
        pin_envs: Pin env process ``i`` to core ``i`` when the env processes fill the machine
            (:func:`~.runtime.pinned_maker`: the stage ran 1.09x faster on 2 cores).
        torch_threads: torch's threads for the updates.
        rollout_threads: torch's threads while a rollout is collected: the env processes need
            the cores then, and a second torch thread only spins against them (with the
            channels-last updates, the stage ran 1.41x faster than on 2 threads throughout:
            docs/training.md).
        command: The command line that ran (recorded in the policy).
        progress: Show a progress bar.
    """

    out_dir: pathlib.Path
    policy: pathlib.Path
    seed: int = 0
    timesteps: int = RECIPE_STEPS
    max_minutes: float | None = None
    n_envs: int = 2
    n_steps: int = 1024
    batch_size: int = 256
    n_epochs: int = 4
    learning_rate: float = 1e-4
    clip_range: float = 0.1
    target_kl: float | None = 0.03
    ent_coef: float = 0.0
    gamma: float = 0.99
    gae_lambda: float = 0.95
    critic_warmup_rollouts: int = 3
    critic_encoder: str = "actor"
    normalize_reward: bool = True
    contact_anchor: float = 0.0
    pin_envs: bool = True
    torch_threads: int = 2
    rollout_threads: int = 1
    command: str = ""
    progress: bool = True

    def __post_init__(self) -> None:
        for name in (
            "timesteps",
            "n_envs",
            "n_steps",
            "batch_size",
            "n_epochs",
            "torch_threads",
            "rollout_threads",
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if (
            isinstance(self.critic_warmup_rollouts, bool)
            or not isinstance(self.critic_warmup_rollouts, int)
            or self.critic_warmup_rollouts < 0
        ):
            raise ValueError(
                "critic_warmup_rollouts must be a non-negative integer, "
                f"got {self.critic_warmup_rollouts!r}"
            )
        if self.critic_encoder not in CRITIC_ENCODERS:
            raise ValueError(
                f"critic_encoder must be one of {CRITIC_ENCODERS}, got {self.critic_encoder!r}"
            )
        positive = {"learning_rate": self.learning_rate, "clip_range": self.clip_range}
        if self.max_minutes is not None:
            positive["max_minutes"] = self.max_minutes
        if self.target_kl is not None:
            positive["target_kl"] = self.target_kl
        for name, value in positive.items():
            number(value, name, low=0.0)
        for name in ("gamma", "gae_lambda"):
            if number(getattr(self, name), name, low=0.0) > 1.0:
                raise ValueError(f"{name} must be in (0, 1], got {getattr(self, name)!r}")
        for name in ("ent_coef", "contact_anchor"):
            number(getattr(self, name), name, low=0.0, strict=False)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly dict of the fields."""
        return {
            name: str(getattr(self, name))
            if isinstance(getattr(self, name), pathlib.Path)
            else getattr(self, name)
            for name in self.__dataclass_fields__
        }


@dataclass(frozen=True, slots=True, kw_only=True)
class FinetuneResult:
    """What :func:`finetune_policy` wrote.

    Attributes:
        policy_path: The fine-tuned policy (``policy.pt``).
        steps: Env steps of fine-tuning.
        episodes: Training episodes finished.
        minutes: Wall time, minutes.
        learn_minutes: The part of it in PPO's rollouts and updates (without loading the
            policy, starting the env processes and saving).
    """

    policy_path: pathlib.Path
    steps: int
    episodes: int
    minutes: float
    learn_minutes: float


def _env_maker(meta: dict[str, Any], egomap: Any, bins: int, seed: int) -> Any:
    """A function that builds one fine-tuning env (in the subprocess that calls it)."""

    def make() -> Any:
        from stable_baselines3.common.monitor import Monitor

        from agents.learning.wrappers import make_training_env

        config = meta["config"]
        env = make_training_env(
            dict(config["env_kwargs"]),
            families=config["families"],
            weights=config["weights"],
            teacher=None,
            egomap=egomap,
        )
        env = Monitor(BinActions(env, bins), info_keywords=("is_success",))
        env.reset(seed=seed)
        return env

    return make


def finetune_vector_env(cfg: FinetuneConfig, bundle: Any) -> Any:
    """The fine-tuning's VecEnv for the policy ``bundle``: ``cfg.n_envs`` training envs with
    :class:`BinActions` (in ``SubprocVecEnv`` processes, pinned to cores as ``cfg.pin_envs``
    says, when more than one), no teacher."""
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    makers = [
        _env_maker(bundle.meta, bundle.egomap, bundle.bins, cfg.seed * 1000 + RESET_SEED_OFFSET + i)
        for i in range(cfg.n_envs)
    ]
    if cfg.n_envs == 1:
        return DummyVecEnv(makers)
    if cfg.pin_envs:
        makers = [pinned_maker(make, i, cfg.n_envs) for i, make in enumerate(makers)]
    return SubprocVecEnv(makers, start_method="forkserver")


def _features_class(net: Any) -> Any:
    """The features extractor class whose modules are copies of ``net``'s encoder and feature
    MLP (stable-baselines3 builds the actor's and the critic's from it)."""
    import torch
    from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

    class EgoFeatures(BaseFeaturesExtractor):
        """The imitation network's map encoder and feature MLP, their outputs concatenated."""

        def __init__(self, observation_space: gym.spaces.Dict) -> None:
            super().__init__(observation_space, net.head[0].in_features)
            self.encoder = copy.deepcopy(net.encoder)
            self.state = copy.deepcopy(net.state)

        def forward(self, obs: dict[str, torch.Tensor]) -> torch.Tensor:
            maps = (obs["map"].float() / 255.0).contiguous(memory_format=torch.channels_last)
            image = self.encoder(maps)
            return torch.cat([image, self.state(obs["state"])], dim=1)

    return EgoFeatures


def sample_bins(logits: Any, dims: Sequence[int], deterministic: bool = False) -> tuple[Any, Any]:
    """The actions and their log-probabilities of a policy over ``len(dims)`` commands of
    ``dims[0]`` bins each, with ``logits`` ((N, sum(dims)): the commands' logits side by side),
    drawn (or, ``deterministic``, the most probable) as stable-baselines3's
    ``MultiCategoricalDistribution`` draws them: per command a categorical over its normalised
    logits, drawn in one ``torch.multinomial`` call whose rows come command by command, which
    draws what one call per command draws: from the same random state the actions and
    log-probabilities are the same bit for bit (``tests/agents/learning/test_finetune.py``);
    without building and checking a ``torch.distributions.Categorical`` per command, which took
    over a third of the rollouts' policy forward (docs/training.md).

    Returns:
        (N, len(dims)) int64 actions and (N,) log-probabilities (summed over the commands).

    Raises:
        ValueError: When the commands' bins differ in number or do not add up to the logits'
            width.
    """
    import torch

    bins = int(dims[0]) if len(dims) else 0
    if bins < 1 or any(int(d) != bins for d in dims) or logits.shape[-1] != bins * len(dims):
        raise ValueError(
            f"dims must be equal bin counts adding up to the logits' width {logits.shape[-1]}, "
            f"got {list(dims)}"
        )
    n, commands = logits.shape[0], len(dims)
    per_command = logits.view(n, commands, bins).transpose(0, 1)  # (commands, N, bins)
    normalised = per_command - per_command.logsumexp(dim=-1, keepdim=True)
    probs = torch.softmax(normalised, dim=-1)
    if deterministic:
        actions = torch.argmax(probs, dim=-1)
    else:  # rows in command order: the draws of one multinomial call per command
        actions = torch.multinomial(probs.reshape(commands * n, bins), 1, True).view(commands, n)
    log_probs = normalised.gather(-1, actions.unsqueeze(-1)).squeeze(-1)
    return actions.T, log_probs.sum(dim=0)


def _bin_policy(base: Any) -> Any:
    """``base`` (a stable-baselines3 actor-critic for dict observations) whose ``forward``, the
    rollouts' call, draws its multi-discrete actions with :func:`sample_bins` (the same draws,
    values and log-probabilities as ``base.forward``; updates still go through ``base``'s
    distribution: ``evaluate_actions``)."""
    import torch

    class BinPolicy(base):  # type: ignore[misc]
        """``base`` with a lean rollout forward over its action bins."""

        def forward(
            self, obs: Any, deterministic: bool = False
        ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
            features = self.extract_features(obs)
            if self.share_features_extractor:
                latent_pi, latent_vf = self.mlp_extractor(features)
            else:
                latent_pi = self.mlp_extractor.forward_actor(features[0])
                latent_vf = self.mlp_extractor.forward_critic(features[1])
            values = self.value_net(latent_vf)
            actions, log_prob = sample_bins(
                self.action_net(latent_pi), self.action_dist.action_dims, deterministic
            )
            return actions.reshape((-1, *self.action_space.shape)), values, log_prob

    return BinPolicy


def _detached_critic_policy() -> Any:
    """stable-baselines3's actor-critic for dict observations whose critic reads the shared
    features through a stop-gradient (``FinetuneConfig.critic_encoder == "actor"``)."""
    import torch
    from stable_baselines3.common.policies import MultiInputActorCriticPolicy
    from stable_baselines3.common.torch_layers import MlpExtractor

    class DetachedCriticMlp(MlpExtractor):
        """The actor's and the critic's hidden layers; no value gradient reaches the
        features."""

        def forward_critic(self, features: torch.Tensor) -> torch.Tensor:
            latent: torch.Tensor = self.value_net(features.detach())
            return latent

    class DetachedCriticPolicy(MultiInputActorCriticPolicy):
        """One features extractor (the actor's), the critic's input detached from it."""

        def _build_mlp_extractor(self) -> None:
            self.mlp_extractor = DetachedCriticMlp(
                self.features_dim,
                net_arch=self.net_arch,
                activation_fn=self.activation_fn,
                device=self.device,
            )

    return DetachedCriticPolicy


class ContactAnchor:
    """Pulls the PPO actor back towards a reference policy (the imitation's) on the contact
    states of each rollout (``FinetuneConfig.contact_anchor``).

    The rules price a contact step at 0.1, what 10 cm of progress earns, and PPO's rollouts draw
    their actions, so that they leave a contact within a few steps whatever the most probable
    action is: the updates hardly shape what the policy does in contact, and what they do
    shape generalises from elsewhere. Fine-tuned students came to back away from contacts they
    should have driven on from, reversing into what was behind them for tens of steps where
    the planner (and the student it taught) would drive on (docs/training.md). After each
    update, ``n_epochs`` passes over the rollout's contact states, in minibatches of PPO's size
    and with PPO's optimizer and gradient clip, minimise ``weight`` x KL(reference || actor),
    summed over the three commands; states without contact and the critic are left to PPO.

    Args:
        reference: The reference network (``(maps, states) -> (N, 3, bins)`` logits); a frozen
            copy is kept.
        weight: The KL's weight (> 0).
    """

    def __init__(self, reference: Any, weight: float) -> None:
        from agents.learning.egomap import STATE_FEATURES

        self.reference = copy.deepcopy(reference).eval()
        for parameter in self.reference.parameters():
            parameter.requires_grad_(False)
        self.weight = float(weight)
        self.contact = STATE_FEATURES.index("contact")
        self.history: list[dict[str, float]] = []
        """Per update with contact states: their number and the mean KL before and after."""

    def _kl(self, policy: Any, obs: dict[str, Any], target: Any) -> Any:
        """Mean over ``obs`` of KL(reference || actor), summed over the commands; ``target``:
        the reference's (N, 3, bins) log-probabilities."""
        import torch

        heads = policy.get_distribution(obs).distribution  # one Categorical per command
        log_p = torch.stack([head.logits for head in heads], dim=1)  # normalised log-probs
        return (target.exp() * (target - log_p)).sum(dim=(1, 2)).mean()

    def update(self, model: Any) -> None:
        """The anchor's passes over ``model``'s last rollout (after its update); nothing while
        the actor is frozen (the critic's warm-up) or the rollout touched nothing."""
        import torch

        policy = model.policy
        if not policy.action_net.weight.requires_grad:
            return
        observations = model.rollout_buffer.observations
        states = observations["state"].reshape(-1, observations["state"].shape[-1])
        rows = np.flatnonzero(states[:, self.contact] > 0.5)
        if rows.size == 0:
            return
        maps_all = observations["map"]
        maps = torch.as_tensor(maps_all.reshape(-1, *maps_all.shape[-3:])[rows])
        obs = {"map": maps, "state": torch.as_tensor(states[rows])}
        with torch.no_grad():
            target = torch.log_softmax(self.reference(obs["map"], obs["state"]), dim=-1)
            before = float(self._kl(policy, obs, target))
        policy.set_training_mode(True)
        for _ in range(model.n_epochs):
            order = torch.randperm(rows.size)
            for start in range(0, rows.size, model.batch_size):
                idx = order[start : start + model.batch_size]
                batch = {key: value[idx] for key, value in obs.items()}
                loss = self.weight * self._kl(policy, batch, target[idx])
                policy.optimizer.zero_grad()
                loss.backward()
                torch.nn.utils.clip_grad_norm_(policy.parameters(), model.max_grad_norm)
                policy.optimizer.step()
        policy.set_training_mode(False)
        with torch.no_grad():
            after = float(self._kl(policy, obs, target))
        self.history.append({"states": float(rows.size), "kl_before": before, "kl_after": after})


def _anchored_ppo() -> Any:
    """stable-baselines3's PPO that runs its :class:`ContactAnchor` (if any) after each
    update."""
    from stable_baselines3 import PPO

    class AnchoredPPO(PPO):
        """PPO; then the contact anchor's passes over the same rollout."""

        contact_anchor: ContactAnchor | None = None

        def train(self) -> None:
            super().train()
            if self.contact_anchor is not None:
                self.contact_anchor.update(self)

    return AnchoredPPO


def actor_critic(bundle: Any, env: Any, cfg: FinetuneConfig) -> Any:
    """The PPO model on ``env`` whose actor is ``bundle``'s network (weights copied in) and
    whose critic starts from the same encoder (its own copy, or the actor's read through a
    stop-gradient: ``cfg.critic_encoder``) and hidden layers with a fresh output."""
    import torch
    from stable_baselines3.common.policies import MultiInputActorCriticPolicy
    from torch import nn

    net = bundle.net
    width = net.head[0].out_features
    shared = cfg.critic_encoder == "actor"
    model = _anchored_ppo()(
        _bin_policy(_detached_critic_policy() if shared else MultiInputActorCriticPolicy),
        env,
        n_steps=cfg.n_steps,
        batch_size=cfg.batch_size,
        n_epochs=cfg.n_epochs,
        learning_rate=cfg.learning_rate,
        gamma=cfg.gamma,
        gae_lambda=cfg.gae_lambda,
        clip_range=cfg.clip_range,
        ent_coef=cfg.ent_coef,
        target_kl=cfg.target_kl,
        seed=cfg.seed,
        device="cpu",
        verbose=0,
        policy_kwargs={
            "features_extractor_class": _features_class(net),
            "share_features_extractor": shared,
            "net_arch": {"pi": [width, width], "vf": [width, width]},
            "activation_fn": nn.ReLU,
            "normalize_images": False,
        },
    )
    policy: Any = model.policy
    # PPO's orthogonal initialisation ran over every module: copy the imitation's weights now.
    with torch.no_grad():
        # One extractor when the critic reads the actor's (the same object twice): copy it once.
        for features in dict.fromkeys((policy.pi_features_extractor, policy.vf_features_extractor)):
            features.encoder.load_state_dict(net.encoder.state_dict())
            features.state.load_state_dict(net.state.state_dict())
        for hidden in (policy.mlp_extractor.policy_net, policy.mlp_extractor.value_net):
            hidden[0].load_state_dict(net.head[0].state_dict())
            hidden[2].load_state_dict(net.head[2].state_dict())
        policy.action_net.load_state_dict(net.head[4].state_dict())
    # Channels-last (NHWC) convolutions, as the imitation fits: the same sums, faster on this
    # CPU (the extractor hands its maps over in that layout too).
    policy.to(memory_format=torch.channels_last)
    if cfg.contact_anchor > 0.0:
        model.contact_anchor = ContactAnchor(net, cfg.contact_anchor)
    return model


def rollout_forward_speed(
    bundle: Any, venv: Any, cfg: FinetuneConfig, calls: int = 400, repeats: int = 3
) -> dict[str, float]:
    """Policy forwards per second as a rollout calls them (one batch of ``venv``'s observations
    after a reset, ``cfg.rollout_threads`` threads, no gradient): the fine-tuning's forward
    (:func:`sample_bins`) and stable-baselines3's ``ActorCriticPolicy.forward`` on the same
    policy, alternately ``repeats`` times ``calls`` each; the best of each and their ratio
    (``forward_lean_over_sb3``). Printed by ``scripts/bench_training.py``."""
    import torch
    from stable_baselines3.common.policies import ActorCriticPolicy
    from stable_baselines3.common.utils import obs_as_tensor

    threads = torch.get_num_threads()
    torch.set_num_threads(cfg.rollout_threads)
    try:
        policy = actor_critic(bundle, venv, cfg).policy
        policy.set_training_mode(False)
        obs = obs_as_tensor(venv.reset(), policy.device)
        forwards = {"lean": policy.forward, "sb3": lambda o: ActorCriticPolicy.forward(policy, o)}
        best = dict.fromkeys(forwards, 0.0)
        with torch.no_grad():
            for _ in range(repeats):
                for name, forward in forwards.items():
                    forward(obs)
                    t0 = time.perf_counter()
                    for _ in range(calls):
                        forward(obs)
                    best[name] = max(best[name], calls / (time.perf_counter() - t0))
    finally:
        torch.set_num_threads(threads)
    return {
        "forward_per_s_lean": best["lean"],
        "forward_per_s_sb3": best["sb3"],
        "forward_lean_over_sb3": best["lean"] / best["sb3"],
    }


def _actor_parameters(policy: Any) -> list[Any]:
    return [
        *policy.pi_features_extractor.parameters(),
        *policy.mlp_extractor.policy_net.parameters(),
        *policy.action_net.parameters(),
    ]


def copy_actor_back(policy: Any, net: Any) -> None:
    """Copy the PPO actor's weights into the imitation network ``net`` (the inverse of the copy
    in :func:`actor_critic`)."""
    import torch

    with torch.no_grad():
        net.encoder.load_state_dict(policy.pi_features_extractor.encoder.state_dict())
        net.state.load_state_dict(policy.pi_features_extractor.state.state_dict())
        net.head[0].load_state_dict(policy.mlp_extractor.policy_net[0].state_dict())
        net.head[2].load_state_dict(policy.mlp_extractor.policy_net[2].state_dict())
        net.head[4].load_state_dict(policy.action_net.state_dict())


def _callback(cfg: FinetuneConfig, rows: list[dict[str, float]], started: float) -> Any:
    import torch
    from stable_baselines3.common.callbacks import BaseCallback

    from agents.learning.training import finished_episode

    class FinetuneCallback(BaseCallback):
        """Freezes the actor for the critic's warm-up, sets torch's threads for rollouts and
        updates, records every finished episode, shows progress and stops at the wall-time
        budget."""

        def _on_training_start(self) -> None:
            self._rollouts = 0
            self._actor = _actor_parameters(self.model.policy)
            self._train_actor(cfg.critic_warmup_rollouts == 0)
            self._bar: Any = None
            if cfg.progress:
                from tqdm.auto import tqdm

                self._bar = tqdm(total=cfg.timesteps, unit="step", desc="PPO fine-tuning")

        def _train_actor(self, on: bool) -> None:
            for parameter in self._actor:
                parameter.requires_grad_(on)

        def _on_rollout_start(self) -> None:
            if self._rollouts == cfg.critic_warmup_rollouts:
                self._train_actor(True)
            self._rollouts += 1
            torch.set_num_threads(cfg.rollout_threads)

        def _on_rollout_end(self) -> None:
            torch.set_num_threads(cfg.torch_threads)

        def _on_step(self) -> bool:
            for info in self.locals.get("infos", ()):
                row = finished_episode(info, self.num_timesteps)
                if row is not None:
                    training = self._rollouts > cfg.critic_warmup_rollouts
                    rows.append({**row, "actor_training": float(training)})
            if self._bar is not None:
                self._bar.update(max(0, self.num_timesteps - self._bar.n))
            if cfg.max_minutes is None:
                return True
            return time.monotonic() - started < 60.0 * cfg.max_minutes

        def _on_training_end(self) -> None:
            if self._bar is not None:
                self._bar.close()
            self._train_actor(True)
            torch.set_num_threads(cfg.torch_threads)

    return FinetuneCallback()


def finetune_policy(cfg: FinetuneConfig) -> FinetuneResult:
    """Fine-tune ``cfg.policy`` with PPO (module docstring); write ``cfg.out_dir``'s files.

    Sets this process's ``malloc`` to keep freed memory (:func:`~.runtime.keep_freed_memory`:
    PPO's updates took 1.4-1.8x as long without it).

    Raises:
        FileNotFoundError: When there is no policy at ``cfg.policy``.
        ValueError: When it was trained on another observation version.
    """
    import torch
    from stable_baselines3.common.vec_env import VecNormalize

    from agents.learning.imitation import load_policy

    keep_freed_memory()
    started = time.monotonic()
    torch.set_num_threads(cfg.torch_threads)
    bundle = load_policy(cfg.policy)
    venv = finetune_vector_env(cfg, bundle)
    if cfg.normalize_reward:
        venv = VecNormalize(venv, norm_obs=False, norm_reward=True, gamma=cfg.gamma)
    rows: list[dict[str, float]] = []
    try:
        model = actor_critic(bundle, venv, cfg)
        learn_started = time.monotonic()
        model.learn(total_timesteps=cfg.timesteps, callback=_callback(cfg, rows, started))
        learn_minutes = (time.monotonic() - learn_started) / 60.0
        steps = int(model.num_timesteps)
    finally:
        venv.close()
    copy_actor_back(model.policy, bundle.net)
    bundle.net.eval()
    minutes = (time.monotonic() - started) / 60.0
    summary = {
        "config": cfg.to_dict(),
        "command": cfg.command,
        "steps": steps,
        "episodes": len(rows),
        "minutes": minutes,
        "learn_minutes": learn_minutes,
        "success_rate_last_100": float(np.mean([r["success"] for r in rows[-100:]]))
        if rows
        else math.nan,
    }
    if model.contact_anchor is not None:
        history = model.contact_anchor.history
        summary["contact_anchor"] = {
            "updates": len(history),
            **{
                f"mean_{key}": float(np.mean([h[key] for h in history])) if history else math.nan
                for key in ("states", "kl_before", "kl_after")
            },
        }
    bundle.meta["finetune"] = summary
    out = pathlib.Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "policy.pt"
    bundle.save(path)
    (out / "finetune.json").write_text(json.dumps(summary, indent=2) + "\n")
    with (out / "finetune_curve.csv").open("w", newline="") as fh:
        fields = ["timesteps", "return", "length", "success", "actor_training"]
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    return FinetuneResult(
        policy_path=path,
        steps=steps,
        episodes=len(rows),
        minutes=minutes,
        learn_minutes=learn_minutes,
    )


def append_to_curve(curve_csv: pathlib.Path, finetune_csv: pathlib.Path) -> None:
    """Append the fine-tuning's episodes (``finetune_csv``) to the imitation's learning curve
    ``curve_csv`` (:func:`agents.learning.imitation.train_imitation`'s), as phase
    :data:`PHASE` with the teacher's share 0 and the env steps counted on from the imitation's
    last episode, so that one curve covers the whole recipe."""
    with curve_csv.open(newline="") as fh:
        reader = csv.DictReader(fh)
        fields = list(reader.fieldnames or ())
        rows = list(reader)
    offset = float(rows[-1]["timesteps"]) if rows else 0.0
    with finetune_csv.open(newline="") as fh:
        tuned = list(csv.DictReader(fh))
    with curve_csv.open("a", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        for row in tuned:
            writer.writerow(
                {
                    "timesteps": offset + float(row["timesteps"]),
                    "length": row["length"],
                    "success": row["success"],
                    "phase": PHASE,
                    "beta": 0.0,
                }
            )
