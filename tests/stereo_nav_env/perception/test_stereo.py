"""Pixel noise, content equality of models, and the perception stage on a rendered pair."""

from __future__ import annotations

import math
import pickle

import cv2
import numpy as np
import pytest
import shapely
from scipy.stats import norm

from modeling.model.build import build_model
from modeling.model.records import EnvironmentModel
from modeling.observation import FloorObservation, FloorSegment
from modeling.stereo.rig import HeadPose, StereoRig
from stereo_nav_env.perception.base import ComparableModel, Stopwatch, structurally_equal
from stereo_nav_env.perception.noise import (
    add_pixel_noise,
    draw_noise_levels,
    draw_pixel_noise,
    noise_of_levels,
    noise_of_levels_reference,
    noisy_grey,
    noisy_grey_reference,
)
from stereo_nav_env.perception.stereo import perceive
from stereo_nav_env.rendering.renderer import StereoRenderer


def test_pixel_noise_is_gaussian_with_the_configured_sigma_and_seeded() -> None:
    sigma = 2.5
    noise = draw_pixel_noise(np.random.default_rng(0), 240, 320, sigma)
    assert noise is not None
    assert noise.shape == (2, 240, 320) and noise.dtype == np.int16
    # whole grey levels: the variance of a rounded normal is sigma^2 + 1/12
    assert abs(noise.mean()) < 0.02
    assert noise.std() == pytest.approx(math.sqrt(sigma**2 + 1 / 12), rel=0.01)
    # |noise| >= 5 where |sigma z| >= 4.5, |noise| >= 8 where |sigma z| >= 7.5 (3 sigma)
    assert np.mean(np.abs(noise) >= 5) == pytest.approx(2 * norm.sf(4.5 / sigma), abs=0.002)
    assert np.mean(np.abs(noise) >= 8) == pytest.approx(2 * norm.sf(7.5 / sigma), abs=0.0006)
    assert abs(np.corrcoef(noise[0].ravel(), noise[1].ravel())[0, 1]) < 0.01
    again = draw_pixel_noise(np.random.default_rng(0), 240, 320, sigma)
    assert again is not None and np.array_equal(noise, again)
    assert draw_pixel_noise(np.random.default_rng(0), 240, 320, 0.0) is None


def test_adding_noise_saturates_and_keeps_the_grey_level_noise() -> None:
    image = np.array([[[0, 100, 255], [10, 10, 10]]], dtype=np.uint8)
    noise = np.array([[-2, 2]], dtype=np.int16)
    out = add_pixel_noise(image, noise)
    assert out.tolist() == [[[0, 98, 253], [12, 12, 12]]]
    assert add_pixel_noise(image, None) is image
    # the grey image of the noisy RGB image is the noisy grey image (no channel saturating)
    rng = np.random.default_rng(1)
    rgb = rng.integers(20, 236, (60, 80, 3), dtype=np.uint8)
    drawn = draw_pixel_noise(rng, 60, 80, 3.0)
    assert drawn is not None
    noise = drawn[0]
    grey_of_noisy = cv2.cvtColor(add_pixel_noise(rgb, noise), cv2.COLOR_RGB2GRAY)
    grey: np.ndarray = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
    noisy_grey = add_pixel_noise(grey, noise)
    assert np.array_equal(grey_of_noisy, noisy_grey)


@pytest.mark.parametrize(
    ("height", "width", "pending_half"),
    [(240, 320, False), (240, 320, True), (7, 9, False), (5, 6, False)],
)
def test_noise_levels_are_the_generators_own_uint16_draws(
    height: int, width: int, pending_half: bool
) -> None:
    # whatever the generator's state (a 32-bit half pending, any count), the draws and the state
    # the generator is left in are those of rng.integers itself
    fast, slow = np.random.default_rng(7), np.random.default_rng(7)
    if pending_half:
        for rng in (fast, slow):
            rng.integers(0, 10, dtype=np.uint32)  # leaves one 32-bit half buffered
        assert fast.bit_generator.state["has_uint32"] == 1
    levels = draw_noise_levels(fast, height, width)
    want = slow.integers(0, 1 << 16, (2, height, width), dtype=np.uint16)
    assert levels.dtype == np.uint16 and np.array_equal(levels, want)
    for _ in range(2):  # and the generators go on alike
        assert np.array_equal(draw_noise_levels(fast, 4, 6), draw_noise_levels(slow, 4, 6))
        assert fast.random() == slow.random()
        assert fast.integers(0, 1000, 3).tolist() == slow.integers(0, 1000, 3).tolist()


