"""The k-nearest-neighbour steps with and without a far point, and against another build:
time and peak memory.

Usage:
    python benchmarks/speed/far_points.py [--before SITE] [--rounds 3] [--points 1000000]

A far point lies beyond float32's reach of the cloud's local origin (a record at
(0, 0, 0) in a UTM tile): the steps leave it out, which copies the other points
and makes their frame again. Each cell is the median over the rounds of the best
of 3 calls in a fresh child process; the rounds alternate the builds (the other
one, with --before, is a site folder of an older commit's build, as in
ground_builds.py; older builds refused the far point). Clouds: `--points`
uniform points over 100 x 100 x 5 m at UTM coordinates, with the record at the
origin appended for "stray"; convex segmentation on the mOSD frame learn0 (its
defaults, voxel grid and all), with a point 5,400 km away for "stray". Peak memory:
the child's peak resident size over the calls (VmHWM, reset just before them through
/proc/self/clear_refs) less its resident size then (the cloud loaded), in MB, the
median over the rounds.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import SHARED_DATA  # noqa: E402

CHILD = r"""
import json, sys, time
import numpy as np
import pcl_rg
steps = {
    "statistical_outlier_removal": pcl_rg.statistical_outlier_removal,
    "normals (k = 15)": lambda p: pcl_rg.normals(p, k=15),
    "region_growing (k = 30)": lambda p: pcl_rg.region_growing(p, k=30),
    "convex_segmentation": pcl_rg.convex_segmentation,
}
points = np.load(sys.argv[2])
def status_kib(key):
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith(key))
with open("/proc/self/clear_refs", "w") as clear_refs:
    clear_refs.write("5")  # the peak resident size starts again from the current one
before = status_kib("VmRSS:")
best = []
for _ in range(3):
    start = time.perf_counter()
    try:
        steps[sys.argv[1]](points)
    except ValueError:  # an older build refuses a far point
        print(json.dumps(None))
        sys.exit()
    best.append(time.perf_counter() - start)
peak = (status_kib("VmHWM:") - before) / 1024
print(json.dumps([min(best), peak]))
"""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", help="site folder of another build")
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args(argv)

    from pcl_rg.datasets import load_mosd

    data = SHARED_DATA / "mosd" / "learn0.pcd"
    if not data.exists():
        sys.exit(f"far_points.py: {data} is missing (../shared/data, see its README)")
    rng = np.random.default_rng(0)
    uniform = rng.random((args.points, 3)) * [100.0, 100.0, 5.0] + [5e5, 5.4e6, 0.0]
    frame = load_mosd(data).points
    builds = {"this build": None} | ({"before": args.before} if args.before else {})
    with tempfile.TemporaryDirectory() as folder:
        clouds = {}
        for name, points in (
            ("uniform", uniform),
            ("uniform + stray", np.r_[uniform, [[0.0, 0.0, 0.0]]]),
            ("learn0", frame),
            ("learn0 + stray", np.r_[frame, [[-5e5, -5.4e6, 0.0]]]),
        ):
            clouds[name] = os.path.join(folder, f"{name}.npy")
            np.save(clouds[name], points)
        cases = [
            (step, cloud)
            for step in (
                "statistical_outlier_removal",
                "normals (k = 15)",
                "region_growing (k = 30)",
            )
            for cloud in ("uniform", "uniform + stray")
        ] + [("convex_segmentation", "learn0"), ("convex_segmentation", "learn0 + stray")]
        runs: dict[tuple[str, str, str], list[list[float] | None]] = {}
        for _ in range(args.rounds):
            for step, cloud in cases:
                for build, site in builds.items():
                    env = dict(os.environ) | ({"PYTHONPATH": site} if site else {})
                    done = subprocess.run(
                        [sys.executable, "-c", CHILD, step, clouds[cloud]],
                        env=env, capture_output=True, text=True, check=True,
                    )  # fmt: skip
                    runs.setdefault((step, cloud, build), []).append(json.loads(done.stdout))
    heads = [f"{b} (s)" for b in builds] + [f"{b}, peak (MB)" for b in builds]
    print("| step | cloud | " + " | ".join(heads) + " |")
    print("|---|---|" + "---:|" * len(heads))
    for step, cloud in cases:
        cells = []
        for column, form in ((0, "{:.3f}"), (1, "{:.0f}")):
            for b in builds:
                measured = runs[step, cloud, b]
                cells.append(
                    "refused"
                    if None in measured
                    else form.format(statistics.median(m[column] for m in measured))
                )
        print(f"| {step} | {cloud} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
