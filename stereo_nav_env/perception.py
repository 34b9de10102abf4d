"""From a rendered stereo pair to an environment model: pixel noise, the modeling pipeline, timing.

The pipeline is the one of ``modeling`` (Miura, ICRA-94): :func:`modeling.pipeline.stereo_to_floor`
(segments in both images, matching, floor segments with uncertainty, plain faces), each stage
timed through its ``on_stage`` callback, then :func:`modeling.model.build_model` (obstacles,
critical regions, occlusion, situations).

The model returned is a :class:`ComparableModel`: an :class:`~modeling.model.EnvironmentModel`
whose ``==`` compares content (arrays, geometries, nested dataclasses) instead of identity, so that
two rollouts with one seed give equal ``info`` dictionaries (Gymnasium's determinism check
compares them with ``==``).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from dataclasses import dataclass
from typing import Any, cast

import cv2
import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.special import ndtri

from modeling.jit import compiled_on_first_call
from modeling.model import EnvironmentModel, build_model
from modeling.pipeline import stereo_to_floor
from modeling.rig import HeadPose, StereoRig

__all__ = [
    "ComparableModel",
    "Stopwatch",
    "add_pixel_noise",
    "draw_noise_levels",
    "draw_pixel_noise",
    "noise_of_levels",
    "noise_of_levels_reference",
    "noisy_grey",
    "noisy_grey_reference",
    "perceive",
    "structurally_equal",
]

UInt8Image = NDArray[np.uint8]
_NOISE_LEVELS = 1 << 16


def structurally_equal(a: Any, b: Any) -> bool:
    """Whether ``a`` and ``b`` hold the same content (deep; NaN equals NaN).

    Compares dataclass fields, numpy arrays (shape, dtype, values), shapely geometries (their WKB),
    dicts, lists and tuples recursively, floats with NaN equal to NaN, anything else with ``==``.
    """
    if a is b:
        return True
    if type(a) is not type(b):
        return False
    if dataclasses.is_dataclass(a):
        return all(
            structurally_equal(getattr(a, f.name), getattr(b, f.name))
            for f in dataclasses.fields(a)
        )
    if isinstance(a, np.ndarray):
        if a.shape != b.shape or a.dtype != b.dtype:
            return False
        if a.dtype == object:
            return all(structurally_equal(x, y) for x, y in zip(a.flat, b.flat, strict=True))
        return bool(np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"))
    if isinstance(a, shapely.Geometry):
        return bool(shapely.to_wkb(a) == shapely.to_wkb(b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(structurally_equal(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple):
        return len(a) == len(b) and all(structurally_equal(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return bool(a == b)


@dataclass(frozen=True, slots=True, kw_only=True, eq=False)
class ComparableModel(EnvironmentModel):
    """An :class:`~modeling.model.EnvironmentModel` compared by content (see the module doc)."""

    @classmethod
    def of(cls, model: EnvironmentModel) -> ComparableModel:
        """The same model (fields shared, not copied) with content equality."""
        return cls(**{f.name: getattr(model, f.name) for f in dataclasses.fields(model)})

    def __eq__(self, other: object) -> bool:
        return isinstance(other, EnvironmentModel) and structurally_equal(
            {f.name: getattr(self, f.name) for f in dataclasses.fields(self)},
            {f.name: getattr(other, f.name) for f in dataclasses.fields(other)},
        )

    __hash__ = None  # type: ignore[assignment]


class Stopwatch:
    """Wall-clock laps in milliseconds: ``lap(name)`` adds the time since the previous lap."""

    def __init__(self) -> None:
        self.laps: dict[str, float] = {}
        self._t = time.perf_counter()

    def lap(self, name: str) -> None:
        """Add the time since the last lap (or creation) to ``laps[name]``, milliseconds."""
        now = time.perf_counter()
        self.laps[name] = self.laps.get(name, 0.0) + (now - self._t) * 1e3
        self._t = now


@functools.lru_cache(maxsize=8)
def _noise_table(sigma: float) -> NDArray[np.int16]:
    """(65536,) int16: ``sigma`` times the standard normal quantiles at ``(k + 0.5) / 65536``,
    rounded to whole grey levels."""
    quantiles = sigma * ndtri((np.arange(_NOISE_LEVELS) + 0.5) / _NOISE_LEVELS)
    table = np.rint(quantiles).astype(np.int16)
    table.setflags(write=False)
    return table


def draw_noise_levels(
    rng: np.random.Generator, height_px: int, width_px: int
) -> NDArray[np.uint16]:
    """Uniform 16-bit draws for both images of a pair, uint16 (2, H, W), from ``rng``."""
    return rng.integers(0, _NOISE_LEVELS, (2, height_px, width_px), dtype=np.uint16)


def draw_pixel_noise(
    rng: np.random.Generator, height_px: int, width_px: int, sigma: float
) -> NDArray[np.int16] | None:
    """Gaussian grey-level noise for both images of a pair, or ``None`` if ``sigma`` is 0.

    Each value is the standard normal quantile of a uniform 16-bit draw (inverse-CDF sampling
    from a 65536-entry table, :func:`noise_of_levels` of :func:`draw_noise_levels`), times
    ``sigma``, rounded to a whole grey level: an exact sample of the normal distribution
    discretised to 65536 equiprobable levels (its tails cut at 4.3 sigma, which the clipping of
    the grey levels to [0, 255] makes immaterial), then rounded. Adding it to a uint8 image is the
    same as adding the unrounded value and rounding the sum (the image is whole grey levels
    already); its standard deviation is ``sqrt(sigma^2 + 1/12)``. Five times faster than
    ``rng.standard_normal``.

    Args:
        rng: The env's generator (``np_random``); the only source of randomness.
        height_px: Image height, pixels.
        width_px: Image width, pixels.
        sigma: Standard deviation, grey levels (>= 0).

    Returns:
        int16 (2, H, W): the noise of the left (0) and right (1) image, one value per pixel.
    """
    if sigma <= 0:
        return None
    return noise_of_levels(draw_noise_levels(rng, height_px, width_px), sigma)


def noise_of_levels(levels: NDArray[np.uint16], sigma: float) -> NDArray[np.int16]:
    """The grey-level noise (int16, the shape of ``levels``) of uniform 16-bit draws ``levels``:
    ``table[levels]`` with the quantile table of ``sigma`` (:func:`noise_of_levels_reference`),
    by a compiled gather (NumPy's fancy indexing first widens the indices to intp; the gather
    saves about 1 ms a step)."""
    flat = np.ascontiguousarray(levels).ravel()
    return _gather(_noise_table(float(sigma)), flat).reshape(levels.shape)


def noise_of_levels_reference(levels: NDArray[np.uint16], sigma: float) -> NDArray[np.int16]:
    """:func:`noise_of_levels` in NumPy: the inverse-CDF table of ``sigma`` indexed by the
    draws."""
    return _noise_table(float(sigma))[levels]


@compiled_on_first_call
def _gather(table: NDArray[np.int16], flat_levels: NDArray[np.uint16]) -> NDArray[np.int16]:
    """``table[flat_levels]`` (n,), one pass."""
    out = np.empty(flat_levels.shape[0], np.int16)
    for i in range(flat_levels.shape[0]):
        out[i] = table[flat_levels[i]]
    return out


def noisy_grey(rgb: UInt8Image, levels: NDArray[np.uint16], sigma: float) -> UInt8Image:
    """The grey image of ``rgb`` (H, W, 3) uint8 plus the noise of ``levels`` (H, W), saturated to
    [0, 255] (:func:`noisy_grey_reference`), with the table lookup and the saturated addition in
    one compiled pass (about 0.5 ms a step faster than the reference).
    """
    _check_noise_inputs(rgb, levels)
    grey = cast(UInt8Image, cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY))
    return _add_table_noise(grey, np.ascontiguousarray(levels), _noise_table(float(sigma)))


def noisy_grey_reference(rgb: UInt8Image, levels: NDArray[np.uint16], sigma: float) -> UInt8Image:
    """:func:`noisy_grey` in NumPy and OpenCV: ``add_pixel_noise(cv2.cvtColor(rgb,
    cv2.COLOR_RGB2GRAY), noise_of_levels_reference(levels, sigma))``."""
    _check_noise_inputs(rgb, levels)
    grey = cast(UInt8Image, cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY))
    return add_pixel_noise(grey, noise_of_levels_reference(levels, sigma))


def _check_noise_inputs(rgb: UInt8Image, levels: NDArray[np.uint16]) -> None:
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
        raise ValueError(f"rgb must be a uint8 (H, W, 3) image, got {rgb.dtype} {rgb.shape}")
    if levels.shape != rgb.shape[:2] or levels.dtype != np.uint16:
        raise ValueError(
            f"levels must be uint16 {rgb.shape[:2]} (the image's size), "
            f"got {levels.dtype} {levels.shape}"
        )


@compiled_on_first_call
def _add_table_noise(
    grey: UInt8Image, levels: NDArray[np.uint16], table: NDArray[np.int16]
) -> UInt8Image:
    """``grey + table[levels]`` saturated to [0, 255], in place in ``grey`` (returned)."""
    flat_grey = grey.ravel()
    flat_levels = levels.ravel()
    noise = np.empty(flat_levels.shape[0], np.int16)
    for i in range(noise.shape[0]):  # the gather apart: the addition below then vectorises
        noise[i] = table[flat_levels[i]]
    for i in range(flat_grey.shape[0]):
        value = np.int32(flat_grey[i]) + np.int32(noise[i])
        flat_grey[i] = 0 if value < 0 else (255 if value > 255 else value)
    return grey


def add_pixel_noise(image: UInt8Image, noise: NDArray[np.int16] | None) -> UInt8Image:
    """``image`` uint8 (H, W) grey or (H, W, 3) RGB plus ``noise`` (H, W) int16 grey levels.

    An RGB image gets the same value on its three channels, so its grey image
    (``cv2.COLOR_RGB2GRAY``, fixed-point weights summing exactly to 1) is the noisy grey image,
    wherever no channel saturates. Saturated to [0, 255]. Returns ``image`` itself when ``noise``
    is ``None``.
    """
    if noise is None:
        return image
    if image.ndim == 3:
        noise = cast(NDArray[np.int16], cv2.merge([noise, noise, noise]))
    return cast(UInt8Image, cv2.add(image, noise, dtype=cv2.CV_8U))


def perceive(
    left: UInt8Image,
    right: UInt8Image,
    rig: StereoRig,
    head_pose: HeadPose,
    *,
    robot_width_m: float,
    robot_height_m: float,
    eps: float,
    max_situations: int,
    close_faces: bool = True,
    ground_lines: bool = False,
    stopwatch: Stopwatch | None = None,
) -> ComparableModel:
    """The environment model of one rectified pair (the whole modeling pipeline).

    Args:
        left: Left image, uint8 (H, W) grey or (H, W, 3) RGB of the rig's size.
        right: Right image, the same.
        rig: The stereo rig that took the pair.
        head_pose: Pose of the left optical centre, world frame.
        robot_width_m: Robot diameter, metres (gap classification).
        robot_height_m: Floor segments are kept between 0.05 m and this height, metres.
        eps: Classification tolerance in (0, 0.5).
        max_situations: Most situations enumerated.
        close_faces: Close the "gaps" that are plain faces (:func:`modeling.faces.close_faces`).
        ground_lines: Add the floor segments of the lowest near-horizontal lines
            (:func:`modeling.ground_lines.add_ground_lines`).
        stopwatch: If given, its laps ``segments``, ``matching``, ``triangulation`` and
            ``modeling`` are added to (its clock must have been lapped just before the call).

    Returns:
        The :class:`ComparableModel`.
    """
    watch = stopwatch if stopwatch is not None else Stopwatch()
    floor = stereo_to_floor(
        left,
        right,
        rig,
        head_pose,
        close_faces=close_faces,
        ground_lines=ground_lines,
        on_stage=watch.lap,
        max_height_m=robot_height_m,
    )
    model = build_model(floor, robot_width_m, eps=eps, max_situations=max_situations)
    out = ComparableModel.of(model)
    watch.lap("modeling")
    return out
