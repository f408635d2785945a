"""Segmentation at every scale on mOSD: convex_segmentation, region_growing, PCL, LCCP.

Usage:
    python benchmarks/studies/segmentation_mosd.py [--results benchmarks/RESULTS.md] [--cache FILE]

The seven mOSD learn scenes, each as the raw Kinect frame (valid pixels, about
1.5 mm spacing) and after voxel grids of 3, 5 and 8 mm. Labels go back to every
valid pixel and are scored with segmentation_scores (mean best-match IoU per truth
segment; a truth segment is over-segmented when two or more clusters each hold at
least 10 % of it).

Methods, all on the same points, the camera (origin) as viewpoint where one is used:
- pcl_rg.convex_segmentation over GRID; the default is chosen by leave-one-scene-out
  cross-validation: for each scene, the setting with the highest mean IoU over the
  other six scenes at all four scales is scored on it. "CV" rows are those held-out
  scores, "fitted" the setting best on all seven (the package default).
- pcl_rg.region_growing at its defaults.
- PCL's RegionGrowing (pcl_rg.pcl.region_growing) at region_growing's k, angle and
  cluster sizes, its own default curvature threshold.
- PCL's LCCP (pcl_rg.pcl.lccp, supervoxels + local convexity) at the eight settings
  of LCCP_SETTINGS; its row per scale is the setting best at that scale (fitted,
  in LCCP's favour).
Times: wall clock of each call, summed over the seven scenes, one run each.
"""

from __future__ import annotations

import argparse
import itertools
import pickle
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import (  # noqa: E402
    MOSD_SCENES,
    carry,
    machine,
    markdown_table,
    mosd_at,
    write_section,
)

import pcl_rg
from pcl_rg import ConvexSegmentationParams, RegionGrowingParams
from pcl_rg.evaluation import segmentation_scores

SCENES = MOSD_SCENES
LEAVES = (0.0, 0.003, 0.005, 0.008)  # m; 0: the raw frame
SECTION = "## Segmentation at every scale on mOSD (convex_segmentation, PCL, LCCP)"
GRID = {
    "smoothness_deg": (10.0, 12.0, 14.0),
    "curvature_threshold": (0.4, 0.6, 0.8),
    "concavity_tolerance_deg": (0.0, 2.5, 5.0),
}
LCCP_SETTINGS = [
    dict(seed_resolution=seed, concavity_tolerance_deg=tol, k_factor=kf, sanity_check=bool(kf))
    for seed, tol, kf in itertools.product((0.02, 0.03), (10.0, 15.0), (0, 1))
]


NOTES = [
    "",
    "- convex_segmentation segments a voxel grid of 10 x the measured surface noise whenever "
    "that is coarser than the point spacing (noise_leaves; point_scale reads the noise on "
    "surface neighbourhoods only), and carries the labels back; its times include that step. "
    "LCCP likewise works on its own 7.5 mm supervoxel octree.",
    "- LCCP's row is its best of the eight settings at that scale (fitted, in its favour).",
]


def scale_name(leaf: float) -> str:
    return "raw" if leaf == 0 else f"{leaf * 1000:g} mm"


def timed(function, points, **kwargs):
    start = time.perf_counter()
    labels = function(points, **kwargs)
    return labels, time.perf_counter() - start


def run_all():
    """scores[(method, setting, leaf)] = [(iou, over, under) per scene]; seconds likewise."""
    scores: dict[tuple, list] = {}
    seconds: dict[tuple, float] = {}
    mine = RegionGrowingParams()
    settings = [dict(zip(GRID, values)) for values in itertools.product(*GRID.values())]
    for leaf in LEAVES:
        for _, truth, points, vop in mosd_at(leaf):
            runs = [("convex", i, pcl_rg.convex_segmentation, s) for i, s in enumerate(settings)]
            runs += [("region_growing", 0, pcl_rg.region_growing, {})]
            runs += [
                (
                    "PCL RegionGrowing",
                    0,
                    pcl_rg.pcl.region_growing,
                    dict(
                        k=mine.k,
                        smoothness_deg=mine.smoothness_deg,
                        min_cluster_size=mine.min_cluster_size,
                    ),
                )
            ]
            runs += [("LCCP", i, pcl_rg.pcl.lccp, s) for i, s in enumerate(LCCP_SETTINGS)]
            for method, index, function, kwargs in runs:
                labels, took = timed(function, points, **kwargs)
                s = segmentation_scores(truth, carry(labels, vop))
                key = (method, index, leaf)
                scores.setdefault(key, []).append((s.mean_iou, s.over_segmented, s.under_segmented))
                seconds[key] = seconds.get(key, 0.0) + took
        print(f"  {scale_name(leaf)} done", file=sys.stderr)
    return settings, scores, seconds


def summary(rows: list) -> tuple[float, int, int]:
    return (float(np.mean([r[0] for r in rows])), sum(r[1] for r in rows), sum(r[2] for r in rows))


