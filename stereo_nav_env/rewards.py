"""The reward as named components, weighted by :class:`~stereo_nav_env.config.RewardConfig`.

The reward of a step is the sum of ``info["reward_components"]``:

| name       | value                                                                        |
|------------|------------------------------------------------------------------------------|
| `goal`     | ``+goal_reward`` in the step whose end puts the robot within the goal radius   |
| `collision`| ``-collision_penalty`` in a step in which the robot touched an obstacle (a    |
|            | contact step; under the ``"v1"`` rules the episode goes on)                   |
| `time`     | ``-time_penalty`` in every step                                              |
| `progress` | ``progress_weight`` x (geodesic distance to the goal before - after), metres |

The geodesic distance runs through the true free space for the robot's disc
(:class:`~stereo_nav_env.sim.geodesic.GeodesicField`), so going around an obstacle is progress and
driving at a wall the goal lies behind is not.

:class:`StuckTimer` is the optional truncation when stuck (``EnvConfig.stuck_steps``): the episode
is cut once the robot has gone ``stuck_steps`` steps without getting ``stuck_progress_m`` closer
to the goal than where it last did.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from stereo_nav_env.config import RewardConfig

__all__ = ["REWARD_COMPONENTS", "StuckTimer", "reward_components"]

REWARD_COMPONENTS = ("goal", "collision", "time", "progress")


def reward_components(
    weights: RewardConfig,
    *,
    geodesic_before_m: float,
    geodesic_after_m: float,
    collided: bool,
    reached_goal: bool,
) -> dict[str, float]:
    """The named reward terms of one step (their sum is the reward).

    Args:
        weights: The reward weights.
        geodesic_before_m: Geodesic distance to the goal at the start of the step, metres.
        geodesic_after_m: The same at the end of the step, metres.
        collided: Whether the robot touched an obstacle during the step.
        reached_goal: Whether the robot ended the step within the goal radius.

    Returns:
        ``{"goal", "collision", "time", "progress"}``: floats, in that order.
    """
    return {
        "goal": float(weights.goal_reward) if reached_goal else 0.0,
        "collision": -float(weights.collision_penalty) if collided else 0.0,
        "time": -float(weights.time_penalty),
        "progress": float(weights.progress_weight) * (geodesic_before_m - geodesic_after_m),
    }


@dataclass(slots=True, kw_only=True)
class StuckTimer:
    """Counts the steps since the robot last made ``progress_m`` of geodesic progress.

    Attributes:
        window_steps: Steps without that progress after which the episode is stuck (0: never).
        progress_m: The decrease of the geodesic distance to the goal that resets the count,
            metres, measured from ``reference_m``.
        reference_m: Geodesic distance at the last reset of the count, metres.
        steps: Steps since then.
    """

    window_steps: int
    progress_m: float
    reference_m: float
    steps: int = 0

    def update(self, geodesic_m: float) -> bool:
        """Count one step ending ``geodesic_m`` metres from the goal; whether it is now stuck."""
        if self.window_steps <= 0:
            return False
        if not math.isfinite(self.reference_m) or self.reference_m - geodesic_m >= self.progress_m:
            self.reference_m = float(geodesic_m)
            self.steps = 0
        else:
            self.steps += 1
        return self.steps >= self.window_steps
