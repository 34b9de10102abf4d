"""PPO fine-tuning of an imitation policy: the action bins, the weight copies, a smoke run."""

from __future__ import annotations

import copy
import csv
import os
import pathlib
import pickle
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents import make_agent
from agents.learning import runtime
from agents.learning.egomap import CHANNELS, STATE_FEATURES, EgoMapConfig
from agents.learning.finetune import (
    PHASE,
    BinActions,
    FinetuneConfig,
    actor_critic,
    append_to_curve,
    copy_actor_back,
    finetune_policy,
    finetune_vector_env,
    rollout_forward_speed,
    sample_bins,
)
from agents.learning.imitation import (
    ImitationConfig,
    _new_bundle,
    load_policy,
    training_vector_env,
)
from agents.learning.seeds import _phase_starts
from agents.learning.wrappers import make_training_env
from tests.scripts.loader import load_script

SMALL = EgoMapConfig(size_px=16, cell_m=0.5)


@pytest.fixture(scope="module")
def imitation_policy(imitation_run: pathlib.Path) -> pathlib.Path:
    """A tiny imitation policy (the suite's ``imitation_run``: 120 planner steps on a small map)."""
    return imitation_run / "policy.pt"


def tiny_run(policy: pathlib.Path, out: pathlib.Path, **overrides: Any) -> FinetuneConfig:
    """A fine-tuning of a few 64-step rollouts on one in-process env."""
    settings: dict[str, Any] = {
        "timesteps": 128,
        "n_envs": 1,
        "n_steps": 64,
        "batch_size": 32,
        "n_epochs": 1,
        "progress": False,
        **overrides,
    }
    return FinetuneConfig(out_dir=out, policy=policy, **settings)


