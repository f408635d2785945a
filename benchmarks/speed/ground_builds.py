"""A ground filter of two builds side by side (before/after a change), on one scene.

Usage:
    python benchmarks/speed/ground_builds.py --before SITE [--method tin_ground]
        [--label NAME] [--repeats 3] [--points 10000000]

SITE is a folder holding another build of pcl_rg (for example
`pip install --no-deps --no-build-isolation --target SITE .` run in a worktree of
the older commit). The two builds run alternately, each call in a fresh child
process (PYTHONPATH=SITE for the older one), on the same saved
synthetic_scene(seed=0, size=sqrt(points / 4), density=4); the method
(tin_ground or grid_ground) runs with its defaults. The table gives the median
wall time, the median CPU time of all threads and, for tin_ground, the median of
each of the core's stage clocks; the masks are compared (they must be equal).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

CHILD = r"""
import json, sys, time
import numpy as np
import pcl_rg
points = np.load(sys.argv[1])
wall, cpu = time.perf_counter(), time.process_time()
with pcl_rg.collect_diagnostics() as diagnostics:
    ground = getattr(pcl_rg, sys.argv[3])(points)
wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
np.save(sys.argv[2], ground)
out = {"wall": wall, "cpu": cpu}
if "tin_ground" in diagnostics:
    s = diagnostics["tin_ground"]
    out.update(prepare=s["prepare_seconds"], triangulation=s["triangulation_seconds"],
               classification=s["classification_seconds"])
print(json.dumps(out))
"""
STAGES = ("prepare", "triangulation", "classification")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="site folder of the other build")
    parser.add_argument("--method", choices=("tin_ground", "grid_ground"), default="tin_ground")
    parser.add_argument("--points", type=int, default=10_000_000)
    parser.add_argument("--label", default="before")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)

    from pcl_rg.datasets import synthetic_scene

    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(tmp) / "scene.npy"
        cloud = synthetic_scene(seed=0, size=math.sqrt(args.points / 4), density=4).points
        points = len(cloud)
        np.save(scene, cloud)
        del cloud
        equal = True
        builds = {args.label: args.before, "this checkout": ""}
        runs: dict[str, list[dict]] = {name: [] for name in builds}
        for _ in range(args.repeats):
            masks = []
            for k, (name, site) in enumerate(builds.items()):
                out = Path(tmp) / f"ground{k}.npy"
                env = dict(os.environ, PYTHONPATH=site)
                done = subprocess.run(
                    [sys.executable, "-c", CHILD, str(scene), str(out), args.method],
                    env=env,
                    capture_output=True,
                    text=True,
                    check=True,
                )
                runs[name].append(json.loads(done.stdout))
                masks.append(np.load(out))
                print(name, runs[name][-1], file=sys.stderr)
            equal = equal and bool(np.array_equal(*masks))
            print("masks equal:", bool(np.array_equal(*masks)), file=sys.stderr)
    stages = STAGES if args.method == "tin_ground" else ()
    print(f"{args.method} (defaults) on {points:,} points; masks equal in every round: {equal}")
    header = ["build", "wall s (runs)", "median wall s", "CPU s"] + [f"{k} s" for k in stages]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for name, results in runs.items():
        cells = [", ".join(f"{r['wall']:.2f}" for r in results)]
        for key in ("wall", "cpu", *stages):
            cells.append(f"{statistics.median(r[key] for r in results):.2f}")
        print(f"| {name} | " + " | ".join(cells) + " |")
    print(f"1-minute load average after: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
