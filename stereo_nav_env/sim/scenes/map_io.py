"""Map I/O: the JSON map format, bundled maps, and scenes by name.

JSON map format.

A :class:`Scene` is what the simulator knows for certain: the room's bounds, the obstacles (each
with its true 2D collision outline and the 3D boxes that draw it), the robot's start pose and the
goal. Frames and units follow ARCHITECTURE.md: world metres, floor plane x-y, z up, headings in
radians counter-clockwise from +x.

Obstacles
---------
Every obstacle has a ``kind`` (:class:`ObstacleKind`), a ``footprint`` (k, 2) polygon in world
metres that is the robot's true collision outline, a height and a tuple of :class:`BoxPart` prisms
used only for rendering. A table's footprint is the outline of its top: the robot (1.0 m tall)
cannot pass under a 0.75 m table, although the camera sees the floor between its legs. Parts are
built from the kind (:func:`make_obstacle`): tables and chairs stand on legs, bookshelves carry
shelf boards and vertical dividers whose repeated front edges make stereo matching ambiguous, walls
and boxes are plain prisms. Walls with doorways are several wall obstacles; the doorway is the gap
between them.

Gaps
----
:meth:`Scene.gaps` lists the true gaps between pairs of obstacles (closest points, width), the
ground truth for passability; :meth:`Scene.doubtful_gaps` keeps those within a relative tolerance
of the robot's width. Generated scenes always have at least two doubtful gaps (width within 30 % of
the robot width) and a route from start to goal that the robot fits through.

JSON map format (``stereo-nav-map/1``)
--------------------------------------
A map file is one JSON object::

    {
      "format": "stereo-nav-map/1",          # optional; if present it must be this string
      "name": "default",                      # optional, default: the file's stem
      "bounds": [xmin, ymin, xmax, ymax],     # metres, the floor area (xmin < xmax, ymin < ymax)
      "start": [x, y, heading_rad],           # robot start pose, inside the bounds
      "goal": [x, y],                         # goal position, inside the bounds
      "obstacles": [                          # list, may be empty
        {
          "kind": "wall" | "table" | "chair" | "bookshelf" | "box",
          "footprint": [[x, y], ...],         # >= 3 points, a simple polygon, metres, world frame
          "rect": {"center": [x, y], "size": [length, depth], "yaw_deg": 0.0},
                                              # alternative to "footprint": an oriented rectangle
                                              # whose length runs along yaw; exactly one of the two
          "height": 0.75,                     # metres, > 0 (default per kind, see DEFAULT_HEIGHT_M)
          "color": [r, g, b],                 # optional, each in [0, 1] (default per kind)
          "parts": [                          # optional; default: built from kind/footprint/height
            {"footprint": [[x, y], ...], "z": [z_min, z_max], "color": [r, g, b]}
          ],
          "detail": [                         # optional surface detail (surface.py)
            {"kind": "seam" | "door_frame" | "front" | "spine", "face": 0, "offset": 0.5,
             "width": 0.05, "z": [z_min, z_max], "color": [r, g, b]}
          ]
        }
      ]
    }

Tables, chairs and bookshelves need a rectangular footprint to get their legs, seat or shelves
(their front, i.e. a bookshelf's open side or a chair's seat edge, is the side from the first to
the second footprint corner); other footprints are drawn as one prism. A bookshelf's footprint runs
counter-clockwise with the front first. :func:`load_map` raises ``ValueError`` naming the bad field,
e.g. ``obstacles[2].footprint must have shape (k, 2) with k >= 3``.
"""

from __future__ import annotations

import json
import math
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from shapely.geometry import Point

