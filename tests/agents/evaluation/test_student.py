"""A learned student traced beside its teacher: the figures, a traced episode, the report."""

from __future__ import annotations

import json
import math
import pathlib

import numpy as np
import pytest

from agents.evaluation.student import StudentTrace, student_patterns, trace_student
from agents.evaluation.suite import SuiteConfig, suite_episodes
from tests.scripts.loader import ROOT, load_script


def _trace(sent: list[list[float]], teacher: list[list[float]], **kw: object) -> StudentTrace:
    n = len(sent)
    fields: dict[str, object] = {
        "family": "room",
        "seed": 7,
        "success": False,
        "sent": np.array(sent, dtype=np.float64).reshape(n, 3),
        "teacher": np.array(teacher, dtype=np.float64).reshape(n, 3),
        "xy": np.zeros((n, 2)),
        "collided": np.zeros(n, dtype=bool),
        "geodesic_m": np.linspace(5.0, 4.0, n),
    }
    fields.update(kw)
    return StudentTrace(**fields)  # type: ignore[arg-type]


def test_the_figures_count_dithering_disagreement_and_standing_still() -> None:
    # four steps: on the spot twice; turns +, -, (weak), + : two flips; the teacher turns
    # left at every step, so of the three steps where both turn strongly one is opposite
    sent = [[0.0, 0.9, 0.0], [0.1, -0.8, 0.0], [0.5, 0.1, 0.0], [1.0, 0.5, 0.0]]
    teacher = [[0.2, -0.5, 0.0], [0.2, -0.5, 0.0], [0.2, -0.5, 0.0], [0.2, 0.6, 0.0]]
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    collided = np.array([False, True, True, False])
    geodesic = np.array([5.0, 3.0, 3.5, 4.0])
    f = student_patterns(_trace(sent, teacher, xy=xy, collided=collided, geodesic_m=geodesic))
    assert f["steps"] == 4 and f["in_place_share"] == 0.5
    assert f["turn_flips_per_100"] == pytest.approx(100 * 2 / 4)
    assert f["opposite_turn_share"] == pytest.approx(1 / 3)
    assert f["forward_excess"] == pytest.approx(np.mean([-0.2, -0.1, 0.3, 0.8]))
    assert f["collision_steps"] == 2
    assert (f["geodesic_start_m"], f["geodesic_min_m"], f["geodesic_end_m"]) == (5.0, 3.0, 4.0)
    assert f["last_radius_m"] == pytest.approx(1.0)  # mean x 1.0: the ends are 1 m from it


def test_a_robot_that_stays_put_has_no_radius_and_no_turns_to_compare() -> None:
    f = student_patterns(_trace([[0.0, 0.0, 0.5]] * 3, [[0.5, 0.0, 0.0]] * 3))
    assert f["in_place_share"] == 1.0 and f["last_radius_m"] == 0.0
    assert f["turn_flips_per_100"] == 0.0 and math.isnan(f["opposite_turn_share"])
    empty = student_patterns(_trace([], []))
    assert empty["steps"] == 0 and math.isnan(empty["in_place_share"])


def test_a_traced_episode_labels_each_state_the_student_reached() -> None:
    cfg = SuiteConfig(
        episodes=1, max_steps=12, env_kwargs={"diagnostics": False, "perception": "surrogate"}
    )
    spec = suite_episodes(cfg)[0]
    trace = trace_student("learned", spec, cfg)
    assert trace.sent.shape == trace.teacher.shape == (12, 3)
    assert np.all(np.abs(trace.sent) <= 1.0) and np.all(np.abs(trace.teacher) <= 1.0)
    assert np.all(np.isfinite(trace.geodesic_m))
    # the robot drove: its positions move, and the first one is the episode's start
    assert float(np.hypot(*(trace.xy[-1] - trace.xy[0]))) > 0.05
    with pytest.raises(ValueError, match="replan_evry"):
        trace_student("learned", spec, cfg, teacher_settings={"replan_evry": 1})


def test_a_planner_labelled_by_its_own_twin_agrees_and_one_replanning_always_may_not() -> None:
    """With the planner driving, a teacher with the same settings sends its very commands (the
    trace compares teachers without a student); one that re-plans at every step differs."""
    cfg = SuiteConfig(
        episodes=2, max_steps=40, env_kwargs={"diagnostics": False, "perception": "surrogate"}
    )
    spec = suite_episodes(cfg)[1]
    twin = trace_student("planner", spec, cfg)
    np.testing.assert_array_equal(twin.sent, twin.teacher)
    eager = trace_student("planner", spec, cfg, teacher_settings={"replan_every": 1})
    np.testing.assert_array_equal(eager.sent, twin.sent)  # the same drive
    assert not np.array_equal(eager.teacher, twin.teacher)


def test_the_student_report_writes_each_episode_and_the_means_by_outcome(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))
    out = tmp_path / "student.json"
    report = load_script("student_report")
    rows = report.main(
        [
            "--episodes", "2", "--seed", "0", "--only", "1", "--perception", "surrogate",
            "--max-steps", "10", "--json", str(out),
        ]
    )  # fmt: skip
    written = json.loads(out.read_text())
    assert written["episodes"] == rows
    assert [(r["index"], r["family"], r["steps"]) for r in rows] == [(1, "corridor", 10)]
    assert written["by_outcome"]["failed"]["episodes"] == 1.0
    assert written["by_outcome"]["failed"]["steps"] == 10.0
    assert written["by_outcome"]["success"] == {"episodes": 0.0}
    with pytest.raises(SystemExit):
        report.main(["--episodes", "1", "--teacher-setting", "replan_every"])
    with pytest.raises(SystemExit):
        report.main(["--episodes", "1", "--teacher-setting", "no_such_field=1"])
