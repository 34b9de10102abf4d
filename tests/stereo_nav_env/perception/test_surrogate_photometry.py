"""The surrogate's photometry: the grey levels beside edges against the rendered image, the
pieces of an edge, and the compiled loops against their NumPy references."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from modeling.stereo.rig import HeadPose, StereoRig
from stereo_nav_env.perception.surrogate.photometry import (
    ROWS,
    edge_greys,
    edge_pieces,
    edge_pieces_reference,
    first_surface_greys,
    first_surface_greys_reference,
    sample_rows,
)
from stereo_nav_env.perception.surrogate.visibility import SceneEdges, visible_edges
from stereo_nav_env.rendering.renderer import StereoRenderer
from stereo_nav_env.sim.scenes import ObstacleKind, Scene, generate_scene
from stereo_nav_env.sim.scenes.parts import make_obstacle, oriented_rect

RIG = StereoRig()
HEAD = HeadPose(x_m=0.5, y_m=2.5, heading_rad=0.0, height_m=0.8)


def _box_before_wall() -> Scene:
    box = make_obstacle(ObstacleKind.BOX, oriented_rect([2.5, 2.3], 0.5, 0.5, 0.4), 0.6)
    wall = make_obstacle(ObstacleKind.WALL, oriented_rect([4.5, 2.5], 0.1, 3.0), 2.0)
    return Scene(
        name="test",
        bounds=(0.0, 0.0, 6.0, 5.0),
        obstacles=(box, wall),
        start=(0.5, 2.5, 0.0),
        goal=(5.5, 2.5),
    )


def _rendered_samples(grey: np.ndarray, cols: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The grey image at columns ``cols`` (n,) (linear interpolation) and rows ``rows`` (n, R)."""
    x = np.clip(cols, 0, grey.shape[1] - 1.001)
    x0 = np.floor(x).astype(int)
    w = (x - x0)[:, None]
    r = np.clip(np.rint(rows).astype(int), 0, grey.shape[0] - 1)
    return np.asarray(grey[r, x0[:, None]] * (1 - w) + grey[r, x0[:, None] + 1] * w)


def test_the_grey_levels_beside_the_edges_are_the_rendered_ones() -> None:
    scene = _box_before_wall()
    edges = SceneEdges.of(scene)
    vis = visible_edges(edges, HEAD, RIG, trim_px=2, min_length_px=12.0)
    assert len(vis) >= 3  # the box's two outlines and its front crease (the wall's are out)
    rows = sample_rows(vis.v_top, vis.v_bottom)
    got = edge_greys(edges, HEAD, RIG, vis.u, vis.Z, rows, near_px=1.5, side_px=3.0)
    renderer = StereoRenderer(RIG, scene)
    try:
        pair = renderer.render_stereo(HEAD)
    finally:
        renderer.close()
    diffs = []
    for k, image in enumerate(pair):
        grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY).astype(np.float64)
        u = vis.u - k * RIG.fb / vis.Z
        for j, offset in enumerate((-3.0, 3.0, -1.5, 1.5)):
            diffs.append(np.abs(_rendered_samples(grey, u + offset, rows) - got[k, j]))
    d = np.concatenate([x.ravel() for x in diffs])
    assert np.mean(d <= 2.0) > 0.95  # the rest: anti-aliased samples by another edge
    assert len(np.unique(got)) >= 4  # box faces, wall, floor: not one grey


def test_an_outline_changing_background_is_cut_where_its_polarity_flips() -> None:
    # one edge, rows 0-5 darker on the right (contrast -40), rows 6-11 brighter (+40)
    near_left = np.full((1, ROWS), 100.0)
    near_right = np.where(np.arange(ROWS) < 6, 60.0, 140.0)[None]
    greys = np.stack([near_left, near_right, near_left, near_right])
    pieces = edge_pieces(
        greys, np.array([100.0]), np.array([220.0]), min_contrast=10.0, min_length_px=12.0
    )
    assert pieces.polarity.tolist() == [-1, 1]
    np.testing.assert_allclose(pieces.v_top, [100.0, 160.0])
    np.testing.assert_allclose(pieces.v_bottom, [160.0, 220.0])
    np.testing.assert_allclose(pieces.greys[3], [60.0, 140.0])
    # too little contrast nowhere images it; the end loss shortens both ends
    flat = edge_pieces(
        np.full((4, 1, ROWS), 90.0),
        np.array([0.0]),
        np.array([50.0]),
        min_contrast=10.0,
        min_length_px=12.0,
    )
    assert len(flat) == 0
    lossy = edge_pieces(
        greys,
        np.array([100.0]),
        np.array([220.0]),
        min_contrast=10.0,
        min_length_px=12.0,
        end_loss_px=3.0,
    )
    np.testing.assert_allclose(lossy.v_top, [103.0, 163.0])
    np.testing.assert_allclose(lossy.v_bottom, [157.0, 217.0])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_photometry_equals_its_numpy_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    scene = generate_scene(seed, family="office")
    edges = SceneEdges.of(scene)
    x0, y0, x1, y1 = scene.bounds
    m = 200
    origin = np.c_[rng.uniform(x0 + 0.5, x1 - 0.5, m), rng.uniform(y0 + 0.5, y1 - 0.5, m)]
    heading = rng.uniform(-math.pi, math.pi, m)
    x = rng.uniform(-0.7, 0.7, m)
    forward = np.c_[np.cos(heading), np.sin(heading)]
    right = np.c_[np.sin(heading), -np.cos(heading)]
    direction = forward + x[:, None] * right
    y = rng.uniform(-0.5, 0.5, (m, ROWS))
    got = first_surface_greys(edges, origin, direction, y, 0.8)
    want = first_surface_greys_reference(edges, origin, direction, y, 0.8)
    assert np.mean(got == want) > 0.999  # (a tie of two surfaces may resolve either way)
    assert len(np.unique(want)) > 5  # floor, background, faces, tops
    greys = rng.choice([30.0, 70.0, 110.0, 150.0], size=(4, 40, ROWS))
    v_top = rng.uniform(0, 120, 40)
    v_bottom = v_top + rng.uniform(5, 120, 40)
    kw = {"min_contrast": 10.0, "min_length_px": 12.0, "end_loss_px": 2.0}
    a = edge_pieces(greys, v_top, v_bottom, **kw)
    b = edge_pieces_reference(greys, v_top, v_bottom, **kw)
    assert len(a) > 10
    np.testing.assert_array_equal(a.edge, b.edge)
    np.testing.assert_array_equal(a.polarity, b.polarity)
    np.testing.assert_allclose(a.v_top, b.v_top)
    np.testing.assert_allclose(a.v_bottom, b.v_bottom)
    np.testing.assert_allclose(a.greys, b.greys)