from modeling.validation import positive
from stereo_nav_env.sim.scenes.generator import FAMILIES, STANDARD_FAMILIES, generate_scene
from stereo_nav_env.sim.scenes.parts import build_parts, make_obstacle, oriented_rect
from stereo_nav_env.sim.scenes.surface import (
    add_surface_detail,
    has_surface_detail,
    plain_surfaces,
)
from stereo_nav_env.sim.scenes.types import (
    DEFAULT_COLOR,
    DEFAULT_HEIGHT_M,
    DEFAULT_ROBOT_WIDTH_M,
    BoxPart,
    DetailKind,
    FaceFeature,
    Obstacle,
    ObstacleKind,
    Scene,
    _color,
    _err,
    _member,
    _number,
    _polygon_array,
    _vector,
)

__all__ = [
    "MAPS_DIR",
    "MAP_FORMAT",
    "MAP_LIMITS",
    "MapLimits",
    "available_maps",
    "check_navigable",
    "load_map",
    "load_scenario",
    "save_map",
    "scene_from_json",
    "scene_to_json",
]

MAPS_DIR = pathlib.Path(__file__).resolve().parent.parent / "maps"
"""The bundled maps, ``stereo_nav_env/sim/maps/*.json``."""
MAP_FORMAT = "stereo-nav-map/1"


def _obstacle_to_json(ob: Obstacle) -> dict[str, Any]:
    out: dict[str, Any] = {
        "kind": ob.kind.value,
        "footprint": np.round(ob.footprint, 6).tolist(),
        "height": round(ob.height_m, 6),
        "color": [round(c, 6) for c in ob.color],
    }
    default = build_parts(ob.kind, ob.footprint, ob.height_m, ob.color)
    same = len(default) == len(ob.parts) and all(
        a.footprint.shape == b.footprint.shape
        and np.allclose(a.footprint, b.footprint, atol=1e-6)
        and abs(a.z_min_m - b.z_min_m) < 1e-6
        and abs(a.z_max_m - b.z_max_m) < 1e-6
        and np.allclose(a.color, b.color, atol=1e-6)
        for a, b in zip(default, ob.parts, strict=True)
    )
    if not same:
        out["parts"] = [
            {
                "footprint": np.round(p.footprint, 6).tolist(),
                "z": [p.z_min_m, p.z_max_m],
                "color": list(p.color),
            }
            for p in ob.parts
        ]
    if ob.detail:
        out["detail"] = [
            {
                "kind": f.kind.value,
                "face": f.face,
                "offset": f.offset_m,
                "width": f.width_m,
                "z": [f.z_min_m, f.z_max_m],
                "color": list(f.color),
            }
            for f in ob.detail
        ]
    return out


def scene_to_json(scene: Scene) -> dict[str, Any]:
    """The JSON-ready dict of a scene (map format ``stereo-nav-map/1``, see the module doc)."""
    return {
        "format": MAP_FORMAT,
        "name": scene.name,
        "bounds": list(scene.bounds),
        "start": list(scene.start),
        "goal": list(scene.goal),
        "obstacles": [_obstacle_to_json(ob) for ob in scene.obstacles],
    }


