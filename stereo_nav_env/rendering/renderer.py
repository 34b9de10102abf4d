"""Headless stereo rendering of a :class:`~stereo_nav_env.sim.scenes.Scene` with pyrender.

The only module that imports pyrender, trimesh or OpenGL. The OpenGL platform is chosen before
pyrender is imported: ``PYOPENGL_PLATFORM`` if already set, else EGL (Mesa's software rasteriser
works with no GPU and no display), else OSMesa where no EGL library can be found. On machines with
fewer than 4 cores the rasteriser gets 4 threads (``LP_NUM_THREADS``, unless set).

Geometry: every static piece of the scene (floor, walls, every part of every obstacle) is merged
into ONE triangle mesh with per-face colours, so a frame is one draw call whatever the number of
pieces. Shading is baked: each face gets its part's base colour times a factor fixed by the face's
orientation (tops brightest, the four side directions of world +x, +y, -x, -y at distinct levels;
the values are in :mod:`stereo_nav_env.rendering.shading`, which the surrogate reads too), and the
mesh is drawn with ``RenderFlags.FLAT`` (no lighting computation), so adjacent faces of a box differ
and its edges appear as straight intensity steps. Surface detail (``Obstacle.detail``: seams,
door frames, fronts, book spines) is drawn the same way, each feature a thin prism
(``Obstacle.detail_parts``) 3 mm proud of its face (a book: set back in its shelf), in the same
merged mesh: no texture, no extra draw call. A directional light is kept in the scene for
non-flat use.

Cameras: the SAME :class:`modeling.StereoRig` drives the renderer. pyrender's ``IntrinsicsCamera``
measures pixels from the top-left pixel's corner while the rig uses the centre of the top-left pixel
as (0, 0), so ``cx_pyrender = cx_px + 0.5`` (likewise cy). pyrender cameras look down their -z axis
with y up, so a camera's pose is ``cam2world @ diag(1, -1, -1, 1)``. The right camera sits
``baseline_m`` along the left camera's +x axis with the same orientation (a rectified pair).
pyrender's multisampled framebuffer (4 samples) anti-aliases edges, so edge positions can be read to
sub-pixel precision from the intensity profile.
"""

from __future__ import annotations

import ctypes.util
import os
from typing import Any

if "PYOPENGL_PLATFORM" not in os.environ:  # must precede the first OpenGL import
    if ctypes.util.find_library("EGL") is None and ctypes.util.find_library("OSMesa") is not None:
        os.environ["PYOPENGL_PLATFORM"] = "osmesa"
    else:
        os.environ["PYOPENGL_PLATFORM"] = "egl"
# llvmpipe rasterises with one thread per core. With fewer than 4 cores, 4 threads gave faster env
# steps in 11 of 12 paired runs on a 2-core VM (while the step's Python holds one core, more,
# smaller jobs balance better) and the same vector-env throughput; images are identical.
# Read when the first context is made; a value set by the user is kept.
if "LP_NUM_THREADS" not in os.environ and (os.cpu_count() or 1) < 4:
    os.environ["LP_NUM_THREADS"] = "4"

import numpy as np
import pyrender
import trimesh
from numpy.typing import NDArray

from modeling.stereo.rig import HeadPose, StereoRig
from modeling.types import FloatArray, UInt8Image
from stereo_nav_env.rendering.shading import (
    BACKGROUND_COLOR,
    BOTTOM_SHADE,
    FLOOR_COLOR,
    FLOOR_MARGIN_M,
    SIDE_SHADES,
    TOP_SHADE,
    face_shade,
)
from stereo_nav_env.sim.scenes import BoxPart, Scene

__all__ = [
    "BACKGROUND_COLOR",
    "FLOOR_COLOR",
    "SIDE_SHADES",
    "StereoRenderer",
    "build_scene_mesh",
    "face_shade",
]


_OPENCV_TO_OPENGL = np.diag([1.0, -1.0, -1.0, 1.0])


