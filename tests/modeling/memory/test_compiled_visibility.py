"""The compiled free-space test of the memory (``modeling.memory.fusion._seen_free``, running
``modeling.memory._kernels.visibility.segments_seen_free``) equals its NumPy reference
(``modeling.memory.fusion._seen_free_reference``, through ``Visibility.seen_free``) on seeded random
segments and views."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modeling import FloorObservation, FloorSegment, MemoryOptions
from modeling.memory.association import stack_of
from modeling.memory.fusion import _seen_free, _seen_free_reference
from modeling.memory.visibility import visibility


@pytest.mark.parametrize("head_height_m", [0.0, 0.8])
@pytest.mark.parametrize("seed", range(5))
def test_compiled_seen_free_equals_reference(seed: int, head_height_m: float) -> None:
    rng = np.random.default_rng(seed)
    cov = np.tile(np.eye(2) * 1e-4, (2, 1, 1))

    def segment(a: np.ndarray, b: np.ndarray, top: float) -> FloorSegment:
        return FloorSegment(endpoints=np.stack([a, b]), cov=cov, height_m=np.array([0.0, top]))

    # walls that occlude part of the view, and many short segments around the viewpoint
    walls = tuple(
        segment(p, p + rng.normal(0, 1.0, 2), 0.5) for p in rng.uniform([1, -3], [6, 3], (4, 2))
    )
    heading = rng.uniform(-math.pi, math.pi)
    obs = FloorObservation(segments=walls, viewpoint=np.array([0.2, -0.1, heading]))
    opts = MemoryOptions(
        head_height_m=head_height_m, half_vfov_rad=math.atan(120 / 256), near_range_m=0.3
    )
    vis = visibility(obs, stack_of(walls).ends, n_rays=opts.n_rays, near_m=1.7)
    # anywhere, and near the viewpoint (the near limits, the floor out of the image)
    starts = np.concatenate([rng.uniform(-8, 8, (150, 2)), rng.normal(0, 1.0, (150, 2))])
    tests = tuple(
        segment(p, p + rng.normal(0, 0.3, 2), float(t))
        for p, t in zip(starts, rng.uniform(0.05, 0.9, 300), strict=True)
    )
    segs = stack_of(tests)
    got, want = _seen_free(vis, segs, opts), _seen_free_reference(vis, segs, opts)
    assert got.dtype == want.dtype == np.bool_
    np.testing.assert_array_equal(got, want)
    assert 10 < int(want.sum()) < 290  # some seen free, most not (out of view, hidden, near)
    assert _seen_free(vis, stack_of(()), opts).shape == (0,)
