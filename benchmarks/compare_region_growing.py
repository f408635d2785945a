"""Curvature-seeded region growing (pcl_rg) against PCL's RegionGrowing on mOSD.

Usage:
    python benchmarks/compare_region_growing.py [--leaf 0.005] [--results benchmarks/RESULTS.md]
    python benchmarks/compare_region_growing.py --grid     # the search that chose the defaults

Both methods run on the same input: each scene's valid points, downsampled by
pcl_rg.voxel_grid (the seed 004 simplification; --leaf 0 to skip), at the same k,
smoothness angle and cluster sizes (pcl_rg.RegionGrowingParams defaults), each with
its own default curvature threshold (curvedness for pcl_rg, surface variation for
PCL; both chosen on these seven scenes by --grid). Labels go back to every valid
pixel through voxel_of_point and are scored against the mOSD truth with
segmentation_scores (mean best-match IoU, over-/under-segmented counts, ARI). The
PCL tutorial cloud has no truth: clusters and time only. Times are wall clock of
the core phases (normals, growth), single run each; preprocessing is shared and
reported once. A third row per scene runs pcl_rg with seed_measure="concavity" (an
option beyond the seed's definition: the gate only stops growth in concave creases
as seen from the camera at the origin), same k and angle, threshold CONCAVITY.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import sys
import time
from pathlib import Path

import numpy as np
from _common import machine, markdown_table

import pcl_rg
from pcl_rg import _core
from pcl_rg.datasets import load_mosd
from pcl_rg.evaluation import segmentation_scores
from pcl_rg.io import read_pcd
from pcl_rg.reference.region_growing import measure_values
from pcl_rg.region_growing import RegionGrowingParams, _region_growing_timed
from pcl_rg.region_growing_pcl import RegionGrowingPclParams

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
SCENES = ("learn0", "learn5", "learn17", "learn20", "learn25", "learn33", "learn40")
SECTION = "## Region growing on mOSD"
CONCAVITY = 40.0  # 1/m: the best concavity threshold at the defaults' k and angle (--grid)
TRUTH_SEGMENTS = 30  # labels of the seven scenes together (table parts and object parts)
NOTES = [
    "- Defaults from `--grid` on these scenes (k 10/12/15/20, 8-25 deg, every seed measure, "
    "thresholds in steps of ~20 %), ranked by the mean IoU averaged with both neighbouring "
    "thresholds, because single settings are knife-edged (one object merging with the "
    "table moves a scene by 0.3): curvedness 100 at k 10, 16 deg (raw best: 0.854 at "
    "k 12, 20 deg, 90). PCL's threshold is tuned the same way at the same k and angle. "
    "Honest caveat: PCL's own best grid setting (k 12, 20 deg, 0.025) reaches 0.845 with 8 "
    "over-segmented segments, which the curvedness default (0.837, 11) does not beat; the "
    "concavity option does (best 0.941 with 1 at k 10, 20 deg, 20).",
    "- Over-segmented segments are boxes split into their faces by either gate (curvedness "
    "or surface variation stops at convex and concave edges alike); the concavity option "
    "lets growth pass convex edges and cuts only concave creases, hence objects instead "
    "of faces. It is an option, not the default, which keeps the seed's definition.",
    "- Time: pcl_rg reuses the normal pass's neighbour lists for the growth, while "
    "pcl::RegionGrowing searches them again; this is where most of the difference lies.",
]


def load(leaf: float):
    """Per scene: (name, truth per valid pixel, segmented points, voxel_of_point or None)."""
    scenes = []
    for name in SCENES:
        scene = load_mosd(DATA / "mosd" / f"{name}.pcd")
        if leaf > 0:
            grid = pcl_rg.voxel_grid(scene.points, leaf_size=leaf)
            scenes.append((name, scene.labels, grid.centroids, grid.voxel_of_point))
        else:
            scenes.append((name, scene.labels, scene.points, None))
    return scenes


def carry(labels: np.ndarray, voxel_of_point: np.ndarray | None) -> np.ndarray:
    if voxel_of_point is None:
        return labels
    return np.where(voxel_of_point >= 0, labels[np.maximum(voxel_of_point, 0)], -1)


def ours(points: np.ndarray, p: RegionGrowingParams):
    labels, normals_s, growth_s = _region_growing_timed(points, p)
    return labels, normals_s, growth_s


def pcl(points: np.ndarray, p: RegionGrowingPclParams):
    r = pcl_rg.region_growing_pcl(points, params=p, full_output=True)
    return r.labels, r.normals_seconds, r.growth_seconds


def pcl_params_like(p: RegionGrowingParams, threshold: float) -> RegionGrowingPclParams:
    return RegionGrowingPclParams(
        k=p.k,
        smoothness_deg=p.smoothness_deg,
        curvature_threshold=threshold,
        min_cluster_size=p.min_cluster_size,
        max_cluster_size=min(p.max_cluster_size, 2**32 - 1),
    )


def compare(leaf: float) -> tuple[str, list[list[str]], list[str]]:
    mine = RegionGrowingParams()
    theirs = pcl_params_like(mine, RegionGrowingPclParams().curvature_threshold)
    concave = dataclasses.replace(mine, seed_measure="concavity", curvature_threshold=CONCAVITY)
    methods = (("pcl_rg", ours, mine), ("pcl_rg concavity", ours, concave), ("PCL", pcl, theirs))
    header = ["scene", "points", "method", "clusters", "mean IoU", "over", "under", "ARI",
              "normals (s)", "growth (s)", "total (s)"]
    rows: list[list[str]] = []
    totals: dict[str, list] = {method: [] for method, _, _ in methods}
    for name, truth, points, vop in load(leaf):
        for method, run, params in methods:
            labels, normals_s, growth_s = run(points, params)
            s = segmentation_scores(truth, carry(labels, vop))
            totals[method].append((s.mean_iou, s.over_segmented, s.under_segmented,
                                   s.adjusted_rand_index, normals_s, growth_s, s.n_clusters))
            rows.append([name, f"{len(points):,}", method, str(s.n_clusters),
                         f"{s.mean_iou:.3f}", str(s.over_segmented), str(s.under_segmented),
                         f"{s.adjusted_rand_index:.3f}", f"{normals_s:.3f}", f"{growth_s:.3f}",
                         f"{normals_s + growth_s:.3f}"])
            print("  " + " | ".join(rows[-1]), file=sys.stderr)
    summary = []
    base = np.array(totals["PCL"])
    for method in ("pcl_rg", "pcl_rg concavity"):
        v = np.array(totals[method])
        ratio = (v[:, 4].sum() + v[:, 5].sum()) / (base[:, 4].sum() + base[:, 5].sum())
        summary.append(
            f"- {method} against PCL over the seven scenes: mean IoU {v[:, 0].mean():.3f} vs "
            f"{base[:, 0].mean():.3f}, over-segmented {int(v[:, 1].sum())} vs "
            f"{int(base[:, 1].sum())}, under-segmented {int(v[:, 2].sum())} vs "
            f"{int(base[:, 2].sum())} (of {TRUTH_SEGMENTS} truth segments), time "
            f"{ratio:.2f}x PCL's."
        )
    for method, values in totals.items():
        v = np.array(values)
        rows.append(["**all 7**", "", f"**{method}**", str(int(v[:, 6].sum())),
                     f"**{v[:, 0].mean():.3f}**", f"**{int(v[:, 1].sum())}**",
                     f"**{int(v[:, 2].sum())}**", f"{v[:, 3].mean():.3f}",
                     f"{v[:, 4].sum():.3f}", f"{v[:, 5].sum():.3f}",
                     f"**{v[:, 4].sum() + v[:, 5].sum():.3f}**"])

    # The tutorial cloud (millimetres in the file): no truth, clusters and time only.
    tutorial = read_pcd(DATA / "pcl" / "region_growing_tutorial.pcd").points / 1000.0
    if leaf > 0:
        tutorial = pcl_rg.voxel_grid(tutorial, leaf_size=leaf).centroids
    for method, run, params in methods:
        if method == "pcl_rg concavity":
            continue  # no viewpoint known for this cloud
        labels, normals_s, growth_s = run(np.ascontiguousarray(tutorial), params)
        clusters = int(labels.max()) + 1
        rows.append(["tutorial", f"{len(tutorial):,}", method, str(clusters), "", "", "", "",
                     f"{normals_s:.3f}", f"{growth_s:.3f}", f"{normals_s + growth_s:.3f}"])
        print("  " + " | ".join(rows[-1]), file=sys.stderr)

    setup = (
        f"k {mine.k}, smoothness {mine.smoothness_deg} deg, cluster sizes "
        f"[{mine.min_cluster_size}, {mine.max_cluster_size}] for both; curvature threshold "
        f"{mine.curvature_threshold} ({mine.seed_measure}) for pcl_rg, "
        f"{theirs.curvature_threshold} (surface variation) for PCL, {CONCAVITY} for the "
        "concavity option (viewpoint: the camera at the origin); "
        + (f"{leaf * 1000:g} mm voxel grid first" if leaf > 0 else "no voxel grid")
    )
    return setup, [header] + rows, summary


def grid(leaf: float) -> None:
    """The search behind the defaults: mean IoU over the seven scenes, per setting."""
    scenes = load(leaf)
    ks, angles = (10, 12, 15, 20), (8, 12, 16, 20, 25)
    thresholds = {
        "curvedness": (50, 75, 90, 100, 110, 150),
        "mean": (30, 45, 60),
        "gaussian": (1000, 3000),
        "surface_variation": (0.015, 0.02, 0.03),
        "concavity": (10, 20, 40, 60),
    }
    pcl_thresholds = (0.01, 0.015, 0.02, 0.025, 0.03, 0.05)
    results = []
    for k in ks:
        # Normals and neighbour lists once per k; the growth alone per setting (exactly
        # what pcl_rg.region_growing does, see tests/test_region_growing.py).
        prepared = []
        for _, truth, points, vop in scenes:
            geometry = pcl_rg.normals(points, k=k)
            lists = _core.neighbour_lists(points, pcl_rg.NormalsParams(k=k).to_core())
            prepared.append((truth, vop, geometry, lists, points))
        for angle, (measure, values) in itertools.product(angles, thresholds.items()):
            for c in values:
                p = RegionGrowingParams(k=k, smoothness_deg=angle, curvature_threshold=c,
                                        min_cluster_size=20, seed_measure=measure)
                scores = []
                for truth, vop, geometry, lists, points in prepared:
                    m = np.ascontiguousarray(measure_values(geometry, measure, points))
                    labels = _core.grow_regions(lists, geometry.normals, m, p.to_core())
                    scores.append(segmentation_scores(truth, carry(labels, vop)))
                results.append(("pcl_rg", k, angle, measure, c, scores))
        for angle, c in itertools.product(angles, pcl_thresholds):
            p = RegionGrowingPclParams(k=k, smoothness_deg=angle, curvature_threshold=c,
                                       min_cluster_size=20)
            scores = [segmentation_scores(truth, carry(pcl(points, p)[0], vop))
                      for _, truth, points, vop in scenes]
            results.append(("PCL", k, angle, "surface_variation", c, scores))
    # Rank by the mean IoU averaged with the two neighbouring thresholds: single
    # settings are knife-edged on seven scenes, a robust optimum is wanted.
    table = {}
    for method, k, angle, measure, c, scores in results:
        table.setdefault((method, k, angle, measure), []).append(
            (c, float(np.mean([x.mean_iou for x in scores])),
             sum(x.over_segmented for x in scores), sum(x.under_segmented for x in scores))
        )
    ranked = []
    for key, series in table.items():
        series.sort()
        for i in range(1, len(series) - 1):
            smooth = (series[i - 1][1] + series[i][1] + series[i + 1][1]) / 3
            ranked.append((smooth, key, series[i]))
    ranked.sort(key=lambda r: -r[0])
    for method, measure in [("pcl_rg", m) for m in thresholds] + [("PCL", "surface_variation")]:
        print(f"best settings of {method} with {measure}: smoothed IoU | k angle threshold: "
              "IoU over under")
        chosen = [r for r in ranked if r[1][0] == method and r[1][3] == measure]
        for smooth, key, (c, iou, over, under) in chosen[:5]:
            print(f"  {smooth:.3f} | k {key[1]:>2} {key[2]:>4} deg {c:>7}: "
                  f"{iou:.3f} {over:>3} {under:>3}")


def write_section(path: Path, section: str, lines: list[str]) -> None:
    """Put `section` (a "## " title) with `lines` into `path`, replacing an older copy."""
    body = "\n".join([section, "", *lines, ""])
    text = path.read_text() if path.exists() else "# Benchmark results\n"
    start = text.find(section + "\n")
    if start >= 0:  # replace our own section, keep everyone else's
        end = text.find("\n## ", start + len(section))
        text = text[:start] + body + ("\n" + text[end + 1:] if end >= 0 else "")
    else:
        text = text.rstrip("\n") + "\n\n" + body
    path.write_text(text)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--leaf", type=float, default=0.005, help="voxel leaf in m (0: none)")
    parser.add_argument("--grid", action="store_true", help="run the parameter search")
    parser.add_argument("--results", type=Path, help="append/replace our section in this file")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    if args.grid:
        grid(args.leaf)
        return 0
    setup, table, summary = compare(args.leaf)
    print(f"machine: {machine()}\n{setup}")
    print(markdown_table(table[0], table[1:]))
    print("\n".join(summary))
    if args.results:
        command = "python benchmarks/compare_region_growing.py" + (
            f" --leaf {args.leaf:g}" if args.leaf != 0.005 else ""
        ) + f" --results {args.results}"
        write_section(args.results, SECTION, [
            f"Command: `{command}`",
            "",
            f"Machine: {machine()}. {setup}.",
            "",
            markdown_table(table[0], table[1:]),
            "",
            *summary,
            *NOTES,
        ])
    print(f"({time.perf_counter() - start:.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
