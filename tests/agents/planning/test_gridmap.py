"""The agents' occupancy map (seen, bumps, gates) and cost grid, on synthetic models."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.sparse import csr_matrix

from agents.planning.costmap import CostGrid, cost_from, cost_to_go, path_from
from agents.planning.gridmap import GateHistory, GridSpec, OccupancyMap, _line_points
from tests.agents.synthetic import model_of, wall_segments


def _at(spec: GridSpec, grid: np.ndarray, x: float, y: float) -> bool:
    row, col = spec.cell_of(np.array([[x, y]]))[0]
    return bool(grid[row, col])


def test_grid_spec_cells_round_trip() -> None:
    spec = GridSpec.from_bounds((0.0, 0.0, 2.0, 1.0), 0.1)
    assert spec.shape == (10, 20) and spec.size == 200
    idx = spec.index_of(np.array([[0.05, 0.05], [1.234, 0.56]]))
    assert idx.tolist() == [0, 5 * 20 + 12]
    assert spec.xy_of(idx) == pytest.approx(np.array([[0.05, 0.05], [1.25, 0.55]]))
    with pytest.raises(ValueError, match="bounds must satisfy"):
        GridSpec.from_bounds((1.0, 0.0, 1.0, 1.0))


def test_line_points_are_each_lines_linspace() -> None:
    # _line_points samples every line at once; the points must be those of np.linspace per line,
    # bit for bit (the rasters, and so the planner's maps, are unchanged by it).
    rng = np.random.default_rng(3)
    for step in (0.025, 0.05, 0.3):
        lines = rng.uniform(-5.0, 5.0, (40, 2, 2))
        lines[7, 1] = lines[7, 0]  # zero length: both ends
        lengths = np.hypot(*(lines[:, 1] - lines[:, 0]).T)
        counts = np.maximum(2, np.ceil(lengths / step).astype(np.int64) + 1)
        want = np.concatenate(
            [
                a + (b - a) * np.linspace(0.0, 1.0, c)[:, None]
                for (a, b), c in zip(lines, counts, strict=True)
            ]
        )
        assert np.array_equal(_line_points(lines, step), want)
    assert _line_points(np.zeros((0, 2, 2)), 0.05).shape == (0, 2)


def test_occupancy_fuses_hits_and_clears_what_it_sees_free() -> None:
    spec = GridSpec.from_bounds((0.0, 0.0, 6.0, 4.0), 0.1)
    occupancy = OccupancyMap(spec)
    wall = model_of(wall_segments(2.5, [(1.5, 2.5)], 0.02), (0.5, 2.0, 0.0))
    occupancy.update(wall)
    assert _at(spec, occupancy.occupied(), 2.5, 2.0)
    assert not _at(spec, occupancy.occupied(), 1.5, 2.0)
    empty = model_of([], (0.5, 2.0, 0.0))
    for _ in range(2):
        occupancy.update(empty)
        assert _at(spec, occupancy.occupied(), 2.5, 2.0)  # 1.0 - 0.35 - 0.35 > 0: still there
    occupancy.update(empty)
    assert not _at(spec, occupancy.occupied(), 2.5, 2.0)  # seen free three times


def test_the_fused_models_nearby_obstacles_enter_the_map_only_when_asked() -> None:
    """The memory model's obstacles within ``fused_range_m`` of the head count as seen in a view
    that shows nothing (an empty model); farther ones, and any with the option at 0, do not."""
    spec = GridSpec.from_bounds((0.0, 0.0, 6.0, 4.0), 0.1)
    empty = model_of([], (0.5, 2.0, 0.0))
    fused = model_of(wall_segments(2.0, [(1.5, 2.5)], 0.02), (0.0, 2.0, 0.0))
    far = model_of(wall_segments(4.0, [(1.5, 2.5)], 0.02), (0.0, 2.0, 0.0))
    on = OccupancyMap(spec, fused_range_m=1.8)
    on.update(empty, fused=fused)
    assert _at(spec, on.occupied(), 2.0, 2.0)  # 1.5 m from the viewpoint at x = 0.5
    on.update(empty, fused=far)  # 3.5 m away: left out
    assert not _at(spec, on.occupied(), 4.0, 2.0)
    for occupancy in (OccupancyMap(spec), OccupancyMap(spec, fused_range_m=1.8)):
        occupancy.update(empty, fused=fused if occupancy.fused_range_m == 0.0 else None)
        assert not occupancy.occupied()[1:-1, 1:-1].any()


def test_a_wrong_memory_model_is_refused_by_name() -> None:
    from agents.base import memory_model_of

    assert memory_model_of({}) is None and memory_model_of({"memory_model": None}) is None
    with pytest.raises(ValueError, match=r"info\['memory_model'\] must be an EnvironmentModel"):
        memory_model_of({"memory_model": "a map"})


def test_bumps_are_forgotten_but_the_border_is_not() -> None:
    spec = GridSpec.from_bounds((0.0, 0.0, 4.0, 4.0), 0.1)
    occupancy = OccupancyMap(spec)
    assert occupancy.occupied()[0, :].all() and occupancy.occupied()[:, -1].all()
    occupancy.add_bump(np.array([2.0, 2.0]), 0.0, 1.0, step=10)  # a segment across +x
    occupancy.add_bump(np.array([1.0, 1.0]), 0.0, 0.4, step=50)
    assert _at(spec, occupancy.occupied(), 2.05, 2.45) and _at(
        spec, occupancy.occupied(), 2.05, 1.55
    )
    occupancy.forget(before_step=30)
    occ = occupancy.occupied()
    assert not _at(spec, occ, 2.05, 2.0) and _at(spec, occ, 1.05, 1.0) and occ[0, :].all()


def test_gate_history_matches_and_keeps_the_sharper_estimate() -> None:
    segs_far = wall_segments(4.0, [(0.5, 1.74), (2.26, 3.5)], 0.1)
    segs_near = wall_segments(4.0, [(0.5, 1.74), (2.26, 3.5)], 0.03)
    gates = GateHistory()
    gates.update(model_of(segs_far, (0.0, 2.0, 0.0)), step=0)
    (gate,) = gates.gates
    assert gate.midpoint == pytest.approx([4.0, 2.0]) and gate.seen_distance_m == pytest.approx(4)
    far_std = gate.width_std_m
    gates.update(model_of(segs_near, (2.5, 2.0, 0.0)), step=1)
    assert len(gates.gates) == 1 and gate.width_std_m < far_std / 2
    assert gate.seen_distance_m == pytest.approx(1.5) and gate.last_step == 1
    gates.update(model_of(segs_far, (0.0, 2.0, 0.0)), step=2)  # a worse view: estimate kept
    assert gate.width_std_m < far_std / 2 and gate.last_step == 2
    assert gates.mark_failed(np.array([3.8, 2.0]), 0.5) == [0]
    assert gate.failed and gate.p_passable == 0.0


def test_a_gate_closed_by_an_old_bump_reopens_with_its_passability_and_a_recent_one_not() -> None:
    segs = wall_segments(4.0, [(0.5, 1.74), (2.26, 3.5)], 0.1)
    gates = GateHistory()
    gates.update(model_of(segs, (0.0, 2.0, 0.0)), step=0)
    (gate,) = gates.gates
    seen_p = gate.p_passable
    assert 0.05 < seen_p < 0.95
    assert gates.mark_failed(np.array([3.8, 2.0]), 0.5, step=40) == [0]
    assert gate.failed and gate.failed_step == 40 and gate.p_passable == 0.0
    assert gates.reopen(before_step=40) == [] and gate.failed  # the bump is recent
    assert gates.reopen(before_step=41) == [0]
    assert not gate.failed and gate.failed_step is None and gate.p_passable == seen_p
    gates.update(model_of(wall_segments(4.0, [(0.5, 3.5)], 0.02), (2.0, 2.0, 0.0)), step=50)
    assert gate.p_passable == 0.0  # open to views again: one wall, no gap
    assert gates.reopen(before_step=100) == []  # a view closed it, not a bump


def test_a_closer_view_decides_a_remembered_gate_from_its_sides() -> None:
    """A remembered gate in clear view, closer than before, with no region there now: passable
    when its two ends lie on two obstacles, impassable when on one."""
    far = model_of(wall_segments(4.0, [(0.5, 1.74), (2.26, 3.5)], 0.1), (0.0, 2.0, 0.0))
    for spans, sigma, p_passable in (
        ([(0.5, 1.74), (2.26, 3.5)], 0.002, 1.0),  # the 0.52 m gap, now surely wide enough
        ([(0.5, 3.5)], 0.02, 0.0),  # no gap: one wall
    ):
        gates = GateHistory()
        gates.update(far, step=0)
        (gate,) = gates.gates
        assert 0.05 < gate.p_passable < 0.95
        gates.update(model_of(wall_segments(4.0, spans, sigma), (2.0, 2.0, 0.0)), step=1)
        assert len(gates.gates) == 1 and gate.p_passable == p_passable
        assert gate.seen_distance_m == pytest.approx(2.0) and gate.last_step == 1


def test_a_gate_the_robot_drove_through_stays_passable() -> None:
    """Crossing a gate's narrowest relation proves it passable: later views do not re-estimate it
    and a bump beside it (the robot stuck just beyond) does not close it; a gate not crossed is
    closed by the same bump."""
    segs = wall_segments(4.0, [(0.5, 1.74), (2.26, 3.5)], 0.1)
    gates = GateHistory()
    gates.update(model_of(segs, (0.0, 2.0, 0.0)), step=0)
    (gate,) = gates.gates
    assert 0.05 < gate.p_passable < 0.95  # undecided: 0.52 m for the 0.5 m robot
    gates.note_motion(np.array([3.0, 2.0]), np.array([3.9, 2.05]))  # up to it, not through
    assert not gate.crossed and gate.p_passable < 0.95
    gates.note_motion(np.array([3.9, 2.05]), np.array([4.1, 2.1]))
    assert gate.crossed and not gate.failed and gate.p_passable == 1.0
    gates.update(model_of(segs, (2.5, 2.0, 0.0)), step=1)  # a new view does not undo it
    assert gate.p_passable == 1.0
    assert gates.mark_failed(np.array([4.3, 2.0]), 0.6) == [] and not gate.failed
    other = GateHistory()
    other.update(model_of(segs, (0.0, 2.0, 0.0)), step=0)
    other.note_motion(np.array([3.0, 2.0]), np.array([3.9, 2.05]))
    assert other.mark_failed(np.array([4.3, 2.0]), 0.6) == [0]


def _wall_with_one_gap() -> tuple[GridSpec, OccupancyMap, GateHistory]:
    """A 6 m x 4 m grid, its map and gates after one view of a wall at x = 3 with a 0.52 m gap
    (an undecided gate for the 0.5 m robot) seen from (1, 2)."""
    spec = GridSpec.from_bounds((0.0, 0.0, 6.0, 4.0), 0.1)
    model = model_of(wall_segments(3.0, [(0.0, 1.74), (2.26, 4.0)], 0.08), (1.0, 2.0, 0.0))
    occupancy = OccupancyMap(spec)
    occupancy.update(model)
    gates = GateHistory()
    gates.update(model, step=0)
    return spec, occupancy, gates


def test_cost_grid_crosses_a_gap_only_by_its_gate_edge() -> None:
    spec, occupancy, gates = _wall_with_one_gap()
    (gate,) = gates.gates
    assert 0.05 < gate.p_passable < 0.95
    grid = CostGrid(spec, occupancy.occupied(), gates.gates, hard_m=0.2, soft_m=0.4)
    (edge,) = grid.gate_edges
    assert edge.mid_xy == pytest.approx([3.0, 2.0], abs=0.02)
    start = int(spec.index_of(np.array([[1.0, 2.0]]))[0])
    goal = int(spec.index_of(np.array([[5.0, 2.0]]))[0])
    closed, _ = cost_to_go(grid.matrix({}), goal)
    assert math.isinf(closed[start])
    value, pred = cost_to_go(grid.matrix({(edge.a, edge.b): 1.0, (edge.b, edge.a): 1.0}), goal)
    path = path_from(pred, start)
    assert path[0] == start and path[-1] == goal
    assert any({u, v} == {edge.a, edge.b} for u, v in itertools.pairwise(path))
    assert 3.9 < value[start] < 5.5


def test_cost_grid_graphs_equal_the_graph_made_at_once() -> None:
    # to_target / from_source add each call's gate edges to the grid's edges built once; the
    # matrices and the Dijkstra results must be those of all the edges made into one matrix.
    spec, occupancy, gates = _wall_with_one_gap()
    grid = CostGrid(spec, occupancy.occupied(), gates.gates, hard_m=0.2, soft_m=0.4)
    (edge,) = grid.gate_edges
    src, dst, w = grid._base
    beside = (int(src[0]), int(dst[0]))  # a pair with a grid edge too: the weights add up
    start = int(spec.index_of(np.array([[1.0, 2.0]]))[0])
    goal = int(spec.index_of(np.array([[5.0, 2.0]]))[0])
    for weights in ({}, {(edge.a, edge.b): 1.3, (edge.b, edge.a): 0.0, beside: 0.7}):
        a = np.concatenate([src, np.array([k[0] for k in weights], dtype=np.int64)])
        b = np.concatenate([dst, np.array([k[1] for k in weights], dtype=np.int64)])
        ws = np.maximum(np.concatenate([w, list(weights.values())]), 1e-9)
        whole = csr_matrix((ws, (a, b)), shape=(spec.size, spec.size))
        reverse = csr_matrix((ws, (b, a)), shape=(spec.size, spec.size))
        for got, want in (
            (grid.matrix(weights), whole),
            (grid._graph(weights, reverse=True), reverse),
        ):
            assert np.array_equal(got.indptr, want.indptr)
            assert np.array_equal(got.indices, want.indices)
            assert np.array_equal(got.data, want.data)
        for got_, want_ in (
            (grid.to_target(weights, goal), cost_to_go(whole, goal)),
            (grid.from_source(weights, start), cost_from(whole, start)),
        ):
            assert np.array_equal(got_[0], want_[0]) and np.array_equal(got_[1], want_[1])
    before = grid.from_source({}, start)[0]
    grid.matrix({}).data[:] = 1e6  # a caller's matrix is its own copy, not the shared one
    assert np.array_equal(grid.from_source({}, start)[0], before)


def test_no_gate_edge_jumps_over_a_bump_mark() -> None:
    # Dev seed 4242, episode 10: a bump mark lay across a gate edge's way, which jumps over the
    # blocked cells beside its gap, so the re-plan crossed there again and bumped six times.
    spec, occupancy, gates = _wall_with_one_gap()
    (edge,) = CostGrid(spec, occupancy.occupied(), gates.gates, hard_m=0.2, soft_m=0.4).gate_edges
    occupancy.add_bump(0.5 * (edge.a_xy + edge.mid_xy), 0.0, 0.6, step=1)  # on the entry side
    walls = occupancy.bumps >= 0
    grid = CostGrid(spec, occupancy.occupied(), gates.gates, hard_m=0.2, soft_m=0.4, walls=walls)
    assert grid.gate_edges == []
    elsewhere = np.zeros_like(walls)
    elsewhere[0, 5] = True  # a bump away from the gap leaves the edge
    grid = CostGrid(
        spec, occupancy.occupied(), gates.gates, hard_m=0.2, soft_m=0.4, walls=elsewhere
    )
    assert len(grid.gate_edges) == 1
