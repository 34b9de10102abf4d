"""train.py and evaluate.py build their envs from one configuration."""

from __future__ import annotations

import pathlib

from agents.evaluation.suite import suite_env_config, suite_rules
from tests.scripts.loader import load_script


def test_training_and_evaluation_build_identical_env_configs(tmp_path: pathlib.Path) -> None:
    for family in ("open", "sparse", "room"):
        train = load_script("train").train_config(
            ["--timesteps", "10", "--out", str(tmp_path), "--scenario", family]
        )
        suite = load_script("evaluate").suite_config(
            ["--agent", "greedy", "--json", str(tmp_path / "e.json"), "--scenario", family]
        )
        assert suite.families == (family,)
        trained, evaluated = train.env_config(), suite_env_config(suite, family)
        assert trained == evaluated and trained.scenario == family
        assert trained.rules_dict() == evaluated.rules_dict()
        assert trained.rules_dict()["preset"] == "v1"
        assert suite_rules(suite)["env_id"] == "StereoNav-v1"


def test_evaluate_tilt_sets_the_suite_envs_head_tilt(tmp_path: pathlib.Path) -> None:
    base = ["--agent", "greedy", "--json", str(tmp_path / "e.json")]
    tilted = load_script("evaluate").suite_config([*base, "--tilt", "0.3"])
    level = load_script("evaluate").suite_config(base)
    assert suite_env_config(tilted, "room").camera.tilt_rad == 0.3
    assert suite_env_config(level, "room").camera.tilt_rad == 0.0
    assert (
        suite_env_config(tilted, "room").blind_range_m
        < suite_env_config(level, "room").blind_range_m
    )
