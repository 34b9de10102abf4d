"""Synthetic environment models for the planner's unit tests (no rendering).

A *wall* is a row of collinear floor segments along x = ``x_m`` with gaps; every endpoint has an
isotropic covariance ``sigma_m^2`` so the width of a gap of width ``w`` is ``N(w, 2 sigma^2)`` and
its passability for a 0.5 m robot is undecided when ``w`` is within about two sigmas of 0.5 m.
"""

from __future__ import annotations

import math

import numpy as np

from modeling.model.build import build_model
from modeling.model.records import EnvironmentModel
from modeling.observation import FloorObservation, FloorSegment

ROBOT_WIDTH_M = 0.5


def wall_segments(
    x_m: float, y_breaks: list[tuple[float, float]], sigma_m: float
) -> list[FloorSegment]:
    """Segments along x = ``x_m`` covering each ``(y0, y1)`` of ``y_breaks``."""
    cov = np.stack([np.eye(2) * sigma_m**2] * 2)
    return [
        FloorSegment(endpoints=np.array([[x_m, y0], [x_m, y1]]), cov=cov) for y0, y1 in y_breaks
    ]


def model_of(
    segments: list[FloorSegment], viewpoint: tuple[float, float, float], *, fov_deg: float = 64.0
) -> EnvironmentModel:
    """The environment model of an observation made of ``segments`` seen from ``viewpoint``."""
    obs = FloorObservation(
        segments=tuple(segments),
        viewpoint=np.asarray(viewpoint, dtype=np.float64),
        fov_rad=math.radians(fov_deg),
        max_range_m=8.0,
    )
    return build_model(obs, ROBOT_WIDTH_M)
