"""Indoor scenes: their types, furniture parts, the JSON map format and a seeded generator.

A :class:`Scene` is what the simulator knows for certain: the room's bounds, the obstacles (each
with its true 2D collision outline and the 3D boxes that draw it), the robot's start pose and the
goal. The package has one module per concept:

* :mod:`~stereo_nav_env.sim.scenes.types`: :class:`Scene`, :class:`Obstacle`, :class:`BoxPart`,
  :class:`Gap`, :class:`ObstacleKind` (true gaps: :meth:`Scene.gaps`, :meth:`Scene.doubtful_gaps`),
* :mod:`~stereo_nav_env.sim.scenes.parts`: the rendered prisms of each kind (:func:`make_obstacle`),
* :mod:`~stereo_nav_env.sim.scenes.map_io`: the JSON map format (``stereo-nav-map/1``,
  :func:`load_map`, :func:`save_map`), the bundled maps and :func:`load_scenario`,
* :mod:`~stereo_nav_env.sim.scenes.generator`: the families and their layouts
  (:func:`generate_scene`),
* :mod:`~stereo_nav_env.sim.scenes.surface`: surface detail on the faces (seams, door frames,
  fronts, book spines: :func:`add_surface_detail`, :func:`plain_surfaces`).

Every public name is importable from here: ``from stereo_nav_env.sim.scenes import Scene``.
"""

from stereo_nav_env.sim.scenes.generator import (
    BOX_PALETTE,
    CURRICULUM_FAMILIES,
    FAMILIES,
    STANDARD_FAMILIES,
    WALL_THICKNESS_M,
    generate_scene,
)
from stereo_nav_env.sim.scenes.map_io import (
    MAP_FORMAT,
    MAP_LIMITS,
    MAPS_DIR,
    MapLimits,
    available_maps,
    check_navigable,
    load_map,
    load_scenario,
    save_map,
    scene_from_json,
    scene_to_json,
)
from stereo_nav_env.sim.scenes.parts import make_obstacle, oriented_rect
from stereo_nav_env.sim.scenes.surface import (
    add_surface_detail,
    has_surface_detail,
    plain_surfaces,
)
from stereo_nav_env.sim.scenes.types import (
    DEFAULT_COLOR,
    DEFAULT_HEIGHT_M,
    DEFAULT_MARGIN_M,
    DEFAULT_ROBOT_WIDTH_M,
    BoxPart,
    DetailKind,
    FaceFeature,
    Gap,
    Obstacle,
    ObstacleKind,
    Scene,
    outline_sides,
)

__all__ = [
    "BOX_PALETTE",
    "CURRICULUM_FAMILIES",
    "DEFAULT_COLOR",
    "DEFAULT_HEIGHT_M",
    "DEFAULT_MARGIN_M",
    "DEFAULT_ROBOT_WIDTH_M",
    "FAMILIES",
    "MAPS_DIR",
    "MAP_FORMAT",
    "MAP_LIMITS",
    "STANDARD_FAMILIES",
    "WALL_THICKNESS_M",
    "BoxPart",
    "DetailKind",
    "FaceFeature",
    "Gap",
    "MapLimits",
    "Obstacle",
    "ObstacleKind",
    "Scene",
    "add_surface_detail",
    "available_maps",
    "check_navigable",
    "generate_scene",
    "has_surface_detail",
    "load_map",
    "load_scenario",
    "make_obstacle",
    "oriented_rect",
    "outline_sides",
    "plain_surfaces",
    "save_map",
    "scene_from_json",
    "scene_to_json",
]
