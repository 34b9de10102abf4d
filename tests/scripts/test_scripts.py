"""Smoke tests of the command-line programs (thin argparse glue over ``agents``).

Each script is loaded from its file (scripts/ is not a package) and its ``main(argv)`` called.
"""

from __future__ import annotations

import json
import pathlib
from types import SimpleNamespace

import numpy as np
import pytest

from tests.scripts.loader import load_script

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_evaluate_writes_json_markdown_plot_and_details(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "eval.json"
    summary = load_script("evaluate").main(
        [
            "--agent", "oracle", "--agent", "random", "--episodes", "2", "--seed", "1",
            "--families", "room", "corridor", "--max-steps", "15", "--json", str(out),
            "--markdown", str(tmp_path / "eval.md"), "--plot", str(tmp_path / "eval.png"),
            "--details", str(tmp_path / "details.json"), "--no-progress",
        ]
    )  # fmt: skip
    data = json.loads(out.read_text())
    assert data == summary and list(data) == ["oracle", "random"]
    assert set(data["oracle"]) == {
        "episodes", "success_rate", "collision_rate", "mean_collisions", "spl", "mean_steps",
        "mean_looks", "mean_episode_time_s", "success_rate_ci", "spl_ci", "collision_rate_ci",
        "rules", "split", "suite_seed", "navigator",
    }  # fmt: skip
    assert data["oracle"]["split"] == "dev" and data["oracle"]["navigator"] == {}
    assert data["oracle"]["rules"]["preset"] == "v1" and data["oracle"]["rules"]["env_id"] == (
        "StereoNav-v1"
    )
    assert data["oracle"]["episodes"] == 2 and data["oracle"]["mean_steps"] == 15
    assert "| oracle | 2 |" in (tmp_path / "eval.md").read_text()
    assert (tmp_path / "eval.png").stat().st_size > 1000
    details = json.loads((tmp_path / "details.json").read_text())
    assert sorted((d["agent"], d["family"]) for d in details) == [
        ("oracle", "corridor"), ("oracle", "room"), ("random", "corridor"), ("random", "room"),
    ]  # fmt: skip
    assert "| random | 2 |" in capsys.readouterr().out


def test_evaluate_without_json_prints_the_table_and_writes_no_file(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    summary = load_script("evaluate").main(
        [
            "--agent", "oracle", "--episodes", "1", "--families", "corridor", "--max-steps", "3",
            "--perception", "surrogate", "--no-progress",
        ]
    )  # fmt: skip
    assert list(summary) == ["oracle"] and summary["oracle"]["episodes"] == 1
    assert "| oracle | 1 |" in capsys.readouterr().out
    assert list(tmp_path.iterdir()) == []


def test_demo_writes_gif_figure_and_summary(
    tmp_path: pathlib.Path, small_map: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    result = load_script("demo").main(
        ["--scenario", str(small_map), "--seed", "0", "--out", str(tmp_path / "demo"),
         "--max-steps", "12"]
    )  # fmt: skip
    assert result.gif.read_bytes()[:6] == b"GIF89a"
    assert result.figure.stat().st_size > 1000
    summary = json.loads(result.summary.read_text())
    assert summary["agent"] == "planner" and summary["steps"] == 12
    assert summary["files"] == {"gif": "episode.gif", "figure": "model_steps.png"}
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("step ")]
    assert len(lines) == 12


def test_train_runs_end_to_end(tmp_path: pathlib.Path, small_map: pathlib.Path) -> None:
    result = load_script("train").main(
        ["--timesteps", "64", "--n-envs", "1", "--out", str(tmp_path / "ppo"),
         "--rollout-steps", "32", "--batch-size", "32", "--eval-freq", "0",
         "--checkpoint-freq", "0", "--scenario", str(small_map), "--no-progress"]
    )  # fmt: skip
    assert result.model_path.is_file() and result.timesteps == 64
    assert (tmp_path / "ppo" / "learning_curve.png").is_file()


def test_memory_eval_compares_the_fused_and_single_view_figures_on_the_same_steps(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))  # its _figures helper lives there
    out = tmp_path / "memory.json"
    figures = load_script("memory_eval").main(
        ["--seeds", "1", "--max-steps", "4", "--scenario", "two_gaps", "--json", str(out)]
    )
    assert json.loads(out.read_text()) == pytest.approx(figures, nan_ok=True)
    assert figures["steps"] == 5  # the reset and 4 steps
    for name in ("p_true_candidate", "passability_brier", "coverage_95"):
        assert {name, f"memory_{name}", f"{name}_steps"} <= set(figures)
    assert figures["coverage_95_steps"] >= 1 and 0 <= figures["memory_coverage_95"] <= 1
    assert figures["view_ambiguities"] >= 1  # the two gaps' posts give ambiguous matches
    assert figures["p_true_candidate_steps"] >= 1  # the steps that have them
    assert 0 <= figures["memory_p_true_candidate"] <= 1


def test_ablation_writes_its_table_plot_views_and_json_per_agent_and_perception(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))  # it reuses evaluate.py's options
    out = tmp_path / "ablation"
    summary = load_script("ablation").main(
        [
            "--agent", "oracle", "--perception", "truth", "--perception", "stereo_means",
            "--episodes", "1", "--families", "corridor", "--max-steps", "3",
            "--step-steps", "2", "--view-steps", "1", "--out", str(out), "--no-progress",
        ]
    )  # fmt: skip
    data = json.loads((out / "ablation.json").read_text())
    assert data == summary
    assert list(data["results"]) == ["oracle"]
    assert list(data["results"]["oracle"]) == ["truth", "stereo_means"]
    assert list(data["step_ms"]) == ["truth", "stereo_means"]
    figures = data["results"]["oracle"]["truth"]
    assert figures["episodes"] == 1 and figures["mean_steps"] == 3
    assert {"success_rate_ci", "spl_ci", "collision_rate_ci", "mean_collisions_ci"} <= set(figures)
    assert data["suite"]["split"] == "dev" and data["suite"]["families"] == ["corridor"]
    table = (out / "ablation.md").read_text()
    assert "| oracle | stereo_means | 1 |" in table and table in capsys.readouterr().out
    details = json.loads((out / "ablation_details.json").read_text())
    assert sorted(d["perception"] for d in details) == ["stereo_means", "truth"]
    for name in ("ablation_plot.png", "ablation_views.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(SystemExit):  # a test seed under --split dev, as evaluate.py refuses
        load_script("ablation").main(["--seed", "900000", "--out", str(out)])


def test_memory_figure_draws_one_view_beside_the_fused_model(
    tmp_path: pathlib.Path, small_map: pathlib.Path
) -> None:
    path = load_script("memory_figure").main(
        ["--scenario", str(small_map), "--views", "3", "--out", str(tmp_path / "m.png")]
    )
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 5000


def test_perception_cost_pairs_the_suite_under_both_perceptions(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))  # it imports evaluate.py's suite
    out = tmp_path / "cost.json"
    cost = load_script("perception_cost").main(
        [
            "--agent", "greedy", "--episodes", "2", "--seed", "3", "--families", "open",
            "--max-steps", "40", "--json", str(out), "--markdown", str(tmp_path / "cost.md"),
            "--no-progress",
        ]
    )  # fmt: skip
    data = json.loads(out.read_text())
    assert data["agents"] == cost and data["suite"]["families"] == ["open"]
    greedy = cost["greedy"]
    assert greedy["stereo"]["episodes"] == greedy["surrogate"]["episodes"] == 2
    assert greedy["spl_cost"] == pytest.approx(greedy["stereo"]["spl"] - greedy["surrogate"]["spl"])
    assert "| greedy | 2 |" in (tmp_path / "cost.md").read_text()

    # the same pairing from two evaluate.py --details runs
    details = []
    for perception in ("stereo", "surrogate"):
        details.append(str(tmp_path / f"{perception}.json"))
        load_script("evaluate").main(
            [
                "--agent", "greedy", "--episodes", "2", "--seed", "3", "--families", "open",
                "--max-steps", "40", "--json", str(tmp_path / "e.json"), "--details", details[-1],
                "--perception", perception, "--no-progress",
            ]
        )  # fmt: skip
    paired = load_script("perception_cost").main(
        ["--agent", "greedy", "--from-details", *details, "--json", str(tmp_path / "p.json")]
    )
    assert paired["greedy"]["spl_cost"] == greedy["spl_cost"]
    assert paired["greedy"]["surrogate"]["spl"] == greedy["surrogate"]["spl"]
    with pytest.raises(ValueError, match="no episodes of \\['planner'\\]"):
        load_script("perception_cost").main(
            ["--agent", "planner", "--from-details", *details, "--json", str(tmp_path / "q.json")]
        )


