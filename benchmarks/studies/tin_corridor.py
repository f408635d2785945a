"""tin_ground along corridors: the border vertices on and off.

Usage: python benchmarks/studies/tin_corridor.py [--write] [--seeds N]

A corridor survey (a road, a railway, a power line) is far longer than it is wide.
With the four box corners as its only virtual vertices, the TIN's border triangles
reach from the data to corners kilometres away; and on terrain sloping across the
corridor, the seeds' opening, clipped at the cloud's border, leaves the uphill
strip almost without seeds. Densification does not recover that strip there, as it
does in a square tile. TinGroundParams.border_vertices adds virtual vertices along
the long sides (ground_tin.hpp: border_points). This study scores the default with
the option on and off on synthetic corridors (corridor(): terrain rising across the
corridor and rolling along it, a share of the points vegetation above it), with a
square tile and a corridor across the axes (whose box is about square, so it gets
no border vertices) as controls.

No evaluation code lives here: the scores come from pcl_rg.evaluation.ground_errors.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import machine, markdown_table, publish, study_arguments  # noqa: E402

import pcl_rg  # noqa: E402
from pcl_rg.evaluation import ground_errors  # noqa: E402

SECTION = "## tin_ground along corridors (border vertices)"

#: (length m, width m, points per m^2, direction deg from x): the scenes of the table.
SCENES = (
    (2000.0, 30.0, 2.0, 0.0),
    (3000.0, 50.0, 4.0, 0.0),
    (3000.0, 100.0, 4.0, 0.0),
    (3000.0, 50.0, 4.0, 90.0),
    (1000.0, 200.0, 4.0, 0.0),
    (3000.0, 50.0, 4.0, 45.0),
    (500.0, 500.0, 4.0, 0.0),
)
#: Rise across the corridor (m per m) and the width of the strip along its uphill side
#: whose missed ground the table gives apart (m).
CROSS_SLOPE = 0.25
UPHILL_STRIP = 10.0


def corridor(
    length: float,
    width: float,
    density: float,
    seed: int,
    direction: float = 0.0,
    vegetation: float = 0.3,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points (N, 3), true ground (N,), distance across the corridor (N,)) of a corridor
    `length` x `width` m at `density` points per m^2, running `direction` degrees from x,
    in UTM-sized coordinates: terrain rising CROSS_SLOPE across it and rolling along it
    (15 m over 250 m, 3 m over about 40 m), a `vegetation` share of the points 0.5-15 m
    above it, 3 cm of noise on every height."""
    rng = np.random.default_rng(seed)
    n = int(length * width * density)
    along, across = rng.uniform(0.0, length, n), rng.uniform(0.0, width, n)
    z = (
        CROSS_SLOPE * across
        + 15.0 * np.sin(along / 250.0)
        + 3.0 * np.sin(along / 37.0 + across / 23.0)
    )
    ground = rng.random(n) >= vegetation
    z[~ground] += rng.uniform(0.5, 15.0, int((~ground).sum()))
    z += 0.03 * rng.standard_normal(n)
    c, s = math.cos(math.radians(direction)), math.sin(math.radians(direction))
    x = 480_000.0 + along * c - across * s
    y = 5_400_000.0 + along * s + across * c
    return np.c_[x, y, z], ground, across


def score(seeds: int) -> list[list[str]]:
    """One row per scene and setting: mean errors over the seeds, time of one call."""
    rows = []
    for length, width, density, direction in SCENES:
        sums: dict[bool, np.ndarray] = {border: np.zeros(6) for border in (False, True)}
        for seed in range(seeds):
            points, truth, across = corridor(length, width, density, seed, direction)
            uphill = truth & (across > width - UPHILL_STRIP)
            for border in (False, True):
                start = time.perf_counter()
                ground = pcl_rg.tin_ground(points, border_vertices=border)
                seconds = time.perf_counter() - start
                e = ground_errors(truth, ground)
                strip = np.mean(~ground[uphill])
                sums[border] += [e.type_i, e.type_ii, e.total, e.kappa, strip, seconds]
        for border in (False, True):
            i, ii, total, kappa, strip, seconds = sums[border] / seeds
            rows.append(
                [
                    f"{length:g} x {width:g} m, {density:g} pts/m^2, {direction:g} deg",
                    str(border),
                    f"{100 * i:.2f}",
                    f"{100 * ii:.2f}",
                    f"{100 * total:.2f}",
                    f"{kappa:.3f}",
                    f"{100 * strip:.2f}",
                    f"{seconds:.2f}",
                ]
            )
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = study_arguments(__doc__)
    parser.add_argument("--seeds", type=int, default=3, help="scenes per row (seeds 0..N-1)")
    args = parser.parse_args(argv)
    rows = score(args.seeds)
    command = "python benchmarks/studies/tin_corridor.py" + (" --write" if args.write else "")
    command += f" --seeds {args.seeds}" if args.seeds != 3 else ""
    header = [
        "corridor",
        "border_vertices",
        "Type I %",
        "Type II %",
        "total %",
        "kappa",
        f"uphill {UPHILL_STRIP:g} m, Type I %",
        "time s",
    ]
    text = (
        f"{SECTION}\n\n`{command}` on {machine()}. tin_ground defaults (TinGroundParams."
        f"isprs()) with border_vertices on (the default) and off, on synthetic corridors "
        f"(study's corridor(): terrain rising {CROSS_SLOPE:g} across the corridor and "
        "rolling along it, 30 % of the points vegetation 0.5-15 m above it), means over "
        f"seeds 0-{args.seeds - 1}; time: one call, wall clock, mean over the seeds. The "
        "uphill column is the ground missed in the strip along the corridor's uphill "
        "side. Controls: a corridor across the axes (45 deg), whose box is about square and "
        "gets no border vertices, and a square tile.\n\n" + markdown_table(header, rows) + "\n"
    )
    publish(text, SECTION, args.write)
    return 0


if __name__ == "__main__":
    sys.exit(main())
