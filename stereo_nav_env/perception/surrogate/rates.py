"""How the stereo pipeline departs from the ideal: the surrogate's measured rates.

:class:`SurrogateRates` holds, per class of edge (:data:`EDGE_CLASSES`) and depth bin, how often
the stereo's segment extraction images a seen edge in both images, one or neither, how often a
match is wrong and by how much, how far segments stop short of their edges' ends, and the
stereo's actual column error over the error model's. They are measured against the ground
truth by :mod:`stereo_nav_env.perception.surrogate.calibration` (``scripts/measure_surrogate.py``)
and shipped in ``data/surrogate_rates.json`` (:func:`default_rates`).
"""

from __future__ import annotations

import functools
import importlib.resources
import json
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from modeling.types import FloatArray, IntArray
from stereo_nav_env.perception.surrogate.visibility import SceneEdges, VisibleEdges
from stereo_nav_env.sim.scenes import ObstacleKind

__all__ = ["EDGE_CLASSES", "RATES_FILE", "SurrogateRates", "default_rates", "edge_classes"]


RATES_FILE = "surrogate_rates.json"
"""The measured rates, in this package's ``data/`` (written by ``scripts/measure_surrogate.py``)."""


EDGE_CLASSES = tuple(f"{kind.value}{crease}" for kind in ObstacleKind for crease in ("", "_crease"))
"""The classes of edge the detection rates are kept for: an obstacle kind's outlines (one of the
two sides meeting there faces the head: the edge stands against what lies behind it) and its
creases (``_crease``: both sides face the head; the edge is only the shading step between two
faces). The kind stands for its parts' size and colour: a chair's thin dark legs are found far
less often than a table's."""


