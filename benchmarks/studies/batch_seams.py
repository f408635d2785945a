"""Seams of pcl_rg.batch: labels of tiled runs against the run on the merged cloud.

Usage: python benchmarks/studies/batch_seams.py [--write] [--buffers 0 10 20 40 60 80 90 120]

For a synthetic survey of 5 x 5 tiles (datasets.synthetic_survey, objects across
tile borders) and for each ISPRS sample of ../shared/data cut into four quadrant
tiles, both ground filters run tiled (pcl_rg.batch.ground, each buffer size) and
merged (one call on the concatenated tiles, with the lengths of the survey's spacing
that the tiles use, batch.survey_spacing). The table gives the share of labels
that differ, over all points and over the points within 5 m of a tile border (the
seams). Denoise and downsample are exact by construction; their rows check it.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import SHARED_DATA, publish_report, study_arguments  # noqa: E402

import pcl_rg  # noqa: E402
from pcl_rg import batch  # noqa: E402
from pcl_rg.datasets import load_isprs, synthetic_survey  # noqa: E402
from pcl_rg.io import read_points, write_points  # noqa: E402

SECTION = "## Survey batches: seams (pcl_rg.batch)"
SAMPLES = ("samp11", "samp21", "samp31", "samp41", "samp51", "samp52", "samp61")
SEAM = 5.0  # m: a point this close to a tile border is on a seam


def isprs_quadrants(folder: Path, sample: str) -> tuple[list[str], list[float], list[float]]:
    points, _ = load_isprs(
        SHARED_DATA / "isprs" / f"{sample}-utm.pcd",
        SHARED_DATA / "isprs" / f"{sample}-utm-ground.pcd",
    )
    mid = (points[:, :2].min(axis=0) + points[:, :2].max(axis=0)) / 2
    paths = []
    for east in (False, True):
        for north in (False, True):
            inside = ((points[:, 0] >= mid[0]) == east) & ((points[:, 1] >= mid[1]) == north)
            path = folder / f"{sample}_{int(north)}{int(east)}.las"
            write_points(path, points[inside], classification=np.ones(inside.sum(), np.uint8))
            paths.append(str(path))
    return paths, [mid[0]], [mid[1]]


def seam_mask(points: np.ndarray, xs: list[float], ys: list[float]) -> np.ndarray:
    near = np.zeros(len(points), bool)
    for x in xs:
        near |= np.abs(points[:, 0] - x) <= SEAM
    for y in ys:
        near |= np.abs(points[:, 1] - y) <= SEAM
    return near


def ground_rows(name, paths, xs, ys, buffers, scheduler, folder) -> list[list[str]]:
    clouds = [read_points(p) for p in paths]
    points = np.concatenate([c.points for c in clouds])
    classes = np.concatenate([c.classification for c in clouds])
    seam = seam_mask(points, xs, ys)
    # The merged run as `pcl-rg ground` makes it: points already classed noise are
    # left out and keep their class (the synthetic tiles carry their true classes).
    work = ~np.isin(classes, (7, 18))
    rows = []
    # The tiles take their unset lengths from the survey's nominal spacing (headers); a
    # call on the merged cloud would measure point_spacing instead: give it the same.
    spacing = batch.survey_spacing(paths)
    for method, function in (("grid", pcl_rg.grid_ground), ("tin", pcl_rg.tin_ground)):
        params = pcl_rg.GridGroundParams() if method == "grid" else pcl_rg.TinGroundParams()
        merged = classes.copy()
        merged[work] = np.where(function(points[work], params=params.at_spacing(spacing)), 2, 1)
        cells = []
        for buffer in buffers:
            report = batch.ground(
                paths,
                folder / f"{method}-{buffer:g}",
                method=method,
                buffer=buffer,
                scheduler=scheduler,
                resume=False,
            )
            tiled = np.concatenate([read_points(t.output).classification for t in report.tiles])
            differ = tiled != merged
            cells.append(f"{100 * differ.mean():.3f} / {100 * differ[seam].mean():.2f}")
        default = batch.default_buffer("ground", params)
        rows.append(
            [name, method, f"{len(points):,}", f"{seam.mean() * 100:.1f}", f"{default:g}", *cells]
        )
        print(f"  {name} {method}: {cells}", file=sys.stderr)
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = study_arguments(__doc__)
    parser.add_argument(
        "--buffers", type=float, nargs="+", default=[0, 10, 20, 40, 60, 80, 90, 120]
    )
    args = parser.parse_args(argv)
    from distributed import LocalCluster

    rows = []
    with (
        tempfile.TemporaryDirectory() as tmp,
        LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=":0") as cluster,
    ):
        folder = Path(tmp)
        scheduler = cluster.scheduler_address
        survey = synthetic_survey(folder / "survey", tiles=(5, 5), tile_size=100.0, seed=1)
        xs = sorted({b[0] for b in survey.bounds} - {min(b[0] for b in survey.bounds)})
        ys = sorted({b[1] for b in survey.bounds} - {min(b[1] for b in survey.bounds)})
        rows += ground_rows(
            "synthetic 5 x 5", survey.paths, xs, ys, args.buffers, scheduler, folder / "s"
        )
        for sample in SAMPLES:
            paths, qx, qy = isprs_quadrants(folder, sample)
            rows += ground_rows(sample, paths, qx, qy, args.buffers, scheduler, folder / sample)
        exact = exact_rows(survey.paths, scheduler, folder)
    header = ["cloud", "method", "points", "seam points %", "default buffer m"] + [
        f"buffer {b:g} m" for b in args.buffers
    ]
    about = (
        "Labels of `pcl_rg.batch.ground` (2 local "
        "workers) against one call on the merged cloud, per buffer size: "
        '"all / seam" is the % of labels that differ over all points and over the points '
        f"within {SEAM:g} m of a tile border. Grids are anchored in world coordinates. The "
        "merged run takes the lengths of the spacing the tiles use "
        "(`params.at_spacing(batch.survey_spacing(paths))`)."
    )
    command = "python benchmarks/studies/batch_seams.py"
    publish_report(SECTION, command, about, header, rows, exact, write=args.write)
    return 0


def exact_rows(paths: list[str], scheduler: str, folder: Path) -> list[str]:
    clouds = [read_points(p) for p in paths]
    points = np.concatenate([c.points for c in clouds])
    sor = pcl_rg.StatisticalOutlierRemovalParams()
    report = batch.denoise(paths, folder / "denoise", params=sor, scheduler=scheduler)
    tiled = np.concatenate([read_points(t.output).classification for t in report.tiles]) == 7
    merged = ~pcl_rg.statistical_outlier_removal(points, params=sor)
    voxel = pcl_rg.VoxelGridParams(leaf_size=1.0)
    report = batch.downsample(paths, folder / "downsample", params=voxel, scheduler=scheduler)
    tiled_voxels = sum(len(read_points(t.output)) for t in report.tiles)
    merged_voxels = len(pcl_rg.voxel_grid(points, params=voxel).counts)
    return [
        f"- denoise (defaults) on the synthetic survey: {int((tiled != merged).sum())} of "
        f"{len(points):,} labels differ from the merged run ({int(merged.sum()):,} noise).",
        f"- downsample (leaf 1 m): {tiled_voxels:,} voxels written by the tiles, "
        f"{merged_voxels:,} in the merged run (tests/test_batch.py compares them one by one).",
    ]


if __name__ == "__main__":
    raise SystemExit(main())
