"""Where an agent's collisions come from: every contact of the suite with what was hit and how.

    python scripts/collision_report.py --agent NAME [--episodes N] [--seed S] [--json FILE]
        [--families F [F ...]] [--max-steps N] [--memory]

Runs the suite of ``scripts/evaluate.py`` (the same env and episodes) with one agent and records,
for every step with a contact (``info["collision"]``, the suite's collision steps), the obstacle
kind touched (the true obstacle nearest the robot's centre), the action that led to it, the head
pan, the contact's bearing from the body heading and in how many earlier steps the contact point
lay in the field of view beyond the blind band (``EnvConfig.blind_range_m``) and within
``--view-range`` metres: a contact point often in view was something the model could have shown.
For the model-based agents (``greedy``, ``cautious``, ``planner``) also what their occupancy map
(:class:`agents.planning.gridmap.OccupancyMap`) knew of the contact point: ``held_before`` (a
cell within 0.2 m of it counted as an obstacle just before the step) and ``ever_held`` (one had had
positive log-odds at some earlier step of the episode: held, then cleared, when not
``held_before``). With ``--memory`` (the env keeps its fused memory, which the agents do not
read: the same episodes) also ``fused_distance_m``, the distance from the contact point to the
nearest segment of the env's fused memory (:class:`modeling.memory.fusion.ModelMemory`, existence at
least 0.5) just before the step (null when it held none). Prints counts by family and kind,
and of the first contacts (no contact in the 10 steps before) how many the map had ever held
and how many the fused memory held within 0.1 m; the JSON has every collision step.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import os
import pathlib
from typing import Any

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import gymnasium as gym
import numpy as np
import shapely
import shapely.ops
from evaluate import suite_config

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents import make_agent
from agents.evaluation.suite import ENV_ID, suite_episodes
from modeling.geometry import wrap_angle
from stereo_nav_env.perception.base import PerceptionName


def _views_of(
    point: np.ndarray,
    poses: list[tuple[float, float, float]],
    half_fov: float,
    band: tuple[float, float],
) -> int:
    """How many of the gaze poses ``(x, y, gaze)`` had ``point`` in view at a range in ``band``."""
    if not poses:
        return 0
    p = np.asarray(poses)
    d = point[None, :] - p[:, :2]
    r = np.hypot(d[:, 0], d[:, 1])
    bearing = np.abs(wrap_angle(np.arctan2(d[:, 1], d[:, 0]) - p[:, 2]))
    return int(np.count_nonzero((bearing < half_fov) & (r > band[0]) & (r < band[1])))


def _cells_near(spec: Any, point: np.ndarray, radius_m: float) -> np.ndarray:
    """(ny, nx) the cells of grid ``spec`` whose centres lie within ``radius_m`` of ``point``."""
    X, Y = spec.centers()
    near: np.ndarray = np.hypot(X - point[0], Y - point[1]) <= radius_m
    return near


FUSED_EXISTENCE = 0.5
"""A fused segment at least this probable counts as held (``--memory``)."""

FUSED_NEAR_M = 0.1
"""A contact the fused memory held: a held segment within this of the contact point, metres."""


def _fused_distance(memory: Any, point: np.ndarray) -> float:
    """Distance from ``point`` to the nearest segment of ``memory`` (a ``ModelMemory``) at least
    :data:`FUSED_EXISTENCE` probable, metres (infinite when it holds none)."""
    lines = [
        shapely.LineString(s.endpoints) if s.length_m > 0 else shapely.Point(s.endpoints[0])
        for s, e in zip(memory.segments, memory.existence, strict=True)
        if e >= FUSED_EXISTENCE
    ]
    if not lines:
        return math.inf
    return float(shapely.distance(shapely.Point(point), lines).min())


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    """Parse the arguments, run the suite, print and write the contacts."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent", required=True, help="agent name (see scripts/evaluate.py)")
    parser.add_argument("--episodes", type=int, default=32, help="episodes")
    parser.add_argument("--seed", type=int, default=0, help="suite seed")
    parser.add_argument("--families", nargs="+", default=None, help="scene families")
    parser.add_argument("--max-steps", type=int, default=500, help="steps at most per episode")
    parser.add_argument("--view-range", type=float, default=6.0, help="metres (see above)")
    parser.add_argument("--json", type=pathlib.Path, help="every contact as JSON")
    parser.add_argument(
        "--perception",
        choices=[p.value for p in PerceptionName],
        default=PerceptionName.STEREO.value,
        help="the perception",
    )
    parser.add_argument(
        "--memory", action="store_true", help="also what the env's fused memory held (see above)"
    )
    args = parser.parse_args(argv)
    suite_args = ["--agent", args.agent, "--json", "-"]
    suite_args += ["--episodes", str(args.episodes), "--seed", str(args.seed)]
    suite_args += ["--max-steps", str(args.max_steps), "--perception", args.perception]
    cfg = suite_config(suite_args + (["--families", *args.families] if args.families else []))
    env_kwargs = cfg.env_kwargs | ({"memory": True} if args.memory else {})

    contacts: list[dict[str, Any]] = []
    for spec in suite_episodes(cfg):
        env = gym.make(ENV_ID, scenario=spec.family, **env_kwargs)
        agent = make_agent(args.agent)
        obs, info = env.reset(seed=spec.seed)
        agent.reset(env, seed=spec.seed)
        base: Any = env.unwrapped
        world = base._require_world()
        camera = base.config.camera
        half_fov = math.atan((camera.width_px / 2.0) / camera.focal_px)
        band = (base.config.blind_range_m, args.view_range)
        outlines = [(o.kind.value, shapely.Polygon(o.footprint)) for o in base.scene.obstacles]
        poses: list[tuple[float, float, float]] = []
        most: np.ndarray | None = None  # the highest log-odds of each cell so far
        for step in range(cfg.max_steps):
            state = world.state
            poses.append((state.x_m, state.y_m, state.heading_rad + state.pan_rad))
            fused = base.memory  # before the step (None without --memory)
            core = getattr(agent, "core", None)
            occupied = None if core is None else core.occupancy.occupied()
            if core is not None:
                lo = core.occupancy.log_odds
                most = lo.copy() if most is None else np.maximum(most, lo)
            action = agent.act(obs, info)
            obs, _, terminated, truncated, info = env.step(action)
            if not info.get("collision", False):
                if terminated or truncated:
                    break
                continue
            state = world.state
            centre = shapely.Point(state.x_m, state.y_m)
            kind, outline = min(outlines, key=lambda ko: ko[1].distance(centre))
            point = np.asarray(shapely.ops.nearest_points(outline, centre)[0].coords[0])
            d = point - (state.x_m, state.y_m)
            contacts.append(
                {
                    "episode": spec.index,
                    "family": spec.family,
                    "step": step,
                    "kind": kind,
                    "point_xy": [float(v) for v in point],
                    "action": [float(a) for a in np.atleast_1d(action)],
                    "pan_rad": state.pan_rad,
                    "bearing_rad": float(wrap_angle(math.atan2(d[1], d[0]) - state.heading_rad)),
                    "views_in_range": _views_of(point, poses, half_fov, band),
                }
            )
            if fused is not None:
                dist = _fused_distance(fused, point)
                contacts[-1]["fused_distance_m"] = dist if math.isfinite(dist) else None
            if core is not None and occupied is not None and most is not None:
                near = _cells_near(core.spec, point, 0.2)
                contacts[-1]["held_before"] = bool(occupied[near].any())
                contacts[-1]["ever_held"] = bool((most[near] > 0.0).any())
            if terminated or truncated:
                break
        agent.close()
        env.close()

    by_kind = collections.Counter((c["family"], c["kind"]) for c in contacts)
    print(f"{len(contacts)} contacts in {args.episodes} episodes ({args.agent})")
    for (family, kind), n in sorted(by_kind.items()):
        print(f"  {family:10s} {kind:10s} {n}")
    never = sum(c["views_in_range"] == 0 for c in contacts)
    ahead = sum(abs(c["bearing_rad"]) < math.radians(20.0) for c in contacts)
    print(f"  never in view beyond the blind band: {never}; within 20 deg of the heading: {ahead}")
    first = [
        c
        for k, c in enumerate(contacts)
        if not (
            k
            and contacts[k - 1]["episode"] == c["episode"]
            and c["step"] - contacts[k - 1]["step"] <= 10
        )
    ]
    if first and "ever_held" in first[0]:
        ever = sum(c["ever_held"] for c in first)
        before = sum(c["held_before"] for c in first)
        print(
            f"  first contacts {len(first)}: the map ever held {ever} "
            f"(held just before {before}), never held {len(first) - ever}"
        )
    if first and "fused_distance_m" in first[0]:
        held = sum(
            c["fused_distance_m"] is not None and c["fused_distance_m"] <= FUSED_NEAR_M
            for c in first
        )
        print(
            f"  first contacts {len(first)}: the fused memory held {held} within "
            f"{FUSED_NEAR_M} m just before, not {len(first) - held}"
        )
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(contacts, indent=1) + "\n")
    return contacts


if __name__ == "__main__":
    main()
