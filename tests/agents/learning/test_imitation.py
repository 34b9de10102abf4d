"""Imitation of the planner: the action coding, the teacher's relabelling, a DAgger smoke run."""

from __future__ import annotations

import itertools
import pathlib
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents import make_agent
from agents.evaluation.suite import SuiteConfig, suite_rules
from agents.learning.egomap import EgoMapConfig, mirrored
from agents.learning.imitation import (
    ImitationConfig,
    PolicyBundle,
    _bin_loss,
    _Dataset,
    _fit,
    _minibatch,
    _new_bundle,
    _validate,
    decode_bins,
    encode_bins,
    fit_speed,
    load_policy,
    train_imitation,
)
from agents.learning.wrappers import PlannerTeacher
from tests.scripts.loader import load_script


def test_bins_give_every_action_back() -> None:
    actions = np.random.default_rng(0).uniform(-1, 1, (500, 3))
    actions[:3] = [[-1, 1, 0], [1, -1, 0.5], [0, 0, -0.2]]
    np.testing.assert_allclose(decode_bins(encode_bins(actions, 11)), actions, atol=1e-6)


def test_two_modes_decode_to_one_of_them_not_their_mean() -> None:
    left, right = (
        encode_bins(np.array([[0.5, -0.8, 0.0]]), 11),
        encode_bins(np.array([[0.5, 0.8, 0.0]]), 11),
    )
    mixed = 0.45 * left + 0.55 * right
    assert decode_bins(mixed)[0, 1] == pytest.approx(0.8, abs=1e-6)


def test_the_teacher_labels_the_state_the_student_drove_into() -> None:
    """With the teacher's own actions sent, the wrapper's labels are the planner's actions of a
    planner driving alone; and an executed command other than the label reaches its memory."""
    alone = gym.make("StereoNav-v1", scenario="room", perception="surrogate")
    planner = make_agent("planner")
    obs, info = alone.reset(seed=3)
    planner.reset(alone, seed=3)
    reference = []
    for _ in range(25):
        action = planner.act(obs, info)
        reference.append(action)
        obs, *_, info = alone.step(action)
    wrapped = PlannerTeacher(gym.make("StereoNav-v1", scenario="room", perception="surrogate"))
    _, info = wrapped.reset(seed=3)
    labels = []
    for _ in range(25):
        labels.append(info["teacher_action"])
        _, *_, info = wrapped.step(info["teacher_action"])
    np.testing.assert_array_equal(np.array(labels), np.array(reference))
    wrapped.teacher.executed(np.array([-0.7, 0.0, 0.0]))
    assert wrapped.teacher._recovery is not None
    assert wrapped.teacher._recovery._last_forward == pytest.approx(-0.7)


def test_a_dagger_smoke_run_writes_a_policy_that_loads_and_acts(tmp_path: pathlib.Path) -> None:
    cfg = ImitationConfig(
        out_dir=tmp_path,
        n_envs=1,
        demo_steps=150,
        rounds=1,
        round_steps=100,
        epochs=1,
        families=("open", "room"),
        weights=(1.0, 1.0),
        progress=False,
    )
    result = train_imitation(cfg)
    assert [r["phase"] for r in result.record] == ["demonstrations", "dagger 1"]
    assert result.record[0]["samples"] >= 150 and result.record[1]["samples"] >= 250
    for row in result.record:  # 5 % of ~150 samples held out: a few, never all
        assert 0.0 <= row["val_accuracy_turn"] <= 1.0 and row["val_loss"] > 0.0
    policy = load_policy(result.policy_path)
    assert policy.meta["rules"] == cfg.rules()
    agent = make_agent(f"learned:{result.policy_path}")
    env = gym.make("StereoNav-v1", scenario="office", perception="surrogate")
    obs, info = env.reset(seed=1)
    agent.reset(env, seed=1)
    for _ in range(5):
        action = agent.act(obs, info)
        assert action.shape == (3,) and np.all(np.abs(action) <= 1.0)
        obs, *_, info = env.step(action)
    fixed = make_agent(f"learned-fixed-head:{result.policy_path}")
    fixed.reset(env, seed=1)
    assert fixed.act(obs, info)[2] == 0.0
    env.close()


