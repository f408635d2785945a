"""Ground filters on the seven ISPRS samples: Type I / II / total error, kappa, time.

Usage:
    python benchmarks/studies/ground_isprs.py [--write] [--methods NAME ...]
    python benchmarks/studies/ground_isprs.py --search

The default run scores every method of METHODS on every sample of
../shared/data/isprs (Sithole & Vosselman's metrics, pcl_rg.evaluation) and
prints a markdown table; --write also puts it, with the command, in the
"Ground filters on ISPRS (grid_ground)" section of benchmarks/RESULTS.md.

--search chooses one parameter set for all samples, by the mean total error,
never per sample: the defaults of pcl_rg.GridGroundParams are its pick with
--rule resolution (RULES: the cell size a multiple of each sample's point
spacing), the rule with the lowest leave-one-sample-out error (ground_isprs_cv.py).
It runs a coordinate descent over a small fixed grid of values (SEARCH_GRID: eight
fields, and the cell size under the rules that scale it) from the definition of
algorithms.md section 3 with every option on at a middle value (START), then an
ablation that switches each option of the chosen
set back to the definition, to show each one earns its place. It takes a minute.

To add a method, append a (name, callable) pair to METHODS: the callable takes
the float64 (N, 3) points in UTM coordinates and returns a bool ground mask.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import importlib.metadata
import os
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import (  # noqa: E402
    RESULTS,
    SHARED_DATA,
    coordinate_descent,
    error_cells,
    former_grid_default,
    machine,
    markdown_table,
    publish,
)
from _scaled import PER_SPACING, Scaled, sample_errors  # noqa: E402

import pcl_rg
import pcl_rg.pcl
from pcl_rg.datasets import load_isprs
from pcl_rg.evaluation import ground_errors

DATA = SHARED_DATA / "isprs"
SAMPLES = ("samp11", "samp21", "samp31", "samp41", "samp51", "samp52", "samp61")
SECTION = "## Ground filters on ISPRS (grid_ground)"


@contextlib.contextmanager
def quiet_stdout() -> Iterator[None]:
    """Silence C-level stdout (CSF prints its progress there)."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def pcl_pmf(points: np.ndarray) -> np.ndarray:
    """pcl::ProgressiveMorphologicalFilter with PCL's tutorial parameters."""
    return pcl_rg.pcl.progressive_morphological_filter(points)


def installed_version(distribution: str) -> str:
    """The installed version of a peer (its figures move between releases)."""
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return "(not installed)"


def csf(points: np.ndarray) -> np.ndarray:
    """Cloth simulation filter (PyPI cloth-simulation-filter) with its defaults."""
    import CSF

    cloth = CSF.CSF()
    cloth.setPointCloud(points - points.min(axis=0))
    ground, off_ground = CSF.VecInt(), CSF.VecInt()
    with quiet_stdout():
        cloth.do_filtering(ground, off_ground, False)
    mask = np.zeros(len(points), dtype=bool)
    mask[np.asarray(ground, dtype=np.intp)] = True
    return mask


METHODS: list[tuple[str, Callable[[np.ndarray], np.ndarray]]] = [
    ("grid_ground (defaults)", lambda points: pcl_rg.grid_ground(points)),
    ("PCL ProgressiveMorphologicalFilter (tutorial)", pcl_pmf),
    (f"CSF {installed_version('cloth-simulation-filter')} (defaults)", csf),
    (
        "tin_ground (LiDAR360 defaults)",
        lambda points: pcl_rg.tin_ground(points, params=pcl_rg.TinGroundParams.lidar360()),
    ),
    ("tin_ground (isprs preset, the defaults)", lambda points: pcl_rg.tin_ground(points)),
]


def load_samples() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    return {s: load_isprs(DATA / f"{s}-utm.pcd", DATA / f"{s}-utm-ground.pcd") for s in SAMPLES}


def score(samples, methods) -> list[list[str]]:
    rows = []
    means: dict[str, list[list[float]]] = {name: [] for name, _ in methods}
    for sample, (points, truth) in samples.items():
        for name, method in methods:
            start = time.perf_counter()
            predicted = method(points)
            seconds = time.perf_counter() - start
            e = ground_errors(truth, predicted)
            means[name].append([e.type_i, e.type_ii, e.total, e.kappa, seconds])
            rows.append([sample, name, *error_cells(*means[name][-1])])
            print(f"  {sample} {name}: total {100 * e.total:.2f} %", file=sys.stderr)
    for name, values in means.items():
        m = np.mean(values, axis=0)
        rows.append(["**mean**", f"**{name}**", *error_cells(*m)])
    return rows


def mean_total(samples, setting) -> float:
    """Mean total error of `setting` (a Scaled, or params run as given)."""
    return float(np.mean([e.total for e in sample_errors(pcl_rg.grid_ground, samples, setting)]))