def tiny_venv() -> Any:
    """One in-process surrogate training env of the small map, with 11-bin actions."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    env = make_training_env(
        {"perception": "surrogate"}, families=("open",), teacher=None, egomap=SMALL
    )
    return DummyVecEnv([lambda: BinActions(env, 11)])


def fresh_model(critic_encoder: str) -> tuple[Any, Any, Any]:
    """A fresh small imitation network (torch seed 0), its tiny training env and the PPO model
    built around it with ``critic_encoder``."""
    torch.manual_seed(0)
    bundle = _new_bundle(SMALL, 11, 32, {})
    venv = tiny_venv()
    cfg = FinetuneConfig(
        out_dir=pathlib.Path("."), policy=pathlib.Path("unused.pt"), critic_encoder=critic_encoder
    )
    return bundle, venv, actor_critic(bundle, venv, cfg)


def test_bin_actions_send_the_values_the_bins_stand_for() -> None:
    env: Any = BinActions(gym.make("StereoNav-v1", scenario="open", perception="surrogate"), 11)
    assert env.action_space == gym.spaces.MultiDiscrete([11, 11, 11])
    np.testing.assert_allclose(env.action(np.array([0, 5, 10])), [-1.0, 0.0, 1.0])
    np.testing.assert_allclose(env.action(np.array([3, 7, 9])), [-0.4, 0.4, 0.8], atol=1e-6)
    with pytest.raises(ValueError, match="bins"):
        BinActions(env, 1)
    env.close()


@pytest.mark.parametrize("critic_encoder", ["own", "actor"])
def test_ppo_starts_from_the_imitation_policy_and_gives_its_actor_back(
    critic_encoder: str,
) -> None:
    bundle, venv, model = fresh_model(critic_encoder)
    rng = np.random.default_rng(0)
    maps = torch.from_numpy(rng.integers(0, 256, (5, len(CHANNELS), 16, 16), dtype=np.uint8))
    states = torch.from_numpy(rng.uniform(-1, 1, (5, len(STATE_FEATURES))).astype(np.float32))
    with torch.no_grad():
        want = torch.log_softmax(bundle.net(maps, states), dim=-1)
        dist = model.policy.get_distribution({"map": maps.float(), "state": states})
        got = torch.stack([d.logits for d in dist.distribution], dim=1)
    torch.testing.assert_close(got, want, rtol=0, atol=1e-5)
    # an update moves the actor; copying it back makes the imitation network compute the same
    with torch.no_grad():
        for p in model.policy.action_net.parameters():
            p.add_(0.1)
        for p in model.policy.pi_features_extractor.parameters():
            p.mul_(0.9)
        moved = torch.stack(
            [
                d.logits
                for d in model.policy.get_distribution(
                    {"map": maps.float(), "state": states}
                ).distribution
            ],
            dim=1,
        )
    assert not torch.allclose(moved, want, atol=1e-3)
    copy_actor_back(model.policy, bundle.net)
    with torch.no_grad():
        back = torch.log_softmax(bundle.net(maps, states), dim=-1)
    torch.testing.assert_close(back, moved, rtol=0, atol=1e-5)
    venv.close()


@pytest.mark.parametrize("deterministic", [False, True])
def test_sample_bins_draws_what_stable_baselines3s_distribution_draws(
    deterministic: bool,
) -> None:
    from stable_baselines3.common.distributions import MultiCategoricalDistribution

    generator = torch.Generator().manual_seed(0)
    for trial in range(40):
        n = int(torch.randint(1, 9, (1,), generator=generator))
        logits = torch.randn(n, 33, generator=generator) * 3.0
        dist = MultiCategoricalDistribution([11, 11, 11]).proba_distribution(logits)
        torch.manual_seed(trial)
        want = dist.get_actions(deterministic=deterministic)
        want_log_prob = dist.log_prob(want)
        torch.manual_seed(trial)
        got, got_log_prob = sample_bins(logits, [11, 11, 11], deterministic)
        assert torch.equal(got, want) and torch.equal(got_log_prob, want_log_prob)
    # the draws are draws: over many states each command's bins come at their probabilities
    logits = torch.log(torch.tensor([[0.7, 0.2, 0.1, 0.5, 0.5, 1e-9]]))
    torch.manual_seed(1)
    counts = np.zeros((2, 3))
    for _ in range(2000):
        action, _ = sample_bins(logits, [3, 3])
        counts[0, action[0, 0]] += 1
        counts[1, action[0, 1]] += 1
    np.testing.assert_allclose(counts / 2000, [[0.7, 0.2, 0.1], [0.5, 0.5, 0.0]], atol=0.04)
    with pytest.raises(ValueError, match="dims"):
        sample_bins(torch.zeros(1, 5), [3, 2])
    with pytest.raises(ValueError, match="dims"):
        sample_bins(torch.zeros(1, 6), [3, 3, 3])


@pytest.mark.parametrize("critic_encoder", ["own", "actor"])
def test_the_rollout_forward_gives_what_stable_baselines3s_forward_gives(
    critic_encoder: str,
) -> None:
    from stable_baselines3.common.policies import ActorCriticPolicy

    _, venv, model = fresh_model(critic_encoder)
    policy = model.policy
    policy.set_training_mode(False)
    assert type(policy).forward is not ActorCriticPolicy.forward
    rng = np.random.default_rng(0)
    for n in (1, 2, 5):
        obs: Any = {
            "map": torch.from_numpy(
                rng.integers(0, 256, (n, len(CHANNELS), 16, 16), dtype=np.uint8)
            ),
            "state": torch.from_numpy(
                rng.uniform(-1, 1, (n, len(STATE_FEATURES))).astype(np.float32)
            ),
        }
        for deterministic in (False, True):
            with torch.no_grad():
                torch.manual_seed(n)
                got = policy(obs, deterministic=deterministic)
                torch.manual_seed(n)
                want = ActorCriticPolicy.forward(policy, obs, deterministic=deterministic)
            for got_part, want_part in zip(got, want, strict=True):
                assert got_part.shape == want_part.shape
                assert torch.equal(got_part, want_part)
    venv.close()


def test_rollout_forward_speed_times_both_forwards_and_restores_the_threads() -> None:
    bundle = _new_bundle(SMALL, 11, 32, {})
    venv = tiny_venv()
    cfg = FinetuneConfig(
        out_dir=pathlib.Path("."), policy=pathlib.Path("unused.pt"), rollout_threads=1
    )
    threads = torch.get_num_threads()
    speed = rollout_forward_speed(bundle, venv, cfg, calls=3, repeats=1)
    assert torch.get_num_threads() == threads
    assert speed["forward_per_s_lean"] > 0 and speed["forward_per_s_sb3"] > 0
    assert speed["forward_lean_over_sb3"] == pytest.approx(
        speed["forward_per_s_lean"] / speed["forward_per_s_sb3"]
    )
    venv.close()


def test_a_critic_on_the_actors_encoder_sends_it_no_value_gradient() -> None:
    torch.manual_seed(1)
    bundle = _new_bundle(SMALL, 11, 32, {})
    venv = tiny_venv()
    rng = np.random.default_rng(1)
    maps = torch.from_numpy(rng.integers(0, 256, (4, len(CHANNELS), 16, 16), dtype=np.uint8))
    obs = {
        "map": maps.float(),
        "state": torch.from_numpy(rng.uniform(-1, 1, (4, len(STATE_FEATURES))).astype(np.float32)),
    }
    grads = {}
    for critic_encoder in ("own", "actor"):
        cfg = FinetuneConfig(
            out_dir=pathlib.Path("."), policy=pathlib.Path("p.pt"), critic_encoder=critic_encoder
        )
        policy = actor_critic(bundle, venv, cfg).policy
        policy.predict_values(obs).sum().backward()
        actor_encoder = policy.pi_features_extractor.encoder
        critic_encoder_grads = [p.grad for p in policy.vf_features_extractor.encoder.parameters()]
        grads[critic_encoder] = (
            all(p.grad is None for p in actor_encoder.parameters()),
            all(g is not None and g.abs().sum() > 0 for g in critic_encoder_grads),
            policy.pi_features_extractor is policy.vf_features_extractor,
            sum(p.numel() for p in policy.parameters()),
        )
        assert all(p.grad is not None for p in policy.mlp_extractor.value_net.parameters())
    own, actor = grads["own"], grads["actor"]
    assert own[:3] == (True, True, False)  # its own encoder learns from the value loss
    assert actor[:3] == (True, False, True)  # one encoder, which the value loss never reaches
    encoder = sum(p.numel() for p in bundle.net.encoder.parameters())
    state = sum(p.numel() for p in bundle.net.state.parameters())
    assert own[3] - actor[3] == encoder + state
    venv.close()


def _contact_kl(policy: Any, reference: Any, obs: dict[str, torch.Tensor]) -> torch.Tensor:
    """Per state, KL(reference || actor) summed over the three commands."""
    with torch.no_grad():
        want = torch.log_softmax(reference(obs["map"], obs["state"]), dim=-1)
        heads = policy.get_distribution(obs).distribution
        got = torch.stack([head.logits for head in heads], dim=1)
    return (want.exp() * (want - got)).sum(dim=(1, 2))


def test_the_contact_anchor_pulls_the_actor_back_on_contact_states_only() -> None:
    torch.manual_seed(2)
    bundle = _new_bundle(SMALL, 11, 32, {})
    reference = copy.deepcopy(bundle.net)
    venv = tiny_venv()
    cfg = FinetuneConfig(
        out_dir=pathlib.Path("."),
        policy=pathlib.Path("p.pt"),
        n_steps=64,
        batch_size=8,
        learning_rate=1e-3,
        contact_anchor=1.0,
    )
    model = actor_critic(bundle, venv, cfg)
    anchor = model.contact_anchor
    assert anchor is not None
    policy = model.policy
    with torch.no_grad():  # PPO moved the actor away from the imitation
        for p in policy.action_net.parameters():
            p.add_(0.3 * torch.randn_like(p))
    rng = np.random.default_rng(2)
    buffer = model.rollout_buffer
    maps = rng.integers(0, 256, buffer.observations["map"].shape).astype(np.float32)
    states = rng.uniform(-1, 1, buffer.observations["state"].shape).astype(np.float32)
    contact = STATE_FEATURES.index("contact")
    states[..., contact] = 0.0
    buffer.observations["map"][:], buffer.observations["state"][:] = maps, states
    critic = [p.detach().clone() for p in policy.value_net.parameters()]
    actor = [p.detach().clone() for p in policy.action_net.parameters()]
    anchor.update(model)  # a rollout that touched nothing: nothing to do
    assert anchor.history == []
    unchanged = zip(actor, policy.action_net.parameters(), strict=True)
    assert all(torch.equal(a, b) for a, b in unchanged)
    touched = np.zeros(states.shape[:-1], dtype=bool)
    touched[::3] = True
    states[touched, contact] = 1.0
    buffer.observations["state"][:] = states
    obs = {
        "map": torch.from_numpy(maps[touched]),
        "state": torch.from_numpy(states[touched]),
    }
    before = _contact_kl(policy, reference, obs)
    anchor.update(model)
    after = _contact_kl(policy, reference, obs)
    (row,) = anchor.history
    assert row["states"] == touched.sum()
    assert row["kl_before"] == pytest.approx(float(before.mean()), rel=1e-4)
    assert row["kl_after"] == pytest.approx(float(after.mean()), rel=1e-4)
    assert float(after.mean()) < 0.8 * float(before.mean())
    # the critic's layers get no gradient from it
    unchanged = zip(critic, policy.value_net.parameters(), strict=True)
    assert all(torch.equal(a, b) for a, b in unchanged)
    # a frozen actor (the critic's warm-up) is left alone
    for p in policy.action_net.parameters():
        p.requires_grad_(False)
    anchor.update(model)
    assert len(anchor.history) == 1
    venv.close()


def test_a_finetuning_smoke_run_writes_a_policy_that_loads_and_acts(
    imitation_policy: pathlib.Path, tmp_path: pathlib.Path
) -> None:
    before = load_policy(imitation_policy)
    result = finetune_policy(
        tiny_run(imitation_policy, tmp_path, timesteps=256, critic_warmup_rollouts=1)
    )
    assert result.steps >= 256 and result.policy_path == tmp_path / "policy.pt"
    after = load_policy(result.policy_path)
    assert after.meta["rules"] == before.meta["rules"]
    assert after.meta["finetune"]["steps"] == result.steps
    assert 0.0 < result.learn_minutes < result.minutes  # the set-up and saving lie outside
    assert after.meta["finetune"]["learn_minutes"] == result.learn_minutes
    changed = [
        not torch.equal(a, b)
        for a, b in zip(
            before.net.state_dict().values(), after.net.state_dict().values(), strict=True
        )
    ]
    assert any(changed)  # the actor trained after the critic's warm-up rollout
    lines = (tmp_path / "finetune_curve.csv").read_text().splitlines()
    assert lines[0] == "timesteps,return,length,success,actor_training"
    agent = make_agent(f"learned:{result.policy_path}")
    env = gym.make("StereoNav-v1", scenario="room", perception="surrogate")
    obs, info = env.reset(seed=3)
    agent.reset(env, seed=3)
    for _ in range(3):
        action = agent.act(obs, info)
        assert action.shape == (3,) and np.all(np.abs(action) <= 1.0)
        obs, *_, info = env.step(action)
    env.close()


@pytest.mark.parametrize("pin", [True, False])
def test_the_env_processes_of_both_stages_are_pinned_when_they_fill_the_machine(
    imitation_policy: pathlib.Path,
    tmp_path: pathlib.Path,
    monkeypatch: pytest.MonkeyPatch,
    pin: bool,
) -> None:
    cores = runtime.allowed_cores()
    # Two env processes fill a machine of two cores (this one's, CI's): decide as on one.
    monkeypatch.setattr(runtime, "allowed_cores", lambda: cores[:2])
    imitation = ImitationConfig(
        out_dir=tmp_path, n_envs=2, families=("open",), weights=(1.0,), egomap=SMALL, pin_envs=pin
    )
    venvs = [
        (training_vector_env(imitation), "processes"),
        (
            finetune_vector_env(
                tiny_run(imitation_policy, tmp_path, n_envs=2, pin_envs=pin),
                load_policy(imitation_policy),
            ),
            "processes",
        ),
    ]
    try:
        for venv, attribute in venvs:
            pids = [process.pid for process in getattr(venv, attribute)]
            expected = [{cores[i % len(cores)]} if pin else set(cores) for i in range(2)]
            assert [os.sched_getaffinity(pid) for pid in pids] == expected
        assert os.sched_getaffinity(0) == set(cores)  # the learner's process is left free
    finally:
        for venv, _ in venvs:
            venv.close()


def test_pinning_changes_nothing_that_is_computed(
    imitation_policy: pathlib.Path, tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    cores = runtime.allowed_cores()
    monkeypatch.setattr(runtime, "allowed_cores", lambda: cores[:2])  # 2 env processes: pinned
    weights = []
    for pin in (True, False):
        cfg = tiny_run(imitation_policy, tmp_path / str(pin), n_envs=2, pin_envs=pin)
        weights.append(load_policy(finetune_policy(cfg).policy_path).net.state_dict())
    assert all(torch.equal(a, b) for a, b in zip(*(w.values() for w in weights), strict=True))


def test_env_processes_fewer_than_the_cores_are_left_to_the_scheduler(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(runtime, "allowed_cores", lambda: list(range(16)))
    assert runtime.pinned_maker(int, 1, 2) is int  # unchanged: 2 env processes, 16 cores
    monkeypatch.setattr(runtime, "allowed_cores", lambda: [0, 1])
    pinned = runtime.pinned_maker(int, 1, 2)  # pins, and travels to a subprocess by pickle
    assert pinned is not int and pickle.loads(pickle.dumps(pinned)).args[:2] == (1, int)
    before = os.sched_getaffinity(0)
    assert pinned() == 0 and os.sched_getaffinity(0) == before  # here: made, nothing pinned


@pytest.mark.parametrize("critic_encoder", ["own", "actor"])
def test_the_critic_warms_up_alone(
    imitation_policy: pathlib.Path, tmp_path: pathlib.Path, critic_encoder: str
) -> None:
    # The warm-up is longer than the run: the actor never trains (nor, with the actor's encoder
    # shared, does that encoder).
    cfg = tiny_run(
        imitation_policy, tmp_path, critic_warmup_rollouts=5, critic_encoder=critic_encoder
    )
    before = load_policy(imitation_policy).net.state_dict()
    after = load_policy(finetune_policy(cfg).policy_path).net.state_dict()
    for name, value in before.items():
        assert torch.equal(value, after[name]), name


def test_rollouts_run_torch_on_rollout_threads_and_updates_on_torch_threads(
    imitation_policy: pathlib.Path, tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from stable_baselines3 import PPO

    seen: dict[str, set[int]] = {"rollout": set(), "update": set()}
    act, train = BinActions.action, PPO.train

    def recording_action(self: BinActions, action: Any) -> Any:
        seen["rollout"].add(torch.get_num_threads())
        return act(self, action)

    def recording_train(self: Any) -> None:
        seen["update"].add(torch.get_num_threads())
        train(self)

    monkeypatch.setattr(BinActions, "action", recording_action)
    monkeypatch.setattr(PPO, "train", recording_train)
    threads = torch.get_num_threads()
    # One env: it steps in this process, where the threads can be seen.
    cfg = tiny_run(imitation_policy, tmp_path, torch_threads=2, rollout_threads=1)
    try:
        finetune_policy(cfg)
        assert seen == {"rollout": {1}, "update": {2}}
        assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(threads)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("timesteps", 0),
        ("n_steps", -1),
        ("learning_rate", 0.0),
        ("clip_range", float("nan")),
        ("gamma", 1.5),
        ("critic_warmup_rollouts", -1),
        ("target_kl", -0.1),
        ("max_minutes", 0),
        ("ent_coef", -0.01),
        ("rollout_threads", 0),
        ("critic_encoder", "shared"),
        ("contact_anchor", -1.0),
        ("contact_anchor", float("inf")),
        ("contact_anchor", True),
        ("ent_coef", True),
        ("learning_rate", True),
        ("gamma", True),
    ],
)
def test_bad_finetuning_configs_are_named(field: str, value: object) -> None:
    with pytest.raises(ValueError, match=field):
        FinetuneConfig(
            out_dir=pathlib.Path("."),
            policy=pathlib.Path("p.pt"),
            **{field: value},  # type: ignore[arg-type]
        )


def test_train_py_fine_tunes_after_the_imitation_or_a_policy_already_trained(
    tmp_path: pathlib.Path,
) -> None:
    train = load_script("train")
    out = str(tmp_path)
    recipe = FinetuneConfig(out_dir=tmp_path, policy=tmp_path).timesteps
    assert train.finetune_of(["--teacher", "planner", "--out", out]) == (None, recipe)
    assert train.finetune_of(["--teacher", "planner", "--out", out, "--finetune-steps", "0"]) == (
        None,
        0,
    )
    policy, steps = train.finetune_of(["--finetune", "run/policy.pt", "--out", out])
    assert (
        policy == pathlib.Path("run/policy.pt")
        and steps == FinetuneConfig(out_dir=tmp_path, policy=policy).timesteps
    )
    cfg = train.finetune_config(
        ["--finetune", "run/policy.pt", "--out", out, "--seed", "3", "--finetune-steps", "900"]
    )
    assert (cfg.policy, cfg.out_dir, cfg.seed, cfg.timesteps) == (policy, tmp_path, 3, 900)
    assert cfg.command.startswith("python scripts/train.py --finetune run/policy.pt")
    assert cfg.contact_anchor == 0.0
    anchored = train.finetune_config(
        ["--finetune", "run/policy.pt", "--out", out, "--contact-anchor", "0.5"]
    )
    assert anchored.contact_anchor == 0.5
    with pytest.raises(SystemExit):
        train.finetune_config(["--finetune", "p.pt", "--out", out, "--contact-anchor", "-1"])
    imitation = train.imitation_config(
        ["--teacher", "planner", "--out", out, "--finetune-steps", "900"]
    )
    assert imitation.out_dir == tmp_path  # the imitation's own config is unchanged by it
    with pytest.raises(SystemExit):
        train.imitation_config(["--teacher", "planner", "--out", out, "--finetune-steps", "-1"])
    with pytest.raises(SystemExit):
        train.finetune_config(["--finetune", "p.pt", "--out", out, "--finetune-steps", "0"])


def test_the_finetuning_continues_the_imitations_learning_curve(tmp_path: pathlib.Path) -> None:
    curve = tmp_path / "curve.csv"
    curve.write_text(
        "timesteps,length,success,phase,beta\n"
        "120.0,120.0,1.0,demonstrations,1.0\n"
        "300.0,90.0,0.0,dagger 1,0.5\n"
    )
    tuned = tmp_path / "finetune_curve.csv"
    tuned.write_text(
        "timesteps,return,length,success,actor_training\n"
        "80.0,3.5,80.0,1.0,0.0\n"
        "250.0,-2.0,170.0,0.0,1.0\n"
    )
    append_to_curve(curve, tuned)
    with curve.open() as fh:
        rows = list(csv.DictReader(fh))
    assert [(float(r["timesteps"]), r["phase"], float(r["beta"])) for r in rows] == [
        (120.0, "demonstrations", 1.0),
        (300.0, "dagger 1", 0.5),
        (380.0, PHASE, 0.0),
        (550.0, PHASE, 0.0),
    ]
    assert [float(r["success"]) for r in rows] == [1.0, 0.0, 1.0, 0.0]
    assert _phase_starts(curve) == [
        (0.0, " teacher 100%"),
        (120.0, " teacher 50%"),
        (300.0, " PPO"),
    ]


def test_the_recipe_imitates_then_fine_tunes_into_one_run_folder(tmp_path: pathlib.Path) -> None:
    out = tmp_path / "run"
    result = load_script("train").main(
        ["--teacher", "planner", "--out", str(out), "--n-envs", "1", "--demo-steps", "120",
         "--rounds", "1", "--round-steps", "60", "--epochs", "1", "--finetune-steps", "64",
         "--no-progress"]
    )  # fmt: skip
    assert result.policy_path == out / "policy.pt" and result.steps >= 64
    policy = load_policy(out / "policy.pt")
    assert policy.meta["config"]["mirror_share"] == 0.5  # the recipe's
    assert policy.meta["finetune"]["steps"] == result.steps
    assert policy.meta["finetune"]["command"].startswith("python scripts/train.py --teacher")
    assert (out / "checkpoints" / "phase1.pt").is_file()  # the imitation's own policy
    with (out / "curve.csv").open() as fh:
        phases = [row["phase"] for row in csv.DictReader(fh)]
    tuned = (out / "finetune_curve.csv").read_text().splitlines()[1:]
    # every fine-tuning episode continues the curve, after the imitation's episodes
    assert len(tuned) >= 1 and phases[len(phases) - len(tuned) :] == [PHASE] * len(tuned)
    assert PHASE not in phases[: len(phases) - len(tuned)]
