"""A behaviour fingerprint of the environments, for refactors that must change nothing.

    python scripts/fingerprint.py --json FILE [--case NAME ...] [--compare OLD.json]

Each case makes one env (id and keywords below), resets it with seed 7, takes seeded random
actions and hashes, step by step and each under its own kind, the observation with the reward and
the end flags (``obs``), the info (``info``), the view's model (``model``), what comes of the
fused memory (``memory``: ``memory_model`` and the ``memory_*`` diagnostics) and every tenth
rendered frame (``frame``). The hash
walks dataclasses, arrays, dicts and sequences by value and names classes without their module,
so moving code between modules keeps it; any change of a value, a dtype or a shape changes it.
``--compare`` prints the cases whose hashes differ from an earlier file's, with the kinds that
differ, and exits 1 if any do.
"""

from __future__ import annotations

import argparse
import dataclasses
import enum
import hashlib
import json
import os
import pathlib
import sys
from typing import Any

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import gymnasium as gym
import numpy as np

import stereo_nav_env  # noqa: F401  (registers the ids)

CASES: dict[str, tuple[str, dict[str, Any], int]] = {
    "v0_stereo_memory": ("StereoNav-v0", {"memory": True}, 40),
    "v0_default_obs": ("StereoNav-v0", {}, 40),
    "v1_stereo": ("StereoNav-v1", {}, 40),
    "v1_surrogate_office": ("StereoNav-v1", {"perception": "surrogate", "scenario": "office"}, 80),
    "v0_surrogate_memory_cluttered": (
        "StereoNav-v0",
        {"perception": "surrogate", "scenario": "cluttered", "memory": True},
        60,
    ),
    "v1_stereo_ground_room": ("StereoNav-v1", {"scenario": "room", "ground_lines": True}, 30),
    "discrete_v0_images": (
        "StereoNavDiscrete-v0",
        {"observation_mode": "both", "scenario": "corridor"},
        25,
    ),
    "v0_model_memory": (
        "StereoNav-v0",
        {"observation_mode": "model_memory", "perception": "surrogate"},
        50,
    ),
}
"""Name: (env id, ``gym.make`` keywords, steps)."""

KINDS = ("obs", "info", "model", "memory", "frame")


def _feed(x: Any, h: Any, depth: int = 0) -> None:
    """Feed ``x``'s content to the hash ``h`` (see the module doc)."""
    if depth > 40:
        h.update(b"<deep>")
    elif x is None or isinstance(x, bool | int | str):
        h.update(repr(x).encode())
    elif isinstance(x, enum.Enum):
        h.update(f"{type(x).__name__}.{x.name}".encode())
    elif isinstance(x, float | np.generic):
        h.update(np.asarray(x, np.float64 if isinstance(x, float) else None).tobytes())
    elif isinstance(x, np.ndarray):
        h.update(str((x.dtype.str, x.shape)).encode())
        if x.dtype == object:
            for v in x.ravel():
                _feed(v, h, depth + 1)
        else:
            h.update(np.ascontiguousarray(x).tobytes())
    elif isinstance(x, dict):
        for k in sorted(x, key=repr):
            _feed(k, h, depth + 1)
            _feed(x[k], h, depth + 1)
    elif isinstance(x, list | tuple | set | frozenset):
        items = sorted(x, key=repr) if isinstance(x, set | frozenset) else x
        h.update(b"(")
        for v in items:
            _feed(v, h, depth + 1)
        h.update(b")")
    elif dataclasses.is_dataclass(x):
        h.update(type(x).__name__.encode())
        for f in dataclasses.fields(x):
            h.update(f.name.encode())
            _feed(getattr(x, f.name), h, depth + 1)
    elif hasattr(x, "wkb"):  # a shapely geometry
        h.update(x.wkb)
    else:
        h.update(type(x).__name__.encode())
        names = sorted(getattr(x, "__dict__", {}))
        for name in names:
            h.update(name.encode())
            _feed(getattr(x, name), h, depth + 1)
        if not names:
            h.update(repr(x).encode())


def digest(x: Any) -> str:
    """A 16-hex-digit hash of ``x``'s content."""
    h = hashlib.sha256()
    _feed(x, h)
    return h.hexdigest()[:16]


def _split_info(info: dict[str, Any]) -> dict[str, Any]:
    """``info`` as the ``info``, ``model`` and ``memory`` kinds (see the module doc)."""
    diagnostics = info.get("diagnostics", {})
    rest = {k: v for k, v in info.items() if k not in ("model", "memory_model", "diagnostics")}
    rest["diagnostics"] = {k: v for k, v in diagnostics.items() if not k.startswith("memory_")}
    memory = {k: v for k, v in diagnostics.items() if k.startswith("memory_")}
    return {"info": rest, "model": info.get("model"), "memory": (info.get("memory_model"), memory)}


def run_case(name: str) -> dict[str, Any]:
    """The per-step hashes of case ``name`` by kind, and each kind's combined hash."""
    env_id, kwargs, steps = CASES[name]
    env = gym.make(env_id, render_mode="rgb_array", **kwargs)
    rows: dict[str, list[str]] = {kind: [] for kind in KINDS}

    def add(obs: Any, info: dict[str, Any], *rest: Any) -> None:
        rows["obs"].append(digest((obs, *rest)))
        for kind, value in _split_info(info).items():
            rows[kind].append(digest(value))

    obs, info = env.reset(seed=7)
    env.action_space.seed(11)
    add(obs, info)
    rows["frame"].append(digest(env.render()))
    for t in range(steps):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        add(obs, info, reward, terminated, truncated)
        if t % 10 == 0:
            rows["frame"].append(digest(env.render()))
        if terminated or truncated:
            obs, info = env.reset()
            add(obs, info)
    env.close()
    return {"hash": digest(rows), "kinds": {k: digest(v) for k, v in rows.items()}, "steps": rows}


def main(argv: list[str] | None = None) -> int:
    """Run the cases, write the JSON, compare with an earlier one; the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=pathlib.Path, required=True, help="output file")
    parser.add_argument("--case", action="append", choices=sorted(CASES), help="(repeat)")
    parser.add_argument("--compare", type=pathlib.Path, help="an earlier output to compare with")
    args = parser.parse_args(argv)
    results = {name: run_case(name) for name in args.case or CASES}
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(results, indent=1) + "\n")
    for name, result in results.items():
        print(f"{name:32s} {result['hash']}")
    if args.compare is None:
        return 0
    old = json.loads(args.compare.read_text())
    differ = [n for n in results if n in old and old[n]["hash"] != results[n]["hash"]]
    for name in differ:
        kinds = [k for k in KINDS if old[name]["kinds"][k] != results[name]["kinds"][k]]
        print(f"DIFFERS: {name} in {', '.join(kinds)}")
    print("identical" if not differ else f"{len(differ)} case(s) differ")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