# The start of --search: the definition with every option on at a middle value (the
# final pass included), fixed before any search.
START = pcl_rg.GridGroundParams.definition(
    block_size=30.0,
    cell_size=3.0,
    slope=0.8,
    height_tolerance=0.0,
    min_seed_component=10,
    outlier_depth=0.0,
    grow_across_blocks=True,
    filter_passes=2,
    filter_slope=0.7,
    filter_tolerance=0.5,
    final_cell=4.0,
    final_above=0.5,
    final_below=1.0,
    final_slope=1.0,
    final_passes=1,
)

# Values tried by --search, per field; the other fields keep START's values. A search
# over every field (block and cell sizes, tolerances, seed component, passes too) fits
# the seven samples better (4.30 % with the final pass) but picks unstable sets on six
# of them: leave one sample out, its held-out error was about twice this small
# search's (benchmarks/RESULTS.md, cross-validated presets). The nine fields left are
# the growth's and the pre-filter's slopes, the low-outlier depth (from 0, off, the
# START), and the final pass (its depth below the TIN with tin_isprs_params.py's values;
# its low-ground depth from 0, off, the START; its rounds from one, the START), which
# decides last.
SEARCH_GRID = {
    "slope": [0.3, 0.5, 0.8, 1.2],
    "filter_slope": [0.5, 0.7, 1.0],
    "outlier_depth": [0.0, 1.0, 2.0, 5.0],
    "final_cell": [3.0, 4.0, 5.0, 6.0],
    "final_above": [0.3, 0.5, 0.8, 1.0],
    "final_below": [0.5, 1.0, 2.0, 5.0],
    "final_slope": [0.5, 1.0, 2.0],
    "final_low_depth": [0.0, 2.0, 3.0, 5.0],
    "final_passes": [1, 2, 3],
}


# What --search --rule fixed picks on the seven samples (3 m cells; its fitted and
# cross-validated errors are in RESULTS.md); the default is the "resolution" rule's pick.
SEARCH_PICK = dataclasses.replace(
    START, slope=0.3, filter_slope=0.7, final_cell=3.0, final_above=0.5, final_slope=1.0
)


# The preset before final_passes, outlier_depth and the search over final_below (cells
# of at most 2 spacings, one final round 0.8 m + 1 x gradient above and 1 m below the
# TIN, low outliers kept): 4.64 % fitted, 5.15 % cross-validated (RESULTS.md, before
# issue 14's grid improvements).
FORMER_PRESET = Scaled(
    dataclasses.replace(
        pcl_rg.GridGroundParams(),
        outlier_depth=0.0,
        final_above=0.8,
        final_below=1.0,
        final_slope=1.0,
        final_low_depth=0.0,
        final_passes=1,
    ),
    (("cell_size", 2.0),),
)


# The lengths that follow the point spacing, per rule (as tin_isprs_params.RULES):
# "fixed" is the search above (3 m cells; also the capped rule's picks on ISPRS);
# "spacing" searches cell_size and final_cell as multiples of each sample's spacing;
# "resolution" only cell_size. SPACING_GRID holds the multiples tried (ISPRS spacing:
# 1.0-1.1 m urban, 2.3-2.4 m rural), SPACING_START where they start.
RULES: dict[str, tuple[str, ...]] = {
    "fixed": (),
    "spacing": ("cell_size", "final_cell"),
    "resolution": ("cell_size",),
}
RULE = "resolution"  # the rule of GridGroundParams.isprs() (its lowest CV error)
# No cell below 2 spacings: 1.5 was tried and picked by the resolution rule (4.19 %
# fitted, 4.62 % CV, RESULTS.md), but on the dense synthetic check (ground_density.py)
# it split the ground at 20 points per m^2 (Type I 3.3 % against 1.6 %): the spacing
# counts every return, so under vegetation a cell that small holds too little ground
# for the 3 x 3 links (at 2 spacings: 4.22 % fitted on ISPRS).
SPACING_GRID = {"cell_size": [2.0, 3.0, 4.0], "final_cell": [2.0, 3.0, 4.0, 5.0, 6.0]}
SPACING_START = {"cell_size": 3.0, "final_cell": 4.0}


def choose(samples, lines: list[str], rule: str = RULE) -> tuple[Scaled, float]:
    """The search's pick on `samples`: (setting, mean total error)."""
    scaled = RULES[rule]
    start = Scaled(START)
    grid = {}
    for name in scaled:
        start = start.replace(name + PER_SPACING, SPACING_START[name])
    if "cell_size" in scaled:
        grid["cell_size" + PER_SPACING] = SPACING_GRID["cell_size"]
    for name, values in SEARCH_GRID.items():
        if name in scaled:
            grid[name + PER_SPACING] = SPACING_GRID[name]
        else:
            grid[name] = values
    return coordinate_descent(
        lambda p: mean_total(samples, p), start, grid, lines, replace=Scaled.replace
    )


