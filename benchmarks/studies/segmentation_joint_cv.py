"""One default set for Kinect and airborne scenes: leave-one-scene-out over both studies.

Usage:
    python benchmarks/studies/segmentation_joint_cv.py --mosd-cache FILE \\
        --airborne-cache FILE [--airborne-cache FILE ...] [--write]

Reads the measurements that segmentation_mosd.py and segmentation_airborne.py keep
with their --cache option (run those first) and cross-validates
convex_segmentation's settings over the 13 scenes of both: the 7 mOSD learn scenes
(raw and 3, 5, 8 mm) and the 6 airborne scenes (2, 8, 20 points per m^2; raw, 0.5
and 1 m voxels; ground removed). The candidates are the settings both studies ran
(the airborne grid; the mOSD grid also varies the concavity tolerance, held at its
default here). For each held-out scene the setting with the highest score on the
other twelve is chosen and scored on it; the score of a setting on a set of scenes
is the mean of the two studies' mean IoU (mOSD: mean over scenes and scales of each
scene's mean IoU; airborne: mean best-match IoU over the buildings of those scenes
at every density and voxel size), so each study weighs the same whatever its
number of scenes. "fitted" is the setting best on all thirteen.
"""

from __future__ import annotations

import argparse
import pickle
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/_common.py
from _common import MOSD_SCENES, machine, markdown_table, publish  # noqa: E402

import pcl_rg

SECTION = "## One default set for Kinect and airborne scenes (joint cross-validation)"
REMOVED = "ground removed"


def load(path: Path):
    with path.open("rb") as handle:
        return pickle.load(handle)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mosd-cache", type=Path, required=True)
    parser.add_argument(
        "--airborne-cache",
        type=Path,
        required=True,
        action="append",
        help="segmentation_airborne.py's pickle (several: read together); "
        "the ground-removed measurements are used",
    )
    parser.add_argument("--write", action="store_true", help="put the section into RESULTS.md")
    args = parser.parse_args(argv)
    mosd_settings, mosd_scores, _ = load(args.mosd_cache)
    parts = [load(path) for path in args.airborne_cache]
    scenes = parts[0][0]
    air_settings = next(part[1] for part in parts if part[1])
    air_scores = {key: value for part in parts for key, value in part[2].items()}
    mosd_leaves = sorted({key[2] for key in mosd_scores if key[0] == "convex"})
    air_cases = sorted({key[3:] for key in air_scores if key[0] == REMOVED})
    n_mosd = len(mosd_scores[("convex", 0, mosd_leaves[0])])
    n_air = len(scenes)
    default = pcl_rg.ConvexSegmentationParams()
    # Each airborne setting and the mOSD setting equal to it (the rest at the defaults).
    pairs = []
    for a, setting in enumerate(air_settings):
        full = {**{k: getattr(default, k) for k in mosd_settings[0]}, **setting}
        m = next(i for i, s in enumerate(mosd_settings) if s == full)
        pairs.append((m, a))

    def mosd_iou(m: int, which: list[int]) -> float:
        return float(
            np.mean([mosd_scores[("convex", m, leaf)][s][0] for leaf in mosd_leaves for s in which])
        )

    def air_iou(a: int, which: list[int]) -> float:
        return float(
            np.mean(
                np.concatenate(
                    [
                        air_scores[(REMOVED, "convex", a, *case)][s][0]
                        for case in air_cases
                        for s in which
                    ]
                )
            )
        )

    def score(pair: int, mosd_in: list[int], air_in: list[int]) -> float:
        m, a = pairs[pair]
        return 0.5 * (mosd_iou(m, mosd_in) + air_iou(a, air_in))

    all_mosd, all_air = list(range(n_mosd)), list(range(n_air))
    held_mosd: dict[float, list] = {leaf: [] for leaf in mosd_leaves}
    held_air: dict[tuple, list] = {case: [] for case in air_cases}
    chosen = []
    for out in range(n_mosd + n_air):
        mosd_in = [s for s in all_mosd if s != out]
        air_in = [s for s in all_air if s != out - n_mosd]
        best = max(range(len(pairs)), key=lambda i: (score(i, mosd_in, air_in), -i))
        chosen.append(best)
        m, a = pairs[best]
        if out < n_mosd:
            for leaf in mosd_leaves:
                held_mosd[leaf].append(mosd_scores[("convex", m, leaf)][out])
        else:
            for case in air_cases:
                held_air[case].append(air_scores[(REMOVED, "convex", a, *case)][out - n_mosd])
    fitted = max(range(len(pairs)), key=lambda i: (score(i, all_mosd, all_air), -i))
    default_pair = next(
        i
        for i, (m, a) in enumerate(pairs)
        if all(getattr(default, k) == v for k, v in air_settings[a].items())
    )

    header = ["study", "scale", "CV (held out) mean IoU / over", "fitted", "defaults"]
    rows = []
    for leaf in mosd_leaves:

        def cell(per_scene):
            return f"{np.mean([r[0] for r in per_scene]):.3f} / {sum(r[1] for r in per_scene)}"

        rows.append(
            [
                "mOSD",
                "raw" if leaf == 0 else f"{leaf * 1000:g} mm",
                cell(held_mosd[leaf]),
                cell(mosd_scores[("convex", pairs[fitted][0], leaf)]),
                cell(mosd_scores[("convex", pairs[default_pair][0], leaf)]),
            ]
        )
    for case in air_cases:

        def cell(per_scene):
            ious = np.concatenate([r[0] for r in per_scene])
            return f"{ious.mean():.3f} / {sum(r[1] for r in per_scene)}"

        density, leaf = case
        rows.append(
            [
                f"airborne {density:g}/m^2",
                "raw" if leaf == 0 else f"{leaf:g} m voxels",
                cell(held_air[case]),
                cell(air_scores[(REMOVED, "convex", pairs[fitted][1], *case)]),
                cell(air_scores[(REMOVED, "convex", pairs[default_pair][1], *case)]),
            ]
        )
    names = [*(f"mOSD {name}" for name in MOSD_SCENES[:n_mosd]), *(f"{k} {s}" for k, s in scenes)]
    text = "\n".join(
        [
            SECTION,
            "",
            "`python benchmarks/studies/segmentation_joint_cv.py --mosd-cache FILE "
            f"--airborne-cache FILE{' --write' if args.write else ''}` on {machine()}, from the "
            "measurements of segmentation_mosd.py and segmentation_airborne.py (their --cache). "
            f"{len(pairs)} settings ("
            + ", ".join(f"{k} {sorted({s[k] for s in air_settings})}" for k in air_settings[0])
            + "; the rest at the defaults), leave one of the 13 scenes out, chosen by the mean of "
            "the two studies' mean IoU on the other twelve. Over: truth segments (mOSD) or "
            "buildings (airborne) split over two or more clusters each holding 10 %.",
            "",
            markdown_table(header, rows),
            "",
            f"Fitted on all 13 scenes: {air_settings[pairs[fitted][1]]}; the defaults: "
            f"{air_settings[pairs[default_pair][1]]}. Chosen per held-out scene: "
            + "; ".join(f"{name}: {air_settings[pairs[c][1]]}" for name, c in zip(names, chosen)),
            "",
        ]
    )
    publish(text, SECTION, args.write)
    return 0


if __name__ == "__main__":
    sys.exit(main())
