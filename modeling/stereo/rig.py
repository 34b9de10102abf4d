"""The calibrated, rectified stereo rig and the pose of its head.

Frames (see ARCHITECTURE.md):

* World: metres, floor plane x-y, z up, heading in radians counter-clockwise from +x.
* Camera: OpenCV convention, x right, y down, z forward, origin at the LEFT optical centre.
* Image: pixels, u right, v down, (0, 0) is the centre of the top-left pixel.

The head is level (optical axes parallel to the floor) and the pair is rectified: the right camera
sits ``baseline_m`` to the right of the left one, with the same orientation and intrinsics, so a
world point appears on the same row in both images and its disparity is
``focal_px * baseline_m / Z``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from modeling.types import FloatArray

__all__ = ["HeadPose", "StereoRig"]


def _as_points(P: ArrayLike, name: str, dim: int = 3) -> FloatArray:
    arr = np.asarray(P, dtype=np.float64)
    if arr.ndim == 1 and arr.shape[0] == dim:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != dim:
        raise ValueError(f"{name} must have shape (n, {dim}), got {np.shape(P)}")
    return arr


@dataclass(frozen=True, slots=True, kw_only=True)
class StereoRig:
    """A rectified horizontal stereo pair; the left camera is the reference.

    Attributes:
        focal_px: Focal length in pixels (same for u and v, both cameras).
        baseline_m: Distance between the optical centres, metres (right camera at +x_cam).
        width_px: Image width in pixels.
        height_px: Image height in pixels.
        cx_px: Principal point u, pixels (pixel-centre convention); ``None`` (the default) means
            the image centre, resolved at construction (read it as a float through
            :attr:`principal_point_px`).
        cy_px: Principal point v, pixels; ``None`` means the image centre, as ``cx_px``.
        sigma_px: Nominal standard deviation of one edge point's horizontal position, pixels
            (quantisation plus noise): the floor of the per-point variance of the segment fit
            (:mod:`modeling.stereo.segments`, which takes it from the rig, its one source), so it
            drives the endpoint covariances of clean edges, whose fit residual is smaller.
        min_depth_m: Nearest depth the matcher accepts (largest disparity), metres.
        max_depth_m: Farthest depth the matcher accepts (smallest disparity), metres.
    """

    focal_px: float = 260.0
    baseline_m: float = 0.12
    width_px: int = 320
    height_px: int = 240
    cx_px: float | None = None
    cy_px: float | None = None
    sigma_px: float = 0.5
    min_depth_m: float = 0.3
    max_depth_m: float = 8.0

    def __post_init__(self) -> None:
        if not (isinstance(self.width_px, int | np.integer) and self.width_px >= 8):
            raise ValueError(f"width_px must be an integer >= 8, got {self.width_px!r}")
        if not (isinstance(self.height_px, int | np.integer) and self.height_px >= 8):
            raise ValueError(f"height_px must be an integer >= 8, got {self.height_px!r}")
        for name in ("focal_px", "baseline_m", "sigma_px", "min_depth_m", "max_depth_m"):
            value = getattr(self, name)
            if not (
                isinstance(value, int | float | np.floating) and math.isfinite(value) and value > 0
            ):
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")
        if self.max_depth_m <= self.min_depth_m:
            raise ValueError(
                f"max_depth_m ({self.max_depth_m}) must exceed min_depth_m ({self.min_depth_m})"
            )
        cx = (self.width_px - 1) / 2.0 if self.cx_px is None else self.cx_px
        cy = (self.height_px - 1) / 2.0 if self.cy_px is None else self.cy_px
        if not (math.isfinite(cx) and -0.5 <= cx <= self.width_px - 0.5):
            raise ValueError(
                f"cx_px must lie inside the image [-0.5, {self.width_px - 0.5}], got {cx!r}"
            )
        if not (math.isfinite(cy) and -0.5 <= cy <= self.height_px - 0.5):
            raise ValueError(
                f"cy_px must lie inside the image [-0.5, {self.height_px - 0.5}], got {cy!r}"
            )
        object.__setattr__(self, "cx_px", cx)
        object.__setattr__(self, "cy_px", cy)

    # ------------------------------------------------------------------ derived values
    @property
    def principal_point_px(self) -> tuple[float, float]:
        """``(cx_px, cy_px)``, pixels: never ``None`` once constructed."""
        cx, cy = self.cx_px, self.cy_px
        assert cx is not None and cy is not None  # resolved in __post_init__
        return cx, cy

    @classmethod
    def from_fov(
        cls, *, width_px: int = 320, height_px: int = 240, hfov_deg: float = 64.0, **kw: float
    ) -> StereoRig:
        """A rig whose horizontal field of view is ``hfov_deg`` degrees."""
        if not (0.0 < hfov_deg < 179.0):
            raise ValueError(f"hfov_deg must be in (0, 179), got {hfov_deg!r}")
        focal = (width_px / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
        return cls(width_px=width_px, height_px=height_px, focal_px=focal, **kw)

    @property
    def K(self) -> FloatArray:
        """3x3 intrinsic matrix of either camera (pixel-centre convention)."""
        cx, cy = self.principal_point_px
        return np.array([[self.focal_px, 0.0, cx], [0.0, self.focal_px, cy], [0.0, 0.0, 1.0]])

    @property
    def hfov_rad(self) -> float:
        """Horizontal field of view of the left camera, radians."""
        cx, _ = self.principal_point_px
        left = math.atan((cx + 0.5) / self.focal_px)
        right = math.atan((self.width_px - 0.5 - cx) / self.focal_px)
        return left + right

    @property
    def vfov_rad(self) -> float:
        """Vertical field of view, radians."""
        _, cy = self.principal_point_px
        top = math.atan((cy + 0.5) / self.focal_px)
        bottom = math.atan((self.height_px - 0.5 - cy) / self.focal_px)
        return top + bottom

    @property
    def fb(self) -> float:
        """``focal_px * baseline_m``: disparity times depth, px*m."""
        return self.focal_px * self.baseline_m

    @property
    def min_disparity_px(self) -> float:
        """Disparity at ``max_depth_m``."""
        return self.fb / self.max_depth_m

    @property
    def max_disparity_px(self) -> float:
        """Disparity at ``min_depth_m``."""
        return self.fb / self.min_depth_m

    # ------------------------------------------------------------------ geometry
    def disparity_px(self, depth_m: ArrayLike) -> FloatArray:
        """Disparity ``f b / Z`` in pixels of a point at depth ``Z`` (metres, > 0)."""
        depth = np.asarray(depth_m, dtype=np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(depth > 0, self.fb / depth, np.nan)

    def depth_m(self, disparity_px: ArrayLike) -> FloatArray:
        """Depth ``f b / d`` in metres of a disparity ``d`` (pixels, > 0); NaN otherwise."""
        disp = np.asarray(disparity_px, dtype=np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(disp > 0, self.fb / disp, np.nan)

    def project(self, P_cam: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Project left-camera-frame points into both images.

        Args:
            P_cam: (n, 3) points in the left camera frame, metres.

        Returns:
            ``(uv_left, uv_right)``, each (n, 2) pixels. Points with ``Z <= 0`` give NaN.
        """
        P = _as_points(P_cam, "P_cam")
        Z = P[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.where(Z > 0, 1.0 / Z, np.nan)
        cx, cy = self.principal_point_px
        u_left = self.focal_px * P[:, 0] * inv + cx
        v = self.focal_px * P[:, 1] * inv + cy
        u_right = self.focal_px * (P[:, 0] - self.baseline_m) * inv + cx
        return np.stack([u_left, v], axis=1), np.stack([u_right, v], axis=1)

    def triangulate(self, u_left: ArrayLike, v: ArrayLike, disparity_px: ArrayLike) -> FloatArray:
        """Left-camera-frame points from left-image coordinates and disparity.

        Args:
            u_left: (n,) column in the left image, pixels.
            v: (n,) row, pixels (the same in both rectified images).
            disparity_px: (n,) ``u_left - u_right``, pixels; non-positive gives NaN.

        Returns:
            (n, 3) points, metres, in the left camera frame.
        """
        u = np.atleast_1d(np.asarray(u_left, dtype=np.float64))
        vv = np.atleast_1d(np.asarray(v, dtype=np.float64))
        d = np.atleast_1d(np.asarray(disparity_px, dtype=np.float64))
        Z = self.depth_m(d)
        cx, cy = self.principal_point_px
        X = (u - cx) * Z / self.focal_px
        Y = (vv - cy) * Z / self.focal_px
        return np.stack([X, Y, Z], axis=-1)

    def in_image(self, uv: ArrayLike) -> NDArray[np.bool_]:
        """Whether pixel coordinates (n, 2) fall inside the image."""
        uv_arr = _as_points(uv, "uv", dim=2)
        return (
            (uv_arr[:, 0] >= -0.5)
            & (uv_arr[:, 0] <= self.width_px - 0.5)
            & (uv_arr[:, 1] >= -0.5)
            & (uv_arr[:, 1] <= self.height_px - 0.5)
        )


@dataclass(frozen=True, slots=True, kw_only=True)
class HeadPose:
    """Pose of the LEFT optical centre of a stereo head, level or tilted down.

    Attributes:
        x_m: World x of the left optical centre, metres.
        y_m: World y, metres.
        heading_rad: Direction of the optical axis on the floor, radians counter-clockwise from
            world +x.
        height_m: Height of the optical centre above the floor, metres (> 0).
        tilt_rad: Pitch of the optical axis below the horizon, radians (positive: looking down),
            in (-pi/2, pi/2). The pair stays rectified (the rotation is about the camera x axis,
            the baseline).
    """

    x_m: float
    y_m: float
    heading_rad: float
    height_m: float
    tilt_rad: float = 0.0

    def __post_init__(self) -> None:
        for name in ("x_m", "y_m", "heading_rad", "height_m", "tilt_rad"):
            value = getattr(self, name)
            if not math.isfinite(float(value)):
                raise ValueError(f"{name} must be finite, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.height_m <= 0:
            raise ValueError(f"height_m must be positive, got {self.height_m!r}")
        if not abs(self.tilt_rad) < 0.5 * math.pi:
            raise ValueError(f"tilt_rad must be in (-pi/2, pi/2), got {self.tilt_rad!r}")

    @property
    def R_cam2world(self) -> FloatArray:
        """3x3 rotation whose columns are the camera x (right), y (down), z (forward), world.

        Level: right ``(s, -c, 0)``, down ``(0, 0, -1)``, forward ``(c, s, 0)`` (``c, s`` of
        the heading); the tilt turns forward and down about right: forward
        ``cos(t) (c, s, 0) + sin(t) (0, 0, -1)``, down ``cos(t) (0, 0, -1) - sin(t) (c, s, 0)``.
        """
        c, s = math.cos(self.heading_rad), math.sin(self.heading_rad)
        ct, st = math.cos(self.tilt_rad), math.sin(self.tilt_rad)
        right = [s, -c, 0.0]
        down = [-st * c, -st * s, -ct]
        forward = [ct * c, ct * s, -st]
        return np.array([right, down, forward]).T

    @property
    def position_world(self) -> FloatArray:
        """(3,) world position of the left optical centre."""
        return np.array([self.x_m, self.y_m, self.height_m])

    @property
    def cam2world(self) -> FloatArray:
        """4x4 homogeneous transform from the left camera frame to the world frame."""
        T = np.eye(4)
        T[:3, :3] = self.R_cam2world
        T[:3, 3] = self.position_world
        return T

    def right_camera_position(self, rig: StereoRig) -> FloatArray:
        """(3,) world position of the right optical centre."""
        return self.position_world + rig.baseline_m * self.R_cam2world[:, 0]

    def cam_to_world(self, P_cam: ArrayLike) -> FloatArray:
        """(n, 3) left-camera-frame points to world points."""
        P = _as_points(P_cam, "P_cam")
        return P @ self.R_cam2world.T + self.position_world

    def world_to_cam(self, P_world: ArrayLike) -> FloatArray:
        """(n, 3) world points to left-camera-frame points."""
        P = _as_points(P_world, "P_world")
        return (P - self.position_world) @ self.R_cam2world
