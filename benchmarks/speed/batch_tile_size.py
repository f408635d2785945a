"""One survey cut into tiles of several sizes: what small tiles cost ``pcl_rg.batch``.

Usage: python benchmarks/speed/batch_tile_size.py [--side 120] [--tiles 2 6 12]
       [--buffer M] [--repeats 3]

The same square of --side metres (datasets.synthetic_survey, seed 3, 4 points per
m^2) as n x n tiles for each n of --tiles, ground-filtered by ``batch.ground`` with
its defaults (grid, 2 workers, the default 90 m buffer, or --buffer). Every tile's task reads
the tiles within the buffer around it, so tiles much smaller than the buffer make
each task read most of the survey. The runs alternate; medians of --repeats.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--side", type=float, default=120.0)
    parser.add_argument("--tiles", type=int, nargs="+", default=[2, 6, 12])
    parser.add_argument("--buffer", type=float, help="metres (default: batch's own)")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)

    from pcl_rg import batch
    from pcl_rg.datasets import synthetic_survey

    with tempfile.TemporaryDirectory() as folder:
        surveys = {
            n: synthetic_survey(
                Path(folder) / f"in{n}", tiles=(n, n), tile_size=args.side / n, seed=3
            ).paths
            for n in args.tiles
        }
        seconds: dict[int, list[float]] = {n: [] for n in args.tiles}
        points: dict[int, int] = {}
        for _ in range(args.repeats):
            for n, paths in surveys.items():
                out = Path(folder) / f"out{n}"
                shutil.rmtree(out, ignore_errors=True)
                start = time.perf_counter()
                report = batch.ground(paths, out, buffer=args.buffer)
                seconds[n].append(time.perf_counter() - start)
                points[n] = sum(tile.points for tile in report.tiles)
    print("| tiles | tile side m | points | times s | median s | ms per tile |")
    print("|---|---|---|---|---|---|")
    for n in args.tiles:
        median = statistics.median(seconds[n])
        times = ", ".join(f"{s:.2f}" for s in seconds[n])
        print(
            f"| {n} x {n} | {args.side / n:g} | {points[n]:,} | {times} | {median:.2f} "
            f"| {1000 * median / n**2:.0f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
