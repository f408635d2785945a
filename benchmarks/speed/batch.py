"""Survey scale: ``pcl-rg batch ground`` on 2 workers against a loop of ``pcl-rg ground``.

Usage: python benchmarks/speed/batch.py [--tiles 5 5] [--tile-size 1000] [--density 4]
       [--method grid] [--folder DIR] [--repeats 1] [--write]

The synthetic survey (datasets.synthetic_survey: LAZ tiles of about 4M points at
the defaults, 100M points in all) is written once into --folder and reused. Both
runs are whole command lines, timed end to end (LAZ decoding and encoding
included), alternated when repeated, medians reported. Memory: the largest peak
RSS of any worker process over the run (each task reports its process's
ru_maxrss), on the first 6 tiles and on the whole survey, to show it does not
grow with the survey.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import publish_report  # noqa: E402

from pcl_rg.datasets import synthetic_survey  # noqa: E402
from pcl_rg.io import read_extent  # noqa: E402

SECTION = "## Survey batches: speed and memory (pcl_rg.batch)"
PCL_RG = [sys.executable, "-m", "pcl_rg"]


def survey_paths(folder: Path, tiles: tuple[int, int], tile_size: float, density: float):
    marker = folder / "survey.json"
    wanted = {"tiles": list(tiles), "tile_size": tile_size, "density": density}
    if marker.exists() and json.loads(marker.read_text()) == wanted:
        return sorted(str(p) for p in folder.glob("*.laz"))
    shutil.rmtree(folder, ignore_errors=True)
    start = time.perf_counter()
    survey = synthetic_survey(folder, tiles=tiles, tile_size=tile_size, density=density, seed=0)
    print(f"  survey written in {time.perf_counter() - start:.0f} s", file=sys.stderr)
    marker.write_text(json.dumps(wanted))
    return sorted(survey.paths)


def loop(paths: list[str], out: Path, method: str, threads: int | None = None) -> float:
    """A loop of single-file runs; `threads` limits OpenMP (None: every core)."""
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    env = dict(os.environ)
    env.pop("OMP_NUM_THREADS", None)
    if threads is not None:
        env["OMP_NUM_THREADS"] = str(threads)
    start = time.perf_counter()
    for path in paths:
        name = str(out / os.path.basename(path))
        subprocess.run(
            [*PCL_RG, "ground", path, name, "--method", method, "--quiet"],
            check=True,
            env=env,
            stdout=subprocess.DEVNULL,
        )
    return time.perf_counter() - start


def batch(paths: list[str], out: Path, method: str, workers: int) -> tuple[float, dict]:
    shutil.rmtree(out, ignore_errors=True)
    start = time.perf_counter()
    result = subprocess.run(
        [
            *PCL_RG,
            "batch",
            "ground",
            *paths,
            "--out",
            str(out),
            "--method",
            method,
            "--workers",
            str(workers),
            "--json",
            "--no-resume",
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    return time.perf_counter() - start, json.loads(result.stdout)


def peak_mib(summary: dict) -> float:
    return max(t["details"].get("peak_mib", 0.0) for t in summary["tiles"])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tiles", type=int, nargs=2, default=[5, 5])
    parser.add_argument("--tile-size", type=float, default=1000.0)
    parser.add_argument("--density", type=float, default=4.0)
    parser.add_argument("--method", choices=["grid", "tin"], default="grid")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--folder", default="/tmp/pcl_rg-bench-survey")
    parser.add_argument("--write", action="store_true")
    args = parser.parse_args(argv)
    folder = Path(args.folder)
    paths = survey_paths(folder / "in", tuple(args.tiles), args.tile_size, args.density)
    points = sum(read_extent(p).points for p in paths)
    small = paths[:6]
    small_points = sum(read_extent(p).points for p in small)

    loops, serial_loops, batches, summary = [], [], [], {}
    for _ in range(args.repeats):
        loops.append(loop(paths, folder / "loop", args.method))
        serial_loops.append(loop(paths, folder / "loop1", args.method, threads=1))
        seconds, summary = batch(paths, folder / "batch", args.method, args.workers)
        batches.append(seconds)
        print(
            f"  loop {loops[-1]:.1f} s, serial loop {serial_loops[-1]:.1f} s, "
            f"batch {batches[-1]:.1f} s",
            file=sys.stderr,
        )
    small_seconds, small_summary = batch(small, folder / "small", args.method, args.workers)
    t_loop, t_batch = statistics.median(loops), statistics.median(batches)
    t_serial = statistics.median(serial_loops)
    header = ["run", "tiles", "points", "time s", "M points/s", "speed-up", "worker peak MiB"]
    rows = [
        [
            "loop of `pcl-rg ground`",
            str(len(paths)),
            f"{points:,}",
            f"{t_loop:.1f}",
            f"{points / t_loop / 1e6:.2f}",
            "1.00",
            "",
        ],
        [
            "loop of `pcl-rg ground`, OMP_NUM_THREADS=1",
            str(len(paths)),
            f"{points:,}",
            f"{t_serial:.1f}",
            f"{points / t_serial / 1e6:.2f}",
            f"{t_loop / t_serial:.2f}",
            "",
        ],
        [
            f"`pcl-rg batch ground`, {args.workers} workers",
            str(len(paths)),
            f"{points:,}",
            f"{t_batch:.1f}",
            f"{points / t_batch / 1e6:.2f}",
            f"{t_loop / t_batch:.2f}",
            f"{peak_mib(summary):.0f}",
        ],
        [
            f"`pcl-rg batch ground`, {args.workers} workers",
            str(len(small)),
            f"{small_points:,}",
            f"{small_seconds:.1f}",
            f"{small_points / small_seconds / 1e6:.2f}",
            "",
            f"{peak_mib(small_summary):.0f}",
        ],
    ]
    command = (
        f"python benchmarks/speed/batch.py --tiles {args.tiles[0]} {args.tiles[1]} "
        f"--tile-size {args.tile_size:g} --density {args.density:g} --method {args.method} "
        f"--repeats {args.repeats}"
    )
    about = (
        f"Synthetic LAZ survey, {len(paths)} tiles; "
        f"method {args.method}, default buffer ({summary.get('buffer', 0):g} m). Both runs are "
        "whole command lines, timed end to end with LAZ decoding and encoding; the loop "
        "runs one `pcl-rg ground` per tile (OpenMP on every core, or on one), the batch "
        "one-thread Dask workers, each tile with its buffer. Speed-up is against the "
        f"first loop. Median of {args.repeats}."
    )
    publish_report(SECTION, command, about, header, rows, write=args.write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
