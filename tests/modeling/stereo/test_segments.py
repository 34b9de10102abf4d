"""Segment extraction: exact columns of synthetic edges, the LS variance model, the side grey
levels, OpenCV's LSD output layouts, degenerate input."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

import modeling.stereo.segments as segments_module
from modeling.stereo.rig import StereoRig
from modeling.stereo.segments import ImageSegments, SegmentOptions, extract_segments


def _bars(columns: list[tuple[int, int]], shape: tuple[int, int] = (240, 320)) -> np.ndarray:
    img = np.full(shape, 80, dtype=np.uint8)
    for c0, c1 in columns:
        img[20:220, c0:c1] = 200
    return img


def test_vertical_bar_edges_at_pixel_boundaries() -> None:
    # a bright bar over columns 100..139: its edges lie between pixel centres 99|100 and 139|140
    segs = extract_segments(_bars([(100, 140)]))
    assert len(segs) == 2
    order = np.argsort(segs.endpoints[:, 0, 0])
    u = segs.endpoints[order][:, :, 0]
    np.testing.assert_allclose(u, [[99.5, 99.5], [139.5, 139.5]], atol=1e-6)
    np.testing.assert_allclose(segs.slope, 0.0, atol=1e-9)
    # brighter on the right of the left edge, darker on the right of the right edge
    assert segs.polarity[order].tolist() == [1, -1]
    # ordered top -> bottom, spanning (trimmed) rows of the bar
    assert np.all(segs.endpoints[:, 0, 1] < segs.endpoints[:, 1, 1])
    assert np.all(segs.endpoints[:, 0, 1] <= 25) and np.all(segs.endpoints[:, 1, 1] >= 214)


def test_slanted_edge_position_and_slope() -> None:
    # anti-aliased slanted edge u = 100 + 0.2 (v - 120), bright on the right
    H, W, ss = 240, 320, 16
    vv = np.arange(H)[:, None]
    us = (np.arange(W * ss) + 0.5) / ss - 0.5
    edge = 100.0 + 0.2 * (vv - 120.0)
    img = np.where(us[None, :] >= edge, 200.0, 60.0).reshape(H, W, ss).mean(axis=2)
    segs = extract_segments(np.rint(img).astype(np.uint8))
    assert len(segs) == 1
    np.testing.assert_allclose(segs.slope[0], 0.2, atol=2e-3)
    np.testing.assert_allclose(segs.u_at(np.array([0]), np.array([120.0])), [100.0], atol=0.05)
    assert segs.polarity[0] == 1


def test_variance_model_matches_least_squares_theory() -> None:
    rng = np.random.default_rng(3)
    img = _bars([(100, 140)])
    segs = extract_segments(img, rig=StereoRig(sigma_px=0.5), bias_sigma_px=0.0)
    i = int(np.argmin(segs.endpoints[:, 0, 0]))
    n, svv = segs.n_points[i], segs.s_vv[i]
    v = np.array([segs.v_center[i], segs.endpoints[i, 0, 1]])
    want = 0.25 * (1.0 / n + (v - segs.v_center[i]) ** 2 / svv)
    np.testing.assert_allclose(segs.u_var_at(np.array([i, i]), v), want)
    # with heavy noise the residual (not the nominal sigma) sets the per-point variance,
    # and the predicted scatter of the fitted centre column matches repeated draws
    centres = []
    for _ in range(40):
        noisy = np.clip(img + rng.normal(0.0, 25.0, img.shape), 0, 255).astype(np.uint8)
        s = extract_segments(
            noisy, rig=StereoRig(sigma_px=0.01), bias_sigma_px=0.0, min_gradient=20.0
        )
        j = np.flatnonzero(np.abs(s.endpoints[:, 0, 0] - 99.5) < 2)
        if j.size == 1 and s.n_points[j[0]] > 150:
            centres.append((s.u_at(j, np.array([120.0]))[0], s.u_var_at(j, np.array([120.0]))[0]))
    arr = np.array(centres)
    assert len(arr) >= 30
    empirical = arr[:, 0].var()
    predicted = arr[:, 1].mean()
    assert 0.5 < empirical / predicted < 2.0
    assert np.all(arr[:, 1] > 0.01**2 * 1.0 / 150)


def test_bias_variance_is_added() -> None:
    img = _bars([(100, 140)])
    a = extract_segments(img, bias_sigma_px=0.0)
    b = extract_segments(img, bias_sigma_px=0.3)
    idx = np.arange(len(a))
    v = a.v_center
    np.testing.assert_allclose(b.u_var_at(idx, v) - a.u_var_at(idx, v), 0.09)


def test_near_horizontal_segments_are_not_fitted_but_kept_aside() -> None:
    img = np.full((240, 320), 80, dtype=np.uint8)
    img[120:, 30:290] = 200  # a horizontal edge (row 119.5, columns 30 .. 289) ...
    cv2.line(img, (40, 20), (300, 60), 255, 3)  # ... and a line ~9 degrees to the rows
    segs = extract_segments(img)
    assert len(segs) == 0 or np.all(np.abs(segs.slope) < 0.2)  # only the box's short sides
    assert len(extract_segments(img, min_angle_deg=0.0)) > len(segs)
    hor = segs.horizontal
    assert hor.shape[1:] == (2, 2) and not hor.flags.writeable
    assert np.all(hor[:, 0, 0] <= hor[:, 1, 0])  # left end first
    # the step edge: a line along row 119.5 spanning most of the box's width
    on_edge = hor[np.all(np.abs(hor[:, :, 1] - 119.5) <= 1.5, axis=1)]
    assert on_edge.shape[0] >= 1
    assert (on_edge[:, 1, 0] - on_edge[:, 0, 0]).sum() >= 0.8 * 260
    # and the slanted line (two edges, 9 degrees)
    slope = (hor[:, 1, 1] - hor[:, 0, 1]) / (hor[:, 1, 0] - hor[:, 0, 0])
    assert np.any(np.abs(slope - 40 / 260) < 0.03)


def test_blank_and_noise_images_give_empty_or_valid_result() -> None:
    blank = np.zeros((240, 320), dtype=np.uint8)
    segs = extract_segments(blank)
    assert isinstance(segs, ImageSegments) and len(segs) == 0
    assert segs.endpoints.shape == (0, 2, 2) and segs.image_shape == (240, 320)
    rng = np.random.default_rng(0)
    noise = rng.integers(0, 256, (240, 320)).astype(np.uint8)
    segs = extract_segments(noise)
    # LSD finds short lines in noise; the fitted ones are few, long enough, steep and inside
    assert len(segs) < 100
    assert np.all(np.isfinite(segs.endpoints)) and np.all(segs.length >= 12.0)
    v, u = segs.endpoints[..., 1], segs.endpoints[..., 0]
    assert np.all((v >= 1) & (v <= 238)) and np.all((u > -4) & (u < 323))
    rise = segs.endpoints[:, 1, 1] - segs.endpoints[:, 0, 1]
    assert np.all(rise >= np.sin(np.radians(25.0)) * segs.length - 1e-9)
    assert np.all(segs.u_var_at(np.arange(len(segs)), segs.v_center) > 0)


@pytest.mark.parametrize(
    "bad",
    [
        np.zeros((240, 320), dtype=np.float32),
        np.zeros((240, 320, 3), dtype=np.uint8),
        np.zeros((4, 320), dtype=np.uint8),
        [[0, 1], [2, 3]],
    ],
)
def test_wrong_input_raises_naming_gray(bad: object) -> None:
    with pytest.raises(ValueError, match="gray"):
        extract_segments(bad)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("min_angle_deg", 95.0),
        ("bias_sigma_px", -0.1),
        ("min_length_px", float("nan")),
        ("lsd_scale", 2.0),
        ("search_px", 0),
        ("search_px", 5),
        ("side_px", 0),
        ("near_px", 0.2),
        ("trim_px", -1),
        ("min_gradient", -1.0),
    ],
)
def test_bad_options_raise_naming_them(option: str, value: float) -> None:
    with pytest.raises(ValueError, match=option):
        extract_segments(_bars([(100, 140)]), **{option: value})


def test_side_grey_levels_far_and_near() -> None:
    # bar 200 over columns 100..139 on 80: the left edge (u = 99.5) has 80 on its left, 200 on
    # its right, at 3 px ("far", whole pixels 97 and 103) and 1.5 px ("near", 98.0 and 101.0)
    segs = extract_segments(_bars([(100, 140)]))
    order = np.argsort(segs.endpoints[:, 0, 0])
    np.testing.assert_allclose(segs.grey_left[order], [80.0, 200.0])
    np.testing.assert_allclose(segs.grey_right[order], [200.0, 80.0])
    np.testing.assert_allclose(segs.grey_left_near[order], [80.0, 200.0])
    np.testing.assert_allclose(segs.grey_right_near[order], [200.0, 80.0])
    # a 2-px strip of 110 right of the right edge changes the near level only
    img = _bars([(100, 140)])
    img[20:220, 140:142] = 110
    s2 = extract_segments(img)
    right = int(np.argmin(np.abs(s2.endpoints[:, 0, 0] - 139.5)))
    assert s2.grey_right[right] == pytest.approx(80.0)
    assert abs(s2.endpoints[right, 0, 0] - 139.5) < 0.1
    assert s2.grey_right_near[right] == pytest.approx(110.0)


class _FakeLSD:
    """Stands in for cv2's LSD and returns given lines in a given layout."""

    def __init__(self, lines: np.ndarray | None) -> None:
        self.lines = lines

    def detect(self, image: np.ndarray) -> tuple[np.ndarray | None, None, None, None]:
        return self.lines, None, None, None


