"""Made-up :class:`~agents.evaluation.suite.EpisodeResult` s for the tests of what reads them."""

from __future__ import annotations

import dataclasses
from typing import Any

from agents.evaluation.suite import EpisodeResult


def episode(
    index: int,
    *,
    success: bool,
    spl: float = 0.0,
    collisions: int = 0,
    agent: str = "greedy",
    family: str = "room",
    **overrides: Any,
) -> EpisodeResult:
    """Episode ``index`` (also its seed) of ``agent`` in ``family``; any other field by keyword."""
    result = EpisodeResult(
        agent=agent,
        index=index,
        family=family,
        scene=f"{family}-{index}",
        seed=index,
        success=success,
        collided=collisions > 0,
        collision_steps=collisions,
        steps=100,
        looks=0,
        path_length_m=5.0,
        reference_m=4.0,
        spl=spl,
        time_s=1.0,
    )
    return dataclasses.replace(result, **overrides)
