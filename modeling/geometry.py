"""Small plane-geometry helpers shared by every layer: angle wrapping and frame changes.

World frame: metres, floor plane x-y, heading in radians counter-clockwise from +x. The robot
frame has x forward and y to the left of the robot.
"""

from __future__ import annotations

import math
from typing import TypeVar

import numpy as np

from modeling.types import FloatArray

__all__ = ["to_robot_frame", "wrap_angle"]

A = TypeVar("A", float, FloatArray)


def wrap_angle(angle: A) -> A:
    """``angle`` (radians, a float or an array) wrapped to ``[-pi, pi)``."""
    if isinstance(angle, np.ndarray):
        return (angle + np.pi) % (2.0 * np.pi) - np.pi
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def to_robot_frame(points: FloatArray, robot_pose: tuple[float, float, float]) -> FloatArray:
    """World points (..., 2) to the robot frame (..., 2), metres.

    Args:
        points: (..., 2) world coordinates, metres.
        robot_pose: ``(x_m, y_m, heading_rad)`` of the robot in the world.
    """
    x, y, heading = robot_pose
    c, s = math.cos(heading), math.sin(heading)
    d = np.asarray(points, dtype=np.float64) - np.array([x, y])
    return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], axis=-1)
