"""Normals + segmentation at 1M points: pcl_rg against PCL's RegionGrowing and LCCP.

Usage: python benchmarks/speed/region_growing.py [--points 1000000] [--repeats 3] [--json out.json]

The cloud: the seven mOSD Kinect scenes of ../shared/data/mosd (valid points, 5 mm
voxel grid not applied) laid side by side 2 m apart and cut to --points, so the
neighbourhoods are real ones. Both methods get the same float64 array, the same k
and smoothness angle (the package defaults) and each its default curvature
threshold. Every case runs in its own child process; times are medians of the
repeats, the normal and growth phases as the core measures them, the total as the
caller sees it (input gate and every conversion included). pcl_rg also runs once
more pinned to one thread (OMP_NUM_THREADS=1, in a fresh interpreter), as PCL's
classes are single-threaded. pcl_rg.convex_segmentation (normals, patch growth,
convexity merge) and PCL's LCCP (supervoxels + local convexity, its default
settings, viewpoint at the origin) run on the same cloud at their defaults: on
these raw frames convex_segmentation's default segments a voxel grid of 10 x the
measured noise (about 5 mm) and LCCP its own 7.5 mm supervoxel octree; a row with
noise_leaves=0 times convex_segmentation on every point.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import (  # noqa: E402
    SHARED_DATA,
    dump_json,
    in_child,
    machine,
    markdown_table,
    write_section,
)

DATA = SHARED_DATA / "mosd"
SECTION = "## Region growing speed (normals + growth, 1M points)"
SCENES = ("learn0", "learn5", "learn17", "learn20", "learn25", "learn33", "learn40")


def cloud(n: int) -> np.ndarray:
    from pcl_rg.datasets import load_mosd

    parts = []
    for i, name in enumerate(SCENES):
        points = load_mosd(DATA / f"{name}.pcd").points
        parts.append(points + [2.0 * i, 0.0, 0.0])
    points = np.vstack(parts)
    if n > len(points):
        raise SystemExit(f"--points {n}: the tiled scenes hold only {len(points)}")
    return np.ascontiguousarray(points[:n])


def run_ours(points: np.ndarray) -> tuple[float, float]:
    import pcl_rg

    with pcl_rg.collect_diagnostics() as diagnostics:
        pcl_rg.region_growing(points, params=pcl_rg.RegionGrowingParams())
    normals_s = diagnostics["region_growing"]["normals_seconds"]
    growth_s = diagnostics["region_growing"]["growth_seconds"]
    return normals_s, growth_s


def run_pcl(points: np.ndarray) -> tuple[float, float]:
    import pcl_rg

    defaults = pcl_rg.RegionGrowingParams()
    with pcl_rg.collect_diagnostics() as diagnostics:
        pcl_rg.pcl.region_growing(
            points,
            k=defaults.k,
            smoothness_deg=defaults.smoothness_deg,
            min_cluster_size=defaults.min_cluster_size,
        )
    timings = diagnostics["pcl.region_growing"]
    return timings["normals_seconds"], timings["growth_seconds"]


def run_convex(points: np.ndarray, noise_leaves: float | None = None) -> tuple[float, float]:
    import pcl_rg

    with pcl_rg.collect_diagnostics() as diagnostics:
        pcl_rg.convex_segmentation(points, noise_leaves=noise_leaves)
    timings = diagnostics["convex_segmentation"]
    return timings["normals_seconds"], timings["growth_seconds"] + timings["merge_seconds"]


def run_lccp(points: np.ndarray) -> tuple[float, float]:
    import pcl_rg

    start = time.perf_counter()
    pcl_rg.pcl.lccp(points)
    return float("nan"), time.perf_counter() - start  # supervoxels and LCCP: one phase


RUNS = {
    "ours": run_ours,
    "pcl": run_pcl,
    "convex": run_convex,
    "convex_all_points": lambda points: run_convex(points, noise_leaves=0.0),
    "lccp": run_lccp,
}


def _timed_runs(n: int, method: str, repeats: int) -> dict:
    points = cloud(n)
    run = RUNS[method]
    rows = []
    for _ in range(repeats):
        start = time.perf_counter()
        normals_s, growth_s = run(points)
        rows.append((time.perf_counter() - start, normals_s, growth_s))
    return {"rows": rows}


def measure(n: int, method: str, repeats: int) -> dict:
    result = in_child(lambda: _timed_runs(n, method, repeats))
    if "rows" in result:
        columns = list(zip(*result["rows"]))
        result["total"], result["normals"], result["growth"] = (
            statistics.median(c) for c in columns
        )
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", help="write the raw timings here")
    parser.add_argument("--results", type=Path, help="append/replace our section in this file")
    parser.add_argument("--single-thread-child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.single_thread_child:  # the fresh interpreter with OMP_NUM_THREADS=1
        print(
            json.dumps(
                {
                    method: measure(args.points, method, args.repeats)
                    for method in ("ours", "convex")
                }
            )
        )
        return 0

    import pcl_rg

    p = pcl_rg.RegionGrowingParams()
    print(f"machine: {machine()}")
    print(
        f"{args.points:,} mOSD points; k {p.k}, smoothness {p.smoothness_deg} deg; "
        f"medians of {args.repeats}"
    )
    results = {
        "pcl_rg.convex_segmentation (OpenMP)": measure(args.points, "convex", args.repeats),
        "pcl_rg.convex_segmentation, noise_leaves=0 (every point)": measure(
            args.points, "convex_all_points", args.repeats
        ),
        "pcl_rg.region_growing (OpenMP)": measure(args.points, "ours", args.repeats),
        "PCL NormalEstimation + RegionGrowing": measure(args.points, "pcl", args.repeats),
        "PCL SupervoxelClustering + LCCP": measure(args.points, "lccp", args.repeats),
    }
    env = dict(os.environ, OMP_NUM_THREADS="1")
    child = subprocess.run(
        [
            sys.executable,
            __file__,
            "--single-thread-child",
            "--points",
            str(args.points),
            "--repeats",
            str(args.repeats),
        ],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    single = json.loads(child.stdout.strip().splitlines()[-1])
    results["pcl_rg.convex_segmentation, 1 thread"] = single["convex"]
    results["pcl_rg.region_growing, 1 thread"] = single["ours"]

    baseline = results["PCL NormalEstimation + RegionGrowing"].get("total")
    rows = []
    for name, r in results.items():
        if "error" in r:
            rows.append([name, "n/a", "n/a", "n/a", r["error"][:60]])
            continue
        speedup = f"{baseline / r['total']:.2f}x" if baseline else ""
        normals = "" if r["normals"] != r["normals"] else f"{r['normals']:.2f}"  # NaN: one phase
        rows.append([name, normals, f"{r['growth']:.2f}", f"{r['total']:.2f}", speedup])
    table = markdown_table(
        ["method", "normals (s)", "segmentation (s)", "total (s)", "vs PCL RegionGrowing"], rows
    )
    print(table)
    dump_json(args.json, results)
    if args.results:
        command = (
            f"python benchmarks/speed/region_growing.py --points {args.points} "
            f"--repeats {args.repeats} --results {args.results}"
        )
        machine_line = (
            f"Machine: {machine()}. {args.points:,} mOSD Kinect points (seven scenes side "
            f"by side); region growing: k {p.k}, smoothness {p.smoothness_deg} deg, each "
            "method its default curvature threshold; convex_segmentation and LCCP at their "
            f"defaults; medians of {args.repeats} runs, side by side in one run."
        )
        lines = [SECTION, "", f"Command: `{command}`", "", machine_line, "", table, ""]
        write_section("\n".join(lines), SECTION, Path(args.results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
