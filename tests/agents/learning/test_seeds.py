"""Results over training seeds: means, pooled intervals, the learning-curve band."""

from __future__ import annotations

import csv
import math
import pathlib

import pytest

from agents.evaluation.suite import EpisodeResult
from agents.learning.seeds import (
    _phase_starts,
    _rolling_success,
    plot_seed_curves,
    seed_summary,
    seed_table,
)
from tests.agents.episodes import episode


def _episode(index: int, success: bool, spl: float = 0.0, collided: bool = False) -> EpisodeResult:
    return episode(
        index, success=success, spl=spl, collisions=int(collided), agent="ppo", family="open",
        steps=10, path_length_m=1.0, reference_m=1.0, time_s=0.1,
    )  # fmt: skip


def test_seed_summary_means_the_seeds_and_pools_the_interval() -> None:
    a = [_episode(i, s, spl=0.8 * s) for i, s in enumerate([True, True, True, False])]
    b = [_episode(i, s, collided=not s) for i, s in enumerate([True, False, False, False])]
    out = seed_summary({"0": a, "1": b})
    assert out["seeds"] == 2 and out["episodes"] == 4
    assert (
        out["per_seed"]["0"]["success_rate"] == 0.75
        and out["per_seed"]["1"]["success_rate"] == 0.25
    )
    assert out["success_rate"] == 0.5
    assert out["spl"] == pytest.approx((0.6 + 0.0) / 2)
    assert out["collision_rate"] == pytest.approx(3 / 8)
    lo, hi = out["success_rate_ci"]
    assert 0.0 <= lo < 0.5 < hi <= 1.0
    assert "| PPO / open | 2 x 4 | 0.50 [" in seed_table({"PPO / open": out})
    assert "| 0.75, 0.25 |" in seed_table({"PPO / open": out})


def test_seed_summary_refuses_unequal_or_empty_seeds() -> None:
    with pytest.raises(ValueError, match="per_seed"):
        seed_summary({})
    with pytest.raises(ValueError, match="same, non-zero episode count"):
        seed_summary({"0": [_episode(0, True)], "1": [_episode(0, True), _episode(1, False)]})


def _curve(path: pathlib.Path, successes: list[int]) -> pathlib.Path:
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=["timesteps", "return", "length", "success"])
        writer.writeheader()
        for k, s in enumerate(successes):
            writer.writerow({"timesteps": 100 * (k + 1), "return": 0, "length": 10, "success": s})
    return path


def test_rolling_success_and_the_band_plot(tmp_path: pathlib.Path) -> None:
    path = _curve(tmp_path / "a.csv", [0, 1, 1, 0, 1])
    t, s = _rolling_success(path, window=2)
    assert list(t) == [100, 200, 300, 400, 500]
    assert [round(v, 3) for v in s] == [0.0, 0.5, 1.0, 0.5, 0.5]
    other = _curve(tmp_path / "b.csv", [1, 1, 1])
    png = plot_seed_curves({"0": path, "1": other}, tmp_path / "band.png", window=2)
    assert png.stat().st_size > 1000 and not math.isnan(float(s.sum()))


def test_imitation_phases_are_marked_where_they_begin(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "imitation.csv"
    rows = [(120, "demonstrations", 1.0), (300, "demonstrations", 1.0), (410, "dagger 1", 0.5)]
    rows += [(650, "dagger 2", 0.0)]
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["timesteps", "length", "success", "phase", "beta"])
        writer.writerows([(t, 10, 1, phase, beta) for t, phase, beta in rows])
    assert _phase_starts(path) == [
        (0.0, " teacher 100%"),
        (300.0, " teacher 50%"),
        (410.0, " teacher 0%"),
    ]
    assert _phase_starts(_curve(tmp_path / "ppo.csv", [1, 0])) == []
    png = plot_seed_curves({"seed1": path}, tmp_path / "phases.png")
    assert png.stat().st_size > 1000
