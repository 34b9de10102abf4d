"""Issue 43's ablation: the summary per agent and perception, its table and plot, the step times
and the figure of what each perception sees."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

from agents.evaluation.ablation import (
    METRICS,
    ablation_markdown,
    ablation_summary,
    drive_action,
    perception_step_times,
    plot_ablation,
    plot_views,
    run_ablation,
)
from agents.evaluation.suite import SuiteConfig, bootstrap_ci, summarize
from tests.agents.episodes import episode

CFG = SuiteConfig(episodes=3, seed=4, families=("room",))
SMALL = {"width_px": 160, "height_px": 120, "focal_px": 130.0}


def _results() -> dict[str, dict[str, list]]:
    """Made-up episodes: the planner succeeds more with truth, greedy collides more with dense."""

    def eps(agent: str, successes: list[bool], collisions: list[int]) -> list:
        return [
            episode(i, success=s, spl=0.8 * s, collisions=c, agent=agent)
            for i, (s, c) in enumerate(zip(successes, collisions, strict=True))
        ]

    return {
        "stereo": {
            "planner": eps("planner", [True, False, True], [0, 2, 0]),
            "greedy": eps("greedy", [True, False, False], [1, 1, 0]),
        },
        "truth": {
            "planner": eps("planner", [True, True, True], [0, 0, 0]),
            "greedy": eps("greedy", [True, True, False], [0, 0, 3]),
        },
    }


def test_the_summary_has_every_figure_with_its_interval_per_agent_and_perception() -> None:
    results = _results()
    summary = ablation_summary(results, {"stereo": 7.5, "truth": 1.5}, CFG)
    assert summary["step_ms"] == {"stereo": 7.5, "truth": 1.5}
    assert summary["suite"]["split"] == "dev" and summary["suite"]["suite_seed"] == 4
    assert summary["suite"]["episodes"] == 3 and summary["suite"]["families"] == ["room"]
    assert summary["suite"]["rules"]["preset"] == "v1"
    assert list(summary["results"]) == ["planner", "greedy"]
    for agent in ("planner", "greedy"):
        assert list(summary["results"][agent]) == ["stereo", "truth"]
        for p in ("stereo", "truth"):
            figures = summary["results"][agent][p]
            want = summarize({agent: results[p][agent]})[agent]
            assert {k: figures[k] for k in want} == want
            for key, _ in METRICS:
                lo, hi = figures[f"{key}_ci"]
                assert lo - 1e-12 <= figures[key] <= hi + 1e-12
    greedy_truth = summary["results"]["greedy"]["truth"]
    assert greedy_truth["mean_collisions"] == pytest.approx(1.0)
    assert greedy_truth["mean_collisions_ci"] == bootstrap_ci([0, 0, 3])
    assert summary["results"]["planner"]["truth"]["success_rate_ci"] == [1.0, 1.0]


def test_the_summary_refuses_mismatched_perceptions_agents_and_episodes() -> None:
    results = _results()
    with pytest.raises(ValueError, match="step_ms"):
        ablation_summary(results, {"stereo": 7.5}, CFG)
    other = {**results, "truth": {"planner": results["truth"]["planner"]}}
    with pytest.raises(ValueError, match="agents"):
        ablation_summary(other, {"stereo": 7.5, "truth": 1.5}, CFG)
    shifted = {
        **results,
        "truth": {**results["truth"], "greedy": [episode(9, success=True, agent="greedy")] * 3},
    }
    with pytest.raises(ValueError, match="same episodes"):
        ablation_summary(shifted, {"stereo": 7.5, "truth": 1.5}, CFG)


def test_the_table_and_the_plot(tmp_path: pathlib.Path) -> None:
    summary = ablation_summary(_results(), {"stereo": 7.5, "truth": 1.5}, CFG)
    table = ablation_markdown(summary)
    lines = table.strip().splitlines()
    assert len(lines) == 2 + 4  # header, rule, 2 agents x 2 perceptions
    assert lines[2].startswith("| planner | stereo | 3 | 0.67 [")
    assert "| greedy | truth | 3 | 0.67 [" in table and lines[-1].endswith("| 1.5 |")
    path = plot_ablation(summary, tmp_path / "plot.png")
    assert path.stat().st_size > 10_000


def test_run_ablation_checks_its_perceptions_before_running() -> None:
    with pytest.raises(ValueError, match="perceptions must be"):
        run_ablation(["greedy"], ["lidar"], CFG)
    with pytest.raises(ValueError, match="perception"):
        run_ablation(["greedy"], ["truth"], SuiteConfig(env_kwargs={"perception": "stereo"}))


def test_step_times_are_measured_for_each_perception_on_one_drive() -> None:
    assert drive_action(0).tolist() == pytest.approx([0.6, 0.0, 0.0])
    assert drive_action(0).dtype == np.float32
    times = perception_step_times(
        ["truth", "stereo_means"], steps=3, warmup=1, rounds=1, env_kwargs=SMALL
    )
    assert list(times) == ["truth", "stereo_means"]
    assert all(np.isfinite(v) and v > 0 for v in times.values())
    with pytest.raises(ValueError, match="steps"):
        perception_step_times(["truth"], steps=0)


def test_the_views_figure_has_one_panel_per_perception(tmp_path: pathlib.Path) -> None:
    from PIL import Image

    path = plot_views(["stereo", "truth"], tmp_path / "views.png", steps=2, env_kwargs=SMALL)
    width, height = Image.open(path).size
    assert width > 1.5 * height  # two panels side by side
    with pytest.raises(ValueError, match="steps"):
        plot_views(["truth"], tmp_path / "x.png", steps=-1)