def _prism(part: BoxPart) -> tuple[FloatArray, NDArray[np.int64], FloatArray]:
    """Vertices (2k, 3), triangles (m, 3) and face colours (m, 3) of one extruded convex part."""
    fp = part.footprint
    k = fp.shape[0]
    verts = np.concatenate(
        [np.c_[fp, np.full(k, part.z_min_m)], np.c_[fp, np.full(k, part.z_max_m)]]
    )
    base = np.asarray(part.color, dtype=np.float64)
    faces: list[tuple[int, int, int]] = []
    colors: list[FloatArray] = []
    for a in range(k):
        b = (a + 1) % k
        edge = fp[b] - fp[a]
        shade = face_shade(np.array([edge[1], -edge[0]])) * base  # CCW outline: outward normal
        faces += [(a, b, k + b), (a, k + b, k + a)]
        colors += [shade, shade]
    for t in range(1, k - 1):  # convex: fan triangulation
        faces.append((k, k + t, k + t + 1))
        colors.append(TOP_SHADE * base)
        if part.z_min_m > 1e-9:  # bottoms on the floor are never seen
            faces.append((0, t + 1, t))
            colors.append(BOTTOM_SHADE * base)
    return verts, np.asarray(faces, dtype=np.int64), np.asarray(colors)


def build_scene_mesh(scene: Scene, *, floor_margin_m: float = FLOOR_MARGIN_M) -> trimesh.Trimesh:
    """All static geometry of ``scene`` (floor and every obstacle part) as ONE coloured mesh.

    Args:
        scene: The scene.
        floor_margin_m: How far the floor extends beyond the scene bounds, metres.

    Returns:
        A trimesh with per-face colours (uint8 RGBA), world frame, metres.
    """
    x0, y0, x1, y1 = scene.bounds
    m = floor_margin_m
    floor_v = np.array(
        [[x0 - m, y0 - m, 0], [x1 + m, y0 - m, 0], [x1 + m, y1 + m, 0], [x0 - m, y1 + m, 0]]
    )
    verts: list[FloatArray] = [floor_v.astype(np.float64)]
    faces: list[NDArray[np.int64]] = [np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)]
    colors: list[FloatArray] = [np.tile(FLOOR_COLOR, (2, 1))]
    offset = 4
    for ob in scene.obstacles:
        for part in ob.drawn_parts:  # its parts, then its surface detail's strips
            v, f, c = _prism(part)
            verts.append(v)
            faces.append(f + offset)
            colors.append(c)
            offset += v.shape[0]
    face_colors = np.clip(np.round(np.concatenate(colors) * 255.0), 0, 255).astype(np.uint8)
    rgba = np.c_[face_colors, np.full(face_colors.shape[0], 255, dtype=np.uint8)]
    return trimesh.Trimesh(
        vertices=np.concatenate(verts),
        faces=np.concatenate(faces),
        face_colors=rgba,
        process=False,
    )


# Fork safety. Mesa's EGL/OSMesa state (the initialised display, the rasteriser's threads) does
# not survive fork: in a child of a process that has made a context, making or using one hangs
# for ever. So the process that first made a context is remembered, and a forked child of it
# refuses to render with a RuntimeError that says what to do instead.
_CONTEXT_PID: int | None = None
"""The process that made this interpreter's first OpenGL context (``None``: none yet)."""

FORK_MESSAGE = (
    "this process was forked from one that had already rendered (pid {parent}): an OpenGL context "
    "does not survive fork, and rendering here would hang. Make the environment in a fresh "
    "process instead: use the 'spawn' start method, e.g. "
    "gym.vector.AsyncVectorEnv(env_fns, context='spawn') or multiprocessing.get_context('spawn')."
)


def _no_op() -> None:
    pass


def check_not_forked() -> None:
    """Raise ``RuntimeError`` in a forked child of a process that had made an OpenGL context."""
    if _CONTEXT_PID is not None and _CONTEXT_PID != os.getpid():
        raise RuntimeError(FORK_MESSAGE.format(parent=_CONTEXT_PID))


def _keep_shared_display(renderer: Any) -> None:
    """Make an EGL renderer's ``delete`` destroy only its own context.

    pyrender's EGL platform calls ``eglTerminate`` on close, which kills every other context on the
    process-wide default display (other renderers, other envs); destroying the context alone is
    enough to free it.
    """
    platform = getattr(renderer, "_platform", None)
    if platform is None or not hasattr(platform, "_egl_display"):
        return

    def delete_context() -> None:
        from OpenGL.EGL import eglDestroyContext

        if platform._egl_display is not None and platform._egl_context is not None:
            eglDestroyContext(platform._egl_display, platform._egl_context)
        platform._egl_context = None
        platform._egl_display = None

    platform.delete_context = delete_context


