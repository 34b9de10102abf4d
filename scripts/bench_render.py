"""Rendering benchmark: median time of a stereo pair of the default scene at several image sizes.

    python scripts/bench_render.py [--repeats N] [--json FILE] [--scenario NAME] [--surface-detail]

Figures (milliseconds): ``render_pair_<W>x<H>_ms`` for each size (both views of the rectified pair
from the default start pose) and ``render_single_320x240_ms`` (one view, for reference). The OpenGL
context is created and warmed up before timing. ``--scenario`` renders another map or a generated
family (seed 0) from its start pose; ``--surface-detail`` draws its surface detail
(``EnvConfig.surface_detail``).
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib
import statistics
import time
from collections.abc import Sequence

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
from _figures import print_figures, write_figures

from modeling.stereo.rig import HeadPose, StereoRig
from stereo_nav_env.rendering.renderer import StereoRenderer
from stereo_nav_env.sim.scenes import load_scenario

DEFAULT_SIZES = ((160, 120), (320, 240), (640, 480))


def _median_ms(fn: object, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()  # type: ignore[operator]
        times.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times)


def run(
    sizes: Sequence[tuple[int, int]] = DEFAULT_SIZES,
    repeats: int = 50,
    *,
    quick: bool = False,
    scenario: str = "default",
    surface_detail: bool = False,
) -> dict[str, float]:
    """Median render times in milliseconds, keyed by figure name.

    Args:
        sizes: ``(width, height)`` image sizes of the pairs timed.
        repeats: Timed repetitions per figure (after 3 warm-up renders).
        quick: Smoke run: 5 repetitions.
        scenario: The map or family drawn (a family with seed 0).
        surface_detail: Draw the scene's surface detail.
    """
    if repeats < 1:
        raise ValueError(f"repeats must be a positive integer, got {repeats!r}")
    repeats = 5 if quick else repeats
    scene = load_scenario(scenario, surface_detail=surface_detail)
    x, y, heading = scene.start
    figures: dict[str, float] = {}
    for width, height in sizes:
        # same field of view at every size: the focal length scales with the width
        rig = StereoRig(width_px=width, height_px=height, focal_px=260.0 * width / 320.0)
        half = rig.baseline_m / 2
        head = HeadPose(
            x_m=x - half * math.sin(heading),
            y_m=y + half * math.cos(heading),
            heading_rad=heading,
            height_m=0.8,
        )
        renderer = StereoRenderer(rig, scene)
        try:
            for _ in range(3):
                renderer.render_stereo(head)
            figures[f"render_pair_{width}x{height}_ms"] = _median_ms(
                lambda r=renderer, h=head: r.render_stereo(h), repeats
            )
            if (width, height) == (320, 240):
                figures["render_single_320x240_ms"] = _median_ms(
                    lambda r=renderer, h=head: r.render_view(h), repeats
                )
        finally:
            renderer.close()
    return figures


def main(argv: list[str] | None = None) -> dict[str, float]:
    """Print the figures as a table; write them as JSON with ``--json FILE``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=50, help="timed repetitions per figure")
    parser.add_argument("--json", type=pathlib.Path, help="write the figures to this JSON file")
    parser.add_argument("--quick", action="store_true", help="5 repetitions (smoke run)")
    parser.add_argument("--scenario", default="default", help="map or family (seed 0)")
    parser.add_argument("--surface-detail", action="store_true", help="draw surface detail")
    args = parser.parse_args(argv)
    figures = run(
        repeats=args.repeats,
        quick=args.quick,
        scenario=args.scenario,
        surface_detail=args.surface_detail,
    )
    print_figures(figures)
    write_figures(figures, args.json)
    return figures


if __name__ == "__main__":
    main()
