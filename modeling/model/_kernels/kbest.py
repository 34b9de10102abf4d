"""Compiled loop of :func:`modeling.model.situations.k_best`: the ``k`` most probable joint
choices of independent factors, best first (Eq. 2; reference
:func:`modeling.model.situations.k_best_reference`, Python).

The same best-first search as the reference, on arrays: the same heap entries (``(-log
probability, push count, state, last moved factor)``, a state an index into a table of rank
rows), pushed in the same order, and the same floating-point operations in the same order
(the logarithms and their starting sum are made in Python and passed in), so the results are
equal to the reference's exactly; ``tests/modeling/model/test_compiled_model.py`` compares them.
Compiled with Numba on first use (:mod:`modeling.jit`); importing this module does not import
Numba.
"""

from __future__ import annotations

import heapq
from typing import NamedTuple

import numpy as np

from modeling.jit import compiled_on_first_call


class Factors(NamedTuple):
    """Independent factors, each a few choices sorted by probability, descending.

    Attributes:
        probs: (c,) float64, the choices' probabilities, factor after factor.
        logs: (c,) float64, their logarithms (``log(max(p, 1e-300))``).
        start: (n + 1,) int64, where each factor's choices start in ``probs``.
        seq: (q,) int64, the factors of two or more choices, by the loss of their first step
            down (``logs[0] - logs[1]``, smallest first; ties by factor).
    """

    probs: np.ndarray
    logs: np.ndarray
    start: np.ndarray
    seq: np.ndarray


class Best(NamedTuple):
    """The most probable joint choices, best first.

    Attributes:
        prob: (k,) float64, each one's probability (the product of its choices', in factor
            order).
        ranks: (k, n) int64, its choice (rank) of each factor.
    """

    prob: np.ndarray
    ranks: np.ndarray


@compiled_on_first_call
def k_best(factors: Factors, neg_start: float, k: int) -> Best:
    """The ``k`` most probable joint choices of ``factors`` (``neg_start``: minus the sum of the
    factors' first logarithms, the heap key of the best one); see
    :func:`modeling.model.situations.k_best_reference`."""
    probs, logs, start, seq = factors.probs, factors.logs, factors.start, factors.seq
    n = start.shape[0] - 1
    q = seq.shape[0]
    states = np.zeros((3 * k + 1, n), dtype=np.int64)  # each pop pushes at most three
    n_states = 1
    heap = [(neg_start, 0, 0, -1)]
    count = 1
    prob = np.empty(k)
    chosen = np.empty(k, dtype=np.int64)
    n_out = 0
    while len(heap) > 0 and n_out < k:
        neg, _, state, last = heapq.heappop(heap)
        p = 1.0
        for u in range(n):
            p *= probs[start[u] + states[state, u]]
        prob[n_out] = p
        chosen[n_out] = state
        n_out += 1
        if last >= 0:
            u = seq[last]
            r = states[state, u]
            if r + 1 < start[u + 1] - start[u]:
                loss = logs[start[u] + r] - logs[start[u] + r + 1]
                states[n_states] = states[state]
                states[n_states, u] = r + 1
                heapq.heappush(heap, (neg + loss, count, n_states, last))
                n_states += 1
                count += 1
        if last + 1 < q:
            v = seq[last + 1]
            loss = logs[start[v]] - logs[start[v] + 1]
            states[n_states] = states[state]
            states[n_states, v] = 1
            heapq.heappush(heap, (neg + loss, count, n_states, last + 1))
            n_states += 1
            count += 1
            if last >= 0 and states[state, seq[last]] == 1:
                u = seq[last]
                back = logs[start[u] + 1] - logs[start[u]]
                states[n_states] = states[state]
                states[n_states, u] = 0
                states[n_states, v] = 1
                heapq.heappush(heap, (neg + (loss + back), count, n_states, last + 1))
                n_states += 1
                count += 1
    return Best(prob[:n_out].copy(), states[chosen[:n_out]])