def test_lsd_output_layouts_give_the_same_segments(monkeypatch: pytest.MonkeyPatch) -> None:
    # OpenCV 4 returns (N, 1, 4), OpenCV 5 (N, 4); None when nothing is found
    img = _bars([(100, 140)])
    want = extract_segments(img)
    raw = segments_module._lsd(1.0).detect(cv2.pyrDown(img))[0].reshape(-1, 4)
    for layout in (raw.reshape(-1, 1, 4), raw.reshape(-1, 4), raw[:, None, None, :]):
        monkeypatch.setattr(segments_module, "_lsd", lambda scale, lay=layout: _FakeLSD(lay))
        got = extract_segments(img)
        np.testing.assert_array_equal(got.endpoints, want.endpoints)
    monkeypatch.setattr(segments_module, "_lsd", lambda scale: _FakeLSD(None))
    assert len(extract_segments(img)) == 0
    monkeypatch.setattr(segments_module, "_lsd", lambda scale: _FakeLSD(np.zeros((0, 1, 4))))
    assert len(extract_segments(img)) == 0


def test_single_edge_and_tiny_images() -> None:
    img = np.full((240, 320), 60, dtype=np.uint8)
    img[:, 160:] = 190
    segs = extract_segments(img)
    assert len(segs) == 1
    np.testing.assert_allclose(segs.endpoints[0, :, 0], 159.5, atol=1e-9)
    assert segs.polarity[0] == 1
    # the smallest legal image, and thin ones: empty or valid
    for shape in ((8, 8), (8, 300), (300, 8)):
        tiny = np.zeros(shape, dtype=np.uint8)
        tiny[:, shape[1] // 2 :] = 200
        s = extract_segments(tiny)
        assert s.image_shape == shape
        assert np.all(np.isfinite(s.endpoints)) and np.all(s.endpoints[:, :, 0] <= shape[1])


def test_constructor_defaults_and_read_only_arrays() -> None:
    one = np.ones(1)
    segs = ImageSegments(
        endpoints=np.array([[[10.0, 5.0], [10.0, 45.0]]]),
        u_center=10 * one,
        v_center=25 * one,
        slope=0 * one,
        point_var=0.25 * one,
        n_points=[40],
        s_vv=5000 * one,
        bias_var=0.01 * one,
        polarity=[1],
        contrast=30 * one,
        grey_left=50 * one,
        grey_right=150 * one,
        image_shape=(240, 320),
    )
    np.testing.assert_array_equal(segs.grey_left_near, [50.0])  # near defaults to far
    np.testing.assert_array_equal(segs.grey_right_near, [150.0])
    with pytest.raises(ValueError):
        segs.u_center[0] = 1.0
    with pytest.raises(ValueError, match="slope"):
        ImageSegments(**{**_fields(segs), "slope": np.zeros(2)})
    extracted = extract_segments(_bars([(100, 140)]))
    assert not extracted.endpoints.flags.writeable and not extracted.grey_left_near.flags.writeable


def test_strided_columns_are_stored_contiguous() -> None:
    """Columns given as strided views (rows of a column-major block, as the surrogate's greys
    are) are stored C-contiguous: the matcher's compiled loop sees one layout, so Numba
    compiles it once instead of again (10 ms) at the first view whose arrays are strided."""
    n = 3
    block = np.asfortranarray(np.arange(4.0 * n).reshape(4, n) + 1.0)  # rows are strided
    assert not block[0].flags.c_contiguous
    ones = np.ones(n)
    segs = ImageSegments(
        endpoints=np.tile([[10.0, 5.0], [10.0, 45.0]], (n, 1, 1)),
        u_center=10 * ones,
        v_center=25 * ones,
        slope=block[1],
        point_var=0.25 * ones,
        n_points=[40] * n,
        s_vv=5000 * ones,
        bias_var=0.01 * ones,
        polarity=[1] * n,
        contrast=30 * ones,
        grey_left=block[0],
        grey_right=block[1],
        grey_left_near=block[2],
        grey_right_near=block[3],
        image_shape=(240, 320),
    )
    for name in ("slope", "grey_left", "grey_right", "grey_left_near", "grey_right_near"):
        arr = getattr(segs, name)
        assert arr.flags.c_contiguous, name
        assert not arr.flags.writeable, name
    np.testing.assert_array_equal(segs.grey_right_near, block[3])


def _fields(segs: ImageSegments) -> dict[str, object]:
    names = ImageSegments.__dataclass_fields__
    return {name: getattr(segs, name) for name in names}


def _textured_pair(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Random bars of random slant and contrast, the right image a shifted, noisier copy."""
    rng = np.random.default_rng(seed)
    H, W = 240, 320
    vv, uu = np.mgrid[0:H, 0:W]
    left = np.full((H, W), 90.0)
    for _ in range(12):
        c, w, s = rng.uniform(10, 300), rng.uniform(4, 30), rng.uniform(-0.3, 0.3)
        v0, v1 = sorted(rng.uniform(0, H, 2))
        inside = (uu >= c + s * (vv - 120)) & (uu < c + w + s * (vv - 120)) & (vv >= v0) & (vv < v1)
        left[inside] = rng.uniform(20, 235)
    right = np.roll(left, -7, axis=1) + rng.normal(0, 3, (H, W))
    left = left + rng.normal(0, 2, (H, W))
    return (
        np.clip(np.rint(left), 0, 255).astype(np.uint8),
        np.clip(np.rint(right), 0, 255).astype(np.uint8),
    )


@pytest.mark.parametrize("seed", range(6))
def test_pair_extraction_is_identical_to_each_image_alone(seed: int) -> None:
    left, right = _textured_pair(seed)
    pair = segments_module.extract_segment_pair(left, right, min_length_px=10.0)
    alone = (
        extract_segments(left, min_length_px=10.0),
        extract_segments(right, min_length_px=10.0),
    )
    assert len(pair[0]) > 3 and len(pair[1]) > 3
    for got, want in zip(pair, alone, strict=True):
        assert _fields(got).keys() == _fields(want).keys()
        for name, value in _fields(want).items():
            np.testing.assert_array_equal(_fields(got)[name], value, err_msg=name)


def test_pair_extraction_with_one_blank_image() -> None:
    left, _ = _textured_pair(0)
    blank = np.full_like(left, 128)
    segs_l, segs_r = segments_module.extract_segment_pair(left, blank)
    assert len(segs_l) == len(extract_segments(left)) > 0
    assert len(segs_r) == 0 and segs_r.image_shape == left.shape


def test_pair_extraction_rejects_bad_input_naming_it() -> None:
    left, right = _textured_pair(1)
    with pytest.raises(ValueError, match="right"):
        segments_module.extract_segment_pair(left, right.astype(np.float32))
    with pytest.raises(ValueError, match="same shape"):
        segments_module.extract_segment_pair(left, right[:, :200])
    with pytest.raises(ValueError, match="min_length_pixels"):
        segments_module.extract_segment_pair(left, right, min_length_pixels=3.0)
    with pytest.raises(ValueError, match="search_px"):
        segments_module.extract_segment_pair(left, right, search_px=9)


def _extract_in_child(conn: object) -> None:
    left, right = _textured_pair(2)
    segs_l, segs_r = segments_module.extract_segment_pair(left, right)
    conn.send((len(segs_l), len(segs_r)))  # type: ignore[attr-defined]


def test_pair_extraction_works_in_a_forked_child() -> None:
    # the parent's worker thread does not exist in a fork: the child must make its own
    import multiprocessing as mp

    left, right = _textured_pair(2)
    want = tuple(len(s) for s in segments_module.extract_segment_pair(left, right))
    ctx = mp.get_context("fork")
    parent, child = ctx.Pipe()
    proc = ctx.Process(target=_extract_in_child, args=(child,))
    proc.start()
    assert parent.poll(30), "the forked child hung"
    assert parent.recv() == want
    proc.join(10)


def test_options_as_a_dataclass_or_flat_keywords() -> None:
    img = _bars([(100, 140), (200, 215)])
    want = extract_segments(img, min_length_px=10.0)
    for got in (
        extract_segments(img, SegmentOptions(min_length_px=10.0)),
        extract_segments(img, options=SegmentOptions(min_length_px=30.0), min_length_px=10.0),
    ):
        for name in ("endpoints", "u_center", "point_var", "grey_left_near"):
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
    # an override takes effect: segments longer than the image are none
    assert len(extract_segments(img, min_length_px=1000.0)) == 0 < len(want)
    with pytest.raises(ValueError, match="SegmentOptions"):
        extract_segments(img, options={"sigma_px": 0.5})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="near_px"):
        SegmentOptions(near_px=5.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        SegmentOptions().bias_sigma_px = 1.0  # type: ignore[misc]
