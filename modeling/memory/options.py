"""The options of the fused memory (:mod:`modeling.memory.fusion`): what
:func:`~modeling.memory.fusion.fuse` and :func:`~modeling.memory.fusion.add_contact` are told, each
validated (a ``ValueError`` names it).

Frames: world, metres; angles radians; probabilities in [0, 1].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from modeling.validation import integer, number, positive

__all__ = ["MemoryOptions"]

_CHI2_99_4DOF = 13.276704135987622  # scipy.stats.chi2.ppf(0.99, 4)


@dataclass(frozen=True, slots=True, kw_only=True)
class MemoryOptions:
    """The options of :func:`~modeling.memory.fusion.fuse` and
    :func:`~modeling.memory.fusion.add_contact` (see :mod:`modeling.memory.fusion`).

    Attributes:
        gate_chi2: Association gate on the squared Mahalanobis distance of the endpoint
            difference (4 dof; default ``chi2.ppf(0.99, 4)``), > 0.
        detection_probability: ``pd``, P(a real segment in the floor seen free is detected),
            in (0, 1), above ``false_match_rate``.
        false_match_rate: ``pf``, P(a detection at a place where nothing is), in (0, 1).
        initial_existence: P(real) of a segment seen for the first time, in (0, 1).
        report_existence: Segments at least this probable enter :meth:`ModelMemory.observation`,
            in [min_existence, initial_existence].
        min_existence: Segments below this are forgotten, in (0, initial_existence).
        max_existence: Existence is capped here, in (initial_existence, 1).
        resolve_probability: A candidate (or the none mass) at least this probable resolves its
            ambiguity, in (0.5, 1).
        min_candidate_probability: Candidates below this are pruned (two stay while
            ``p_none`` is 0, one otherwise), in [0, 0.5).
        none_prior: A new ambiguity's ``p_none`` is raised to at least this (its candidates
            scaled down), in [0, 1). A new ambiguity may be a false match altogether; with the
            default (the false-match rate) one whose every candidate is seen free goes after
            four such views (with 0 it would stay until the bound drops it).
        independent_baseline_m: A view from at least this far (metres) from the viewpoint a
            segment was last fused from counts as independent evidence of its endpoints; a
            nearer one is weighted down (:func:`view_weight`); 0: every view counts as
            independent (>= 0).
        repeat_information: The weight of a view from the very viewpoint of the last fusion, as a
            fraction of an independent one, in (0, 1]: its pixel noise is new, its systematic
            errors (edge localisation, quantisation of the same image positions) are not.
        min_sigma_m: The fused endpoints' standard deviation in every direction is at least
            this, metres (>= 0; 0: none): the part of a view's error that every view shares
            (where the segment extraction puts an edge against where it is, the same
            quantisation) does not average away, however many views are fused. The default,
            1.5 mm, is the one of 0, 1.5, 2, 3, 5 and 7.5 mm whose fused endpoints' 95 %
            coverage on ``scripts/memory_eval.py``'s drive is nearest 0.95 (0.962; 0.914
            without a floor).
        max_segments: At most this many remembered segments (>= 1).
        max_ambiguous: At most this many open ambiguities (>= 0).
        max_contacts: At most this many contacts (>= 0).
        free_margin_m: A point is seen free only this far short of the nearest hit along its ray,
            metres (>= 0).
        near_range_m: Floor nearer than this to the viewpoint is not seen (it is out of the
            image), metres (>= 0).
        head_height_m: Height of the camera above the floor, metres (>= 0; 0: no vertical
            limit). With it, a point of height ``h`` nearer than ``(head_height_m - h) /
            tan(half_vfov_rad)`` is below the image: a segment is judged at its top height (a low
            box close to the robot is out of view, a tall shelf is not), the floor at 0. For
            the env's level head: 0.8 m and ``atan(120 / 256)`` = 0.43 rad (the floor seen from
            1.7 m); a tilted head needs the limit of its lower image edge.
        half_vfov_rad: Half the vertical field of view below the optical axis, radians, in
            (0, pi/2).
        min_image_angle_deg: A remembered segment whose image in the new view (a level head at
            ``head_height_m``) lies at less than this angle to the image rows cannot be
            matched there (the segment stereo drops such lines: their disparity is ill-defined
            along the epipolar lines, ``SegmentOptions.min_angle_deg``), so its floor seen free
            is no evidence against it: a face's bottom edge seen face-on keeps its existence.
            Degrees, in [0, 90); 0: every segment could be matched.
        n_rays: Rays of the visibility sweep across the field of view (>= 3).
        seen_tolerance_m: Simplification tolerance of the seen floor, metres (> 0).
        max_seen_vertices: The seen floor is simplified more coarsely while it has more vertices
            (>= 16).
        contact_length_m: Length of a contact's segment, metres (> 0).
        contact_sigma_m: Standard deviation of a contact's endpoints, metres (> 0).
        contact_merge_m: A new contact replaces the contacts whose midpoints are nearer, metres
            (>= 0).
    """

    gate_chi2: float = _CHI2_99_4DOF
    detection_probability: float = 0.8
    false_match_rate: float = 0.05
    initial_existence: float = 0.5
    report_existence: float = 0.3
    min_existence: float = 0.1
    max_existence: float = 0.999
    resolve_probability: float = 0.95
    min_candidate_probability: float = 0.01
    none_prior: float = 0.05
    independent_baseline_m: float = 0.5
    repeat_information: float = 0.5
    min_sigma_m: float = 0.0015
    max_segments: int = 400
    max_ambiguous: int = 64
    max_contacts: int = 64
    free_margin_m: float = 0.1
    near_range_m: float = 0.0
    head_height_m: float = 0.0
    half_vfov_rad: float = 0.43
    min_image_angle_deg: float = 0.0
    n_rays: int = 181
    seen_tolerance_m: float = 0.05
    max_seen_vertices: int = 2000
    contact_length_m: float = 0.2
    contact_sigma_m: float = 0.02
    contact_merge_m: float = 0.1

    def __post_init__(self) -> None:
        def unit(name: str, low: float = 0.0, high: float = 1.0, strict: bool = True) -> None:
            object.__setattr__(
                self, name, number(getattr(self, name), name, low=low, high=high, strict=strict)
            )

        object.__setattr__(self, "gate_chi2", positive(self.gate_chi2, "gate_chi2"))
        for name in ("detection_probability", "false_match_rate", "initial_existence"):
            unit(name)
        if self.detection_probability <= self.false_match_rate:
            raise ValueError(
                f"detection_probability must exceed false_match_rate ({self.false_match_rate}), "
                f"got {self.detection_probability}"
            )
        unit("min_existence", high=self.initial_existence)
        unit("report_existence", self.min_existence, self.initial_existence, strict=False)
        unit("max_existence", low=self.initial_existence)
        unit("resolve_probability", low=0.5)
        unit("min_candidate_probability", high=0.5, strict=False)
        if self.min_candidate_probability >= 0.5:
            raise ValueError(
                f"min_candidate_probability must be < 0.5, got {self.min_candidate_probability}"
            )
        unit("none_prior", strict=False)
        if self.none_prior >= 1.0:
            raise ValueError(f"none_prior must be < 1, got {self.none_prior}")
        for name, low in (
            ("max_segments", 1),
            ("max_ambiguous", 0),
            ("max_contacts", 0),
            ("n_rays", 3),
            ("max_seen_vertices", 16),
        ):
            object.__setattr__(self, name, integer(getattr(self, name), name, low=low))
        unit("half_vfov_rad", high=math.pi / 2)
        unit("min_image_angle_deg", high=90.0, strict=False)
        if self.min_image_angle_deg >= 90.0:
            raise ValueError(f"min_image_angle_deg must be < 90, got {self.min_image_angle_deg}")
        unit("repeat_information", strict=False)
        if self.repeat_information <= 0.0:
            raise ValueError(f"repeat_information must be > 0, got {self.repeat_information}")
        for name in (
            "free_margin_m",
            "near_range_m",
            "contact_merge_m",
            "head_height_m",
            "independent_baseline_m",
            "min_sigma_m",
        ):
            object.__setattr__(self, name, positive(getattr(self, name), name, allow_zero=True))
        for name in ("seen_tolerance_m", "contact_length_m", "contact_sigma_m"):
            object.__setattr__(self, name, positive(getattr(self, name), name))
