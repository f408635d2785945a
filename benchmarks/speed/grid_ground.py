"""grid_ground speed: points per second on a 10M-point scene, and core vs reference.

Usage: python benchmarks/speed/grid_ground.py [--points 10000000] [--reference-points 200000]
                                               [--repeats 3] [--write]

The scenes are pcl_rg.datasets.synthetic_scene at 4 points/m^2 (square, with
buildings and trees in the same proportion per m^2 as the default 200 m scene),
in UTM-sized coordinates. grid_ground runs with its defaults except a 1 m cell;
the plain rule of the seed (GridGroundParams.definition) is timed beside it.
Every case runs in its own child process (_common.measure); times are medians
of the repeats and include the input gate. Targets (issue 3): >= 2M points/s on
10M points, and >= 20x faster than the NumPy/SciPy reference on 200k points.
--write puts the table, with the command, in benchmarks/RESULTS.md.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from functools import partial
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import measure, publish_report  # noqa: E402

import pcl_rg
from pcl_rg import reference
from pcl_rg.datasets import synthetic_scene

SECTION = "## grid_ground speed (bench_grid_ground.py)"
DENSITY = 4.0  # points per m^2
OFFSET = (500_000.0, 5_000_000.0, 100.0)
PARAMS = pcl_rg.GridGroundParams(cell_size=1.0)
PLAIN = pcl_rg.GridGroundParams.definition(cell_size=1.0)


def scene(n: int):
    """About n points: a square of n / DENSITY m^2, 6 buildings and 40 trees per 4 ha."""
    size = math.sqrt(n / DENSITY)
    scale = (size / 200.0) ** 2
    return synthetic_scene(
        seed=0,
        size=size,
        density=DENSITY,
        n_buildings=max(1, round(6 * scale)),
        n_trees=max(1, round(40 * scale)),
        offset=OFFSET,
    ).points


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=10_000_000)
    parser.add_argument("--reference-points", type=int, default=200_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    args = parser.parse_args(argv)
    repeats = max(args.repeats, 3)

    defaults, plain = "grid_ground (defaults, cell 1 m)", "grid_ground (definition, cell 1 m)"
    cases = [
        (args.points, defaults, pcl_rg.grid_ground, PARAMS),
        (args.points, plain, pcl_rg.grid_ground, PLAIN),
        (args.reference_points, defaults, pcl_rg.grid_ground, PARAMS),
        (args.reference_points, "reference (defaults, cell 1 m)", reference.grid_ground, PARAMS),
    ]
    load_before = os.getloadavg()[0]
    rows, medians, counts, notes = [], {}, {}, []
    for n, name, function, params in cases:
        run = partial(function, params=params)
        result = measure(lambda n=n: scene(n), run, repeats)
        if "median" not in result:
            print(f"{name}: {result['error']}", file=sys.stderr)
            return 1
        if n not in counts:
            counts[n] = len(scene(n))
        medians[n, name] = result["median"]
        rate = counts[n] / result["median"]
        rows.append(
            [
                f"{counts[n]:,}",
                name,
                ", ".join(f"{t:.3f}" for t in result["times"]),
                f"{result['median']:.3f}",
                f"{rate / 1e6:.2f}",
                f"{result['peak_mib']:.0f}",
            ]
        )
        print(f"  {n:>10,} {name}: {result['median']:.3f} s", file=sys.stderr)
    # One more run in this process (after every forked case: libgomp's threads do not
    # survive fork), for the CPU time of all threads against the wall time.
    points = scene(args.points)
    wall, cpu = time.perf_counter(), time.process_time()
    pcl_rg.grid_ground(points, params=PARAMS)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    notes.append(
        f"{len(points):,} points, defaults, one more run: {wall:.2f} s wall, {cpu:.2f} s CPU "
        f"(all threads), {len(points) / cpu / 1e6:.2f} M points per CPU-second."
    )
    del points
    speedup = (
        medians[args.reference_points, "reference (defaults, cell 1 m)"]
        / medians[args.reference_points, "grid_ground (defaults, cell 1 m)"]
    )
    about = (
        f"Shared with other jobs (1-minute load average "
        f"{load_before:.1f} before, {os.getloadavg()[0]:.1f} after: on 2 cores, wall times "
        "include waiting for a core). "
        f"Synthetic scenes at {DENSITY:g} points/m^2, UTM offset; median of {repeats} runs, "
        "each case in its own process; times include the input gate."
    )
    header = ["points", "method", "times s", "median s", "M points/s", "peak MiB"]
    speedup_note = f"Core vs reference on {args.reference_points:,} points: {speedup:.0f}x faster."
    notes.insert(0, speedup_note + "\n")
    command = "python benchmarks/speed/grid_ground.py"
    publish_report(SECTION, command, about, header, rows, notes, write=args.write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
