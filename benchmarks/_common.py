"""Benchmark plumbing: each case runs in a fresh child process, so its peak memory
is its own; timings are medians of repeats, compared side by side in one run."""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import multiprocessing as mp
import os
import platform
import re
import resource
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any


def _report(work: Callable[[], dict], queue) -> None:
    try:
        queue.put(work())
    except Exception as error:  # reported in the table, never hidden
        queue.put({"error": f"{type(error).__name__}: {error}"})


def in_child(work: Callable[[], dict]) -> dict:
    """`work()` in a forked child process: its result, or ``{"error": ...}``.

    A fresh child per case keeps each case's peak memory its own.
    """
    ctx = mp.get_context("fork")
    queue = ctx.Queue()
    process = ctx.Process(target=_report, args=(work, queue))
    process.start()
    result = queue.get()
    process.join()
    return result


def _timed_runs(setup: Callable[[], Any], run: Callable[[Any], Any], repeats: int) -> dict:
    data = setup()
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        output = run(data)
        times.append(time.perf_counter() - start)
        del output
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return {"times": times, "peak_mib": (peak - base) / 1024.0}


def measure(setup: Callable[[], Any], run: Callable[[Any], Any], repeats: int) -> dict:
    """Median time (s) of `run(setup())` over `repeats`, and peak memory added by it.

    Peak memory is the growth of the child's maximum RSS during the runs (MiB),
    beyond what the input data already occupied.
    """
    result = in_child(lambda: _timed_runs(setup, run, repeats))
    if "times" in result:
        result["median"] = statistics.median(result["times"])
    return result


def cpu_model() -> str:
    """The processor's name (Linux: /proc/cpuinfo), else what platform knows."""
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def machine() -> str:
    # The processor is named: ratios to PCL move with it (our memory-bound code against
    # PCL's compute-bound filters).
    return (
        f"{cpu_model()} ({platform.machine()}), {os.cpu_count()} cores, "
        f"Python {sys.version.split()[0]}, {platform.platform(terse=True)}"
    )


def study_arguments(doc: str) -> argparse.ArgumentParser:
    """The option every study takes: --write, which puts its section in RESULTS.md."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="update RESULTS.md")
    return parser


def speed_arguments(doc: str, points: int) -> argparse.ArgumentParser:
    """The options every speed run takes: --points, --repeats and --write."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--points", type=int, default=points)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--write", action="store_true", help="update benchmarks/RESULTS.md")
    return parser


def command_of(script: str, parser: argparse.ArgumentParser, args: argparse.Namespace) -> str:
    """The command that repeats this run: `script` and each option not at its default
    (--write is left to publish_report)."""
    words = [f"python {script}"]
    for action in parser._actions:
        value = getattr(args, action.dest, None)
        if not action.option_strings or action.dest in ("help", "write"):
            continue
        if value == action.default:
            continue
        flag = action.option_strings[0]
        if value is True:
            words.append(flag)
        elif isinstance(value, (list, tuple)):
            items = (f"{v:g}" if isinstance(v, float) else str(v) for v in value)
            words.append(" ".join([flag, *items]))
        else:
            words.append(f"{flag} {value}")
    return " ".join(words)


def run_conditions(load_before: float) -> str:
    """OpenMP threads and the 1-minute load average before and now, for a report."""
    threads = os.environ.get("OMP_NUM_THREADS", "all cores")
    return (
        f"OpenMP threads: {threads}; 1-minute load average {load_before:.1f} before, "
        f"{os.getloadavg()[0]:.1f} after"
    )


def carryover_balanced_orders(count: int) -> list[list[int]]:
    """Orders of `count` interleaved methods in which each follows every other equally
    often (Williams' design): a call's time depends on the call before it (memory it
    freed, caches it filled), and rotating one order keeps every method's predecessor.

    For an even `count`, `count` orders, each ordered pair once next to each other; for
    an odd one, those orders and their reverses, each pair twice.
    """
    if count < 1:
        raise ValueError(f"count must be at least 1, got {count}")
    # The first order goes 0, 1, n-1, 2, n-2, ...: its steps are 1, -2, 3, -4, ... (mod n),
    # every nonzero difference once when n is even; the others add a constant.
    first = [0]
    for step in range(1, count):
        first.append((first[-1] + (step if step % 2 else -step)) % count)
    orders = [[(m + shift) % count for m in first] for shift in range(count)]
    return orders if count % 2 == 0 else orders + [order[::-1] for order in orders]


def airborne_scene(points: int, density: float = 4.0) -> tuple[Any, str]:
    """The speed runs' synthetic_scene(seed=0) of about `points` points at `density`
    per m^2, and its description."""
    from pcl_rg.datasets import synthetic_scene

    size = math.sqrt(points / density)
    scene = synthetic_scene(seed=0, size=size, density=density)
    return scene, (
        f"synthetic_scene(seed=0, size={size:.1f}, density={density:g}): "
        f"{len(scene.points):,} points"
    )


def former_grid_default() -> Any:
    """grid_ground's default before the final pass and the density-aware cell: the
    full search over every field on ISPRS, 3 m cells (the studies' reference row)."""
    import pcl_rg

    return pcl_rg.GridGroundParams(
        cell_size=3.0,
        height_tolerance=0.3,
        min_seed_component=30,
        outlier_depth=0.0,
        filter_passes=3,
        filter_slope=1.0,
        filter_tolerance=0.3,
        final_cell=0.0,
        final_above=0.5,
    )


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def dump_json(path: str | None, payload: Any) -> None:
    if path:
        with open(path, "w") as handle:
            json.dump(payload, handle, indent=2)


