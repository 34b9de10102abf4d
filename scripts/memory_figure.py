"""The model of one view beside the model fused over N views (docs/images/memory_model.png).

    python scripts/memory_figure.py [--scenario NAME] [--seed S] [--views N] [--agent NAME]
                                    [--out FILE]

Runs one episode of ``StereoNav-v0`` (default: the ``two_gaps`` map, whose bookshelf stands
between two doubtful doorways), driven by the ``oracle`` agent (the true shortest route, head
level), and draws in the style of the paper's Figs. 6 and 11 (:func:`modeling.plotting.plot_models`)
the most probable situation of the model of the first view beside that of the fused model
(``info["memory_model"]``) after ``--views`` views, the floor seen so far shaded, the true
outlines in green.
"""

from __future__ import annotations

import argparse
import os
import pathlib
from typing import TYPE_CHECKING, cast

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import gymnasium as gym

import stereo_nav_env  # noqa: F401  (registers the ids)
from agents import make_agent
from modeling.plotting import plot_models

if TYPE_CHECKING:
    from stereo_nav_env.env import StereoNavEnv


def main(argv: list[str] | None = None) -> pathlib.Path:
    """Run the episode, draw the figure, write it to ``--out``; returns its path."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="two_gaps", help="map name, .json path or family")
    parser.add_argument("--seed", type=int, default=0, help="seed of the episode")
    parser.add_argument("--views", type=int, default=40, help="views fused (steps + 1)")
    parser.add_argument("--agent", default="oracle", help="agent that drives (default: oracle)")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/memory_model.png"))
    args = parser.parse_args(argv)
    if args.views < 1:
        raise ValueError(f"--views must be positive, got {args.views}")
    env = gym.make("StereoNav-v0", scenario=args.scenario, memory=True, diagnostics=False)
    agent = make_agent(args.agent)
    try:
        obs, info = env.reset(seed=args.seed)
        agent.reset(env, seed=args.seed)
        base = cast("StereoNavEnv", env.unwrapped)
        assert base.memory is not None and base.scene is not None
        first = info["model"]
        first_seen = base.memory.seen
        views = 1
        while views < args.views:
            obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
            views += 1
            if terminated or truncated:
                break
        fused = info["memory_model"]
        assert base.memory is not None
        footprints = base.ground_truth_footprints()
        bounds = base.scene.bounds
        fig = plot_models(
            [first, fused],
            titles=["one view (the first)", f"fused over {views} views"],
            ground_truth=footprints,
            seen=[first_seen, base.memory.seen],
            limits=(bounds[0] - 0.2, bounds[2] + 0.2, bounds[1] - 0.2, bounds[3] + 0.2),
        )
    finally:
        agent.close()
        env.close()
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    print(f"figure: {out}")
    return out


if __name__ == "__main__":
    main()
