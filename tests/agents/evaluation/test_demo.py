"""The demo's pictures (``make demo``): views with several situations are the ones drawn, side by
side with their probabilities, and the GIF is at the env's full frame size.

The figure tests use synthetic models (:func:`modeling.build_model` on hand-made observations: two
boxes 0.5 m apart, the robot's width, and an ambiguous post that is either in the gap or 2.5 m
behind it, the situation of the paper's Figs. 10 and 11); the GIF test runs a 2-step episode.
"""

from __future__ import annotations

import math
import pathlib
import warnings

import numpy as np
import pytest
from matplotlib.text import Text

from agents.evaluation.demo import View, model_figure, pick_views, run_demo
from modeling.model.build import build_model
from modeling.model.records import EnvironmentModel
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment
from modeling.plotting import region_label

WIDTH_M = 0.5
VIEWPOINT = np.array([1.25, -3.0, math.pi / 2])


def _seg(a: tuple[float, float], b: tuple[float, float], sigma: float = 0.01) -> FloorSegment:
    return FloorSegment(
        endpoints=np.array([a, b], dtype=float), cov=np.stack([np.eye(2) * sigma**2] * 2)
    )


def _box(x0: float, y0: float, x1: float, y1: float) -> list[FloorSegment]:
    c = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    return [_seg(c[k], c[(k + 1) % 4]) for k in range(4)]


def _outline(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    return np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)], dtype=float)


FOOTPRINTS = [_outline(0, 0, 1, 1), _outline(1.5, 0, 2.5, 1)]


def _model(p_in_gap: float | None, gap_m: float = 0.5) -> EnvironmentModel:
    """Two boxes ``gap_m`` apart; with ``p_in_gap``, an ambiguous post in the gap (that
    probability) or 2.5 m behind it (the rest): two situations."""
    segments = _box(0, 0, 1, 1) + _box(1 + gap_m, 0, 2 + gap_m, 1)
    ambiguous = ()
    if p_in_gap is not None:
        mid = 1 + gap_m / 2
        ambiguous = (
            AmbiguousSegment(
                candidates=(_seg((mid - 0.1, 0.5), (mid + 0.1, 0.5)), _seg((mid, 3.0), (mid, 3.2))),
                probabilities=(p_in_gap, 1 - p_in_gap),
            ),
        )
    obs = FloorObservation(segments=tuple(segments), ambiguous=ambiguous, viewpoint=VIEWPOINT)
    return build_model(obs, WIDTH_M)


def _views(models: list[EnvironmentModel]) -> list[View]:
    pose = (float(VIEWPOINT[0]), float(VIEWPOINT[1]) - 0.2, float(VIEWPOINT[2]), 0.0)
    return [View(step=k, model=m, pose=pose) for k, m in enumerate(models)]


@pytest.fixture(scope="module")
def plain() -> EnvironmentModel:
    """One situation, one critical region (the 0.5 m gap)."""
    model = _model(None)
    assert len(model.situations) == 1 and len(model.situations[0].critical_regions) == 1
    return model


@pytest.fixture(scope="module")
def far_apart() -> EnvironmentModel:
    """One situation and no critical region (a 2 m gap)."""
    model = _model(None, gap_m=2.0)
    assert len(model.situations) == 1 and not model.situations[0].critical_regions
    return model


@pytest.fixture(scope="module")
def ambiguous() -> EnvironmentModel:
    """Two situations, p = 0.6 (the post closes the gap) and 0.4 (the gap stays undecided)."""
    model = _model(0.6)
    assert [round(s.probability, 6) for s in model.situations] == [0.6, 0.4]
    return model


def test_pick_views_takes_the_views_with_several_situations(
    plain: EnvironmentModel, far_apart: EnvironmentModel, ambiguous: EnvironmentModel
) -> None:
    other = _model(0.8)  # two situations too, but the alternative has p = 0.2 only
    models = [plain, far_apart, ambiguous, plain, plain, far_apart, other, plain]
    several = {k for k, m in enumerate(models) if len(m.situations) > 1}
    assert several == {2, 6}
    assert pick_views(models, 2, min_separation=0) == [2, 6]
    assert pick_views(models, 1) == [2]  # the more balanced ambiguity (0.4 > 0.2)
    # None has several: the views with critical regions, then any.
    no_ambiguity = [far_apart, plain, far_apart, far_apart, plain]
    assert set(pick_views(no_ambiguity, 2, min_separation=0)) == {1, 4}
    assert pick_views([far_apart, far_apart], 1) == [0]
    # Far apart where they can be: not the same moment twice.
    models = [ambiguous, ambiguous, ambiguous, other, plain, plain, plain, plain, ambiguous]
    assert pick_views(models, 2, min_separation=5) == [0, 8]
    with pytest.raises(ValueError, match="count"):
        pick_views(models, 0)


