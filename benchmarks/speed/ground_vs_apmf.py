"""tin_ground and grid_ground against PCL's approximate progressive morphological filter.

Usage:
    python benchmarks/speed/ground_vs_apmf.py [--points 10000000] [--repeats 3] [--write]

One synthetic scene (pcl_rg.datasets.synthetic_scene, seed 0, 4 points/m^2, sized
for the requested number of points) is filtered by tin_ground (isprs preset, the
defaults, and with densify_cell off), grid_ground (defaults) and
pcl::ApproximateProgressiveMorphologicalFilter
(PCL's tutorial parameters, as benchmarks/studies/ground_isprs.py runs PMF). The
four run interleaved in one process, `repeats` rounds, in orders where each method
follows every other equally often (carryover_balanced_orders), so that the load of
the shared machine and the place after another method's call fall on all of them
alike; the table gives each one's median wall
time (input check included), its ratio to APMF's median, and tin_ground's and
grid_ground's stage times from the core's clocks in their median runs. Targets
(issue 14): tin_ground >= 1.5x and grid_ground >= 4x faster than APMF. --write puts
the table in RESULTS.md.
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import (  # noqa: E402
    airborne_scene,
    carryover_balanced_orders,
    command_of,
    publish_report,
    run_conditions,
    speed_arguments,
)

import pcl_rg
import pcl_rg.pcl
from pcl_rg.datasets import GROUND
from pcl_rg.evaluation import ground_errors

SECTION = "## tin_ground and grid_ground vs PCL's APMF (synthetic scene)"
DENSITY = 4.0
APMF = "PCL ApproximateProgressiveMorphologicalFilter (tutorial)"
METHODS = {
    "tin_ground (isprs preset, the defaults)": lambda p: pcl_rg.tin_ground(p),
    "tin_ground (isprs preset, densify_cell=0: off)": lambda p: pcl_rg.tin_ground(
        p, densify_cell=0.0
    ),
    "grid_ground (defaults)": lambda p: pcl_rg.grid_ground(p),
    APMF: lambda p: pcl_rg.pcl.progressive_morphological_filter(p, approximate=True),
}
SHORT = dict(zip(METHODS, ["tin_ground", "tin_ground off", "grid_ground", "APMF"]))


def run_once(run, points: np.ndarray) -> tuple[float, np.ndarray, dict | None, float]:
    """(wall seconds, ground mask, tin_ground's diagnostics, CPU seconds) of one call."""
    start, cpu = time.perf_counter(), time.process_time()
    with pcl_rg.collect_diagnostics() as diagnostics:
        ground = run(points)
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    stats = next(
        (diagnostics[name] for name in ("tin_ground", "grid_ground") if name in diagnostics), None
    )
    return seconds, ground, stats, cpu


def main(argv: list[str] | None = None) -> int:
    parser = speed_arguments(__doc__, points=10_000_000)
    args = parser.parse_args(argv)

    scene, scene_text = airborne_scene(args.points, DENSITY)
    points = scene.points
    truth = scene.labels == GROUND
    load_before = os.getloadavg()[0]
    runs: dict[str, list] = {name: [] for name in METHODS}
    after: dict[tuple[str, str], list[float]] = {}  # (method, the one called before it)
    names = list(METHODS)
    orders = carryover_balanced_orders(len(names))
    previous = None
    for round_ in range(args.repeats):
        # A call right after APMF's (which frees much memory) ran up to 0.7 s slower, so
        # each method follows every other equally often (a rotated order would not).
        for name in (names[m] for m in orders[round_ % len(orders)]):
            runs[name].append(run_once(METHODS[name], points))
            if previous is not None:
                after.setdefault((name, previous), []).append(runs[name][-1][0])
            previous = name
            print(f"round {round_ + 1} {name}: {runs[name][-1][0]:.2f} s", file=sys.stderr)
    conditions = run_conditions(load_before)

    apmf = statistics.median(r[0] for r in runs[APMF])
    apmf_cpu = statistics.median(r[3] for r in runs[APMF])
    rows, splits = [], []
    for name, results in runs.items():
        seconds = statistics.median(r[0] for r in results)
        _, ground, stats, _ = min(results, key=lambda r: abs(r[0] - seconds))
        cpu = statistics.median(r[3] for r in results)
        errors = ground_errors(truth, ground)
        rows.append(
            [
                name,
                ", ".join(f"{r[0]:.2f}" for r in results),
                f"{seconds:.2f}",
                f"{apmf / seconds:.2f}",
                f"{cpu:.2f}",
                f"{apmf_cpu / cpu:.2f}",
                f"{100 * errors.type_i:.2f}",
                f"{100 * errors.type_ii:.2f}",
            ]
        )
        if stats is not None and "tin_vertices" in stats:
            splits.append(
                f"{name}: split in its median run (core clocks): prepare "
                f"{stats['prepare_seconds']:.2f} s, triangulation "
                f"{stats['triangulation_seconds']:.2f} s, classification "
                f"{stats['classification_seconds']:.2f} s; {stats['tin_vertices']:,} TIN "
                f"vertices, {stats['iterations']} iterations, "
                f"{stats['tests'] / len(points):.1f} tests per point."
            )
        elif stats is not None:
            splits.append(
                f"{name}: split in its median run (core clocks): prepare "
                f"{stats['prepare_seconds']:.2f} s, growth {stats['growth_seconds']:.2f} s, "
                f"final pass {stats['final_pass_seconds']:.2f} s "
                f"({stats['final_passes_run']} rounds)."
            )
    splits.append(
        "Median s by the method called just before it: "
        + "; ".join(
            f"{SHORT[name]} after "
            + ", ".join(
                f"{SHORT[before]} {statistics.median(times):.2f}"
                for (method, before), times in sorted(after.items())
                if method == name
            )
            for name in names
        )
        + "."
    )
    about = (
        f"{conditions}. {scene_text}. The four run interleaved in one process, "
        f"{args.repeats} rounds, in orders where each method follows every other equally "
        "often (Williams' design); time is the median wall time of the whole call, "
        "x APMF its ratio to APMF's median (> 1: faster); CPU s: median CPU time of all "
        "threads (less sensitive to the other jobs on the machine than wall time). "
        "Targets (issue 14): tin_ground >= 1.5x, grid_ground >= 4x (wall time)."
    )
    header = ["method", "times s", "median s", "x APMF", "CPU s", "x APMF (CPU)"]
    header += ["Type I %", "Type II %"]
    command = command_of("benchmarks/speed/ground_vs_apmf.py", parser, args)
    publish_report(SECTION, command, about, header, rows, [" ".join(splits)], write=args.write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
