"""The main job: render the default scenario and write pictures of it.

    python scripts/demo.py [--scenario NAME] [--seed N] [--out DIR]

Writes ``topdown.png`` (the true world, robot, head and field of view), ``left.png`` and
``right.png`` (the rectified stereo pair seen from the start pose) into ``--out``.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import sys
import time

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import gymnasium as gym

import stereo_nav_env  # noqa: F401  (registers the ids)
from stereo_nav_env.demo_render import write_stereo_pngs, write_topdown_png


def main(argv: list[str] | None = None) -> dict[str, pathlib.Path]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="default", help="map name, .json path or family")
    parser.add_argument("--seed", type=int, default=0, help="seed of the episode")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/demo"))
    args = parser.parse_args(argv)

    t0 = time.perf_counter()
    env = gym.make("StereoNav-v0", scenario=args.scenario)
    try:
        env.reset(seed=args.seed)
        base = env.unwrapped
        left, right = base.render_stereo()
        top = write_topdown_png(
            base.scene,
            args.out / "topdown.png",
            robot_width_m=base.config.robot_width_m,
            head_pose=base.head_pose,
            rig=base.rig,
        )
        lp, rp = write_stereo_pngs(left, right, args.out)
    finally:
        env.close()
    paths = {"topdown": top, "left": lp, "right": rp}
    for name, path in paths.items():
        print(f"{name:>8s}: {path}")
    print(f"done in {time.perf_counter() - t0:.1f} s")
    return paths


if __name__ == "__main__":
    main()
