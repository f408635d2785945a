"""Leave-one-sample-out cross-validation of the ISPRS presets of both ground filters.

Usage: python benchmarks/studies/ground_isprs_cv.py [--write] [--filters tin grid]

The presets (TinGroundParams.isprs(), GridGroundParams.isprs()) were chosen by a
search over all seven samples of ../shared/data/isprs, so their error there is a
fitted figure. This study repeats each filter's own search (the coordinate descent
of tin_isprs_params.py and ground_isprs.py --search, unchanged) seven times, each
time on six samples, and scores the set it picks on the seventh, the one it never
saw. The mean of those seven held-out errors is the figure that predicts unseen
data; the table puts it beside the fitted one, per sample. The lengths that scale
with the point spacing are searched, and picked, as multiples of each sample's
spacing (the presets leave them unset: SPACING_MULTIPLES).
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
sys.path.insert(0, str(Path(__file__).resolve().parent))  # the two search studies
import ground_isprs  # noqa: E402
import tin_isprs_params  # noqa: E402
from _common import machine, markdown_table, publish  # noqa: E402

import pcl_rg  # noqa: E402
from pcl_rg.evaluation import ground_errors  # noqa: E402

SECTION = "## Ground filters on ISPRS: cross-validated presets"


def tin_search(samples):
    best, _ = tin_isprs_params.search(samples)
    return best


def grid_search(samples):
    best, _ = ground_isprs.choose(samples, [])
    return best


# Each filter: the function, its preset, the search (a (params, spacing multiples)
# setting from the training samples) and how a setting runs on points.
FILTERS = {
    "tin": (
        pcl_rg.tin_ground,
        pcl_rg.TinGroundParams.isprs(),
        tin_search,
        tin_isprs_params.predict,
    ),
    "grid": (
        pcl_rg.grid_ground,
        pcl_rg.GridGroundParams.isprs(),
        grid_search,
        ground_isprs.predict,
    ),
}


def changed_fields(setting, preset) -> str:
    """Where a fold's pick differs from the preset: name=value, multiples as "x spacing"."""
    params, multiples = setting
    names = [f for f in params.__dataclass_fields__ if getattr(params, f) != getattr(preset, f)]
    changed = [f"{n}={getattr(params, n)}" for n in names]
    changed += [
        f"{n}={m:g} x spacing"
        for n, m in multiples.items()
        if getattr(params, n) is None and m != preset.SPACING_MULTIPLES[n]
    ]
    return ", ".join(changed) or "= preset"


def cross_validate_fold(name: str, held_out: str, samples) -> tuple[list[str], float, float]:
    """One fold: the search on the samples but `held_out`, its pick scored on that one.

    Returns the table row, the preset's (fitted) and the pick's (held-out) total error.
    """
    function, preset, search, predict = FILTERS[name]
    points, truth = samples[held_out]
    start = time.perf_counter()
    training = {s: v for s, v in samples.items() if s != held_out}
    chosen = search(training)
    fitted = ground_errors(truth, function(points, params=preset))
    unseen = ground_errors(truth, predict(points, chosen))
    row = [
        name,
        held_out,
        f"{100 * fitted.total:.2f}",
        f"{fitted.kappa:.3f}",
        f"{100 * unseen.type_i:.2f}",
        f"{100 * unseen.type_ii:.2f}",
        f"{100 * unseen.total:.2f}",
        f"{unseen.kappa:.3f}",
        changed_fields(chosen, preset),
    ]
    print(
        f"  {name} without {held_out}: held out {100 * unseen.total:.2f} % "
        f"(fitted {100 * fitted.total:.2f} %), {time.perf_counter() - start:.0f} s",
        file=sys.stderr,
        flush=True,
    )
    return row, fitted.total, unseen.total


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="update RESULTS.md")
    parser.add_argument("--filters", nargs="+", choices=list(FILTERS), default=list(FILTERS))
    parser.add_argument(
        "--jobs", type=int, default=1, help="folds cross-validated at once (processes)"
    )
    args = parser.parse_args(argv)
    samples = ground_isprs.load_samples()
    header = [
        "filter",
        "held-out sample",
        "fitted total %",
        "fitted kappa",
        "CV Type I %",
        "CV Type II %",
        "CV total %",
        "CV kappa",
        "fold's pick (fields unlike the preset)",
    ]
    rows, summary = [], []
    tasks = [(name, held_out) for name in args.filters for held_out in samples]
    if args.jobs > 1:  # folds side by side, each in its own process
        context = multiprocessing.get_context("fork")
        with ProcessPoolExecutor(args.jobs, mp_context=context) as pool:
            futures = [pool.submit(cross_validate_fold, *task, samples) for task in tasks]
            folds = [future.result() for future in futures]
    else:
        folds = [cross_validate_fold(*task, samples) for task in tasks]
    for name in args.filters:
        own = [fold for task, fold in zip(tasks, folds) if task[0] == name]
        fold_rows = [row for row, _, _ in own]
        fitted = [total for _, total, _ in own]
        unseen = [total for _, _, total in own]
        rows += fold_rows
        kappas_fit = np.mean([float(r[3]) for r in fold_rows])
        kappas_cv = np.mean([float(r[7]) for r in fold_rows])
        rows.append(
            [
                f"**{name}**",
                "**mean**",
                f"**{100 * np.mean(fitted):.2f}**",
                f"{kappas_fit:.3f}",
                "",
                "",
                f"**{100 * np.mean(unseen):.2f}**",
                f"{kappas_cv:.3f}",
                "",
            ]
        )
        growth = 100 * (np.mean(unseen) / np.mean(fitted) - 1)
        summary.append(
            f"- {name}: fitted {100 * np.mean(fitted):.2f} %, cross-validated "
            f"{100 * np.mean(unseen):.2f} % ({growth:+.0f} %)."
        )
    command = "python benchmarks/studies/ground_isprs_cv.py" + (" --write" if args.write else "")
    command += f" --jobs {args.jobs}" if args.jobs > 1 else ""
    text = (
        f"{SECTION}\n\n`{command}` on {machine()}. Fitted: the preset, chosen on all seven "
        "samples, scored on each. CV: the same search run on the other six samples, its "
        "pick scored on the held-out one (leave one sample out). Mean total error and mean "
        "kappa over the seven samples.\n\n"
        + markdown_table(header, rows)
        + "\n\n"
        + "\n".join(summary)
        + "\n"
    )
    publish(text, SECTION, args.write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