def _read_color_without_depth(renderer: Any) -> None:
    """Make a renderer skip the depth read-back on colour renders (it costs ~15 % of a frame).

    Wraps pyrender 0.1.45's ``Renderer._read_main_framebuffer`` of this one renderer; depth renders
    (``DEPTH_ONLY``) keep the original path. Does nothing where the internals differ.
    """
    inner: Any = getattr(renderer, "_renderer", None)
    original = getattr(inner, "_read_main_framebuffer", None)
    if original is None or not hasattr(inner, "_main_fb_ms"):
        return
    from OpenGL import GL

    def read(scene: Any, flags: int) -> Any:
        if flags & (pyrender.RenderFlags.DEPTH_ONLY | pyrender.RenderFlags.RGBA):
            return original(scene, flags)
        width, height = inner._main_fb_dims[0], inner._main_fb_dims[1]
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, inner._main_fb_ms)
        GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, inner._main_fb)
        GL.glBlitFramebuffer(
            0, 0, width, height, 0, 0, width, height, GL.GL_COLOR_BUFFER_BIT, GL.GL_LINEAR
        )
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, inner._main_fb)
        buf = GL.glReadPixels(0, 0, width, height, GL.GL_RGB, GL.GL_UNSIGNED_BYTE)
        color = np.frombuffer(buf, dtype=np.uint8).reshape((height, width, 3))
        return np.flip(color, axis=0), None

    inner._read_main_framebuffer = read


def _camera_pose(cam2world: FloatArray) -> FloatArray:
    """pyrender (OpenGL) camera pose from an OpenCV-convention camera-to-world transform."""
    return cam2world @ _OPENCV_TO_OPENGL