def test_the_recipe_trains_under_the_rules_the_suite_evaluates(tmp_path: pathlib.Path) -> None:
    cfg = load_script("train").imitation_config(["--teacher", "planner", "--out", str(tmp_path)])
    assert cfg.rules() == suite_rules(SuiteConfig())
    assert cfg.rules()["preset"] == "v1"
    assert cfg.command.startswith("python scripts/train.py --teacher planner")
    assert cfg.torch_threads == 2
    shared = load_script("train").imitation_config(
        ["--teacher", "planner", "--out", str(tmp_path), "--torch-threads", "1"]
    )
    assert shared.torch_threads == 1 and shared.to_dict() == {
        **cfg.to_dict(),
        **{"torch_threads": 1, "command": shared.command},
    }
    assert cfg.teacher_settings == {}


def test_the_teacher_settings_reach_the_teacher_of_every_training_env(
    tmp_path: pathlib.Path,
) -> None:
    from agents.learning.wrappers import make_training_env

    words = ["--teacher", "planner", "--out", str(tmp_path), "--teacher-setting", "replan_every=1"]
    cfg = load_script("train").imitation_config(words)
    assert cfg.teacher_settings == {"replan_every": 1}
    assert cfg.to_dict()["teacher_settings"] == {"replan_every": 1}
    env = make_training_env(
        dict(cfg.env_kwargs),
        families=("room",),
        teacher=cfg.teacher,
        teacher_settings=cfg.teacher_settings,
    )
    wrapper: Any = env
    while not isinstance(wrapper, PlannerTeacher):
        wrapper = wrapper.env
    assert wrapper.teacher.config.replan_every == 1
    assert wrapper.teacher.config.policy.value == "planner"
    env.close()
    with pytest.raises(SystemExit):  # argparse names the bad setting
        load_script("train").imitation_config(
            ["--teacher", "planner", "--out", str(tmp_path), "--teacher-setting", "nope=1"]
        )
    mirror = load_script("train").imitation_config([*words[:4], "--mirror-share", "0"])
    assert mirror.mirror_share == 0.0 and mirror.to_dict()["mirror_share"] == 0.0
    assert cfg.mirror_share == 0.5  # the recipe's
    with pytest.raises(SystemExit):
        load_script("train").imitation_config([*words[:4], "--mirror-share", "2"])


def test_bad_recipes_are_named(tmp_path: pathlib.Path) -> None:
    with pytest.raises(ValueError, match="teacher"):
        ImitationConfig(out_dir=tmp_path, teacher="oracle")
    with pytest.raises(ValueError, match="betas"):
        ImitationConfig(out_dir=tmp_path, betas=(1.5,))
    with pytest.raises(ValueError, match="validation_share"):
        ImitationConfig(out_dir=tmp_path, validation_share=0.5)
    with pytest.raises(ValueError, match="final_lr_share"):
        ImitationConfig(out_dir=tmp_path, final_lr_share=0.0)
    with pytest.raises(ValueError, match="mirror_share"):
        ImitationConfig(out_dir=tmp_path, mirror_share=1.5)
    with pytest.raises(ValueError, match="info_models"):
        ImitationConfig(out_dir=tmp_path, env_kwargs={"info_models": True})
    with pytest.raises(ValueError, match="no_such_field"):
        ImitationConfig(out_dir=tmp_path, teacher_settings={"no_such_field": 1})
    with pytest.raises(ValueError, match="replan_every"):
        ImitationConfig(out_dir=tmp_path, teacher_settings={"replan_every": 0})
    with pytest.raises(ValueError, match="policy"):
        ImitationConfig(out_dir=tmp_path, teacher_settings={"policy": "greedy"})
    with pytest.raises(FileNotFoundError, match="no trained policy"):
        load_policy(tmp_path / "none.pt")


def test_the_loss_is_each_commands_cross_entropy_averaged() -> None:
    """One sample, three commands: the loss is the mean of the three cross-entropies against
    the soft targets (the scale of every recorded ``loss`` and ``val_loss``)."""
    import torch

    logits = torch.log(torch.tensor([[[0.5, 0.25, 0.25], [0.25, 0.5, 0.25], [0.25, 0.25, 0.5]]]))
    targets = torch.tensor([[[1.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 0.0, 1.0]]])
    per_command = [-np.log(0.5), -(0.5 * np.log(0.25) + 0.5 * np.log(0.5)), -np.log(0.5)]
    assert float(_bin_loss(logits, targets)) == pytest.approx(np.mean(per_command))


