"""SOR and VoxelGrid: pcl_rg vs PCL's own classes vs Open3D vs the NumPy reference.

Usage: python benchmarks/speed/filters.py [--sizes 1000000 10000000] [--repeats 3]
       [--mean-k 8] [--filters VoxelGrid SOR]

A large --mean-k (e.g. --sizes 20000 --mean-k 5000 --filters SOR) times the long
neighbour lists that a heap keeps in pcl_rg's k-NN search (cpp/src/knn.cpp).

Every case runs in its own child process (peak memory is its own), timings are
medians of the repeats and include every conversion from the caller's float64
NumPy array (pcl_rg's input gate, PCL's cloud copy, Open3D's Vector3dVector).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import machine, markdown_table, measure  # noqa: E402

import pcl_rg
import pcl_rg.pcl
from pcl_rg import reference

LEAF = 0.5  # m, on a 200 m x 200 m x 20 m box: 3.2M possible voxels
MEAN_K = 8  # the SOR setting
STD_MUL = 1.0


def uniform_points(n: int) -> np.ndarray:
    return np.random.default_rng(0).uniform([0, 0, 0], [200, 200, 20], (n, 3))


def open3d_cloud(points):
    import open3d as o3d

    return o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))


def input_gate(points: np.ndarray) -> np.ndarray:
    """What pcl_rg's input gate does to a clean float64 C-order array: a finite check."""
    array = np.ascontiguousarray(points, dtype=np.float64)
    if not np.isfinite(array).all():
        raise ValueError("non-finite points")
    return array


def cases(n: int, mean_k: int = MEAN_K):
    yield "VoxelGrid", "pcl_rg", lambda p: pcl_rg.voxel_grid(p, LEAF)
    yield "VoxelGrid", "pcl::VoxelGrid", lambda p: pcl_rg.pcl.voxel_grid(p, LEAF)
    yield "VoxelGrid", "Open3D", lambda p: open3d_cloud(p).voxel_down_sample(LEAF)
    if n <= 1_000_000:
        yield "VoxelGrid", "NumPy reference", lambda p: reference.voxel_grid(p, LEAF)
    yield "VoxelGrid", "pcl_rg input gate", input_gate
    yield (
        "SOR",
        "pcl_rg",
        lambda p: pcl_rg.statistical_outlier_removal(p, mean_k=mean_k, std_mul=STD_MUL),
    )
    yield (
        "SOR",
        "pcl::StatisticalOutlierRemoval",
        lambda p: pcl_rg.pcl.statistical_outlier_removal(p, mean_k=mean_k, std_mul=STD_MUL),
    )
    yield "SOR", "Open3D", lambda p: open3d_cloud(p).remove_statistical_outlier(mean_k, STD_MUL)
    if n <= 1_000_000:
        yield (
            "SOR",
            "NumPy reference",
            lambda p: reference.statistical_outlier_removal(p, mean_k=mean_k, std_mul=STD_MUL),
        )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1_000_000, 10_000_000])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--mean-k", type=int, default=MEAN_K, help="SOR's mean_k")
    parser.add_argument(
        "--filters", nargs="+", choices=["VoxelGrid", "SOR"], default=["VoxelGrid", "SOR"]
    )
    args = parser.parse_args(argv)

    print(f"machine: {machine()}")
    print(f"VoxelGrid leaf {LEAF} m; SOR mean_k {args.mean_k}, std_mul {STD_MUL}; uniform points")
    rows = []
    for n in args.sizes:
        timings: dict[tuple[str, str], dict] = {}
        for algorithm, method, run in cases(n, args.mean_k):
            if algorithm not in args.filters:
                continue
            result = measure(lambda n=n: uniform_points(n), run, args.repeats)
            timings[algorithm, method] = result
            print(
                f"  {n:>10,} {algorithm:9} {method:32} "
                + (f"{result['median']:.3f} s" if "median" in result else result["error"]),
                file=sys.stderr,
            )
        for (algorithm, method), result in timings.items():
            ours = timings[algorithm, "pcl_rg"].get("median")
            if "median" not in result:
                rows.append([f"{n:,}", algorithm, method, "n/a", "", "", result["error"][:60]])
                continue
            ratio = result["median"] / ours if ours else float("nan")
            rows.append(
                [
                    f"{n:,}",
                    algorithm,
                    method,
                    f"{result['median']:.3f}",
                    f"{ratio:.2f}x" if method != "pcl_rg" else "1.00x",
                    f"{result['peak_mib']:.0f}",
                    "",
                ]
            )
    print()
    print(
        markdown_table(
            ["points", "filter", "method", "median s", "time / pcl_rg", "peak MiB", "note"], rows
        )
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
