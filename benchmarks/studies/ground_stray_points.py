"""The ground filters on ISPRS with one stray point far away (a bad GPS fix).

Usage: python benchmarks/studies/ground_stray_points.py [--write]

Each of the seven samples of ../shared/data/isprs is filtered as it is and with one
point added 500 km west and 500 km south of its centroid, at its mean height. The
table gives the measured spacing (pcl_rg.point_spacing), the spacing the box alone
would give (the former rule, pcl_rg.reference.box_spacing: cells of 3 x sqrt(box
area / N)), and each filter's total error on the sample's own points, both defaults.
The stray point makes the box about 700 km wide: measured on the box, the spacing
(and grid_ground's cell of 2 spacings) grew a hundredfold, and tin_ground's seed
raster did not fit.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import publish_report, study_arguments  # noqa: E402
from ground_isprs import load_samples  # noqa: E402  (same folder)

import pcl_rg  # noqa: E402
from pcl_rg import reference  # noqa: E402
from pcl_rg.evaluation import ground_errors  # noqa: E402

SECTION = "## Ground filters on ISPRS with a stray point 700 km away"
OFFSET = np.array([-5e5, -5e5, 0.0])


def main(argv: list[str] | None = None) -> int:
    parser = study_arguments(__doc__)
    args = parser.parse_args(argv)
    rows, totals = [], []
    for name, (points, truth) in load_samples().items():
        n = len(points)
        stray = np.r_[points, [points.mean(axis=0) + OFFSET]]
        figures = [pcl_rg.point_spacing(points), pcl_rg.point_spacing(stray)]
        figures.append(reference.box_spacing(stray))
        for function in (pcl_rg.grid_ground, pcl_rg.tin_ground):
            figures.append(100 * ground_errors(truth, function(points)).total)
            figures.append(100 * ground_errors(truth, function(stray)[:n]).total)
        totals.append(figures[3:])
        rows.append([name, *(f"{v:.3f}" for v in figures[:3]), *(f"{v:.2f}" for v in figures[3:])])
    rows.append(["**mean**", "", "", "", *(f"**{v:.2f}**" for v in np.mean(totals, axis=0))])
    publish_report(
        SECTION,
        "python benchmarks/studies/ground_stray_points.py",
        "Spacings in m, total errors in % of the sample's points; both filters with their "
        "defaults, lengths from the measured spacing.",
        [
            "sample",
            "spacing",
            "spacing, stray",
            "spacing of the box, stray (former rule)",
            "grid_ground total %",
            "grid_ground, stray",
            "tin_ground total %",
            "tin_ground, stray",
        ],
        rows,
        [
            "With the stray point tin_ground's TIN joins it to the border of the data, "
            "whose triangles then judge the points near the border: drop such points first "
            "(statistical_outlier_removal, `pcl-rg denoise`). Under the former rule "
            "grid_ground's mean total error with the stray point was 10.86 %, and "
            "tin_ground refused every sample (its seed raster would not fit)."
        ],
        write=args.write,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