RESULTS = Path(__file__).resolve().parent / "RESULTS.md"
# The shared data folder beside the checkout (../shared/data, see its README).
SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


# Notes written by hand into a generated section (history, analysis) go between these
# lines; write_section carries them over when it replaces the section.
KEPT_START, KEPT_END = "<!-- kept: written by hand -->", "<!-- /kept -->"
_KEPT = re.compile(
    rf"^{re.escape(KEPT_START)}\n.*?^{re.escape(KEPT_END)}$\n?", re.DOTALL | re.MULTILINE
)


def write_section(text: str, section: str, path: Path = RESULTS) -> None:
    """Put `text`, which starts with the "## " title `section`, into `path`.

    An older copy of the section is replaced, every other section kept; a new one
    is appended. The older copy's blocks between KEPT_START and KEPT_END lines
    follow the new text, in their order.
    """
    old = path.read_text() if path.exists() else "# Benchmark results\n"
    pattern = re.compile(rf"^{re.escape(section)}\n.*?(?=^## |\Z)", re.DOTALL | re.MULTILINE)
    found = pattern.search(old)
    if found:
        kept = "".join(
            "\n" + block.group(0).rstrip("\n") + "\n" for block in _KEPT.finditer(found.group(0))
        )
        replacement = text.rstrip("\n") + "\n" + kept + "\n"
        new = old[: found.start()] + replacement + old[found.end() :]
    else:
        new = old.rstrip("\n") + "\n\n" + text
    path.write_text(new)


def publish(text: str, section: str, write: bool) -> None:
    """Print a report and, with ``--write``, put it into RESULTS.md as `section`."""
    print(text)
    if write:
        write_section(text, section)


def publish_report(
    section: str,
    command: str,
    about: str,
    header: list[str],
    rows: list[list[str]],
    notes: Sequence[str] = (),
    *,
    write: bool,
) -> None:
    """The usual section: command and machine, what was run, the table, then notes.

    `command` is the script's path and options; " --write" is added when writing.
    """
    command += " --write" if write else ""
    text = f"{section}\n\n`{command}` on {machine()}. {about}\n\n{markdown_table(header, rows)}\n"
    if notes:
        text += "\n" + "\n".join(notes) + "\n"
    publish(text, section, write)


def coordinate_descent(
    score: Callable[[Any], float],
    start: Any,
    grid: dict[str, list],
    lines: list[str],
    replace: Callable[[Any, str, Any], Any] | None = None,
    min_gain: float = 0.0,
) -> tuple[Any, float]:
    """Lower `score` one field at a time over `grid`'s values, from `start`.

    Sweeps until one changes nothing (three at most); each improvement is logged to
    `lines` and stderr. Returns (best params, its score). The params are frozen
    dataclasses; fields not in `grid` keep `start`'s values. `replace(params, name,
    value)` makes a trial (default: dataclasses.replace; _scaled.Scaled.replace for
    lengths searched as multiples of the point spacing). A trial replaces the best only
    when it lowers the score by more than `min_gain` (0: any gain).
    """
    if replace is None:

        def replace(params: Any, name: str, value: Any) -> Any:
            return dataclasses.replace(params, **{name: value})

    best, best_error = start, score(start)
    lines.append(f"start {start}: mean total {100 * best_error:.2f} %")
    for sweep in range(1, 4):
        changed = False
        for name, values in grid.items():
            for value in values:
                trial = replace(best, name, value)
                error = score(trial)
                if error < best_error - max(min_gain, 1e-12):
                    best, best_error, changed = trial, error, True
                    lines.append(f"  sweep {sweep}: {name} = {value}: {100 * error:.2f} %")
                    print(lines[-1], file=sys.stderr, flush=True)
        if not changed:
            break
    return best, best_error


#: The seven mOSD learn scenes in ../shared/data/mosd.
MOSD_SCENES = ("learn0", "learn5", "learn17", "learn20", "learn25", "learn33", "learn40")


def mosd_at(leaf: float) -> list[tuple[str, Any, Any, Any]]:
    """Per mOSD scene: (name, truth per valid pixel, points to segment, voxel_of_point).

    `leaf` 0 is the raw frame (voxel_of_point None); otherwise the VoxelGrid centroids.
    """
    import numpy as np

    import pcl_rg
    from pcl_rg.datasets import load_mosd

    scenes = []
    for name in MOSD_SCENES:
        scene = load_mosd(SHARED_DATA / "mosd" / f"{name}.pcd")
        if leaf > 0:
            grid = pcl_rg.voxel_grid(scene.points, leaf_size=leaf)
            points = np.ascontiguousarray(grid.centroids)
            scenes.append((name, scene.labels, points, grid.voxel_of_point))
        else:
            scenes.append((name, scene.labels, scene.points, None))
    return scenes


def carry(labels: Any, voxel_of_point: Any) -> Any:
    """Labels of the segmented points carried to every pixel (-1 where none)."""
    import numpy as np

    if voxel_of_point is None:
        return labels
    return np.where(voxel_of_point >= 0, labels[np.maximum(voxel_of_point, 0)], -1)


def error_cells(
    type_i: float, type_ii: float, total: float, kappa: float, seconds: float, digits: int = 2
) -> list[str]:
    """A ground filter's ISPRS errors as table cells: percentages, kappa, time."""
    return [
        f"{100 * type_i:.2f}",
        f"{100 * type_ii:.2f}",
        f"{100 * total:.2f}",
        f"{kappa:.3f}",
        f"{seconds:.{digits}f}",
    ]
