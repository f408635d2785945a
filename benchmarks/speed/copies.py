"""Many copies of one point: does each algorithm take as long as on distinct points?

Usage: python benchmarks/speed/copies.py [--points 40000] [--repeats 3] [--write]

Duplicate returns are common in surveys (overlapping flight lines, merged tiles).
Each algorithm runs at its defaults on two clouds of --points points side by side:
"copies", every point at the origin but 10 spread over a 10 m cube, and "distinct",
the same number spread over that cube; then on a quarter of each. An algorithm that
spends quadratic time on copies shows a copies / distinct ratio that grows about
four-fold from the quarter to the full size; a linear one keeps it. Every case runs
in its own child process; times are medians of the repeats.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
import _common  # noqa: E402

import pcl_rg

SECTION = "## Many copies of one point (speed)"
ALGORITHMS = {
    "statistical_outlier_removal": pcl_rg.statistical_outlier_removal,
    "voxel_grid": lambda points: pcl_rg.voxel_grid(points, 0.5),
    "normals": pcl_rg.normals,
    "region_growing": pcl_rg.region_growing,
    "convex_segmentation": pcl_rg.convex_segmentation,
    "grid_ground": pcl_rg.grid_ground,
    "tin_ground": pcl_rg.tin_ground,
}


def copies(n: int) -> np.ndarray:
    points = np.zeros((n, 3))
    points[-10:] = np.random.default_rng(0).uniform(0.0, 10.0, (10, 3))
    return points


def distinct(n: int) -> np.ndarray:
    return np.random.default_rng(1).uniform(0.0, 10.0, (n, 3))


def main(argv: list[str] | None = None) -> int:
    parser = _common.speed_arguments(__doc__, points=40_000)
    args = parser.parse_args(argv)
    load_before = os.getloadavg()[0]
    sizes = (args.points // 4, args.points)
    rows = []
    for name, function in ALGORITHMS.items():
        ratios = []
        for n in sizes:
            timing = {}
            for cloud in (copies, distinct):
                result = _common.measure(lambda n=n, cloud=cloud: cloud(n), function, args.repeats)
                timing[cloud.__name__] = result.get("median", float("nan"))
                if "median" not in result:
                    print(f"{name} on {cloud.__name__}: {result['error']}", file=sys.stderr)
            ratios.append(timing["copies"] / timing["distinct"])
            rows.append(
                [
                    name,
                    f"{n:,}",
                    f"{timing['copies']:.4f}",
                    f"{timing['distinct']:.4f}",
                    f"{ratios[-1]:.2f}",
                ]
            )
            print("  " + " | ".join(rows[-1]), file=sys.stderr)
        rows[-1].append(f"{ratios[1] / ratios[0]:.2f}")
        rows[-2].append("")
    about = (
        f"{_common.run_conditions(load_before)}. Defaults (voxel_grid: leaf 0.5 m); median of "
        f"{args.repeats} runs, each case in its own process. Growth: the copies / "
        "distinct ratio at the full size over the ratio at a quarter (about 4 when the "
        "time on copies is quadratic, about 1 when it is not)."
    )
    header = ["algorithm", "points", "copies s", "distinct s", "copies / distinct", "growth"]
    command = _common.command_of("benchmarks/speed/copies.py", parser, args)
    _common.publish_report(SECTION, command, about, header, rows, write=args.write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