def cross_validate(settings, scores):
    """Held-out rows per leaf, and the setting chosen for each held-out scene."""

    def pooled_iou(index: int, scenes: list[int]) -> float:
        return float(
            np.mean([scores[("convex", index, leaf)][s][0] for leaf in LEAVES for s in scenes])
        )

    held: dict[float, list] = {leaf: [] for leaf in LEAVES}
    chosen = []
    for out in range(len(SCENES)):
        rest = [s for s in range(len(SCENES)) if s != out]
        best = max(range(len(settings)), key=lambda i: (pooled_iou(i, rest), -i))
        chosen.append(best)
        for leaf in LEAVES:
            held[leaf].append(scores[("convex", best, leaf)][out])
    fitted = max(range(len(settings)), key=lambda i: (pooled_iou(i, list(range(len(SCENES)))), -i))
    return held, chosen, fitted


def report(settings, scores, seconds) -> list[str]:
    held, chosen, fitted = cross_validate(settings, scores)
    default = ConvexSegmentationParams()
    default_index = next(
        (
            i
            for i, s in enumerate(settings)
            if all(getattr(default, key) == value for key, value in s.items())
        ),
        None,
    )
    header = ["scale", "method", "setting", "mean IoU", "over", "under", "time (s)"]
    rows = []
    targets = []
    for leaf in LEAVES:
        lccp_best = max(
            range(len(LCCP_SETTINGS)), key=lambda i: summary(scores[("LCCP", i, leaf)])[0]
        )
        entries = [
            ("convex_segmentation, CV", "held out", summary(held[leaf]), None),
            (
                "convex_segmentation, fitted",
                str(settings[fitted]),
                summary(scores[("convex", fitted, leaf)]),
                seconds[("convex", fitted, leaf)],
            ),
        ]
        if default_index is not None and default_index != fitted:
            entries.append(
                (
                    "convex_segmentation, default",
                    "defaults",
                    summary(scores[("convex", default_index, leaf)]),
                    seconds[("convex", default_index, leaf)],
                )
            )
        entries += [
            (
                "region_growing",
                "defaults",
                summary(scores[("region_growing", 0, leaf)]),
                seconds[("region_growing", 0, leaf)],
            ),
            (
                "PCL RegionGrowing",
                "same k, angle",
                summary(scores[("PCL RegionGrowing", 0, leaf)]),
                seconds[("PCL RegionGrowing", 0, leaf)],
            ),
            (
                "PCL LCCP, best of 8",
                str(LCCP_SETTINGS[lccp_best]),
                summary(scores[("LCCP", lccp_best, leaf)]),
                seconds[("LCCP", lccp_best, leaf)],
            ),
        ]
        for method, setting, (iou, over, under), took in entries:
            rows.append(
                [
                    scale_name(leaf),
                    method,
                    setting,
                    f"{iou:.3f}",
                    str(over),
                    str(under),
                    "" if took is None else f"{took:.2f}",
                ]
            )
        cv, pcl = summary(held[leaf]), summary(scores[("PCL RegionGrowing", 0, leaf)])
        lccp = summary(scores[("LCCP", lccp_best, leaf)])
        targets.append(
            f"- {scale_name(leaf)}: CV mean IoU {cv[0]:.3f} vs PCL RegionGrowing {pcl[0]:.3f} + "
            f"0.05 ({'met' if cv[0] >= pcl[0] + 0.05 else 'missed'}); over-segmented {cv[1]} vs "
            f"half of PCL's {pcl[1]} ({'met' if 2 * cv[1] <= pcl[1] else 'missed'}); against "
            f"LCCP's best: IoU {lccp[0]:.3f}, over {lccp[1]}"
        )
    lines = [
        f"Machine: {machine()}. The {len(SCENES)} learn scenes summed per row "
        "(30 truth segments); `over`/`under`: truth segments over-/under-segmented.",
        f"Grid of convex_segmentation settings ({len(settings)}): "
        + ", ".join(f"{key} {values}" for key, values in GRID.items())
        + f"; k {default.k}, min_cluster_size {default.min_cluster_size} and noise_leaves "
        f"{default.noise_leaves:g} fixed.",
        "",
        markdown_table(header, rows),
        "",
        "Leave-one-scene-out choices (per held-out scene): "
        + "; ".join(f"{SCENES[i]}: {settings[c]}" for i, c in enumerate(chosen)),
        "",
        "Targets (issue 15), cross-validated figures:",
        *targets,
        *NOTES,
        "- "
        + (
            "Every fold of the cross-validation chose the same setting, so the held-out "
            "rows equal the fitted ones."
            if len(set(chosen)) == 1
            else f"The folds chose {len(set(chosen))} different settings (listed above)."
        ),
    ]
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", type=Path, help="append/replace our section in this file")
    parser.add_argument(
        "--cache", type=Path, help="pickle of the measurements: read when it exists, else written"
    )
    args = parser.parse_args(argv)
    start = time.perf_counter()
    if args.cache and args.cache.exists():
        with args.cache.open("rb") as handle:
            settings, scores, seconds = pickle.load(handle)
    else:
        settings, scores, seconds = run_all()
        if args.cache:
            with args.cache.open("wb") as handle:
                pickle.dump((settings, scores, seconds), handle)
    lines = report(settings, scores, seconds)
    print("\n".join(lines))
    if args.results:
        body = [
            f"Command: `python benchmarks/studies/segmentation_mosd.py --results {args.results}`",
            "",
            *lines,
        ]
        write_section("\n".join([SECTION, "", *body, ""]), SECTION, args.results)
    print(f"({time.perf_counter() - start:.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
