"""Floor-level observations: 2D segments with uncertain endpoints (paper sections 2, 3.2, 3.3).

All coordinates are in the world frame, metres; covariances in m^2. :func:`face_value` drops an
observation's uncertainty (the ``stereo_means`` ablation of issue 43: the same segments taken at
face value).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from modeling.types import FloatArray, IntArray
from modeling.validation import covariance, finite_array, positive, probabilities

__all__ = [
    "NEGLIGIBLE_STD_M",
    "AmbiguousSegment",
    "FloorObservation",
    "FloorSegment",
    "face_value",
    "negligible_covariance",
    "none_mass",
]

P_NONE_ATOL = 1e-9  # a p_none below this is rounding: the candidates sum to 1

NEGLIGIBLE_STD_M = 1e-6
"""A standard deviation that stands for no uncertainty at all, metres (1 micrometre).

A zero covariance is refused (:class:`FloorSegment` needs a positive-definite one: the model
stages work in the eigenbasis of a covariance and the memory inverts it), so "no spread" is
``NEGLIGIBLE_STD_M^2`` along each axis. At that spread a gap's passable probability
(:func:`modeling.model.gaps.gap_passable_probability`: the gap of two such endpoints has the
standard deviation ``sqrt(2) NEGLIGIBLE_STD_M`` in every direction) is within ``eps = 0.05`` of
0 or 1 unless the gap's width is within ``1.645 sqrt(2) NEGLIGIBLE_STD_M`` (2.3 micrometres) of
the robot's: every gap is passable or impassable."""


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class FloorSegment:
    """A 3D segment projected onto the floor, each endpoint a 2D normal.

    Attributes:
        endpoints: (2, 2) means of the two endpoints, world frame, metres.
        cov: (2, 2, 2) covariance of each endpoint, m^2 (symmetric positive definite).
        height_m: (2,) heights of the 3D endpoints above the floor before projection (informative).
        source: Free-form provenance, e.g. the left-image segment index (``-1`` if synthetic).
    """

    endpoints: FloatArray
    cov: FloatArray
    height_m: FloatArray = field(default_factory=lambda: np.zeros(2))
    source: int = -1

    def __post_init__(self) -> None:
        ends = finite_array(self.endpoints, "endpoints", (2, 2))
        cov = covariance(self.cov, "cov")
        if cov.shape != (2, 2, 2):
            raise ValueError(f"cov must have shape (2, 2, 2), got {cov.shape}")
        heights = finite_array(self.height_m, "height_m", (2,))
        for name, arr in (("endpoints", ends), ("cov", cov), ("height_m", heights)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @classmethod
    def stack(
        cls,
        endpoints: FloatArray,
        cov: FloatArray,
        height_m: FloatArray,
        source: IntArray,
    ) -> tuple[FloorSegment, ...]:
        """``n`` segments from stacked arrays, checked once in bulk (as the constructor checks
        each: finite endpoints and heights, symmetric positive-definite covariances) instead of
        one by one, which would cost more than the producer's own work (a dense grid's
        outlines: tens of segments a view). Each segment holds read-only views of its rows.

        Args:
            endpoints: (n, 2, 2) endpoint means, world metres.
            cov: (n, 2, 2, 2) endpoint covariances, m^2.
            height_m: (n, 2) heights of the endpoints before projection, metres.
            source: (n,) provenance of each.

        Raises:
            ValueError: An array of the wrong shape or a bad value (naming the field).
        """
        ends = finite_array(endpoints, "endpoints", (None, 2, 2))
        n = ends.shape[0]
        covs = covariance(cov, "cov")
        if covs.shape != (n, 2, 2, 2):
            raise ValueError(f"cov must have shape ({n}, 2, 2, 2), got {covs.shape}")
        heights = finite_array(height_m, "height_m", (n, 2))
        src = np.asarray(source)
        if src.shape != (n,) or src.dtype.kind not in "iu":
            raise ValueError(f"source must be ({n},) integers, got {src.dtype} {src.shape}")
        for arr in (ends, covs, heights):
            arr.setflags(write=False)
        out = []
        for k, provenance in enumerate(src.tolist()):
            seg = object.__new__(cls)
            object.__setattr__(seg, "endpoints", ends[k])
            object.__setattr__(seg, "cov", covs[k])
            object.__setattr__(seg, "height_m", heights[k])
            object.__setattr__(seg, "source", int(provenance))
            out.append(seg)
        return tuple(out)

    @property
    def length_m(self) -> float:
        """Distance between the endpoint means, metres."""
        return float(np.linalg.norm(self.endpoints[1] - self.endpoints[0]))

    @property
    def length_3d_m(self) -> float:
        """Length of the 3D segment, metres: the floor length and the height extent."""
        return math.hypot(self.length_m, float(self.height_m[1] - self.height_m[0]))

    @property
    def midpoint(self) -> FloatArray:
        """(2,) mean of the two endpoint means."""
        out: FloatArray = self.endpoints.mean(axis=0)
        return out

    def transformed(self, R: FloatArray, t: FloatArray) -> FloorSegment:
        """This segment under the rigid motion ``p -> R p + t`` (R a 2x2 rotation)."""
        return FloorSegment(
            endpoints=self.endpoints @ R.T + t,
            cov=R @ self.cov @ R.T,
            height_m=self.height_m,
            source=self.source,
        )


def none_mass(probabilities: list[float] | tuple[float, ...]) -> float:
    """``p_none = 1 - sum(probabilities)`` of candidate probabilities, 0 below
    :data:`P_NONE_ATOL` (rounding is no evidence, and it would grow by Bayes' rule while every
    candidate is seen free)."""
    rest = 1.0 - math.fsum(probabilities)
    return rest if rest > P_NONE_ATOL else 0.0


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class AmbiguousSegment:
    """One image segment with several possible matches (section 3.3).

    The probabilities may sum to less than 1: the rest, :attr:`p_none`, is the probability that
    the segment is no obstacle here (its true match lies above the height band, or it is a false
    match). Every consumer treats "none" as one more choice whose effect is empty. So one
    candidate is allowed when ``p_none > 0`` (a possible obstacle), two or more otherwise.

    Attributes:
        candidates: The possible floor segments, one per kept match.
        probabilities: Their probabilities (Eq. 1 over all the segment's matches), same length,
            each in [0, 1], summing to at most 1.
    """

    candidates: tuple[FloorSegment, ...]
    probabilities: tuple[float, ...]

    def __post_init__(self) -> None:
        cands = tuple(self.candidates)
        if not all(isinstance(c, FloorSegment) for c in cands):
            raise ValueError("candidates must all be FloorSegment instances")
        if not cands:
            raise ValueError("candidates must hold at least 1 FloorSegment, got 0")
        probs = probabilities(self.probabilities, "probabilities", at_most_one=True)
        if probs.shape[0] != len(cands):
            raise ValueError(
                f"probabilities has {probs.shape[0]} entries for {len(cands)} candidates"
            )
        if len(cands) == 1 and not 1.0 - float(probs.sum()) > P_NONE_ATOL:
            raise ValueError(
                "candidates must hold at least 2 FloorSegments when p_none is 0 (one certain"
                " candidate is a FloorSegment)"
            )
        object.__setattr__(self, "candidates", cands)
        object.__setattr__(self, "probabilities", tuple(float(p) for p in probs))

    @property
    def p_none(self) -> float:
        """Probability that none of the candidates is an obstacle: ``1 - sum(probabilities)``
        (0 when they sum to 1 within 1e-9)."""
        return none_mass(self.probabilities)


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class FloorObservation:
    """Everything one stereo observation says about the floor.

    Attributes:
        segments: Unambiguous floor segments.
        ambiguous: Ambiguous segments, each with its candidates and probabilities.
        viewpoint: (3,) ``(x_m, y_m, heading_rad)`` of the left optical centre, world frame.
        fov_rad: Horizontal field of view, radians.
        max_range_m: Range beyond which nothing is trusted, metres.
    """

    segments: tuple[FloorSegment, ...] = ()
    ambiguous: tuple[AmbiguousSegment, ...] = ()
    viewpoint: FloatArray = field(default_factory=lambda: np.zeros(3))
    fov_rad: float = math.radians(64.0)
    max_range_m: float = 8.0

    def __post_init__(self) -> None:
        segs = tuple(self.segments)
        if not all(isinstance(s, FloorSegment) for s in segs):
            raise ValueError("segments must all be FloorSegment instances")
        amb = tuple(self.ambiguous)
        if not all(isinstance(a, AmbiguousSegment) for a in amb):
            raise ValueError("ambiguous must all be AmbiguousSegment instances")
        vp = finite_array(self.viewpoint, "viewpoint", (3,))
        vp.setflags(write=False)
        fov = positive(self.fov_rad, "fov_rad")
        if fov >= 2 * math.pi:
            raise ValueError(f"fov_rad must be below 2*pi, got {fov}")
        object.__setattr__(self, "segments", segs)
        object.__setattr__(self, "ambiguous", amb)
        object.__setattr__(self, "viewpoint", vp)
        object.__setattr__(self, "fov_rad", fov)
        object.__setattr__(self, "max_range_m", positive(self.max_range_m, "max_range_m"))

    def transformed(self, angle_rad: float, translation: FloatArray) -> FloorObservation:
        """The whole observation rotated by ``angle_rad`` about the origin, then translated."""
        c, s = math.cos(angle_rad), math.sin(angle_rad)
        R = np.array([[c, -s], [s, c]])
        t = np.asarray(translation, dtype=np.float64)
        vp = self.viewpoint
        new_xy = R @ vp[:2] + t
        return FloorObservation(
            segments=tuple(seg.transformed(R, t) for seg in self.segments),
            ambiguous=tuple(
                AmbiguousSegment(
                    candidates=tuple(c_.transformed(R, t) for c_ in a.candidates),
                    probabilities=a.probabilities,
                )
                for a in self.ambiguous
            ),
            viewpoint=np.array([new_xy[0], new_xy[1], vp[2] + angle_rad]),
            fov_rad=self.fov_rad,
            max_range_m=self.max_range_m,
        )


def negligible_covariance(std_m: float = NEGLIGIBLE_STD_M) -> FloatArray:
    """(2, 2, 2) the covariance of a :class:`FloorSegment` with no spread to speak of:
    ``std_m^2`` times the identity at both endpoints (default :data:`NEGLIGIBLE_STD_M`).

    Raises:
        ValueError: ``std_m`` not a positive finite number.
    """
    std = positive(std_m, "std_m")
    return np.broadcast_to(std * std * np.eye(2), (2, 2, 2)).copy()


def face_value(
    observation: FloorObservation, *, std_m: float = NEGLIGIBLE_STD_M
) -> FloorObservation:
    """``observation`` taken at face value: its uncertainty dropped (issue 43's ``stereo_means``).

    Every segment keeps its endpoint means, with the covariance :func:`negligible_covariance`
    of ``std_m`` instead of its own (an exact zero is refused: :data:`NEGLIGIBLE_STD_M`). Every
    ambiguous segment is reduced to its most probable choice: its most probable candidate, then
    an unambiguous segment, or nothing when "no obstacle here" (:attr:`AmbiguousSegment.p_none`)
    is more probable than every candidate (a tie goes to the first of the most probable
    candidates). So the model of the result (:func:`modeling.model.build.build_model`) has no
    ambiguity: one situation, of probability 1, whose gaps are all passable or impassable (see
    :data:`NEGLIGIBLE_STD_M`). The viewpoint, field of view and range are kept.

    Args:
        observation: The floor observation.
        std_m: The standard deviation that stands for none, metres (> 0).

    Returns:
        A new :class:`FloorObservation` with no ambiguous segments: the segments first, then the
        chosen candidates in the order of their ambiguous segments.

    Raises:
        ValueError: ``observation`` not a :class:`FloorObservation`, or a bad ``std_m``.
    """
    if not isinstance(observation, FloorObservation):
        raise ValueError(
            f"observation must be a FloorObservation, got {type(observation).__name__}"
        )
    cov = negligible_covariance(std_m)
    cov.setflags(write=False)

    def certain(seg: FloorSegment) -> FloorSegment:
        return FloorSegment(
            endpoints=seg.endpoints, cov=cov, height_m=seg.height_m, source=seg.source
        )

    chosen = [
        amb.candidates[int(np.argmax(amb.probabilities))]
        for amb in observation.ambiguous
        if max(amb.probabilities) >= amb.p_none
    ]
    return FloorObservation(
        segments=tuple(certain(seg) for seg in (*observation.segments, *chosen)),
        viewpoint=observation.viewpoint,
        fov_rad=observation.fov_rad,
        max_range_m=observation.max_range_m,
    )
