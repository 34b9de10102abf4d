"""The evaluation suite: its episodes, one real episode, and the summary, table and plot."""

from __future__ import annotations

import math

import pytest

from agents.evaluation.suite import (
    CI_KEYS,
    SUMMARY_KEYS,
    EpisodeResult,
    SuiteConfig,
    markdown_table,
    plot_summary,
    run_episode,
    suite_episodes,
    summarize,
)
from tests.agents.episodes import episode


def test_suite_cycles_families_with_fixed_seeds() -> None:
    eps = suite_episodes(SuiteConfig(episodes=6, seed=2, families=("room", "office", "corridor")))
    assert [e.family for e in eps] == ["room", "office", "corridor"] * 2
    assert [e.seed for e in eps] == [200_000 + i for i in range(6)]
    assert (
        suite_episodes(SuiteConfig(episodes=6, seed=2, families=("room", "office", "corridor")))[5]
        == eps[5]
    )


def test_suite_config_rejects_bad_values() -> None:
    with pytest.raises(ValueError, match="episodes must be a positive integer"):
        SuiteConfig(episodes=0)
    with pytest.raises(ValueError, match="families must be a non-empty subset"):
        SuiteConfig(families=("kitchen",))
    with pytest.raises(ValueError, match="env_kwargs must not hold 'scenario'"):
        SuiteConfig(env_kwargs={"scenario": "room"})
    with pytest.raises(ValueError, match=r"unknown NavigatorConfig option\(s\) \['fused'\]"):
        SuiteConfig(navigator={"fused": 1.8})
    with pytest.raises(ValueError, match="fused_range_m"):
        SuiteConfig(navigator={"fused_range_m": -1.0})


def test_navigator_settings_reach_the_model_based_agents_only() -> None:
    from agents.evaluation.suite import _agent

    planner = _agent("planner", {"fused_range_m": 1.8})
    assert planner.config.fused_range_m == 1.8 and planner.config.policy.value == "planner"
    assert _agent("planner", {}).config.fused_range_m == 0.0  # another agent, the defaults
    assert _agent("planner", {"fused_range_m": 1.8}) is planner  # one per settings and process
    assert type(_agent("oracle", {"fused_range_m": 1.8})).__name__ == "OracleAgent"


def test_evaluate_cli_sets_the_memory_and_the_navigator(monkeypatch: pytest.MonkeyPatch) -> None:
    import pathlib
    import sys

    monkeypatch.syspath_prepend(str(pathlib.Path(__file__).resolve().parents[3] / "scripts"))
    sys.modules.pop("evaluate", None)
    from evaluate import suite_config

    off = suite_config(["--agent", "planner", "--json", "-"])
    assert off.env_kwargs["memory"] is False and off.navigator == {}
    on = suite_config(["--agent", "planner", "--json", "-", "--fused-range", "1.8"])
    assert on.env_kwargs["memory"] is True and on.navigator == {"fused_range_m": 1.8}
    both = suite_config(
        ["--agent", "planner", "--navigator-setting", "replan_every=1", "--fused-range", "1.8"]
    )
    assert both.navigator == {"replan_every": 1, "fused_range_m": 1.8}
    for bad in ("replan_every", "replan_every=0", "no_such_field=1", "policy=greedy"):
        with pytest.raises(SystemExit):  # argparse names the bad setting
            suite_config(["--agent", "planner", "--navigator-setting", bad])


def test_oracle_episode_succeeds_with_spl_near_one() -> None:
    cfg = SuiteConfig(episodes=1, families=("corridor",), max_steps=320)
    (spec,) = suite_episodes(cfg)
    result = run_episode("oracle", spec, cfg)
    assert result.success and not result.collided and result.looks == 0
    assert result.scene.startswith("corridor-") and math.isfinite(result.reference_m)
    assert result.path_length_m >= result.reference_m
    assert 0.85 < result.spl <= 1.0
    assert result.spl == pytest.approx(result.reference_m / result.path_length_m)


def _result(agent: str, index: int, success: bool, collisions: int, spl: float) -> EpisodeResult:
    return episode(
        index, success=success, spl=spl, collisions=collisions, agent=agent,
        steps=100 + 10 * index, looks=index, time_s=2.0,
    )  # fmt: skip


def test_summary_table_and_plot(tmp_path) -> None:
    results = {
        "planner": [_result("planner", 0, True, 0, 0.8), _result("planner", 1, False, 3, 0.0)],
        "greedy": [_result("greedy", 0, True, 1, 0.5), _result("greedy", 1, True, 2, 0.7)],
    }
    summary = summarize(results)
    assert list(summary) == ["planner", "greedy"]
    assert tuple(summary["planner"]) == SUMMARY_KEYS + CI_KEYS
    assert {k: summary["planner"][k] for k in SUMMARY_KEYS} == {
        "episodes": 2,
        "success_rate": 0.5,
        "collision_rate": 0.5,
        "mean_collisions": 1.5,
        "spl": 0.4,
        "mean_steps": 105.0,
        "mean_looks": 0.5,
        "mean_episode_time_s": 2.0,
    }
    assert summary["greedy"]["collision_rate"] == 1.0
    assert summary["greedy"]["mean_collisions"] == 1.5
    assert summary["greedy"]["spl"] == pytest.approx(0.6)
    table = markdown_table(summary).splitlines()
    assert table[0].startswith(
        "| agent | episodes | success | collision | collisions / episode | SPL |"
    )
    assert table[2] == (
        "| planner | 2 | 0.50 [0.00, 1.00] | 0.50 [0.00, 1.00] | 1.50 | 0.400 [0.000, 0.800] | "
        "105.0 | 0.5 | 2.0 |"
    )
    png = plot_summary(summary, tmp_path / "bars.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_dev_and_test_splits_never_share_an_episode() -> None:
    from agents.evaluation.suite import (
        EPISODE_STRIDE,
        TEST_SEED_START,
        Split,
        default_seed,
        split_of,
    )

    last_dev = SuiteConfig(episodes=EPISODE_STRIDE, seed=TEST_SEED_START - 1)
    first_test = SuiteConfig(episodes=EPISODE_STRIDE, seed=TEST_SEED_START)
    dev_seeds = [spec.seed for spec in suite_episodes(last_dev)]
    test_seeds = [spec.seed for spec in suite_episodes(first_test)]
    assert max(dev_seeds) < min(test_seeds)  # every dev suite seed is below, every test one above
    assert split_of(0) is Split.DEV and split_of(TEST_SEED_START - 1) is Split.DEV
    assert split_of(default_seed("test")) is Split.TEST and default_seed("dev") == 0
    with pytest.raises(ValueError, match="episodes must be at most"):
        SuiteConfig(episodes=EPISODE_STRIDE + 1)


def test_evaluate_cli_runs_the_split_and_refuses_a_seed_of_the_other(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import pathlib

    from agents.evaluation.suite import TEST_SEED_START

    monkeypatch.syspath_prepend(str(pathlib.Path(__file__).resolve().parents[3] / "scripts"))
    from evaluate import suite_config

    assert suite_config(["--agent", "planner"]).seed == 0
    assert suite_config(["--agent", "planner", "--split", "test"]).seed == TEST_SEED_START
    assert suite_config(["--agent", "planner", "--seed", "4242"]).seed == 4242
    with pytest.raises(SystemExit):
        suite_config(["--agent", "planner", "--split", "test", "--seed", "0"])
    with pytest.raises(SystemExit):
        suite_config(["--agent", "planner", "--seed", str(TEST_SEED_START)])
