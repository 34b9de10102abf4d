"""Benchmark of the modeling core (``modeling.build_model``) on synthetic floor observations.

    python scripts/bench_modeling.py [--json FILE] [--seconds S] [--quick]

Figures (median wall time in milliseconds over interleaved rounds; ``_min_ms``: the fastest run,
an estimate for an idle machine; ``_p90_ms``: the 90th percentile). The rounds go on for at least
``--seconds`` (20 by default): this machine's speed switches between a fast and a slow phase that
each last from about a second to minutes, so a measurement of two seconds falls within one phase
and its median is that phase's, not the machine's.

* ``modeling_200_segments_ms``: an indoor-like layout of 200 floor segments (boxes of furniture
  and wall pieces, stereo-like anisotropic covariances, doorway-like gaps near the robot width).
* ``modeling_2000_segments_ms``: the same kind of layout with 2,000 segments.
* ``modeling_30_ambiguous_ms``: 60 floor segments plus 30 ambiguous segments with 3 candidates each,
  in independent groups, to the top ``max_situations`` (64) situations with exact probabilities.
* ``topology_200_segments_path_graph_ms`` and ``topology_200_segments_routes_ms``: the path graph
  (``modeling.model.topology.path_graph``) of the 200-segment model across its whole width, and its
  5 shortest distinct routes (a stress case: about 100 obstacles and 245 critical regions).
"""

from __future__ import annotations

import argparse
import math
import pathlib
import statistics
import time
from collections.abc import Callable

import numpy as np
from _figures import print_figures, write_figures

from modeling.model.build import build_model
from modeling.model.topology import path_graph, routes
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment

ROBOT_WIDTH_M = 0.5


def stereo_cov(p: np.ndarray, viewpoint: np.ndarray, range_m: float | None = None) -> np.ndarray:
    """(2, 2) covariance of a floor point seen from ``viewpoint``: depth sd ~ Z^2, lateral ~ Z."""
    d = p - viewpoint[:2]
    z = float(np.hypot(*d)) if range_m is None else range_m
    z = max(z, 0.5)
    sig_depth = z * z * 0.7 / (260.0 * 0.12)
    sig_lat = z * 0.5 / 260.0
    ang = math.atan2(d[1], d[0])
    R = np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
    cov: np.ndarray = R @ np.diag([sig_depth**2, sig_lat**2]) @ R.T
    return cov


def _segment(a: np.ndarray, b: np.ndarray, vp: np.ndarray, range_m: float) -> FloorSegment:
    return FloorSegment(
        endpoints=np.array([a, b]),
        cov=np.stack([stereo_cov(a, vp, range_m), stereo_cov(b, vp, range_m)]),
    )


def indoor_layout(n_segments: int, rng: np.random.Generator) -> FloorObservation:
    """Random furniture boxes (4 sides) and wall runs with door-like gaps, ~``n_segments`` segments.

    The area grows with the count (about 1.5 boxes per square metre... scaled so density stays
    indoor-like); each segment's covariance is that of a stereo view from 1-4 m away.
    """
    n_boxes = n_segments // 5
    n_walls = n_segments - 4 * n_boxes
    side = math.sqrt(n_segments / 200.0) * 14.0
    vp = np.array([-1.0, side / 2, 0.0])
    segs: list[FloorSegment] = []
    centers = rng.uniform(0, side, (n_boxes, 2))
    for c in centers:
        w, h = rng.uniform(0.3, 1.2, 2)
        th = rng.uniform(0, math.pi)
        R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        corners = c + (np.array([[-w, -h], [w, -h], [w, h], [-w, h]]) / 2) @ R.T
        rng_m = rng.uniform(1.0, 4.0)
        for k in range(4):
            segs.append(_segment(corners[k], corners[(k + 1) % 4], vp, rng_m))
    # Wall runs: collinear pieces separated by gaps around the robot width.
    x0 = rng.uniform(0, side)
    y = rng.uniform(0, side)
    for _ in range(n_walls):
        length = rng.uniform(0.5, 2.0)
        rng_m = rng.uniform(1.0, 4.0)
        segs.append(_segment(np.array([x0, y]), np.array([x0 + length, y]), vp, rng_m))
        x0 += length + rng.uniform(0.3, 0.8)
        if x0 > side:
            x0 = 0.0
            y = rng.uniform(0, side)
    return FloorObservation(
        segments=tuple(segs), viewpoint=vp, fov_rad=math.radians(64.0), max_range_m=8.0
    )


