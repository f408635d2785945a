"""The ground filters on a patch of low points (multipath echoes) under planar terrain.

Usage: python benchmarks/studies/ground_low_patches.py [--write]

A plane of 200 x 200 m at 4 points per m^2 (rise 0.05 or 0.6 per metre, noise 3 cm)
gets a square patch of points at its centre, `depth` metres below it (noise 10 cm): 10
points over 1 m, 60 over 3 m, or 200 over 6 m. Such clusters are what a multipath
echo (off water or glass) or a sensor's artefact leaves in real surveys. The table
gives, per filter with its defaults, how many of the patch's points come out as
ground and the share of the plane's points kept. A patch point taken as ground pulls
the ground surface, and a terrain model made from it, down by `depth` there.

A patch up to final_below (5 m) deep is ground by design: the final pass takes every
point down to that far below its TIN. Deeper patches are the defect this study
measures: both filters' low-outlier tests (outlier_depth) judge a point against its
surroundings, where a patch's points vouch for each other.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import publish_report  # noqa: E402

import pcl_rg  # noqa: E402

SECTION = "## Ground filters on a patch of low points under the terrain"
SIDE, DENSITY = 200.0, 4.0
RISES = (0.05, 0.6)
DEPTHS = (4.0, 8.0, 15.0)
PATCHES = ((1.0, 10), (3.0, 60), (6.0, 200))  # side in m, points


def scene(rise: float, depth: float, side: float, count: int) -> tuple[np.ndarray, int]:
    """The plane's points, then the patch's, and the plane's point count."""
    rng = np.random.default_rng(0)
    n = int(SIDE * SIDE * DENSITY)
    xy = rng.uniform(0.0, SIDE, (n, 2))
    plane = np.column_stack([xy, rise * xy[:, 0] + rng.normal(0.0, 0.03, n)])
    pxy = SIDE / 2 + rng.uniform(-side / 2, side / 2, (count, 2))
    patch = np.column_stack([pxy, rise * pxy[:, 0] - depth + rng.normal(0.0, 0.1, count)])
    return np.vstack([plane, patch]), n


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="update RESULTS.md")
    args = parser.parse_args(argv)
    rows = []
    for rise in RISES:
        for depth in DEPTHS:
            for side, count in PATCHES:
                points, n = scene(rise, depth, side, count)
                row = [f"{rise:g}", f"{depth:g}", f"{side:g} m, {count}"]
                for function in (pcl_rg.grid_ground, pcl_rg.tin_ground):
                    ground = function(points)
                    row += [str(int(ground[n:].sum())), f"{100 * ground[:n].mean():.2f}"]
                rows.append(row)
                print(" | ".join(row), flush=True)
    publish_report(
        SECTION,
        "python benchmarks/studies/ground_low_patches.py",
        "Both filters with their defaults; patch points taken as ground (of the patch's), "
        "and the plane's points kept as ground, %.",
        [
            "rise per m",
            "depth m",
            "patch",
            "grid_ground: patch as ground",
            "grid_ground: plane kept %",
            "tin_ground: patch as ground",
            "tin_ground: plane kept %",
        ],
        rows,
        write=args.write,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
