"""The reward as named components, weighted by :class:`~stereo_nav_env.config.RewardConfig`.

The reward of a step is the sum of ``info["reward_components"]``:

| name       | value                                                                        |
|------------|------------------------------------------------------------------------------|
| `goal`     | ``+goal_reward`` in the step whose end puts the robot within the goal radius   |
| `collision`| ``-collision_penalty`` in a step in which the robot touched an obstacle       |
| `time`     | ``-time_penalty`` in every step                                              |
| `progress` | ``progress_weight`` x (geodesic distance to the goal before - after), metres |

The geodesic distance runs through the true free space for the robot's disc
(:class:`~stereo_nav_env.geodesic.GeodesicField`), so going around an obstacle is progress and
driving at a wall the goal lies behind is not.
"""

from __future__ import annotations

from stereo_nav_env.config import RewardConfig

__all__ = ["REWARD_COMPONENTS", "reward_components"]

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