def search(samples, rule: str = RULE) -> str:
    lines: list[str] = []
    best, best_error = choose(samples, lines, rule)
    lines.append(f"chosen ({rule}): {best.describe()}")
    lines.append(f"mean total error {100 * best_error:.2f} %")
    lines.append("ablation (each option back to the definition):")
    for name, plain in [
        ("min_seed_component", 1),
        ("outlier_depth", 0.0),
        ("grow_across_blocks", False),
        ("filter_passes", 0),
        ("final_cell", 0.0),
        ("final_passes", 1),
    ]:
        error = mean_total(samples, best.replace(name, plain))
        lines.append(f"  {name} = {plain}: {100 * error:.2f} %")
    everything_off = Scaled(
        dataclasses.replace(
            best.params, min_seed_component=1, grow_across_blocks=False, filter_passes=0
        ),
        best.multiples,
    )
    lines.append(f"  all three: {100 * mean_total(samples, everything_off):.2f} %")
    defaults = pcl_rg.GridGroundParams()
    lines.append(f"current defaults: {100 * mean_total(samples, defaults):.2f} %")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--search", action="store_true", help="choose grid_ground defaults")
    parser.add_argument("--write", action="store_true", help=f"update {RESULTS.name}")
    parser.add_argument("--methods", nargs="*", help="names (prefixes) of METHODS to run")
    parser.add_argument("--rule", choices=list(RULES), default=RULE, help="lengths that scale")
    args = parser.parse_args(argv)
    samples = load_samples()
    if args.search:
        print(search(samples, args.rule))
        return 0
    methods = [
        (name, method)
        for name, method in METHODS
        if not args.methods or any(name.startswith(prefix) for prefix in args.methods)
    ]
    rows = score(samples, methods)
    header = ["sample", "method", "Type I %", "Type II %", "total %", "kappa", "time s"]
    command = "python benchmarks/studies/ground_isprs.py" + (" --write" if args.write else "")
    text = (
        f"{SECTION}\n\n"
        f"`{command}` on {machine()}. Errors as Sithole & Vosselman define them, on the\n"
        "seven ISPRS samples of ../shared/data/isprs (y quantised to 0.5 m by float32, so\n"
        "compare methods side by side, not with published figures). Each method runs\n"
        "with one parameter set for all samples; time is one run, wall clock.\n\n"
        f"grid_ground defaults: `{pcl_rg.GridGroundParams()}`\n\n"
        + markdown_table(header, rows)
        + "\n"
    )
    text += "\n" + ablation(samples)
    publish(text, SECTION, args.write)
    return 0


def ablation(samples) -> str:
    """Mean total error of grid_ground with each option back to the definition."""
    defaults = pcl_rg.GridGroundParams()
    variants = [
        ("defaults", defaults),
        ("min_seed_component = 1", dataclasses.replace(defaults, min_seed_component=1)),
        ("grow_across_blocks = False", dataclasses.replace(defaults, grow_across_blocks=False)),
        ("filter_passes = 0", dataclasses.replace(defaults, filter_passes=0)),
        ("filter_passes = 1", dataclasses.replace(defaults, filter_passes=1)),
        ("final_cell = 0 (final pass off)", dataclasses.replace(defaults, final_cell=0.0)),
        ("final_passes = 1 (one final round)", dataclasses.replace(defaults, final_passes=1)),
        ("final_passes = 3", dataclasses.replace(defaults, final_passes=3)),
        ("outlier_depth = 0 (low outliers kept)", dataclasses.replace(defaults, outlier_depth=0.0)),
        (
            "final_low_depth = 0 (low ground gives TIN vertices)",
            dataclasses.replace(defaults, final_low_depth=0.0),
        ),
        ("final_below = 1 m (the former depth)", dataclasses.replace(defaults, final_below=1.0)),
        (
            "final_below = 1 m, outlier_depth = 0, final_passes = 1",
            dataclasses.replace(defaults, final_below=1.0, outlier_depth=0.0, final_passes=1),
        ),
        (
            "final_above = 0.8 m, final_slope = 1 m (the former)",
            dataclasses.replace(defaults, final_above=0.8, final_slope=1.0),
        ),
        ("cell_size = 1.5 x spacing (see SPACING_GRID)", Scaled(defaults, (("cell_size", 1.5),))),
        ("the preset before issue 14's options", FORMER_PRESET),
        ("cell_size = 3 m (fixed)", dataclasses.replace(defaults, cell_size=3.0)),
        ("the --search --rule fixed pick (3 m cells, 3 m final cells)", SEARCH_PICK),
        ("the former default (full search, no final pass)", former_grid_default()),
        ("height_tolerance = 0.3", dataclasses.replace(defaults, height_tolerance=0.3)),
        ("the definition (all options off, t = 0)", pcl_rg.GridGroundParams.definition()),
    ]
    rows = [[name, f"{100 * mean_total(samples, p):.2f}"] for name, p in variants]
    return (
        "grid_ground ablation (each row changes one field of the defaults; the last row is "
        "the pick of `python benchmarks/studies/ground_isprs.py --search`):\n\n"
        + markdown_table(["grid_ground parameters", "mean total %"], rows)
        + "\n"
    )


if __name__ == "__main__":
    raise SystemExit(main())
