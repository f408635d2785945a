"""The ground filters on ISPRS samples delivered in US survey feet.

Usage: python benchmarks/studies/ground_units.py [--write]

Each of the seven samples of ../shared/data/isprs is written to a LAS file in US
survey feet (x, y and z, at 0.01 ft) that states so in its OGC WKT, as a US state-
plane delivery does. The table gives each filter's total error with its defaults:
on the sample in metres (`pcl_rg.grid_ground` / `tin_ground` on the array); on the
feet taken for metres (the same call on the file's coordinates, which is what
`pcl-rg ground` did before it read the units); and `pcl-rg ground` on the feet file,
which now scales the points to metres for the work. Every length of the package is
in metres, so feet taken for metres shrink the 40 m building window to 12 m, the
0.5 m height thresholds to 15 cm, and so on.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))  # units_files.py
from _common import publish_report, study_arguments  # noqa: E402
from ground_isprs import load_samples  # noqa: E402  (same folder)
from units_files import NEW_YORK_FTUS_WKT1, US_FOOT, wkt_record, write_las  # noqa: E402

import pcl_rg  # noqa: E402
from pcl_rg.evaluation import ground_errors  # noqa: E402
from pcl_rg.io import read_points  # noqa: E402

SECTION = "## Ground filters on ISPRS in US survey feet"
METHODS = {"grid": pcl_rg.grid_ground, "tin": pcl_rg.tin_ground}


def command_line(path: Path, method: str, folder: str) -> np.ndarray:
    """The ground mask `pcl-rg ground` writes for the file."""
    out = Path(folder) / f"out-{method}.las"
    command = [sys.executable, "-m", "pcl_rg", "ground", str(path), str(out), "-q"]
    subprocess.run([*command, "--method", method], check=True)
    return read_points(out).classification == 2


def main(argv: list[str] | None = None) -> int:
    parser = study_arguments(__doc__)
    args = parser.parse_args(argv)
    rows, totals = [], []
    with tempfile.TemporaryDirectory() as folder:
        for name, (points, truth) in load_samples().items():
            path = Path(folder) / f"{name}-ftUS.las"
            write_las(path, points / US_FOOT, [wkt_record(NEW_YORK_FTUS_WKT1)])
            feet = read_points(path).points
            figures = []
            for method, function in METHODS.items():
                figures.append(ground_errors(truth, function(points)).total)
                figures.append(ground_errors(truth, function(feet)).total)
                figures.append(ground_errors(truth, command_line(path, method, folder)).total)
            totals.append(figures)
            rows.append([name, *(f"{100 * v:.2f}" for v in figures)])
    rows.append(["**mean**", *(f"**{100 * v:.2f}**" for v in np.mean(totals, axis=0))])
    publish_report(
        SECTION,
        "python benchmarks/studies/ground_units.py",
        "Total errors in % of the sample's points; both filters with their defaults "
        "(lengths from the measured spacing where unset).",
        [
            "sample",
            "grid_ground, metres",
            "grid_ground, feet taken for metres (before)",
            "pcl-rg ground --method grid, feet file",
            "tin_ground, metres",
            "tin_ground, feet taken for metres (before)",
            "pcl-rg ground --method tin, feet file",
        ],
        rows,
        [
            "The feet file differs from the metres only by LAS's rounding (0.01 ft, 3 mm). "
            "A file that states no unit is taken as metres, as before: give `--units us-ft` "
            "(or `units=` to `pcl_rg.batch`). A file that names its system by an EPSG code "
            "alone, without a unit key or a WKT, has units that only a CRS database knows "
            "(PROJ): it is taken as metres too, and says so in the run's report."
        ],
        write=args.write,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