def test_noisy_grey_is_the_grey_image_plus_the_noise_saturated() -> None:
    rng = np.random.default_rng(3)
    rgb = rng.integers(0, 256, (60, 80, 3), dtype=np.uint8)
    rgb[:10] = 0  # saturates below
    rgb[10:20] = 255  # and above
    levels = draw_noise_levels(rng, 60, 80)[0]
    for sigma in (0.5, 2.0, 40.0):
        want = add_pixel_noise(
            np.asarray(cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY), np.uint8),
            noise_of_levels(levels, sigma),
        )
        got = noisy_grey(rgb, levels, sigma)
        assert got.dtype == np.uint8 and np.array_equal(got, want)
    # draw_pixel_noise is the noise of the levels drawn the same way
    noise = draw_pixel_noise(np.random.default_rng(5), 60, 80, 2.0)
    assert noise is not None
    assert np.array_equal(
        noise, noise_of_levels(draw_noise_levels(np.random.default_rng(5), 60, 80), 2.0)
    )
    with pytest.raises(ValueError, match="rgb"):
        noisy_grey(rgb[..., 0], levels, 2.0)
    with pytest.raises(ValueError, match="levels"):
        noisy_grey(rgb, levels[:-1], 2.0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_noise_kernels_equal_their_numpy_references(seed: int) -> None:
    rng = np.random.default_rng(seed)
    height, width = int(rng.integers(1, 40)), int(rng.integers(1, 40))
    rgb = rng.integers(0, 256, (height, width, 3), dtype=np.uint8)
    levels = draw_noise_levels(rng, height, width)
    sigma = float(rng.uniform(0.1, 60.0))
    want = noise_of_levels_reference(levels, sigma)
    assert want.dtype == np.int16 and np.array_equal(noise_of_levels(levels, sigma), want)
    for lv in levels:
        got, ref = noisy_grey(rgb, lv, sigma), noisy_grey_reference(rgb, lv, sigma)
        assert got.dtype == ref.dtype == np.uint8 and np.array_equal(got, ref)


def _model(shift: float = 0.0) -> EnvironmentModel:
    cov = np.tile(np.eye(2) * 1e-3, (2, 1, 1))
    segs = (
        FloorSegment(endpoints=np.array([[2.0, 0.3 + shift], [2.0, 1.3]]), cov=cov),
        FloorSegment(endpoints=np.array([[2.0, -0.25], [2.0, -1.25]]), cov=cov),
    )
    return build_model(FloorObservation(segments=segs, viewpoint=np.zeros(3)), 0.5)


def test_comparable_models_compare_by_content() -> None:
    a, b, c = ComparableModel.of(_model()), ComparableModel.of(_model()), _model(0.01)
    assert isinstance(a, EnvironmentModel)
    assert a == b and a is not b and a != c
    assert a == pickle.loads(pickle.dumps(a))


def test_structural_equality_rules() -> None:
    assert structurally_equal({"a": [1.0, float("nan")]}, {"a": [1.0, float("nan")]})
    assert not structurally_equal((1, 2), [1, 2])
    assert structurally_equal(np.array([np.nan, 1.0]), np.array([np.nan, 1.0]))
    assert not structurally_equal(np.zeros(2), np.zeros(2, np.float32))
    assert structurally_equal(shapely.box(0, 0, 1, 1), shapely.box(0, 0, 1, 1))
    assert not structurally_equal(shapely.box(0, 0, 1, 1), shapely.box(0, 0, 1, 2))


def test_perceive_models_a_rendered_pair_and_times_its_stages(
    rig: StereoRig, default_renderer: StereoRenderer
) -> None:
    head = HeadPose(x_m=1.0, y_m=3.06, heading_rad=0.0, height_m=0.8)
    left, right = default_renderer.render_stereo(head)
    watch = Stopwatch()
    model = perceive(
        left,
        right,
        rig,
        head,
        robot_width_m=0.5,
        robot_height_m=1.0,
        eps=0.05,
        max_situations=16,
        stopwatch=watch,
    )
    assert isinstance(model, ComparableModel) and 1 <= len(model.situations) <= 16
    assert model.observation.segments and model.observation.ambiguous  # the bookshelf's edges
    assert set(watch.laps) == {"segments", "matching", "triangulation", "modeling"}
    assert all(v >= 0 for v in watch.laps.values())
    assert model.observation.viewpoint.tolist() == [1.0, 3.06, 0.0]
