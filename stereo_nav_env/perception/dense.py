"""The dense perception: semi-global matching into an occupancy evidence grid, then outlines.

``perception="dense"`` is what most robots use instead of the paper's segment stereo (issue 43):
a dense disparity map, the points it gives between the floor and the robot's height counted in a
grid on the floor, and the occupied cells taken as obstacles. To reach the same model stages
(:func:`modeling.model.build.build_model`: relations, obstacles, critical regions, situations) and
so the same agents, the grid is turned into a :class:`~modeling.observation.FloorObservation`: the
outlines of its occupied blobs as floor segments with endpoint covariances. Each view:

1. The pair is rendered and given pixel noise exactly as for ``perception="stereo"`` (the same
   draws from the env's ``np_random``: :class:`~stereo_nav_env.perception.stereo.StereoPerception`).
2. OpenCV's ``StereoSGBM`` (:func:`make_sgbm`) gives the disparity of every left pixel
   (:func:`sgbm_disparity`). Both images are padded on the left by the disparity range so that
   the left image's first columns are matched too (OpenCV leaves them invalid otherwise, a third
   of the 320-pixel image); a disparity is kept where it is positive, its right pixel lies in the
   right image, and the left image has texture there: the mean absolute horizontal Sobel
   gradient over the block is at least ``min_texture`` grey levels (SGBM's answers on plain,
   noisy faces are noise; StereoBM's ``textureThreshold`` does the same).
3. Each kept pixel is triangulated with the rig (:meth:`~modeling.stereo.rig.StereoRig.triangulate`)
   and put in the world (:meth:`~modeling.stereo.rig.HeadPose.cam_to_world`); the points between
   ``min_height_m`` and the robot's height, within the rig's depth range, are counted in a grid of
   ``cell_m`` cells on the floor in the head's frame (:func:`evidence_grid`), and a cell with at
   least ``min_points`` points is occupied.
4. The outer outline of each blob of occupied cells, along the cells' outer edges
   (``cv2.findContours`` on the grid of cell corners), simplified by ``cv2.approxPolyDP`` to
   within ``simplify_m``, gives one floor segment per side (:func:`grid_outlines`). Each
   endpoint's covariance is SGBM's disparity error ``disparity_sigma_px`` propagated through the
   rig at the endpoint's depth and column
   (:func:`modeling.stereo.triangulation.triangulate_points`: the depth standard deviation grows
   as ``Z^2 / (f b) sigma_d``), plus the grid's quantisation ``cell_m^2 / 12`` along each axis.
   Nothing is ambiguous: one disparity per pixel.

The parameters (:class:`DenseOptions`) were chosen on the dev views
(:func:`stereo_nav_env.sim.views.scene_views` of seed 0: 12 scenes, 24 views, 2 grey levels of
pixel noise, the renderer's depth and the scenes' outlines as the truth). SGBM's block,
penalties and disparity range are those of :func:`agents.evaluation.stereo_accuracy`'s
comparison (5x5 blocks, ``P1 = 8 * 25``, ``P2 = 32 * 25``, the rig's 0.3 to 8 m), with
``uniquenessRatio`` 10 and speckle filtering (windows of 100 pixels, range 2) added, in the
3-way mode (7-8 ms a pair against 16-17 ms for the 5-way mode, with the same errors). Without the
texture test 56 % of the disparities of obstacle pixels within the height band are within 1 px
of the truth (the plain faces' noise); with ``min_texture`` 20, 17 % of those pixels keep one,
79 % of them within 1 px, median absolute error 0.28 px, robust standard deviation (1.4826 times
the median absolute deviation) 0.43 px: ``disparity_sigma_px``. Of the grid settings tried
(``min_texture`` 10, 20; ``min_points`` 2, 4, 8; ``simplify_m`` 0.05, 0.1), ``20 / 4 / 0.1``
gives outlines whose endpoints lie within two standard deviations (or 0.1 m) of a true outline
94 % of the time, covering 54 % of the length of the true visible outlines within 0.15 m (the
middles of plain faces give no disparity), in 27 segments a view; ``10 / 2 / 0.05`` covers
65 % with 88 % of the endpoints on an outline, in 72 segments (a slower model).

Frames and units: world metres, floor plane x-y, z up; image pixels (u right, v down); the grid's
rows run along the head's heading (row 0 at the head), its columns to the head's left.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import cv2
import numpy as np
from numpy.typing import NDArray

from modeling.observation import FloorObservation, FloorSegment
from modeling.stereo.rig import HeadPose, StereoRig
from modeling.stereo.triangulation import triangulate_points
from modeling.types import FloatArray, UInt8Image
from modeling.validation import boolean, integer, number
from stereo_nav_env.perception.base import ComparableModel, PerceptionName, Stopwatch
from stereo_nav_env.perception.stereo import StereoPerception

if TYPE_CHECKING:  # pragma: no cover
    from stereo_nav_env.config import EnvConfig

__all__ = [
    "DenseOptions",
    "DensePerception",
    "dense_floor_observation",
    "evidence_grid",
    "grid_outlines",
    "make_sgbm",
    "sgbm_disparity",
]


@dataclass(frozen=True, slots=True, kw_only=True)
class DenseOptions:
    """The dense perception's parameters (chosen on the dev views: the module docstring).

    Attributes:
        block_px: SGBM's block size, pixels (odd, >= 3).
        uniqueness_pct: SGBM's ``uniquenessRatio``: the best cost must beat the second best by
            this many percent.
        speckle_window_px: SGBM's ``speckleWindowSize``: blobs of at most this many pixels
            whose disparities differ from their surroundings are removed (0: no filtering).
        speckle_range_px: SGBM's ``speckleRange``: disparity variation within one blob, pixels.
        three_way: SGBM's 3-way mode (``STEREO_SGBM_MODE_SGBM_3WAY``) instead of the 5-way one.
        min_texture: A pixel's disparity is kept where the mean absolute horizontal Sobel
            gradient of the left image over the block is at least this, grey levels.
        disparity_sigma_px: Standard deviation of SGBM's disparity error, pixels (the
            covariance of the outlines' endpoints).
        cell_m: Side of the evidence grid's cells, metres.
        min_points: A cell with at least this many points is occupied.
        min_height_m: Points below this height are floor, metres.
        simplify_m: ``cv2.approxPolyDP``'s tolerance on the blobs' contours, metres.

    Raises:
        ValueError: A value out of its range (naming the field).
    """

    block_px: int = 5
    uniqueness_pct: int = 10
    speckle_window_px: int = 100
    speckle_range_px: int = 2
    three_way: bool = True
    min_texture: float = 20.0
    disparity_sigma_px: float = 0.43
    cell_m: float = 0.05
    min_points: int = 4
    min_height_m: float = 0.05
    simplify_m: float = 0.1

    def __post_init__(self) -> None:
        integer(self.block_px, "block_px", low=3)
        if self.block_px % 2 == 0:
            raise ValueError(f"block_px must be odd, got {self.block_px}")
        integer(self.uniqueness_pct, "uniqueness_pct", low=0)
        integer(self.speckle_window_px, "speckle_window_px", low=0)
        integer(self.speckle_range_px, "speckle_range_px", low=0)
        boolean(self.three_way, "three_way")
        number(self.min_texture, "min_texture", low=0.0, strict=False)
        number(self.disparity_sigma_px, "disparity_sigma_px", low=0.0)
        number(self.cell_m, "cell_m", low=0.0)
        integer(self.min_points, "min_points", low=1)
        number(self.min_height_m, "min_height_m", low=0.0, strict=False)
        number(self.simplify_m, "simplify_m", low=0.0, strict=False)


def make_sgbm(rig: StereoRig, options: DenseOptions | None = None) -> cv2.StereoSGBM:
    """OpenCV's ``StereoSGBM`` for ``rig``: disparities 0 up to the rig's largest (its
    ``min_depth_m``), rounded up to a multiple of 16, ``P1 = 8 b^2`` and ``P2 = 32 b^2`` for
    blocks of ``b`` pixels, and the uniqueness, speckle and mode settings of ``options``
    (default :class:`DenseOptions`)."""
    opts = DenseOptions() if options is None else options
    block = opts.block_px
    return cv2.StereoSGBM.create(
        minDisparity=0,
        numDisparities=disparity_range_px(rig),
        blockSize=block,
        P1=8 * block * block,
        P2=32 * block * block,
        uniquenessRatio=opts.uniqueness_pct,
        speckleWindowSize=opts.speckle_window_px,
        speckleRange=opts.speckle_range_px if opts.speckle_window_px > 0 else 0,
        mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY if opts.three_way else cv2.STEREO_SGBM_MODE_SGBM,
    )


def disparity_range_px(rig: StereoRig) -> int:
    """SGBM's ``numDisparities`` for ``rig``: its largest disparity rounded up to a multiple
    of 16, pixels."""
    return int(math.ceil(rig.max_disparity_px / 16.0) * 16)


def sgbm_disparity(
    matcher: cv2.StereoSGBM,
    left: UInt8Image,
    right: UInt8Image,
    rig: StereoRig,
    options: DenseOptions | None = None,
) -> NDArray[np.float32]:
    """SGBM's disparity of every left pixel, float32 (H, W) pixels, NaN where none is kept.

    The grey images (uint8 (H, W), the rig's size) are padded on the left by the matcher's
    disparity range (``numDisparities``; zeros), matched, and cropped back, so that a left pixel
    near the image's left edge gets a disparity too where its right pixel is in the right image.
    Kept: positive disparities within the rig's depth range whose right pixel lies in the right
    image, where the left image has texture (the mean absolute horizontal Sobel gradient over
    the block is at least ``options.min_texture`` grey levels).
    """
    opts = DenseOptions() if options is None else options
    pad = int(matcher.getNumDisparities())
    width = left.shape[1]
    padded = [
        cv2.copyMakeBorder(g, 0, 0, pad, 0, cv2.BORDER_CONSTANT, value=0) for g in (left, right)
    ]
    raw = np.asarray(matcher.compute(padded[0], padded[1]))[:, pad:]
    disparity = raw.astype(np.float32) / np.float32(16.0)
    gradient = np.abs(cv2.Sobel(left, cv2.CV_32F, 1, 0, ksize=3))
    texture = cv2.boxFilter(gradient, -1, (opts.block_px, opts.block_px))
    column = np.arange(width, dtype=np.float32)[None, :]
    keep = (
        (disparity >= rig.min_disparity_px)
        & (disparity <= rig.max_disparity_px)
        & (disparity <= column)  # the right pixel u - d lies in the right image
        & (texture >= opts.min_texture)
    )
    return cast(NDArray[np.float32], np.where(keep, disparity, np.float32(np.nan)))


def disparity_points(
    disparity: NDArray[np.float32], rig: StereoRig, head_pose: HeadPose
) -> tuple[FloatArray, FloatArray]:
    """The world points (n, 3) [m] of the kept disparities (:func:`sgbm_disparity`) and their
    disparities (n,) [px], in row-major pixel order."""
    v, u = np.nonzero(np.isfinite(disparity))
    d = disparity[v, u].astype(np.float64)
    P_cam = rig.triangulate(u.astype(np.float64), v.astype(np.float64), d)
    return head_pose.cam_to_world(P_cam), d


@dataclass(frozen=True, slots=True, kw_only=True)
class GridFrame:
    """Where the evidence grid lies: cell ``(row, col)`` has its centre at
    ``origin + (row + 0.5) cell_m forward + (col + 0.5 - cols / 2) cell_m left`` (world, metres).

    Attributes:
        origin: (2,) the head's floor point, world metres.
        forward: (2,) unit vector of the heading. ``left``: (2,) that vector turned by +90 deg.
        cell_m: Cell side, metres.
        rows: Cells along the heading (to the rig's range). ``cols``: cells across it.
    """

    origin: FloatArray
    forward: FloatArray
    left: FloatArray
    cell_m: float
    rows: int
    cols: int

    @classmethod
    def of(cls, rig: StereoRig, head_pose: HeadPose, cell_m: float) -> GridFrame:
        """The grid that covers the rig's field of view to its range, from ``head_pose``."""
        c, s = math.cos(head_pose.heading_rad), math.sin(head_pose.heading_rad)
        rows = math.ceil(rig.max_depth_m / cell_m)
        half = rig.max_depth_m * math.tan(min(rig.hfov_rad / 2.0, 1.4))
        cols = 2 * math.ceil(half / cell_m)
        return cls(
            origin=np.array([head_pose.x_m, head_pose.y_m]),
            forward=np.array([c, s]),
            left=np.array([-s, c]),
            cell_m=float(cell_m),
            rows=rows,
            cols=cols,
        )

    def cells(self, xy: FloatArray) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.bool_]]:
        """The ``(row, col)`` of floor points (n, 2) and whether each falls in the grid."""
        d = xy - self.origin
        row = np.floor((d @ self.forward) / self.cell_m).astype(np.intp)
        col = np.floor((d @ self.left) / self.cell_m + self.cols / 2.0).astype(np.intp)
        inside = (row >= 0) & (row < self.rows) & (col >= 0) & (col < self.cols)
        return row, col, inside

    def world(self, row_col: FloatArray) -> FloatArray:
        """World floor points (n, 2) of fractional ``(row, col)`` cell coordinates (n, 2),
        cell centres at whole numbers."""
        ahead = (row_col[:, 0:1] + 0.5) * self.cell_m
        aside = (row_col[:, 1:2] + 0.5 - self.cols / 2.0) * self.cell_m
        out: FloatArray = self.origin + ahead * self.forward + aside * self.left
        return out


