"""Leave-one-sample-out cross-validation of the ISPRS presets of both ground filters.

Usage: python benchmarks/studies/ground_isprs_cv.py [--write] [--filters tin grid]
       [--rules fixed spacing resolution] [--jobs N]

Each filter's search (tin_isprs_params.py, ground_isprs.py --search) picks one set
on all seven samples of ../shared/data/isprs, so its error there is a fitted
figure. This study repeats the search (the same coordinate descent, unchanged)
seven times, each time on six samples, and scores the set it picks on the seventh,
the one it never saw. The mean of those seven held-out errors is the figure that
predicts unseen data; the table puts it beside the fitted one, per sample.

The lengths that can follow the point spacing are searched, and picked, in metres or
as multiples of each sample's spacing, as each study's RULES say (--rules: one
summary row per filter and rule; the per-sample table is of each filter's own rule,
the one its preset follows).
"""

from __future__ import annotations

import functools
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
from _common import machine, markdown_table, publish, study_arguments  # noqa: E402
from _scaled import sample_errors  # noqa: E402

import pcl_rg  # noqa: E402

SECTION = "## Ground filters on ISPRS: cross-validated presets"
# With --selections: the tin search's selection procedures side by side, own section.
SELECTIONS_SECTION = "## tin_ground on ISPRS: selection procedures, cross-validated"


SELECTIONS_NOTE = (
    " Selection procedures of the tin search (tin_isprs_params.SELECTIONS), each applied "
    "in every fold and for the fitted pick: mean, the search of the preset (lowest mean "
    "total error over the training samples); gain, a change of one field is kept only "
    "when it lowers that mean by more than 0.1 percentage points; trimmed, the mean "
    "without the worst training sample; trimmed-gain, both; joint, one descent over the "
    "densification's and the final pass's fields together, so that the densification is "
    "scored after the final pass (mean's first stage scores it with the pass off); rank-2, "
    "mean's search with opening_rank fixed at 2 (a rank-order opening for the seeds, which the "
    "search does not pick on all seven samples when it may). These few candidates were "
    "written after the CV results of mean were known; none was tuned on the CV figures."
)


def tin_search(samples, rule, selection=tin_isprs_params.SELECTION):
    best, _ = tin_isprs_params.search(samples, rule, selection)
    return best


def grid_search(samples, rule):
    best, _ = ground_isprs.choose(samples, [], rule)
    return best


# Each filter: the function, the search (a _scaled.Scaled setting from the training
# samples, for a rule) and the study that holds its RULES and own RULE.
FILTERS = {
    "tin": (pcl_rg.tin_ground, tin_search, tin_isprs_params),
    "grid": (pcl_rg.grid_ground, grid_search, ground_isprs),
}


def cross_validate(
    name: str, rule: str, samples, selection: str | None = None
) -> tuple[list[list[str]], list, list]:
    """Every fold of one filter and rule: (table rows, fitted errors, held-out errors).

    Fitted: the search's pick on all seven samples, scored on each. `selection`: the
    tin search's selection procedure (tin_isprs_params.SELECTIONS; None: its own), the
    same in every fold and for the fitted pick.
    """
    function, search, _ = FILTERS[name]
    start = time.perf_counter()
    search = functools.partial(search, selection=selection) if selection else search
    label = f"{name} ({rule}{', ' + selection if selection else ''})"
    fitted_pick = search(samples, rule)
    print(f"  {label} on all seven: {fitted_pick.describe()}", file=sys.stderr)
    rows, fitted, unseen = [], [], []
    for held_out, (points, truth) in samples.items():
        training = {s: v for s, v in samples.items() if s != held_out}
        chosen = search(training, rule)
        (fit,) = sample_errors(function, {held_out: (points, truth)}, fitted_pick)
        (out,) = sample_errors(function, {held_out: (points, truth)}, chosen)
        fitted.append(fit)
        unseen.append(out)
        rows.append(
            [
                name,
                held_out,
                f"{100 * fit.total:.2f}",
                f"{fit.kappa:.3f}",
                f"{100 * out.type_i:.2f}",
                f"{100 * out.type_ii:.2f}",
                f"{100 * out.total:.2f}",
                f"{out.kappa:.3f}",
                chosen.describe(fitted_pick).replace("= preset", "= the fitted pick"),
            ]
        )
        print(
            f"  {label} without {held_out}: held out {100 * out.total:.2f} % "
            f"(fitted {100 * fit.total:.2f} %), {time.perf_counter() - start:.0f} s",
            file=sys.stderr,
            flush=True,
        )
    rows.insert(0, [name, "(all seven)", "", "", "", "", "", "", fitted_pick.describe()])
    return rows, fitted, unseen


def _own_selection(name: str) -> str | None:
    """The selection procedure of a filter's preset (None: the filter has no choice)."""
    return getattr(FILTERS[name][2], "SELECTION", None)


def jittered(samples, jitter: float):
    """`samples` with x and y moved by uniform draws in [-jitter, jitter] (seed 1)."""
    if not jitter:
        return samples
    rng = np.random.default_rng(1)
    moved = {}
    for name, (points, truth) in samples.items():
        shift = np.zeros_like(points)
        shift[:, :2] = rng.uniform(-jitter, jitter, (len(points), 2))
        moved[name] = (points + shift, truth)
    return moved