def test_collision_report_records_each_contact_with_the_obstacle_hit(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))
    # the planner's first suite episode (a room) touches a table at step 109 (0-based)
    out = tmp_path / "contacts.json"
    contacts = load_script("collision_report").main(
        [
            "--agent", "planner", "--episodes", "1", "--seed", "0", "--families", "room",
            "--max-steps", "112", "--json", str(out),
        ]
    )  # fmt: skip
    assert json.loads(out.read_text()) == contacts
    assert [(c["step"], c["kind"], c["family"]) for c in contacts] == [(109, "table", "room")]
    assert contacts[0]["views_in_range"] > 0
    # in view 31 times, yet the planner's map never held the leg: what the report counts
    assert contacts[0]["held_before"] is False and contacts[0]["ever_held"] is False
    printed = capsys.readouterr().out
    assert "1 contacts in 1 episodes (planner)" in printed
    assert "first contacts 1: the map ever held 0 (held just before 0), never held 1" in printed


def test_stall_report_lists_each_episode_with_its_patterns(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))
    out = tmp_path / "stalls.json"
    rows = load_script("stall_report").main(
        [
            "--episodes", "2", "--seed", "0", "--only", "1", "--perception", "surrogate",
            "--max-steps", "30", "--json", str(out),
        ]
    )  # fmt: skip
    assert json.loads(out.read_text()) == rows
    assert [(r["index"], r["family"], r["steps"]) for r in rows] == [(1, "corridor", 30)]
    assert {"revisit_steps", "route_flips", "gate_retries", "backoff_steps", "lost"} <= set(rows[0])