def ambiguous_layout(
    n_ambiguous: int, n_candidates: int, rng: np.random.Generator
) -> FloorObservation:
    """Pairs of wall pieces (60 segments for 30 ambiguous) with an ambiguous segment in each gap.

    Its candidates block the gap, leave it undecided, or lie away from it: every ambiguous segment
    affects its own space only, so the groups are independent.
    """
    vp = np.array([0.0, 0.0, 0.0])
    segs: list[FloorSegment] = []
    ambs: list[AmbiguousSegment] = []
    for k in range(n_ambiguous):
        cx = 3.0 * (k % 6)
        cy = 3.0 * (k // 6)
        # Two wall pieces with a 1.2 m gap between them (clearly passable without the segment).
        a0, a1 = np.array([cx, cy]), np.array([cx + 0.8, cy])
        b0, b1 = np.array([cx + 2.0, cy]), np.array([cx + 2.8, cy])
        segs.append(_segment(a0, a1, vp, 2.0))
        segs.append(_segment(b0, b1, vp, 2.0))
        cands = []
        offsets = [0.0, 0.35, 1.5][:n_candidates]
        for off in offsets:
            p = np.array([cx + 0.95, cy + off])
            q = np.array([cx + 1.85, cy + off])
            cands.append(_segment(p, q, vp, 2.0))
        pr = rng.dirichlet(np.ones(n_candidates) * 3.0)
        ambs.append(AmbiguousSegment(candidates=tuple(cands), probabilities=tuple(pr / pr.sum())))
    return FloorObservation(segments=tuple(segs), ambiguous=tuple(ambs), viewpoint=vp)


def _times_ms(
    jobs: dict[str, tuple[Callable[[], object], int]], rounds: int, seconds: float = 0.0
) -> dict[str, list[float]]:
    """Wall times (ms) of each job, run in interleaved rounds after one warm-up call each.

    Interleaving spreads a burst of load from other processes over all the jobs instead of
    spoiling one of them; each job runs ``repeats`` times per round. At least ``rounds`` rounds,
    and more until ``seconds`` have passed.
    """
    for fn, _ in jobs.values():
        fn()
    times: dict[str, list[float]] = {name: [] for name in jobs}
    deadline = time.perf_counter() + seconds
    done = 0
    while done < rounds or time.perf_counter() < deadline:
        done += 1
        for name, (fn, repeats) in jobs.items():
            for _ in range(repeats):
                t0 = time.perf_counter()
                fn()
                times[name].append((time.perf_counter() - t0) * 1e3)
    return times


def run(quick: bool = False, seconds: float = 20.0) -> dict[str, float]:
    """Median (minimum, 90th percentile) milliseconds of ``build_model`` on the three synthetic
    workloads, and of the path graph and routes of the 200-segment model, over rounds lasting at
    least ``seconds`` (a few rounds, whatever ``seconds`` says, when ``quick``)."""
    rng = np.random.default_rng(0)
    obs200 = indoor_layout(200, rng)
    obs2000 = indoor_layout(2000, rng)
    obs_amb = ambiguous_layout(30, 3, rng)
    m = build_model(obs_amb, ROBOT_WIDTH_M, max_situations=64)
    m200 = build_model(obs200, ROBOT_WIDTH_M)
    x0, y0 = (float(v) for v in obs200.viewpoint[:2])
    start, goal = (x0, y0), (x0 + 15.0, y0)
    graph = path_graph(m200.situations[0], start, goal)
    jobs = {
        "200": (lambda: build_model(obs200, ROBOT_WIDTH_M), 5),
        "2000": (lambda: build_model(obs2000, ROBOT_WIDTH_M), 1),
        "amb": (lambda: build_model(obs_amb, ROBOT_WIDTH_M, max_situations=64), 2),
        "graph": (lambda: path_graph(m200.situations[0], start, goal), 1),
        "routes": (lambda: routes(graph, max_routes=5), 1),
    }
    t = _times_ms(jobs, rounds=2 if quick else 8, seconds=0.0 if quick else seconds)
    med = {k: statistics.median(v) for k, v in t.items()}
    p90 = {k: statistics.quantiles(v, n=10)[-1] for k, v in t.items()}
    return {
        "modeling_200_segments_ms": med["200"],
        "modeling_2000_segments_ms": med["2000"],
        "modeling_30_ambiguous_ms": med["amb"],
        "modeling_200_segments_min_ms": min(t["200"]),
        "modeling_2000_segments_min_ms": min(t["2000"]),
        "modeling_30_ambiguous_min_ms": min(t["amb"]),
        "modeling_200_segments_p90_ms": p90["200"],
        "modeling_200_segments_within_10_ms_fraction": sum(x <= 10.0 for x in t["200"])
        / len(t["200"]),
        "modeling_200_segments_runs_count": float(len(t["200"])),
        "modeling_30_ambiguous_groups_count": float(len(m.groups)),
        "modeling_30_ambiguous_situations_count": float(len(m.situations)),
        "topology_200_segments_path_graph_ms": med["graph"],
        "topology_200_segments_routes_ms": med["routes"],
        "topology_200_segments_graph_nodes_count": float(graph.number_of_nodes()),
    }


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=pathlib.Path, help="write the figures to this JSON file")
    parser.add_argument(
        "--seconds", type=float, default=20.0, help="least measuring time (default 20)"
    )
    parser.add_argument("--quick", action="store_true", help="fewer repeats (smoke run)")
    args = parser.parse_args(argv)
    figures = run(quick=args.quick, seconds=args.seconds)
    print_figures(figures)
    write_figures(figures, args.json)
    return figures


if __name__ == "__main__":
    main()