def _mean(errors, field: str) -> float:
    return float(np.mean([getattr(e, field) for e in errors]))


def main(argv: list[str] | None = None) -> int:
    parser = study_arguments(__doc__)
    parser.add_argument("--filters", nargs="+", choices=list(FILTERS), default=list(FILTERS))
    parser.add_argument(
        "--rules", nargs="+", default=None, help="rules of the studies' RULES (default: own)"
    )
    parser.add_argument(
        "--selections",
        nargs="+",
        choices=list(tin_isprs_params.SELECTIONS),
        default=None,
        help="tin search's selection procedures (default: its own)",
    )
    parser.add_argument("--jobs", type=int, default=1, help="(filter, rule)s run at once")
    parser.add_argument(
        "--jitter",
        type=float,
        default=0.0,
        metavar="M",
        help="move x and y of every point by a uniform draw in [-M, M] m (seed 1) first, to "
        "see how far the held-out figures hang on millimetres; never written to RESULTS.md",
    )
    args = parser.parse_args(argv)
    if args.jitter and args.write:
        parser.error("--jitter is a check of the figures, not a result: drop --write")
    samples = jittered(ground_isprs.load_samples(), args.jitter)
    tasks = []
    for name in args.filters:
        study = FILTERS[name][2]
        rules = [r for r in (args.rules or [study.RULE]) if r in study.RULES]
        selections = (args.selections or [None]) if name == "tin" else [None]
        tasks += [(name, rule, selection) for rule in rules for selection in selections]
    if args.jobs > 1:  # side by side, each in its own process (own score cache)
        context = multiprocessing.get_context("fork")
        with ProcessPoolExecutor(args.jobs, mp_context=context) as pool:
            futures = [
                pool.submit(cross_validate, name, rule, samples, selection)
                for name, rule, selection in tasks
            ]
            results = [future.result() for future in futures]
    else:
        results = [
            cross_validate(name, rule, samples, selection) for name, rule, selection in tasks
        ]
    header = [
        "filter",
        "held-out sample",
        "fitted total %",
        "fitted kappa",
        "CV Type I %",
        "CV Type II %",
        "CV total %",
        "CV kappa",
        "fold's pick (fields unlike the fitted pick)",
    ]
    rows, summary = [], []
    for (name, rule, selection), (fold_rows, fitted, unseen) in zip(tasks, results):
        own = rule == FILTERS[name][2].RULE and selection in (None, _own_selection(name))
        line = [
            name,
            rule
            + (f", selection {selection}" if selection else "")
            + (" (the preset's)" if own else ""),
            f"{100 * _mean(fitted, 'total'):.2f}",
            f"{_mean(fitted, 'kappa'):.3f}",
            f"{100 * _mean(unseen, 'total'):.2f}",
            f"{_mean(unseen, 'kappa'):.3f}",
        ]
        summary.append(line)
        if rule != FILTERS[name][2].RULE:
            continue
        if selection:  # several selections of the filter's rule: each its own rows
            fold_rows = [[f"{name} ({selection})", *row[1:]] for row in fold_rows]
        rows += fold_rows
        rows.append(
            [
                f"**{fold_rows[0][0]}**",
                "**mean**",
                f"**{line[2]}**",
                line[3],
                "",
                "",
                f"**{line[4]}**",
                line[5],
                "",
            ]
        )
    section = SELECTIONS_SECTION if args.selections else SECTION
    command = "python benchmarks/studies/ground_isprs_cv.py" + (" --write" if args.write else "")
    command += f" --filters {' '.join(args.filters)}" if args.filters != list(FILTERS) else ""
    command += f" --rules {' '.join(args.rules)}" if args.rules else ""
    command += f" --selections {' '.join(args.selections)}" if args.selections else ""
    command += f" --jobs {args.jobs}" if args.jobs > 1 else ""
    command += f" --jitter {args.jitter:g}" if args.jitter else ""
    text = (
        f"{section}\n\n`{command}` on {machine()}. Fitted: the search's pick on all seven "
        "samples, scored on each. CV: the same search run on the other six samples, its "
        "pick scored on the held-out one (leave one sample out). Mean total error and mean "
        "kappa over the seven samples. Rules for the lengths that can follow the point "
        "spacing (the studies' RULES): fixed, every length in metres (on ISPRS also the "
        "capped rule, min(fitted length, multiple x spacing), whose cap binds only below "
        "ISPRS spacing); spacing, every such length a multiple of the spacing; "
        "resolution, only the lengths that set the resolution (tin: stop_edge, "
        "near_vertex_distance; grid: cell_size), the seed and final-pass cells in metres."
        + (SELECTIONS_NOTE if args.selections else "")
        + "\n\n"
        + markdown_table(
            ["filter", "rule", "fitted total %", "fitted kappa", "CV total %", "CV kappa"],
            summary,
        )
        + "\n\nPer held-out sample, each filter's own rule:\n\n"
        + (markdown_table(header, rows) if rows else "(not run)")
        + "\n"
    )
    publish(text, section, args.write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
