"""The compiled association gate and fusion (``modeling.memory.association.gated_pairs`` and
``fused_segments``, running ``modeling.memory._kernels.association``) equal their NumPy references
(``gated_pairs_reference``, ``fused_segments_reference``) on seeded random segments."""

from __future__ import annotations

import numpy as np
import pytest

from modeling.memory.association import (
    Association,
    SegmentStack,
    fused_segments,
    fused_segments_reference,
    gated_pairs,
    gated_pairs_reference,
)


def _segments(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` segments in a 4 m square, endpoint covariances of random shape and size."""
    start = rng.uniform(0.0, 4.0, (n, 2))
    ends = np.stack([start, start + rng.normal(0.0, 0.3, (n, 2))], axis=1)
    root = rng.normal(0.0, 1.0, (n, 2, 2, 2)) * rng.uniform(0.01, 0.15, (n, 2, 1, 1))
    cov = root @ np.swapaxes(root, -1, -2) + 1e-6 * np.eye(2)
    return ends, cov


@pytest.mark.parametrize("seed", range(6))
def test_compiled_gate_equals_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    mem_ends, mem_cov = _segments(rng, 40)
    # half the new segments are remembered ones seen again (noisy, some in reverse order)
    new_ends, new_cov = _segments(rng, 30)
    again = rng.choice(40, 15, replace=False)
    new_ends[:15] = mem_ends[again] + rng.normal(0.0, 0.03, (15, 2, 2))
    new_ends[:7] = new_ends[:7, ::-1]
    got = gated_pairs(new_ends, new_cov, mem_ends, mem_cov, 13.28)
    want = gated_pairs_reference(new_ends, new_cov, mem_ends, mem_cov, 13.28)
    assert 15 <= want.rows.shape[0] < 30 * 40  # the seen-again pairs and a few others
    assert np.any(want.swapped) and not np.all(want.swapped)
    for g, w in zip(got, want, strict=True):
        assert g.dtype == w.dtype
        np.testing.assert_array_equal(g, w)


def test_compiled_gate_with_nothing_to_pair() -> None:
    ends, cov = _segments(np.random.default_rng(1), 3)
    for a, b in (((ends, cov), (ends[:0], cov[:0])), ((ends[:0], cov[:0]), (ends, cov))):
        got = gated_pairs(*a, *b, 13.28)
        want = gated_pairs_reference(*a, *b, 13.28)
        assert got.rows.shape[0] == want.rows.shape[0] == 0
    far = ends + 100.0  # nothing within the gate
    assert gated_pairs(far, cov, ends, cov, 13.28).rows.shape[0] == 0


def _fusion_inputs(rng: np.random.Generator) -> tuple[SegmentStack, SegmentStack, Association]:
    """20 remembered and 12 new random segments, and 8 random pairs of them."""
    mem_ends, mem_cov = _segments(rng, 20)
    new_ends, new_cov = _segments(rng, 12)
    mem = SegmentStack(mem_ends, mem_cov, rng.uniform(0, 1, (20, 2)), np.arange(20))
    new = SegmentStack(new_ends, new_cov, rng.uniform(0, 1, (12, 2)), np.arange(12) + 100)
    pairs = Association(
        rows=rng.permutation(12)[:8],
        cols=rng.permutation(20)[:8],
        d2=np.zeros(8),
        swapped=rng.uniform(size=8) < 0.5,
    )
    return mem, new, pairs


@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("seed", range(4))
def test_compiled_fusion_equals_reference(seed: int, weighted: bool) -> None:
    rng = np.random.default_rng(100 + seed)
    mem, new, pairs = _fusion_inputs(rng)
    weight = rng.uniform(0.5, 1.0, 8) if weighted else None
    got_segs, got = fused_segments(mem, new, pairs, weight)
    want_segs, want = fused_segments_reference(mem, new, pairs, weight)
    for g, w in zip(got, want, strict=True):
        assert g.dtype == w.dtype
        np.testing.assert_array_equal(g, w)
    for g, w in zip(got_segs, want_segs, strict=True):
        np.testing.assert_array_equal(g.endpoints, w.endpoints)
        np.testing.assert_array_equal(g.cov, w.cov)
        np.testing.assert_array_equal(g.height_m, w.height_m)
        assert g.source == w.source
    assert np.all(want.heights >= mem.heights[pairs.cols])  # the larger heights


def test_compiled_fusion_equals_reference_with_a_variance_floor() -> None:
    rng = np.random.default_rng(7)
    mem, new, pairs = _fusion_inputs(rng)
    _, plain = fused_segments(mem, new, pairs)
    smallest = np.linalg.eigvalsh(plain.cov.reshape(-1, 2, 2))[:, 0]
    floor = float(np.median(smallest))  # half the fused endpoints below it, half above
    got_segs, got = fused_segments(mem, new, pairs, min_var=floor)
    want_segs, want = fused_segments_reference(mem, new, pairs, min_var=floor)
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, w)
    for g, w in zip(got_segs, want_segs, strict=True):
        np.testing.assert_array_equal(g.cov, w.cov)
    flat, before = got.cov.reshape(-1, 2, 2), plain.cov.reshape(-1, 2, 2)
    raised = smallest < floor
    assert 0 < np.count_nonzero(raised) < raised.shape[0]
    np.testing.assert_array_equal(flat[~raised], before[~raised])  # bit for bit
    np.testing.assert_allclose(np.linalg.eigvalsh(flat)[:, 0], np.maximum(smallest, floor))
    np.testing.assert_array_equal(got.ends, plain.ends)  # the means are the product's