def save_map(scene: Scene, path: str | pathlib.Path) -> pathlib.Path:
    """Write a scene as a JSON map file; returns the path."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(scene_to_json(scene), indent=1) + "\n")
    return path


@dataclass(frozen=True, slots=True, kw_only=True)
class MapLimits:
    """What a map file may hold, so that no file makes loading or a reset take minutes.

    Attributes:
        max_bytes: Size of the file, bytes.
        max_obstacles: Obstacles.
        max_vertices: Vertices of one footprint or part.
        max_parts: Rendering parts of one obstacle.
        max_detail: Surface-detail features of one obstacle.
        max_area_m2: Area of the bounds, square metres (the geodesic grid of the rewards covers
            it with 5 cm cells).
    """

    max_bytes: int = 4 * 2**20
    max_obstacles: int = 1_000
    max_vertices: int = 256
    max_parts: int = 64
    max_detail: int = 512
    max_area_m2: float = 2_500.0


MAP_LIMITS = MapLimits()
"""The limits :func:`load_map` and :func:`scene_from_json` enforce."""


def _limited(items: Any, field: str, limit: int, what: str) -> None:
    if isinstance(items, list) and len(items) > limit:
        raise _err(field, f"has {len(items)} {what}, more than the limit of {limit}")


def _obstacle_from_json(data: Any, field: str) -> Obstacle:
    if not isinstance(data, Mapping):
        raise _err(field, f"must be an object, got {type(data).__name__}")
    unknown = sorted(
        set(data) - {"kind", "footprint", "rect", "height", "color", "parts", "detail"}
    )
    if unknown:
        raise _err(field, f"has unknown keys {unknown}")
    if "kind" not in data:
        raise _err(f"{field}.kind", "is missing")
    kind = _member(ObstacleKind, data["kind"], f"{field}.kind")
    if ("footprint" in data) == ("rect" in data):
        raise _err(field, "must have exactly one of 'footprint' or 'rect'")
    if "footprint" in data:
        _limited(data["footprint"], f"{field}.footprint", MAP_LIMITS.max_vertices, "vertices")
        fp = _polygon_array(data["footprint"], f"{field}.footprint")
    else:
        rect = data["rect"]
        if not isinstance(rect, Mapping):
            raise _err(f"{field}.rect", "must be an object with center, size, yaw_deg")
        c = _vector(rect.get("center"), f"{field}.rect.center", 2)
        size = _vector(rect.get("size"), f"{field}.rect.size", 2)
        if size[0] <= 0 or size[1] <= 0:
            raise _err(f"{field}.rect.size", f"must be positive, got {list(size)}")
        yaw = math.radians(_number(rect.get("yaw_deg", 0.0), f"{field}.rect.yaw_deg"))
        fp = oriented_rect(c, size[0], size[1], yaw)
    height = _number(data.get("height", DEFAULT_HEIGHT_M[kind]), f"{field}.height")
    if height <= 0:
        raise _err(f"{field}.height", f"must be positive, got {height}")
    color = _color(data["color"], f"{field}.color") if "color" in data else DEFAULT_COLOR[kind]
    obstacle = _obstacle_body(data, field, kind, fp, height, color)
    if "detail" not in data:
        return obstacle
    detail = _detail_from_json(data["detail"], f"{field}.detail")
    try:
        return replace(obstacle, detail=detail)
    except ValueError as exc:  # a feature off its face or above the top: name the obstacle
        raise ValueError(f"{field}.{exc}") from exc


def _detail_from_json(raw: Any, field: str) -> tuple[FaceFeature, ...]:
    if not isinstance(raw, list):
        raise _err(field, "must be a list")
    _limited(raw, field, MAP_LIMITS.max_detail, "features")
    out = []
    for k, f in enumerate(raw):
        ff = f"{field}[{k}]"
        if not isinstance(f, Mapping):
            raise _err(ff, "must be an object")
        unknown = sorted(set(f) - {"kind", "face", "offset", "width", "z", "color"})
        if unknown:
            raise _err(ff, f"has unknown keys {unknown}")
        for key in ("kind", "face", "offset", "width", "z", "color"):
            if key not in f:
                raise _err(f"{ff}.{key}", "is missing")
        kind = _member(DetailKind, f["kind"], f"{ff}.kind")
        face = f["face"]
        if isinstance(face, bool) or not isinstance(face, int) or face < 0:
            raise _err(f"{ff}.face", f"must be a non-negative integer, got {face!r}")
        offset = _number(f["offset"], f"{ff}.offset")
        width = _number(f["width"], f"{ff}.width")
        if width <= 0:
            raise _err(f"{ff}.width", f"must be positive, got {width}")
        z = _vector(f["z"], f"{ff}.z", 2)
        if not 0 <= z[0] < z[1]:
            raise _err(f"{ff}.z", f"must satisfy 0 <= z_min < z_max, got {list(z)}")
        out.append(
            FaceFeature(
                kind=kind,
                face=face,
                offset_m=offset,
                width_m=width,
                z_min_m=z[0],
                z_max_m=z[1],
                color=_color(f["color"], f"{ff}.color"),
            )
        )
    return tuple(out)


def _obstacle_body(
    data: Mapping[str, Any],
    field: str,
    kind: ObstacleKind,
    fp: Any,
    height: float,
    color: Any,
) -> Obstacle:
    """The obstacle of a map entry without its detail: default or listed parts."""
    if "parts" not in data:
        return make_obstacle(kind, fp, height, color)
    raw_parts = data["parts"]
    if not isinstance(raw_parts, list) or not raw_parts:
        raise _err(f"{field}.parts", "must be a non-empty list")
    _limited(raw_parts, f"{field}.parts", MAP_LIMITS.max_parts, "parts")
    parts = []
    for k, p in enumerate(raw_parts):
        pf = f"{field}.parts[{k}]"
        if not isinstance(p, Mapping):
            raise _err(pf, "must be an object")
        _limited(p.get("footprint"), f"{pf}.footprint", MAP_LIMITS.max_vertices, "vertices")
        pfp = _polygon_array(p.get("footprint"), f"{pf}.footprint")
        z = _vector(p.get("z"), f"{pf}.z", 2)
        if not 0 <= z[0] < z[1]:
            raise _err(f"{pf}.z", f"must satisfy 0 <= z_min < z_max, got {list(z)}")
        pc = _color(p["color"], f"{pf}.color") if "color" in p else color
        parts.append(BoxPart(footprint=pfp, z_min_m=z[0], z_max_m=z[1], color=pc))
    return Obstacle(kind=kind, footprint=fp, height_m=height, color=color, parts=tuple(parts))


def scene_from_json(data: Any, *, default_name: str = "map") -> Scene:
    """A scene from a parsed JSON map (see the module doc); ``ValueError`` names a bad field."""
    if not isinstance(data, Mapping):
        raise ValueError(f"map must be a JSON object, got {type(data).__name__}")
    unknown = sorted(set(data) - {"format", "name", "bounds", "start", "goal", "obstacles"})
    if unknown:
        raise ValueError(f"map has unknown keys {unknown}")
    if "format" in data and data["format"] != MAP_FORMAT:
        raise _err("format", f"must be {MAP_FORMAT!r}, got {data['format']!r}")
    for key in ("bounds", "start", "goal", "obstacles"):
        if key not in data:
            raise _err(key, "is missing")
    name = data.get("name", default_name)
    if not isinstance(name, str):
        raise _err("name", f"must be a string, got {name!r}")
    bounds = _vector(data["bounds"], "bounds", 4)
    if not (bounds[0] < bounds[2] and bounds[1] < bounds[3]):
        raise _err("bounds", f"must satisfy xmin < xmax and ymin < ymax, got {list(bounds)}")
    area = (bounds[2] - bounds[0]) * (bounds[3] - bounds[1])
    if area > MAP_LIMITS.max_area_m2:
        raise _err(
            "bounds", f"cover {area:.6g} m^2, more than the limit of {MAP_LIMITS.max_area_m2} m^2"
        )
    start = _vector(data["start"], "start", 3)
    goal = _vector(data["goal"], "goal", 2)
    if not isinstance(data["obstacles"], list):
        raise _err("obstacles", "must be a list")
    _limited(data["obstacles"], "obstacles", MAP_LIMITS.max_obstacles, "entries")
    obstacles = tuple(
        _obstacle_from_json(ob, f"obstacles[{i}]") for i, ob in enumerate(data["obstacles"])
    )
    return Scene(name=name, bounds=bounds, obstacles=obstacles, start=start, goal=goal)  # type: ignore[arg-type]


def load_map(path: str | pathlib.Path) -> Scene:
    """Load a JSON map file (see the module docstring for the format).

    Raises:
        ValueError: The file is not valid JSON or a field is malformed (the message names it).
    """
    path = pathlib.Path(path)
    size = path.stat().st_size
    if size > MAP_LIMITS.max_bytes:
        raise ValueError(
            f"map {path} has {size} bytes, more than the limit of {MAP_LIMITS.max_bytes}"
        )
    try:
        data = json.loads(path.read_bytes().decode("utf-8"), parse_constant=_no_constant)
    except UnicodeDecodeError as exc:
        raise ValueError(f"map {path} is not UTF-8 text: {exc}") from exc
    except json.JSONDecodeError as exc:
        raise ValueError(f"map {path} is not valid JSON: {exc}") from exc
    except RecursionError as exc:
        raise ValueError(f"map {path} nests too deeply") from exc
    return scene_from_json(data, default_name=path.stem)


def _no_constant(name: str) -> Any:
    raise ValueError(f"map values must be finite numbers, got {name}")


_MAX_NAMED = 8
"""Obstacles named at most by the error of an unreachable goal (then "and N more")."""
_MAX_TRIED = 16
"""Obstacles taken away one at a time at most (each try recomputes the free area)."""
_TOUCH_M = 1e-4
"""Distance, metres, under which a grown footprint counts as bordering a piece of free area."""


def _obstacle_names(scene: Scene, indices: list[int]) -> str:
    """``obstacles[i] (kind at (x, y))`` of each index (its centroid), ``_MAX_NAMED`` at most."""
    names = []
    for i in indices[:_MAX_NAMED]:
        c = scene.obstacles[i].polygon.centroid
        names.append(f"obstacles[{i}] ({scene.obstacles[i].kind.value} at ({c.x:.3g}, {c.y:.3g}))")
    more = f" and {len(indices) - _MAX_NAMED} more" if len(indices) > _MAX_NAMED else ""
    return ", ".join(names) + more


def _cut_off(scene: Scene, robot_width_m: float) -> str:
    """The obstacles that keep the goal from the start, as the end of the error message (for a
    scene whose start and goal are free but not connected).

    The free area (where the robot's centre may be: :meth:`Scene.free_space`) falls into pieces.
    The barrier is the obstacles whose footprints, grown by the robot's radius, border both the
    start's piece and the goal's. Named are, in this order of preference: those of the barrier
    whose removal alone opens a route (tried when the barrier has at most ``_MAX_TRIED``); else
    the barrier; else (free pockets lie between the two pieces) those bordering the smaller of
    the two pieces.
    """
    free = scene.free_space(robot_width_m, margin_m=0.0)
    pieces = list(getattr(free, "geoms", [free]))
    start_piece = next(p for p in pieces if p.contains(Point(*scene.start[:2])))
    goal_piece = next(p for p in pieces if p.contains(Point(*scene.goal)))
    grown = [ob.polygon.buffer(robot_width_m / 2.0, quad_segs=8) for ob in scene.obstacles]
    near_start = [i for i, g in enumerate(grown) if g.distance(start_piece) < _TOUCH_M]
    near_goal = [i for i, g in enumerate(grown) if g.distance(goal_piece) < _TOUCH_M]
    barrier = sorted(set(near_start) & set(near_goal))
    tried = len(barrier) <= _MAX_TRIED
    blocking = [
        i
        for i in (barrier if tried else [])
        if replace(scene, obstacles=scene.obstacles[:i] + scene.obstacles[i + 1 :]).route_exists(
            robot_width_m, margin_m=0.0
        )
    ]
    if len(blocking) == 1:
        return f"{_obstacle_names(scene, blocking)} blocks the way (removing it opens a route)"
    if blocking:
        return (
            f"{_obstacle_names(scene, blocking)} block the way "
            "(removing any one of them opens a route)"
        )
    if barrier:
        verb = "stands" if len(barrier) == 1 else "stand"
        alone = " (no one of them alone blocks the way)" if tried and len(barrier) > 1 else ""
        return f"{_obstacle_names(scene, barrier)} {verb} between start and goal{alone}"
    if start_piece.area < goal_piece.area:
        return f"the start is walled in by {_obstacle_names(scene, near_start)}"
    return f"the goal is walled in by {_obstacle_names(scene, near_goal)}"


def check_navigable(scene: Scene, robot_width_m: float) -> Scene:
    """``scene`` if a robot of ``robot_width_m`` can drive it: start and goal clear of every
    footprint by the robot's radius and inside the bounds, and the goal reachable for the
    robot's disc.

    Raises:
        ValueError: Naming ``start`` or ``goal`` (with the nearest obstacle), or the goal when it
            cannot be reached (with the obstacles that cut it off, :func:`_cut_off`).
    """
    radius = positive(robot_width_m, "robot_width_m") / 2.0
    for field, xy in (("start", scene.start[:2]), ("goal", scene.goal)):
        if scene.is_free(xy, robot_width_m, margin_m=0.0):
            continue
        point = Point(*xy)
        dist = [ob.polygon.distance(point) for ob in scene.obstacles]
        near = int(np.argmin(dist)) if dist else -1
        where = f"; obstacles[{near}] is {dist[near]:.3g} m away" if near >= 0 else ""
        raise _err(
            field,
            f"{[round(v, 6) for v in xy]} must be inside the bounds and clear of every obstacle "
            f"by the robot's radius {radius:g} m{where}",
        )
    if not scene.route_exists(robot_width_m, margin_m=0.0):
        raise _err(
            "goal",
            f"cannot be reached from start by a robot {robot_width_m:g} m wide: "
            + _cut_off(scene, robot_width_m),
        )
    return scene


def available_maps() -> tuple[str, ...]:
    """Names of the maps bundled in ``stereo_nav_env/sim/maps``."""
    return tuple(sorted(p.stem for p in MAPS_DIR.glob("*.json")))


def load_scenario(
    scenario: str,
    seed: int = 0,
    *,
    robot_width_m: float = DEFAULT_ROBOT_WIDTH_M,
    surface_detail: bool = False,
) -> Scene:
    """A scene by name: a bundled map, a ``.json`` path, a family name, or ``"random"``.

    Args:
        scenario: ``"default"`` or another bundled map name, a path ending in ``.json``, one of
            :data:`FAMILIES` (generated from ``seed``) or ``"random"`` (the family is drawn from
            ``seed`` as well, among :data:`STANDARD_FAMILIES`).
        seed: Seed of generated scenes (and of their surface detail).
        robot_width_m: Robot width the generator guarantees a route for.
        surface_detail: Whether the faces carry surface detail
            (:mod:`~stereo_nav_env.sim.scenes.surface`): a generated scene gets the detail drawn
            from ``seed``; a map keeps the detail it lists, and a map that lists none gets
            detail drawn from its name. ``False``: plain faces (a map's listed detail is
            dropped); the scene is then exactly the one loaded or generated.
    """
    if not isinstance(scenario, str) or not scenario:
        raise ValueError(f"scenario must be a non-empty string, got {scenario!r}")
    if not isinstance(surface_detail, bool):
        raise ValueError(f"surface_detail must be True or False, got {surface_detail!r}")
    if scenario.endswith(".json") or scenario in available_maps():
        path = scenario if scenario.endswith(".json") else MAPS_DIR / f"{scenario}.json"
        scene = check_navigable(load_map(path), robot_width_m)
        if not surface_detail:
            return plain_surfaces(scene)
        return scene if has_surface_detail(scene) else add_surface_detail(scene)
    if scenario == "random" or scenario in FAMILIES:
        family = scenario
        if scenario == "random":
            family = STANDARD_FAMILIES[
                int(np.random.default_rng(seed).integers(len(STANDARD_FAMILIES)))
            ]
        generated = generate_scene(seed, family=family, robot_width_m=robot_width_m)
        return add_surface_detail(generated, seed) if surface_detail else generated
    raise ValueError(
        f"scenario must be a map name {list(available_maps())}, a .json path, a family "
        f"{list(FAMILIES)} or 'random', got {scenario!r}"
    )