def test_collision_report_with_memory_measures_what_the_fused_memory_held(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))
    report = load_script("collision_report")
    contacts = report.main(
        [
            "--agent", "planner", "--episodes", "1", "--seed", "0", "--families", "room",
            "--max-steps", "112", "--memory",
        ]
    )  # fmt: skip
    # the env's memory does not change the episode: the same contact as without it
    assert [(c["step"], c["kind"]) for c in contacts] == [(109, "table")]
    # the table's leg, in view 31 times, is 0.66 m from every fused segment held
    assert contacts[0]["fused_distance_m"] == pytest.approx(0.6596, abs=1e-3)
    point = np.asarray(contacts[0]["point_xy"])
    ends = point + np.array([[[0.05, 0.0], [0.05, 1.0]], [[0.0, 0.0], [0.0, 0.0]]])
    memory = SimpleNamespace(
        segments=[
            SimpleNamespace(endpoints=e, length_m=float(np.hypot(*(e[1] - e[0])))) for e in ends
        ],
        existence=(0.9, 0.4),  # the point on the contact is too improbable to count
    )
    assert report._fused_distance(memory, point) == pytest.approx(0.05)
    printed = capsys.readouterr().out
    assert "first contacts 1: the fused memory held 0 within 0.1 m just before, not 1" in printed


def test_seed_benchmark_scores_each_run_and_baseline_on_the_same_episodes(
    tmp_path: pathlib.Path, imitation_run: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import shutil

    first, second = tmp_path / "seed0", tmp_path / "seed1"
    shutil.copytree(imitation_run, first)
    shutil.copytree(imitation_run, second)
    out = load_script("seed_benchmark").main(
        [
            "--run", str(first), "--run", str(second), "--baseline", "oracle",
            "--families", "open", "--episodes", "2", "--perception", "surrogate",
            "--json", str(tmp_path / "seeds.json"), "--markdown", str(tmp_path / "seeds.md"),
            "--no-progress",
        ]
    )  # fmt: skip
    assert json.loads((tmp_path / "seeds.json").read_text()) == out
    assert (out["split"], out["suite_seed"]) == ("dev", 0)
    assert list(out["families"]) == ["open", "pooled"]
    pooled = out["families"]["pooled"]
    assert pooled["seeds"] == 2 and pooled["episodes"] == 2
    # the same policy on the same episodes scores the same under either run's name
    runs = list(pooled["per_seed"].values())
    assert [r["success_rate"] for r in runs] == [runs[0]["success_rate"]] * 2
    assert [r["spl"] for r in runs] == [runs[0]["spl"]] * 2
    oracle = out["baselines"]["pooled"]["oracle"]
    assert oracle["episodes"] == 2 and oracle["success_rate"] == 1.0
    assert set(out["training"]) == {str(first), str(second)}
    assert "record" in out["training"][str(first)]
    table = (tmp_path / "seeds.md").read_text()
    assert "| learned / open | 2 x 2 |" in table and "| oracle / pooled | 1 x 2 |" in table
    assert table in capsys.readouterr().out
    with pytest.raises(ValueError, match="--run"):
        load_script("seed_benchmark").agent_of_run(tmp_path)


def test_ship_policy_copies_the_run_and_writes_its_metadata_beside_it(
    tmp_path: pathlib.Path, imitation_run: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import gymnasium as gym

    from agents import make_agent
    from agents.learning.imitation import load_policy

    script = load_script("ship_policy")
    target = tmp_path / "data" / "learned_policy.pt"
    monkeypatch.setattr(script, "SHIPPED_POLICY", target)
    assert script.main([str(imitation_run)]) == target
    assert target.read_bytes() == (imitation_run / "policy.pt").read_bytes()
    meta = json.loads(target.with_suffix(".json").read_text())
    assert meta == json.loads(json.dumps(load_policy(imitation_run / "policy.pt").meta))
    agent = make_agent(f"learned:{target}")
    env = gym.make("StereoNav-v1", scenario="open", perception="surrogate")
    obs, info = env.reset(seed=0)
    agent.reset(env, seed=0)
    action = agent.act(obs, info)
    assert action.shape == (3,) and np.all(np.abs(action) <= 1.0)
    env.close()
    with pytest.raises(FileNotFoundError):
        script.main([str(tmp_path / "no-run")])
