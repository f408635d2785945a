"""Many points at a few positions: does each algorithm take as long as on distinct points?

Usage: python benchmarks/speed/copies.py [--points 40000] [--repeats 3] [--write]

Duplicate returns are common in surveys (overlapping flight lines, merged tiles), and
so are dense spots (near a terrestrial scanner) and returns quantised to a lattice.
Each algorithm runs at its defaults (grid_ground also with the seed's plain rule) on
clouds of --points points and of a quarter of that, side by side with as many distinct
points spread over a 10 m cube:
"one stack", every point at the origin but 10 spread over the cube; "two stacks", half
at the origin and half 1 cm away, and one point 1 m off; "lattice", a 3 cm cube of
returns rounded to 1 cm (64 positions); "column", one vertical line of distinct
heights; "three poles", three such lines 5 m apart; "dense spot", half the points in a
1 cm cube inside a cloud of 10 points per m^2. An algorithm that spends quadratic time
on such a cloud shows a cloud / distinct ratio that grows about four-fold from the
quarter to the full size (growth about 4); a linear one keeps it (growth about 1).
Every case runs in its own child process; times are medians of the repeats.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
import _common  # noqa: E402

import pcl_rg

SECTION = "## Many points at a few positions (speed)"
ALGORITHMS = {
    "statistical_outlier_removal": pcl_rg.statistical_outlier_removal,
    "voxel_grid": lambda points: pcl_rg.voxel_grid(points, 0.5),
    "normals": pcl_rg.normals,
    "region_growing": pcl_rg.region_growing,
    "convex_segmentation": pcl_rg.convex_segmentation,
    "grid_ground": pcl_rg.grid_ground,
    # The seed's plain rule keeps ordinary cells in input order (no pre-filter).
    "grid_ground (definition)": lambda points: pcl_rg.grid_ground(
        points, params=pcl_rg.GridGroundParams.definition()
    ),
    "tin_ground": pcl_rg.tin_ground,
}


def one_stack(n: int) -> np.ndarray:
    points = np.zeros((n, 3))
    points[-10:] = np.random.default_rng(0).uniform(0.0, 10.0, (10, 3))
    return points


def two_stacks(n: int) -> np.ndarray:
    points = np.zeros((n, 3))
    points[n // 2 :, 0] = 0.01
    points[-1] = [0.0, 1.0, 0.0]
    return points


def lattice(n: int) -> np.ndarray:
    return np.round(np.random.default_rng(0).uniform(0.0, 0.03, (n, 3)), 2)


def column(n: int) -> np.ndarray:
    points = np.zeros((n, 3))
    points[:, 2] = np.linspace(0.0, 10.0, n)
    return points


def three_poles(n: int) -> np.ndarray:
    # Each pole shares one x and one y exactly: nanoflann's own split rule cut them by
    # index along an axis they do not spread on (cpp/src/knn.cpp).
    points = np.zeros((n, 3))
    points[:, :2] = np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]])[np.arange(n) % 3]
    points[:, 2] = np.random.default_rng(0).uniform(0.0, 10.0, n)
    return points


def dense_spot(n: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    side = np.sqrt(n / 10.0)
    points = rng.uniform(0.0, side, (n, 3)) * [1.0, 1.0, 0.05]
    points[: n // 2] = side / 2 + rng.uniform(0.0, 0.01, (n // 2, 3))
    return points


def distinct(n: int) -> np.ndarray:
    return np.random.default_rng(1).uniform(0.0, 10.0, (n, 3))


CLOUDS = {
    "one stack": one_stack,
    "two stacks": two_stacks,
    "lattice": lattice,
    "column": column,
    "three poles": three_poles,
    "dense spot": dense_spot,
}


def median_time(function, cloud, n: int, repeats: int) -> float | str:
    """The median seconds, or the error's first words when the call refuses the cloud."""
    result = _common.measure(lambda: cloud(n), function, repeats)
    return result["median"] if "median" in result else result["error"].split(":")[0]


def main(argv: list[str] | None = None) -> int:
    parser = _common.speed_arguments(__doc__, points=40_000)
    args = parser.parse_args(argv)
    load_before = os.getloadavg()[0]
    sizes = (args.points // 4, args.points)
    rows = []
    for name, function in ALGORITHMS.items():
        base = [median_time(function, distinct, n, args.repeats) for n in sizes]
        for label, cloud in CLOUDS.items():
            row, ratios = [name, label], []
            for n, distinct_s in zip(sizes, base, strict=True):
                seconds = median_time(function, cloud, n, args.repeats)
                if isinstance(seconds, str) or isinstance(distinct_s, str):
                    row += [str(seconds) if isinstance(seconds, str) else f"{seconds:.4f}", ""]
                    continue
                ratios.append(seconds / distinct_s)
                row += [f"{seconds:.4f}", f"{ratios[-1]:.2f}"]
            row.append(f"{ratios[1] / ratios[0]:.2f}" if len(ratios) == 2 else "")
            rows.append(row)
            print("  " + " | ".join(row), file=sys.stderr)
    about = (
        f"{_common.run_conditions(load_before)}. Defaults (voxel_grid: leaf 0.5 m; grid_ground "
        "(definition): GridGroundParams.definition()); median of "
        f"{args.repeats} runs, each case in its own process. x distinct: the time over that "
        "of as many distinct points; growth: that ratio at the full size over the ratio at "
        "a quarter (about 4 when the time on the cloud is quadratic, about 1 when it is not)."
    )
    quarter, full = (f"{n:,}" for n in sizes)
    header = [
        "algorithm",
        "cloud",
        f"s at {quarter}",
        "x distinct",
        f"s at {full}",
        "x distinct",
        "growth",
    ]
    command = _common.command_of("benchmarks/speed/copies.py", parser, args)
    _common.publish_report(SECTION, command, about, header, rows, write=args.write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