@dataclass(frozen=True, slots=True, kw_only=True)
class SurrogateRates:
    """How the stereo pipeline departs from the ideal, measured against the ground truth.

    Attributes:
        depth_bins_m: (k + 1,) edges of the depth bins, metres, increasing.
        detection: For each of :data:`EDGE_CLASSES`, (k, 3): per depth bin, the probabilities
            that the segment extraction images a seen edge of that class (one with contrast in
            both images) in both images, in the left one only and in the right one only (the
            rest: in neither).
        false_match_rate: (k,) probability that an edge imaged in both images is matched at a
            wrong disparity (more than 1 px off) beyond the matcher's own false matches, per
            depth bin.
        false_error_px: The absolute disparity errors of the measured false matches, px (> 1);
            a false match draws one of them, with a random sign.
        error_scale: The stereo's actual column errors over the error model's standard
            deviation (1: the model is exact), > 0.
        end_loss_px: Rows by which the stereo's segments stop short of each end of the seen
            run of their edge (the median), px, >= 0.
    """

    depth_bins_m: tuple[float, ...]
    detection: dict[str, tuple[tuple[float, float, float], ...]]
    false_match_rate: tuple[float, ...]
    false_error_px: tuple[float, ...]
    error_scale: float
    end_loss_px: float
    _detection_table: FloatArray = field(init=False, repr=False, compare=False)
    _inner_bins: FloatArray = field(init=False, repr=False, compare=False)
    _false_rate: FloatArray = field(init=False, repr=False, compare=False)
    _false_error: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        bins = np.asarray(self.depth_bins_m, dtype=np.float64)
        k = bins.size - 1
        if k < 1 or not np.all(np.diff(bins) > 0) or not np.all(np.isfinite(bins)):
            raise ValueError(f"depth_bins_m must increase, got {self.depth_bins_m!r}")
        if not isinstance(self.detection, dict) or set(self.detection) != set(EDGE_CLASSES):
            raise ValueError(f"detection must map each of {EDGE_CLASSES} to its rates")
        detection = {}
        for name in EDGE_CLASSES:
            arr = np.asarray(self.detection[name], dtype=np.float64)
            if (
                arr.shape != (k, 3)
                or not np.all((arr >= 0) & (arr <= 1))
                or not np.all(arr.sum(axis=1) <= 1 + 1e-9)
            ):
                raise ValueError(
                    f"detection[{name!r}] must be {k} rows of 3 probabilities summing to at "
                    f"most 1, got {self.detection[name]!r}"
                )
            detection[name] = tuple((a, b, c) for a, b, c in arr.tolist())
        object.__setattr__(self, "detection", detection)
        table = np.array([detection[name] for name in EDGE_CLASSES])  # (classes, k, 3)
        table.setflags(write=False)
        object.__setattr__(self, "_detection_table", table)
        arr = np.asarray(self.false_match_rate, dtype=np.float64)
        if arr.shape != (k,) or not np.all((arr >= 0) & (arr <= 1)):
            raise ValueError(f"false_match_rate must be {k} probabilities, got {arr.tolist()!r}")
        object.__setattr__(self, "false_match_rate", tuple(arr.tolist()))
        errors = np.asarray(self.false_error_px, dtype=np.float64)
        if errors.ndim != 1 or errors.size == 0 or not np.all(np.isfinite(errors) & (errors > 0)):
            raise ValueError(f"false_error_px must be positive numbers, got {errors.tolist()!r}")
        object.__setattr__(self, "false_error_px", tuple(errors.tolist()))
        if not (math.isfinite(self.error_scale) and self.error_scale > 0):
            raise ValueError(f"error_scale must be positive, got {self.error_scale!r}")
        object.__setattr__(self, "depth_bins_m", tuple(bins.tolist()))
        # the arrays the surrogate reads every step, made once
        for name, value in (
            ("_inner_bins", bins[1:-1]),  # a depth's bin: how many of these it reaches
            ("_false_rate", np.array(self.false_match_rate)),
            ("_false_error", np.array(self.false_error_px)),
        ):
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        object.__setattr__(self, "error_scale", float(self.error_scale))
        if not (math.isfinite(self.end_loss_px) and self.end_loss_px >= 0):
            raise ValueError(f"end_loss_px must be >= 0, got {self.end_loss_px!r}")
        object.__setattr__(self, "end_loss_px", float(self.end_loss_px))

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SurrogateRates:
        """The rates of a dict with (at least) the attribute names as keys."""
        return cls(**{name: data[name] for name in cls.__dataclass_fields__ if name[0] != "_"})

    def depth_bin(self, depth_m: FloatArray) -> IntArray:
        """(n,) the bin of each of the depths ``depth_m`` (n,) metres, clipped to the bins (one
        search over the inner bin edges: a depth below the first bin is in it, one past the
        last in the last)."""
        out: IntArray = np.searchsorted(self._inner_bins, depth_m, side="right")
        return out

    def false_rate_at(self, depth_m: FloatArray) -> FloatArray:
        """(n,) the false-match rate at depths ``depth_m`` (n,) metres (clipped to the bins)."""
        out: FloatArray = self._false_rate[self.depth_bin(depth_m)]
        return out

    def false_errors(self, index: IntArray) -> FloatArray:
        """The measured false-match errors ``false_error_px[index]``, px (a new array)."""
        out: FloatArray = self._false_error[index]
        return out

    def detection_at(self, edge_class: IntArray, depth_m: FloatArray) -> FloatArray:
        """(n, 3) detection probabilities (both images, left only, right only) of ``n`` edges
        of classes ``edge_class`` (indices into :data:`EDGE_CLASSES`) at depths ``depth_m``
        (clipped to the bins)."""
        out: FloatArray = self._detection_table[edge_class, self.depth_bin(depth_m)]
        return out


def edge_classes(edges: SceneEdges, vis: VisibleEdges) -> IntArray:
    """(n,) the class of each seen edge, an index into :data:`EDGE_CLASSES`."""
    out: IntArray = 2 * edges.corner_kind[vis.corner] + vis.crease.astype(np.int64)
    return out


@functools.cache
def default_rates() -> SurrogateRates:
    """The rates in the package's ``data/surrogate_rates.json``."""
    text = (
        importlib.resources.files("stereo_nav_env.perception.surrogate")
        .joinpath("data", RATES_FILE)
        .read_text()
    )
    return SurrogateRates.from_dict(json.loads(text))