def test_validation_scores_a_student_against_the_teachers_nearest_bins() -> None:
    import torch

    bins = 11
    rng = np.random.default_rng(3)
    actions = rng.uniform(-1.0, 1.0, size=(40, 3)).astype(np.float32)
    nearest = np.rint((actions + 1.0) * 0.5 * (bins - 1)).astype(np.int64)

    class Echo(torch.nn.Module):
        """Puts all its mass on the bin its state names (the state carries the answer)."""

        def forward(self, image: torch.Tensor, state: torch.Tensor) -> torch.Tensor:
            return 50.0 * torch.nn.functional.one_hot(state.long(), bins).float()

    bundle = PolicyBundle(net=Echo(), egomap=EgoMapConfig(), bins=bins, meta={})
    maps = np.zeros((40, 1, 2, 2), dtype=np.uint8)
    right = _validate(bundle, maps, nearest.astype(np.float32), actions)
    assert right["val_accuracy_forward"] == right["val_accuracy_turn"] == 1.0
    wrong_turn = nearest.copy()
    wrong_turn[:10, 1] = (wrong_turn[:10, 1] + 3) % bins  # a quarter of the turns off
    scored = _validate(bundle, maps, wrong_turn.astype(np.float32), actions)
    assert scored["val_accuracy_turn"] == 0.75 and scored["val_accuracy_pan"] == 1.0
    assert scored["val_loss"] > right["val_loss"]
    empty = _validate(bundle, maps[:0], nearest[:0].astype(np.float32), actions[:0])
    assert np.isnan(empty["val_loss"])


def test_fits_run_channels_last_with_nchws_sums_and_leave_the_net_nchw(tmp_path) -> None:
    import copy

    import torch

    from agents.learning.egomap import CHANNELS, STATE_FEATURES

    rng = np.random.default_rng(5)
    n, size = 48, 16
    egomap = EgoMapConfig(size_px=size)
    maps = rng.integers(0, 256, size=(n, len(CHANNELS), size, size), dtype=np.uint8)
    states = rng.uniform(-1, 1, size=(n, len(STATE_FEATURES))).astype(np.float32)
    actions = rng.uniform(-1, 1, size=(n, 3)).astype(np.float32)
    torch.manual_seed(0)
    nchw = _new_bundle(egomap, 11, 32, {}).net
    nhwc = copy.deepcopy(nchw).to(memory_format=torch.channels_last)
    targets = torch.from_numpy(encode_bins(actions, 11))
    grads = []
    for net, image in (
        (nchw, torch.from_numpy(maps)),
        (nhwc, torch.from_numpy(maps).contiguous(memory_format=torch.channels_last)),
    ):
        loss = _bin_loss(net(image, torch.from_numpy(states)), targets)
        loss.backward()
        grads.append([p.grad.clone() for p in net.parameters()])
    for a, b in zip(*grads, strict=True):
        torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-5)

    bundle = _new_bundle(egomap, 11, 32, {})
    data = _Dataset(validation_share=0.25, seed=1)
    data.add(maps, states, actions)
    cfg = ImitationConfig(out_dir=tmp_path, egomap=egomap, epochs=2, batch_size=16, width=32)
    fitted = _fit(bundle, data, cfg, np.random.default_rng(0))
    assert np.isfinite(fitted["loss"]) and np.isfinite(fitted["val_loss"])
    assert all(p.is_contiguous() for p in bundle.net.parameters())
    assert not bundle.net.training

    speed = fit_speed(cfg, samples=32, repeats=1)
    assert speed["fit_samples_per_s_channels_last"] > 0 and speed["fit_samples_per_s_nchw"] > 0
    assert speed["fit_channels_last_over_nchw"] == pytest.approx(
        speed["fit_samples_per_s_channels_last"] / speed["fit_samples_per_s_nchw"]
    )


