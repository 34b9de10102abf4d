"""The compiled association gate (``modeling.memory_association.gated_pairs``, running
``modeling._compiled.association.gate_pairs``) equals its NumPy reference
(``modeling.memory_association.gated_pairs_reference``) on seeded random segments."""

from __future__ import annotations

import numpy as np
import pytest

from modeling.memory_association import gated_pairs, gated_pairs_reference


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