def evidence_grid(
    points: FloatArray, frame: GridFrame, *, min_height_m: float, max_height_m: float
) -> NDArray[np.int32]:
    """The number of world points (n, 3) between the two heights in each cell of ``frame``,
    int32 (rows, cols)."""
    z = points[:, 2]
    band = points[(z >= min_height_m) & (z <= max_height_m)]
    row, col, inside = frame.cells(band[:, :2])
    flat = row[inside] * frame.cols + col[inside]
    counts = np.bincount(flat, minlength=frame.rows * frame.cols)
    return counts.reshape(frame.rows, frame.cols).astype(np.int32)


def grid_outlines(
    occupied: NDArray[np.bool_], simplify_cells: float
) -> tuple[list[FloatArray], NDArray[np.int32]]:
    """The outer outline of each blob of occupied cells, along the cells' outer edges.

    ``cv2.findContours`` traces the centres of a blob's boundary pixels, which would put a blob's
    outline half a cell inside it (and make a blob of one cell a point). So it traces the grid of
    cell *corners* instead: a corner is set where one of the four cells around it is occupied,
    and the centres of the set corners' boundary are the blob's outer edges. Each outer contour
    (8-connected blobs) is simplified by ``cv2.approxPolyDP`` to within ``simplify_cells``.

    Args:
        occupied: (rows, cols) occupied cells.
        simplify_cells: ``approxPolyDP``'s tolerance, cells.

    Returns:
        ``(outlines, labels)``: each outline (k, 2) float ``(row, col)`` cell coordinates of its
        vertices (cell centres at whole numbers, so its corners at halves; k >= 2: a thin blob
        may simplify to a line), and the int32 (rows + 1, cols + 1) labels of the corners' blobs
        (0: none); the cell ``(r, c)`` belongs to the blob of its corner ``(r, c)``, an
        outline's blob is that of its first vertex's corner.
    """
    rows, cols = occupied.shape
    corners = np.zeros((rows + 1, cols + 1), dtype=np.uint8)
    for dr in (0, 1):
        for dc in (0, 1):
            corners[dr : dr + rows, dc : dc + cols] |= occupied.astype(np.uint8)
    _, labels = cv2.connectedComponents(corners, connectivity=8)
    contours, _ = cv2.findContours(corners, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    out: list[FloatArray] = []
    for contour in contours:
        poly = cv2.approxPolyDP(contour, simplify_cells, True).reshape(-1, 2)
        # OpenCV's (x = col, y = row) of a corner pixel; corner (i, j) is at cell (i - .5, j - .5)
        out.append(poly[:, ::-1].astype(np.float64) - 0.5)
    return out, np.asarray(labels, dtype=np.int32)


def outline_covariances(
    ends: FloatArray, rig: StereoRig, head_pose: HeadPose, options: DenseOptions, height_m: float
) -> FloatArray:
    """(n, 2, 2) covariances [m^2] of floor points ``ends`` (n, 2) of the outlines: SGBM's
    disparity error ``options.disparity_sigma_px`` (and the rig's ``sigma_px`` on the column and
    row) propagated through the rig at the point's depth, seen at ``height_m``
    (:func:`~modeling.stereo.triangulation.triangulate_points`, rotated to the world, its
    ``(x, y)`` block), plus the grid's quantisation ``cell_m^2 / 12`` along each axis."""
    P_world = np.column_stack([ends, np.full(ends.shape[0], height_m)])
    P_cam = head_pose.world_to_cam(P_world)
    Z = np.maximum(P_cam[:, 2], rig.min_depth_m)
    cx, cy = rig.principal_point_px
    u = cx + rig.focal_px * P_cam[:, 0] / Z
    v = cy + rig.focal_px * P_cam[:, 1] / Z
    d = rig.fb / Z
    n = ends.shape[0]
    pixel = np.full(n, rig.sigma_px**2)
    _, cov_cam = triangulate_points(
        u, v, d, pixel, np.full(n, options.disparity_sigma_px**2), np.zeros(n), pixel, rig
    )
    R = head_pose.R_cam2world[:2]  # the (x, y) rows
    cov: FloatArray = R @ cov_cam @ R.T + (options.cell_m**2 / 12.0) * np.eye(2)
    return cov


def dense_floor_observation(
    left: UInt8Image,
    right: UInt8Image,
    rig: StereoRig,
    head_pose: HeadPose,
    *,
    max_height_m: float,
    matcher: cv2.StereoSGBM | None = None,
    options: DenseOptions | None = None,
    stopwatch: Stopwatch | None = None,
) -> FloorObservation:
    """The floor observation of a rectified grey pair through SGBM, the evidence grid and its
    blobs' outlines (steps 2-4 of the module docstring).

    Args:
        left: Left grey image, uint8 (H, W), the rig's size.
        right: Right grey image, the same.
        rig: The stereo rig that took the pair.
        head_pose: Pose of the left optical centre, world frame.
        max_height_m: Highest point that is an obstacle (the robot's height), metres.
        matcher: The SGBM matcher (default: :func:`make_sgbm` of ``rig`` and ``options``).
        options: The parameters (default :class:`DenseOptions`).
        stopwatch: If given, its laps ``matching`` (SGBM) and ``triangulation`` (the points,
            the grid and the outlines) are added to.

    Returns:
        One :class:`~modeling.observation.FloorSegment` per side of each blob's simplified
        outline (``source``: the blob's label; ``height_m``: the lowest and highest point of the
        blob), no ambiguous segment; viewpoint ``(x, y, heading)`` of the head, the rig's field
        of view and range.

    Raises:
        ValueError: Images that are not uint8 (H, W) of the rig's size (naming ``left`` or
            ``right``), or a ``max_height_m`` not above ``options.min_height_m``.
    """
    opts = DenseOptions() if options is None else options
    number(max_height_m, "max_height_m", low=opts.min_height_m)
    want = (rig.height_px, rig.width_px)
    for name, image in (("left", left), ("right", right)):
        if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.shape != want:
            got = f"{image.dtype} {image.shape}" if isinstance(image, np.ndarray) else type(image)
            raise ValueError(f"{name} must be a uint8 grey image of shape {want}, got {got}")
    watch = stopwatch if stopwatch is not None else Stopwatch()
    sgbm = make_sgbm(rig, opts) if matcher is None else matcher
    disparity = sgbm_disparity(sgbm, left, right, rig, opts)
    watch.lap("matching")
    points, _ = disparity_points(disparity, rig, head_pose)
    frame = GridFrame.of(rig, head_pose, opts.cell_m)
    z = points[:, 2]
    band = points[(z >= opts.min_height_m) & (z <= max_height_m)]
    counts = evidence_grid(band, frame, min_height_m=opts.min_height_m, max_height_m=max_height_m)
    occupied = counts >= opts.min_points
    segments: tuple[FloorSegment, ...] = ()
    if occupied.any():
        segments = _outline_segments(
            occupied, band, frame, rig, head_pose, opts, max_height_m=max_height_m
        )
    watch.lap("triangulation")
    return FloorObservation(
        segments=tuple(segments),
        viewpoint=np.array([head_pose.x_m, head_pose.y_m, head_pose.heading_rad]),
        fov_rad=rig.hfov_rad,
        max_range_m=rig.max_depth_m,
    )


def _outline_segments(
    occupied: NDArray[np.bool_],
    band: FloatArray,
    frame: GridFrame,
    rig: StereoRig,
    head_pose: HeadPose,
    opts: DenseOptions,
    *,
    max_height_m: float,
) -> tuple[FloorSegment, ...]:
    """The floor segments of the outlines of the blobs of ``occupied`` (step 4 of the module
    docstring); ``band``: the world points (n, 3) within the height band, whose lowest and
    highest in each blob are its segments' ``height_m``."""
    outlines, labels = grid_outlines(occupied, opts.simplify_m / opts.cell_m)
    if not outlines:
        return ()
    row, col, inside = frame.cells(band[:, :2])
    label = np.zeros(row.shape[0], dtype=np.intp)
    label[inside] = labels[row[inside], col[inside]]
    n_labels = int(labels.max()) + 1
    z_low, z_high = np.full(n_labels, np.inf), np.full(n_labels, -np.inf)
    np.minimum.at(z_low, label, band[:, 2])
    np.maximum.at(z_high, label, band[:, 2])
    vertices = frame.world(np.concatenate(outlines))
    cov = outline_covariances(
        vertices, rig, head_pose, opts, 0.5 * (opts.min_height_m + max_height_m)
    )
    pairs: list[tuple[int, int]] = []
    blobs: list[int] = []
    first = 0
    for outline in outlines:
        k = outline.shape[0]
        sides = [(0, 1)] if k == 2 else [(i, (i + 1) % k) for i in range(k)]
        pairs.extend((first + i, first + j) for i, j in sides)
        corner = np.rint(outline[0] + 0.5).astype(np.intp)
        blobs.extend([int(labels[corner[0], corner[1]])] * len(sides))
        first += k
    ends = np.asarray(pairs, dtype=np.intp)
    blob = np.asarray(blobs, dtype=np.int64)
    heights = np.stack([z_low[blob], z_high[blob]], axis=1)
    return FloorSegment.stack(vertices[ends], cov[ends], heights, blob)


class DensePerception(StereoPerception):
    """``perception="dense"``: the rendered noisy pair of :class:`StereoPerception` (the same
    draws), then SGBM, the evidence grid and its outlines as the floor observation
    (:func:`dense_floor_observation`), then the same model stages (module doc). The matcher is
    made on first use. Laps ``render``, ``noise``, ``matching`` (SGBM), ``triangulation`` (the
    grid and the outlines) and ``modeling``."""

    name = PerceptionName.DENSE

    def __init__(self, config: EnvConfig) -> None:
        super().__init__(config)
        self.options = DenseOptions()
        self._matcher: cv2.StereoSGBM | None = None

    def model_of_pair(
        self, left: UInt8Image, right: UInt8Image, head_pose: HeadPose, watch: Stopwatch
    ) -> ComparableModel:
        """The model of the noisy grey pair through the dense floor observation."""
        rig = self.config.rig
        if self._matcher is None:
            self._matcher = make_sgbm(rig, self.options)
        settings = self.model_settings()
        floor = dense_floor_observation(
            left,
            right,
            rig,
            head_pose,
            max_height_m=settings["robot_height_m"],
            matcher=self._matcher,
            options=self.options,
            stopwatch=watch,
        )
        return self.model_of(floor, watch)

    def __getstate__(self) -> dict[str, Any]:
        state = super().__getstate__()
        state["_matcher"] = None  # an OpenCV object: made again on first use
        return state
