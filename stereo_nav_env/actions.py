"""Actions: validation of continuous actions and the discrete move-and-look macro set.

Every action is turned into one normalised command ``(forward, turn, pan_target)``, each in
[-1, 1]: forward speed times ``max_speed_m_s``, turn rate (counter-clockwise positive) times
``max_turn_rate_rad_s``, head pan target relative to the body (left positive) times
``pan_limit_rad``. The head moves towards its target at most ``max_pan_rate_rad_s``.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ["DISCRETE_ACTIONS", "MacroAction", "continuous_command", "discrete_command"]


class MacroAction(NamedTuple):
    """One discrete action: a name and its normalised command.

    Attributes:
        name: Short label.
        forward: Forward speed in [-1, 1] (times ``max_speed_m_s``).
        turn: Turn rate in [-1, 1] (times ``max_turn_rate_rad_s``, counter-clockwise positive).
        pan: Head pan target in [-1, 1] (times ``pan_limit_rad``, left positive).
    """

    name: str
    forward: float
    turn: float
    pan: float


DISCRETE_ACTIONS: tuple[MacroAction, ...] = (
    MacroAction("forward", 1.0, 0.0, 0.0),
    MacroAction("forward_left", 1.0, 0.5, 0.0),
    MacroAction("forward_right", 1.0, -0.5, 0.0),
    MacroAction("turn_left", 0.0, 1.0, 0.0),
    MacroAction("turn_right", 0.0, -1.0, 0.0),
    MacroAction("stop_look_left", 0.0, 0.0, 0.5),
    MacroAction("stop_look_centre", 0.0, 0.0, 0.0),
    MacroAction("stop_look_right", 0.0, 0.0, -0.5),
    MacroAction("slow_look_left", 0.5, 0.0, 0.5),
    MacroAction("slow_look_right", 0.5, 0.0, -0.5),
    MacroAction("back_up", -0.5, 0.0, 0.0),
)
"""The macro actions of ``StereoNavDiscrete-v0``, by index."""


def continuous_command(action: Any) -> NDArray[np.float64]:
    """The normalised command (3,) of a continuous action, clipped to [-1, 1].

    Args:
        action: Array-like of exactly 3 finite numbers ``(forward, turn, pan_target)``.

    Returns:
        float64 (3,) in [-1, 1]: out-of-range values are clipped (not an error).

    Raises:
        ValueError: A wrong shape (anything but (3,)), a non-numeric value, NaN or infinity.
    """
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"action must be 3 finite numbers, got {action!r}") from exc
    if a.shape != (3,):
        raise ValueError(f"action must have shape (3,), got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"action must be finite (no NaN or infinity), got {a.tolist()}")
    return np.minimum(np.maximum(a, -1.0), 1.0)  # np.clip's values, without its wrapper's cost


def discrete_command(action: Any) -> NDArray[np.float64]:
    """The normalised command (3,) of a discrete action index.

    Args:
        action: An integer (Python or numpy, or an integer array with one element) in
            ``[0, len(DISCRETE_ACTIONS))``.

    Raises:
        ValueError: Not an integer (a float or bool included), or out of range.
    """
    a = np.asarray(action)
    if a.size != 1 or a.ndim > 1 or a.dtype == np.bool_ or not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"action must be one integer index, got {action!r}")
    index = int(a.reshape(()))
    if not 0 <= index < len(DISCRETE_ACTIONS):
        raise ValueError(f"action must be in [0, {len(DISCRETE_ACTIONS)}), got {index}")
    macro = DISCRETE_ACTIONS[index]
    return np.array([macro.forward, macro.turn, macro.pan], dtype=np.float64)