class StereoRenderer:
    """Renders rectified stereo pairs and depth maps of a scene from a stereo head pose.

    The pyrender scene is built once in the constructor; the OpenGL context (an
    ``OffscreenRenderer``) is created on first use and released by :meth:`close`.

    Args:
        rig: The stereo rig (image size, focal length, principal point, baseline).
        scene: The scene to draw.
        znear_m: Near clipping distance, metres.
        zfar_m: Far clipping distance, metres.
    """

    def __init__(
        self, rig: StereoRig, scene: Scene, *, znear_m: float = 0.05, zfar_m: float = 100.0
    ) -> None:
        if not isinstance(rig, StereoRig):
            raise ValueError(f"rig must be a StereoRig, got {type(rig).__name__}")
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be a Scene, got {type(scene).__name__}")
        if not (0 < znear_m < zfar_m):
            raise ValueError(
                f"znear_m and zfar_m must satisfy 0 < znear_m < zfar_m, got {znear_m}, {zfar_m}"
            )
        self.rig = rig
        self._znear = float(znear_m)
        self._zfar = float(zfar_m)
        self._renderer: Any = None
        self._pr_scene = pyrender.Scene(
            bg_color=np.array([*BACKGROUND_COLOR, 1.0]), ambient_light=np.ones(3)
        )
        assert rig.cx_px is not None and rig.cy_px is not None
        camera = pyrender.IntrinsicsCamera(
            fx=rig.focal_px,
            fy=rig.focal_px,
            cx=rig.cx_px + 0.5,
            cy=rig.cy_px + 0.5,
            znear=self._znear,
            zfar=self._zfar,
        )
        self._camera_node = self._pr_scene.add(camera, pose=np.eye(4))
        light = pyrender.DirectionalLight(color=np.ones(3), intensity=3.0)
        self._pr_scene.add(light, pose=_camera_pose(np.eye(4)))
        self._mesh_node: Any = None
        self.scene = scene
        self.set_scene(scene)

    # ------------------------------------------------------------------ scene
    def set_scene(self, scene: Scene) -> None:
        """Replace the drawn scene (the OpenGL context, if any, is kept)."""
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be a Scene, got {type(scene).__name__}")
        mesh = pyrender.Mesh.from_trimesh(build_scene_mesh(scene), smooth=False)
        if self._mesh_node is not None:
            self._pr_scene.remove_node(self._mesh_node)
        self._mesh_node = self._pr_scene.add(mesh)
        self.scene = scene

    # ------------------------------------------------------------------ context
    def _offscreen(self) -> Any:
        global _CONTEXT_PID
        check_not_forked()
        if self._renderer is None:
            try:
                renderer = pyrender.OffscreenRenderer(self.rig.width_px, self.rig.height_px)
            except Exception as exc:  # pragma: no cover - depends on the machine
                platform = os.environ.get("PYOPENGL_PLATFORM")
                raise RuntimeError(
                    f"could not create an OpenGL context with PYOPENGL_PLATFORM={platform!r}: "
                    f"{exc}. Headless rendering needs Mesa's EGL (libegl1, libgl1-mesa-dri) or "
                    "OSMesa (libosmesa6, then set PYOPENGL_PLATFORM=osmesa before importing)."
                ) from exc
            _keep_shared_display(renderer)
            _read_color_without_depth(renderer)
            self._renderer = renderer
            if _CONTEXT_PID is None:
                _CONTEXT_PID = os.getpid()
        return self._renderer

    def close(self) -> None:
        """Release the OpenGL context; idempotent. Rendering again creates a new one.

        In a forked child the inherited context is dropped without a call into OpenGL (which
        would hang)."""
        renderer, self._renderer = self._renderer, None
        if renderer is not None and _CONTEXT_PID != os.getpid():
            renderer.delete = _no_op  # its __del__ would call into the dead context
        elif renderer is not None:
            try:
                renderer.delete()
            except Exception:  # pragma: no cover - context already gone at interpreter exit
                pass

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # pragma: no cover
            pass

    def __getstate__(self) -> dict[str, Any]:
        return {"rig": self.rig, "scene": self.scene, "znear": self._znear, "zfar": self._zfar}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(state["rig"], state["scene"], znear_m=state["znear"], zfar_m=state["zfar"])  # type: ignore[misc]

    # ------------------------------------------------------------------ rendering
    def _render(self, cam2world: FloatArray, flags: int) -> Any:
        renderer = self._offscreen()
        self._pr_scene.set_pose(self._camera_node, _camera_pose(cam2world))
        return renderer.render(self._pr_scene, flags=flags)

    def _right_cam2world(self, head_pose: HeadPose) -> FloatArray:
        T = head_pose.cam2world.copy()
        T[:3, 3] = head_pose.right_camera_position(self.rig)
        return T

    def render_view(self, head_pose: HeadPose, *, right: bool = False) -> UInt8Image:
        """One view: uint8 (H, W, 3) RGB from the left (default) or the right camera."""
        if not isinstance(head_pose, HeadPose):
            raise ValueError(f"head_pose must be a HeadPose, got {type(head_pose).__name__}")
        T = self._right_cam2world(head_pose) if right else head_pose.cam2world
        color, _ = self._render(T, pyrender.RenderFlags.FLAT)
        return np.ascontiguousarray(color)

    def render_stereo(self, head_pose: HeadPose) -> tuple[UInt8Image, UInt8Image]:
        """The rectified pair seen from ``head_pose`` (the LEFT optical centre).

        Returns:
            ``(left, right)``: uint8 (H, W, 3) RGB images, row-aligned, noise-free.
        """
        return self.render_view(head_pose), self.render_view(head_pose, right=True)

    def render_depth(self, head_pose: HeadPose, *, right: bool = False) -> FloatArray:
        """Ground-truth depth (H, W) float64, metres along the optical axis (camera z).

        Pixels that see no surface (background) are ``inf``. Depth is resolved from one of the 4
        multisamples (not averaged), i.e. taken up to ~0.4 px from the pixel centre: at an object's
        silhouette a pixel takes one side's depth, and on a slanted surface such as the floor it is
        off by that sub-pixel shift (about 0.3 % at the bottom row of the default rig).
        """
        if not isinstance(head_pose, HeadPose):
            raise ValueError(f"head_pose must be a HeadPose, got {type(head_pose).__name__}")
        T = self._right_cam2world(head_pose) if right else head_pose.cam2world
        depth = self._render(T, pyrender.RenderFlags.FLAT | pyrender.RenderFlags.DEPTH_ONLY)
        out = np.asarray(depth, dtype=np.float64).copy()
        out[out <= 0] = np.inf
        return out
