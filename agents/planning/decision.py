"""Expected costs of vision-motion decisions at a critical region (after Miura and Shirai, 1992).

A critical region's width ``w`` is uncertain: ``w ~ N(mean, std^2)`` from the model; the robot
fits when ``w > robot width``. Going for the region costs, in expectation,

    C_via(p) = L_entry + p (L_cross + V_beyond) + (1 - p) (C_fail + V_alt_from_entry)

(walk to its entry; with probability ``p`` pass and go on; otherwise find it impassable there and
take the best alternative from there). The best alternative from here is ``C_alt`` (the region
taken as impassable). Committing now is worth ``min(C_via(p), C_alt)``.

The model's passability ``p`` is exact (:mod:`modeling.model.gaps`: the region's width from its two
endpoints' 2-D normal distributions, not a normal distribution itself); the route weights use it.
So that a look is valued with the same ``p``, the width is taken as ``N(mean', std^2)`` with the
mean calibrated to it (:func:`calibrated_mean`: ``P(w > robot width) = p`` exactly) and the
model's std; the preposterior expectation of ``p'`` is then ``p`` again.

Looking at the region (panning the head to it) or approaching it gives a new measurement of its
width with a smaller standard deviation ``meas_std`` (stereo depth error grows with the square of
the distance). After it, the decision is taken with the posterior ``p'``; before it, ``p'`` is
random. The expected cost after the measurement is ``E_m[min(C_via(p'(m)), C_alt)]`` and the value
of information is ``min(C_via(p), C_alt) - E_m[...]`` (>= 0, as the expected minimum of the
posterior costs is below the minimum of the expected costs). Looking is chosen when its value
exceeds its cost.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr, ndtri

__all__ = [
    "GateCosts",
    "calibrated_mean",
    "expected_after_measurement",
    "p_wider",
    "predicted_std",
    "value_of_information",
]

_Z = np.linspace(-7.0, 7.0, 2801)
_Z_W = np.exp(-0.5 * _Z**2)
_Z_W /= _Z_W.sum()


def p_wider(mean_m: float, std_m: float, width_m: float) -> float:
    """``P(w > width_m)`` for ``w ~ N(mean_m, std_m^2)`` (a step when ``std_m`` is 0)."""
    if std_m <= 0:
        return 1.0 if mean_m > width_m else 0.0
    return float(ndtr((mean_m - width_m) / std_m))


def calibrated_mean(p: float, std_m: float, width_m: float) -> float:
    """The mean of ``N(mean, std_m^2)`` for which ``P(w > width_m) = p``: the width distribution
    of a region whose exact passability is ``p`` (``p`` in [0, 1]; the mean is kept within
    ``9 std`` of ``width_m``, so that ``p`` of 0 or 1 stays finite).

    Raises:
        ValueError: If ``p`` is not in [0, 1] or ``std_m`` is negative.
    """
    if not 0.0 <= p <= 1.0:
        raise ValueError(f"p must be a probability, got {p!r}")
    if not std_m >= 0.0:
        raise ValueError(f"std_m must be >= 0, got {std_m!r}")
    z = float(np.clip(ndtri(p), -9.0, 9.0))
    return width_m + max(std_m, 1e-9) * z


def predicted_std(std_m: float, seen_m: float, from_m: float, floor_m: float = 0.01) -> float:
    """Width std expected from a look at distance ``from_m`` given ``std_m`` seen from ``seen_m``.

    Stereo depth error grows as the square of the distance: ``std (from / seen)^2``.
    """
    if seen_m <= 0:
        return max(floor_m, std_m)
    return max(floor_m, std_m * (from_m / seen_m) ** 2)


@dataclass(frozen=True, slots=True, kw_only=True)
class GateCosts:
    """The cost terms of going for one critical region, metres of travel.

    Attributes:
        to_entry_m: From the robot to the region's entry.
        cross_m: Through the region.
        beyond_m: Expected cost from its exit to the goal.
        fail_m: Lost when it proves impassable at the entry (backing off).
        alt_from_entry_m: Best alternative from the entry without the region.
        alt_m: Best alternative from the robot without the region.
    """

    to_entry_m: float
    cross_m: float
    beyond_m: float
    fail_m: float
    alt_from_entry_m: float
    alt_m: float

    def via(self, p: Any) -> Any:
        """Expected cost of going for the region when it is passable with probability ``p``
        (a float or an array of them)."""
        return (
            self.to_entry_m
            + p * (self.cross_m + self.beyond_m)
            + (1.0 - p) * (self.fail_m + self.alt_from_entry_m)
        )

    def commit(self, p: Any) -> Any:
        """Cost of deciding now: ``min(via(p), alt_m)`` (elementwise for an array)."""
        return np.minimum(self.via(p), self.alt_m)


def expected_after_measurement(
    mean_m: float,
    std_m: float,
    meas_std_m: float,
    width_m: float,
    decide: Callable[[NDArray[np.float64]], NDArray[np.float64]],
) -> float:
    """``E_m[decide(p'(m))]`` for a width measurement ``m = w + N(0, meas_std_m^2)``.

    ``w ~ N(mean_m, std_m^2)``; ``p'`` is the posterior probability that ``w > width_m``. The
    expectation over the marginal of ``m`` is a sum over a fine grid of its quantiles (``decide``
    is evaluated on an array of ``p'``; it may jump, as ``min`` of two costs does).
    """
    if std_m <= 0:
        return float(np.asarray(decide(np.array([p_wider(mean_m, 0.0, width_m)])))[0])
    s2, r2 = std_m**2, max(meas_std_m, 1e-6) ** 2
    m = mean_m + math.sqrt(s2 + r2) * _Z
    gain = s2 / (s2 + r2)
    post_mean = mean_m + gain * (m - mean_m)
    post_std = math.sqrt(s2 * r2 / (s2 + r2))
    p_post = ndtr((post_mean - width_m) / post_std)
    return float(np.sum(_Z_W * np.asarray(decide(p_post), dtype=np.float64)))


def value_of_information(
    mean_m: float, std_m: float, meas_std_m: float, width_m: float, costs: GateCosts
) -> float:
    """How much a measurement of std ``meas_std_m`` lowers the expected cost (>= 0), metres."""
    now = float(costs.commit(p_wider(mean_m, std_m, width_m)))
    after = expected_after_measurement(mean_m, std_m, meas_std_m, width_m, costs.commit)
    return max(0.0, now - after)