def test_model_figure_shows_two_situations_of_an_ambiguous_view_with_their_probabilities(
    plain: EnvironmentModel, far_apart: EnvironmentModel, ambiguous: EnvironmentModel
) -> None:
    views = _views([plain, far_apart, plain, ambiguous, plain, far_apart])
    fig = model_figure(views, FOOTPRINTS, robot_radius_m=0.25)
    # The rows are the views with several situations: step 3 only.
    rows = [sub.get_suptitle() for sub in fig.subfigs[1:-1]]
    assert len(rows) == 1 and rows[0].startswith("step 3: 2 possible situations")
    axes = [a for a in fig.axes if a.get_visible()]
    titles = [a.get_title() for a in axes]
    assert titles == ["situation 1 of 2: p = 0.60\na1 true", "situation 2 of 2: p = 0.40\na2 true"]
    # Each panel draws its own situation: the post closes the gap in the first (no critical
    # region), not in the second, whose region is labelled with its width and p_passable.
    texts = [{t.get_text() for t in a.texts} for a in axes]
    (region,) = ambiguous.situations[1].critical_regions
    assert ambiguous.situations[0].critical_regions == ()
    assert region_label(region) in texts[1] and not any(t.startswith("w = ") for t in texts[0])
    assert region_label(region).startswith("w = 0.50 ± 0.01 m\nP(pass) = 0.5")
    assert {"a1", "a2"} <= texts[0] and {"a1", "a2"} <= texts[1]
    # Both panels on the same limits, over the true outlines.
    assert axes[0].get_xlim() == axes[1].get_xlim() and axes[0].get_ylim() == axes[1].get_ylim()
    # One legend for the figure, naming what is drawn.
    (legend,) = fig.subfigs[-1].legends
    names = {t.get_text() for t in legend.get_texts()}
    assert {"obstacle (hull, segments)", "critical region (w, P(pass))", "true outline",
            "occluded area", "robot (true size) and heading", "head (gaze)",
            "ambiguous segment: possible position (a1, a2, ...)"} <= names  # fmt: skip
    # No label overlaps another.
    fig.canvas.draw()
    for a in axes:
        boxes = [Text.get_window_extent(t) for t in a.texts]
        assert not any(b.overlaps(c) for i, b in enumerate(boxes) for c in boxes[i + 1 :])


def test_model_figure_falls_back_to_views_with_critical_regions(
    plain: EnvironmentModel, far_apart: EnvironmentModel
) -> None:
    fig = model_figure(_views([far_apart, plain, far_apart, far_apart]), FOOTPRINTS,
                       robot_radius_m=0.25)  # fmt: skip
    titles = [a.get_title() for a in fig.axes if a.get_visible()]
    assert titles == ["step 1: situation 1 of 1: p = 1.00"]


def test_demo_gif_is_at_full_frame_size_and_uses_v1(
    tmp_path: pathlib.Path, small_map: pathlib.Path
) -> None:
    import gymnasium as gym
    from PIL import Image

    import stereo_nav_env  # noqa: F401  (registers the ids)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run_demo(tmp_path, scenario=str(small_map), max_steps=2, frame_every=1, log=None)
    assert not [w for w in caught if "out of date" in str(w.message)]
    assert result.figures["env_id"] == "StereoNav-v1" and result.figures["frames"] == 3
    env = gym.make("StereoNav-v1", scenario=str(small_map), render_mode="rgb_array")
    try:
        env.reset(seed=0)
        first = env.render()
    finally:
        env.close()
    assert first is not None and first.shape == (480, 960, 3)
    with Image.open(result.gif) as gif:
        assert gif.n_frames == 3 and gif.size == (960, 480)
        gif.seek(0)
        frame = np.asarray(gif.convert("RGB"), dtype=np.int16)
    assert frame.shape == first.shape
    # The same picture, pixel for pixel up to the palette (the status text stays sharp).
    assert np.abs(frame - first).mean() < 2.0
