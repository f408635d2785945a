"""Where tin_ground's errors lie on the seven ISPRS samples: by height above the TIN, by slope.

Usage: python benchmarks/studies/tin_isprs_errors.py [--write]

Runs the default (TinGroundParams.isprs()) on each sample of ../shared/data/isprs and
bins its two kinds of error, ground missed (Type I) and objects taken as ground
(Type II), by the height of each point above the final pass's TIN (z - z_TIN, the
TIN of the lowest point of each final_cell cell of the densification's ground, as
the final pass builds it) and by that TIN's gradient under the point. The final
pass accepts a point when -final_below <= z - z_TIN <= final_above + final_slope *
gradient, so the bins show which errors a threshold on this TIN could still remove
and which lie where no such threshold separates ground from objects.

A third table splits the error between the two stages: the densification alone
(final pass off), the default, and the same final pass given the true ground (the
lowest ground point of each cell by the reference labels): the error that remains
with a perfect densification, at the default's thresholds.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import machine, markdown_table, publish, study_arguments  # noqa: E402
from ground_isprs import load_samples  # noqa: E402  (same folder)

import pcl_rg  # noqa: E402
from pcl_rg.evaluation import ground_errors  # noqa: E402
from pcl_rg.reference._final_pass import final_pass, heights_above_tin  # noqa: E402

SECTION = "## tin_ground's errors on ISPRS by height above the TIN and by slope"

#: Bin edges of z - z_TIN (m) and of the TIN's gradient (rise per run).
HEIGHT_BINS = (-np.inf, 0.0, 0.5, 0.8, 1.5, 2.5, 5.0, np.inf)
GRADIENT_BINS = (0.0, 0.2, 0.5, 1.0, 2.0, np.inf)


def _labels(edges) -> list[str]:
    return [
        f"< {b:g}" if np.isneginf(a) else f">= {a:g}" if np.isinf(b) else f"{a:g}-{b:g}"
        for a, b in zip(edges[:-1], edges[1:])
    ]


def binned(samples) -> tuple[list[list[str]], list[list[str]]]:
    """(rows by height, rows by gradient): per sample and kind of error, the counts."""
    params = pcl_rg.TinGroundParams.isprs()
    by_height, by_gradient = [], []
    for name, (points, truth) in samples.items():
        resolved = params.at_spacing(pcl_rg.point_spacing(points))
        ground = pcl_rg.tin_ground(points, params=resolved)
        densified = pcl_rg.tin_ground(points, params=resolved, final_cell=0.0)
        dz, gradient = heights_above_tin(points, densified, resolved.final_cell)
        e = ground_errors(truth, ground)
        head = [name, f"{100 * e.type_i:.2f}", f"{100 * e.type_ii:.2f}"]
        errors = (("missed ground", truth & ~ground), ("objects as ground", ~truth & ground))
        for kind, wrong in errors:
            heights = np.histogram(dz[wrong], HEIGHT_BINS)[0]
            slopes = np.histogram(gradient[wrong], GRADIENT_BINS)[0]
            by_height.append([*head, kind, *map(str, heights)])
            by_gradient.append([*head, kind, *map(str, slopes)])
        truth_slopes = np.histogram(gradient[truth], GRADIENT_BINS)[0]
        by_gradient.append([*head, "all ground", *map(str, truth_slopes)])
    return by_height, by_gradient


def stages(samples) -> list[list[str]]:
    """Per sample and the mean: errors of the densification alone, of the default, and
    of the default's final pass on the true ground (Type I, Type II, total %)."""
    params = pcl_rg.TinGroundParams.isprs()
    rows, totals = [], []
    for name, (points, truth) in samples.items():
        resolved = params.at_spacing(pcl_rg.point_spacing(points))
        on_truth = final_pass(
            np.asarray(points, dtype=np.float64),
            truth,
            resolved.final_cell,
            resolved.final_above,
            resolved.final_below,
            resolved.final_slope,
        )
        masks = (
            pcl_rg.tin_ground(points, params=resolved, final_cell=0.0),
            pcl_rg.tin_ground(points, params=resolved),
            on_truth,
        )
        errors = [ground_errors(truth, mask) for mask in masks]
        totals.append([v for e in errors for v in (e.type_i, e.type_ii, e.total)])
        rows.append([name, *(f"{100 * v:.2f}" for v in totals[-1])])
    rows.append(["**mean**", *(f"**{100 * v:.2f}**" for v in np.mean(totals, axis=0))])
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = study_arguments(__doc__)
    args = parser.parse_args(argv)
    samples = load_samples()
    by_height, by_gradient = binned(samples)
    head = ["sample", "Type I %", "Type II %", "points counted"]
    command = "python benchmarks/studies/tin_isprs_errors.py" + (" --write" if args.write else "")
    text = (
        f"{SECTION}\n\n`{command}` on {machine()}. The default's errors, counted in bins of "
        "the height above the final pass's TIN (z - z_TIN, m; the TIN of the lowest "
        "densified ground point per final_cell cell) and of that TIN's gradient under the "
        "point. The final pass takes a point as ground up to final_above + final_slope x "
        "gradient above the TIN (0.5 m + 1 x gradient).\n\n"
        + markdown_table(head + _labels(HEIGHT_BINS), by_height)
        + "\n\nBy the TIN's gradient (rise per run), with all ground points for scale:\n\n"
        + markdown_table(head + _labels(GRADIENT_BINS), by_gradient)
        + "\n\nBy stage: the densification alone (final_cell = 0), the default (its final "
        "pass on that densification), and the default's final pass on the true ground (the "
        "TIN of the lowest reference ground point per final_cell cell; the NumPy reference "
        "of the pass). The last is what a perfect densification would leave at the "
        "default's thresholds.\n\n"
        + markdown_table(
            [
                "sample",
                *(
                    f"{stage} {kind}"
                    for stage in ("densification", "default", "pass on true ground")
                    for kind in ("Type I %", "Type II %", "total %")
                ),
            ],
            stages(samples),
        )
        + "\n"
    )
    publish(text, SECTION, args.write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
