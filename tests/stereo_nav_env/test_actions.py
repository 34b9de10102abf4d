"""Action validation and the discrete macro table."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from stereo_nav_env.actions import DISCRETE_ACTIONS, continuous_command, discrete_command


def test_continuous_actions_are_clipped_to_minus_one_one() -> None:
    assert continuous_command([0.2, -0.4, 0.9]).tolist() == pytest.approx([0.2, -0.4, 0.9])
    assert continuous_command(np.array([3.0, -2.0, 1.0001], np.float32)).tolist() == [1, -1, 1]


@pytest.mark.parametrize(
    "action", [[np.nan, 0, 0], [0, 0, np.inf], [0, 0], [[0, 0, 0]], np.zeros(4), "abc", None]
)
def test_bad_continuous_actions_are_value_errors(action: Any) -> None:
    with pytest.raises(ValueError, match="action"):
        continuous_command(action)


def test_discrete_indices_give_the_tabled_commands() -> None:
    for i, macro in enumerate(DISCRETE_ACTIONS):
        for index in (i, np.int64(i), np.array(i), np.array([i], np.int32)):
            assert discrete_command(index).tolist() == [macro.forward, macro.turn, macro.pan]
    names = [m.name for m in DISCRETE_ACTIONS]
    assert len(set(names)) == len(names) == 11
    # every macro moves or looks, and every value is a valid normalised command
    for m in DISCRETE_ACTIONS:
        assert all(-1 <= v <= 1 for v in (m.forward, m.turn, m.pan))
    assert {m.pan for m in DISCRETE_ACTIONS} >= {-0.5, 0.0, 0.5}


@pytest.mark.parametrize("action", [-1, 11, 1.0, np.float64(2.0), True, [1, 2], "1", None])
def test_bad_discrete_actions_are_value_errors(action: Any) -> None:
    with pytest.raises(ValueError, match="action"):
        discrete_command(action)