def test_each_fit_decays_its_step_size_from_the_recipes_to_its_final_share(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import torch

    from agents.learning.egomap import CHANNELS, STATE_FEATURES

    used: list[float] = []

    class Recording(torch.optim.Adam):
        def step(self, closure: Any = None) -> Any:
            used.append(self.param_groups[0]["lr"])
            return super().step(closure)

    monkeypatch.setattr(torch.optim, "Adam", Recording)
    rng = np.random.default_rng(2)
    n, size = 40, 16
    egomap = EgoMapConfig(size_px=size)
    data = _Dataset(validation_share=0.0, seed=1)
    data.add(
        rng.integers(0, 256, size=(n, len(CHANNELS), size, size), dtype=np.uint8),
        rng.uniform(-1, 1, size=(n, len(STATE_FEATURES))).astype(np.float32),
        rng.uniform(-1, 1, size=(n, 3)).astype(np.float32),
    )
    cfg = ImitationConfig(
        out_dir=tmp_path, egomap=egomap, epochs=2, batch_size=8, width=32, final_lr_share=0.1
    )
    for _ in range(2):  # a second fit (the next phase) starts again at the full step size
        used.clear()
        _fit(_new_bundle(egomap, 11, 32, {}), data, cfg, np.random.default_rng(0))
        assert len(used) == 2 * 5
        assert used[0] == pytest.approx(1e-3)
        assert all(a > b for a, b in itertools.pairwise(used))
        # the cosine reaches the floor one step after the last minibatch
        assert used[-1] == pytest.approx(1e-4 + 0.9e-3 * (1 + np.cos(np.pi * 9 / 10)) / 2)


def test_the_dataset_keeps_every_sample_whether_it_reserved_room_or_grew() -> None:
    rng = np.random.default_rng(3)
    chunks = [
        (
            rng.integers(0, 256, size=(k, 2, 4, 4), dtype=np.uint8),
            rng.normal(size=(k, 5)).astype(np.float32),
            rng.uniform(-1, 1, size=(k, 3)).astype(np.float32),
        )
        for k in (3, 4, 5)
    ]
    held = []
    for capacity in (0, 2, 12, 100):
        data = _Dataset(validation_share=0.3, seed=2, capacity=capacity)
        with pytest.raises(ValueError, match="no samples"):
            data.arrays()
        data.add(*chunks[0])
        data.add(*chunks[1])
        first = data.arrays()[0].copy()
        data.add(*chunks[2])
        maps, states, actions, held_out = data.arrays()
        assert len(data) == 12 and maps.shape == (12, 2, 4, 4)
        np.testing.assert_array_equal(maps, np.concatenate([c[0] for c in chunks]))
        np.testing.assert_array_equal(states, np.concatenate([c[1] for c in chunks]))
        np.testing.assert_array_equal(actions, np.concatenate([c[2] for c in chunks]))
        np.testing.assert_array_equal(maps[:7], first)
        held.append(held_out)
    for other in held[1:]:  # the held-out draws do not depend on the storage
        np.testing.assert_array_equal(other, held[0])
    assert 0 < held[0].sum() < 12


def test_a_mirrored_sample_is_the_mirror_observation_with_turn_and_pan_negated() -> None:
    rng = np.random.default_rng(3)
    maps = rng.integers(0, 256, size=(6, 8, 16, 16), dtype=np.uint8)
    states = rng.uniform(-1, 1, size=(6, 27)).astype(np.float32)
    actions = rng.uniform(-1, 1, size=(6, 3)).astype(np.float32)
    targets = encode_bins(actions, 11)
    stored = (maps.copy(), states.copy(), targets.copy())
    idx = np.array([1, 4, 5])
    same = _minibatch(maps, states, targets, idx, 0.0, rng)
    for got, want in zip(same, (maps, states, targets), strict=True):
        np.testing.assert_array_equal(got, want[idx])
    image, state, target = _minibatch(maps, states, targets, idx, 1.0, rng)
    want_maps, want_states = mirrored(maps[idx], states[idx])
    np.testing.assert_array_equal(image, want_maps)
    np.testing.assert_array_equal(state, want_states)
    np.testing.assert_allclose(target, encode_bins(actions[idx] * [1, -1, -1], 11), atol=1e-6)
    for got, want in zip((maps, states, targets), stored, strict=True):
        np.testing.assert_array_equal(got, want)  # the data set is not touched
    half = _minibatch(maps, states, targets, np.arange(6), 0.5, np.random.default_rng(0))
    flipped = [not np.array_equal(half[0][k], maps[k]) for k in range(6)]
    assert 0 < sum(flipped) < 6
