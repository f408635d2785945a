"""``pcl-rg evaluate``: score a classification (or segmentation) against the truth."""

from __future__ import annotations

import argparse
import math
import os

import numpy as np

from ..._classification import usable_points, valid_points, whole_numbers
from ...io import PointFile
from .._common import (
    GROUND,
    add_common_options,
    check_extension,
    check_input,
    existing_classes,
    noise_mask,
    read,
)
from .._flags import CliError
from .._run import Run

__all__ = ["configure", "execute"]


def configure(parser: argparse.ArgumentParser) -> None:
    p = parser
    p.description = (
        "Score the ground classification of PREDICTION (class 2 = ground, anything "
        "else = object) against the truth: Type I (ground rejected / all ground), Type II "
        "(object accepted / all object), total error and Cohen's kappa (Sithole & Vosselman "
        "2004). PREDICTION must hold the truth's points in the same order (an output written "
        "without --drop). With --segments, score its segment_id against a truth segment field. "
        "--json gives the rates as fractions (total 0.0333 for 3.33 %), as "
        "pcl_rg.evaluation does."
    )
    p.add_argument("prediction", metavar="PREDICTION", help="classified point file")
    truth = p.add_argument_group("truth (one of)")
    truth.add_argument(
        "--truth",
        metavar="FILE",
        help="a file with the true classification (class 2 = ground); points "
        "of class 7 or 18 (noise) are left out unless --include-noise, and so are "
        "points no command classified (NaN coordinates, withheld in either file)",
    )
    truth.add_argument(
        "--isprs",
        nargs=2,
        metavar=("ALL.pcd", "GROUND.pcd"),
        help="an ISPRS sample: all points, and the ground points only",
    )
    p.add_argument(
        "--include-noise", action="store_true", help="score truth noise points too, as object"
    )
    p.add_argument(
        "--segments",
        action="store_true",
        help="score segment_id against the truth's --truth-field instead "
        "(mean IoU, over/under-segmentation, adjusted Rand index)",
    )
    p.add_argument(
        "--truth-field",
        help="truth segment field for --segments, 0 = no truth (default: label, as in mOSD)",
    )
    add_common_options(p)
    p.set_defaults(run=execute)


def _check_flags(args: argparse.Namespace) -> None:
    """Refuse flags that the chosen scoring would ignore: a user who asks for noise to be
    scored, or for a segment field, should not get a figure computed without it."""
    if args.include_noise and (args.segments or args.isprs is not None):
        where = "--segments" if args.segments else "--isprs (its samples have no noise class)"
        raise CliError(f"--include-noise has no effect with {where}; leave it out")
    if args.truth_field is not None and not args.segments:
        raise CliError("--truth-field names the truth's segment field: it needs --segments")
    if args.truth_field is None:
        args.truth_field = "label"


def _scales(cloud: PointFile) -> float:
    scales = getattr(cloud.header, "scales", None)
    return float(np.max(scales)) if scales is not None else 0.0


def execute(args: argparse.Namespace, run: Run) -> None:
    if (args.truth is None) == (args.isprs is None):
        raise CliError("evaluate needs exactly one of --truth FILE or --isprs ALL.pcd GROUND.pcd")
    _check_flags(args)
    check_extension(args.prediction, "PREDICTION")
    check_input(args.prediction, "PREDICTION")
    # Every file before any is read: a FIFO would block its read for ever.
    if args.truth is not None:
        check_input(args.truth, "--truth")
    else:
        for path in args.isprs:
            check_input(path, "--isprs")
    prediction = read(run, args.prediction)
    if args.segments:
        _evaluate_segments(args, run, prediction)
        return
    predicted_codes = existing_classes(prediction)
    if predicted_codes is None:
        raise CliError(
            f"PREDICTION {args.prediction!r} has no classification field "
            "(write it with 'pcl-rg ground')"
        )
    if args.isprs is not None:
        from ...datasets import load_isprs

        all_pcd, ground_pcd = args.isprs
        with run.stage("truth", "reading the ISPRS reference"):
            sample = load_isprs(all_pcd, ground_pcd)
        truth_points, truth_ground = sample.points, sample.ground
        scored = np.ones(len(truth_points), bool)
        truth_scale = 0.0
        source = {"isprs": [os.path.abspath(all_pcd), os.path.abspath(ground_pcd)]}
    else:
        truth = read(run, args.truth)
        codes = existing_classes(truth)
        if codes is None:
            raise CliError(f"--truth {args.truth!r} has no classification field")
        truth_points, truth_ground = truth.points, codes == GROUND
        noise = noise_mask(codes, len(codes))
        scored = np.ones(len(codes), bool) if args.include_noise else ~noise
        truth_scale = _scales(truth)
        source = {"truth": os.path.abspath(args.truth)}
    _check_same_points(prediction, truth_points, max(_scales(prediction), truth_scale))
    # Rows no command classified (NaN coordinates, LAS withheld) keep the class they
    # came with, often the truth's own: scored, they would count as right. The truth's
    # withheld flag counts too: a PCD or PLY prediction has none.
    usable = usable_points(prediction)
    if args.truth is not None:
        usable &= usable_points(truth)
    unprocessed = scored & ~usable
    scored &= ~unprocessed
    from ...evaluation import ground_errors

    errors = ground_errors(truth_ground[scored], (predicted_codes == GROUND)[scored])
    (a, b), (c, d) = errors.confusion.tolist()
    run.result.update(
        prediction=os.path.abspath(args.prediction),
        **source,
        points=len(prediction),
        scored=int(scored.sum()),
        excluded_noise=int((~scored).sum()) - int(unprocessed.sum()),
        excluded_unprocessed=int(unprocessed.sum()),
        type_i=errors.type_i,
        type_ii=errors.type_ii,
        total=errors.total,
        kappa=errors.kappa,
        confusion={
            "ground_as_ground": a,
            "ground_as_object": b,
            "object_as_ground": c,
            "object_as_object": d,
        },
    )

    def pct(v: float) -> str:
        return "-" if math.isnan(v) else f"{100 * v:.2f} %"

    excluded = [
        f"{count:,} {what} excluded"
        for count, what in (
            (run.result["excluded_noise"], "noise points"),
            (run.result["excluded_unprocessed"], "NaN or withheld points"),
        )
        if count
    ]
    run.say(
        f"{'points scored':<16}{int(scored.sum()):>12,}"
        + (f"  ({'; '.join(excluded)})" if excluded else "")
    )
    run.say(f"{'Type I':<16}{pct(errors.type_i):>12}  ground classified as object / all ground")
    run.say(f"{'Type II':<16}{pct(errors.type_ii):>12}  object classified as ground / all object")
    run.say(f"{'total':<16}{pct(errors.total):>12}  misclassified / all points")
    kappa = _fixed(errors.kappa)
    run.say(f"{'kappa':<16}{kappa:>12}  Cohen's kappa")
    run.say(
        f"confusion (rows truth ground/object, columns predicted ground/object): "
        f"[[{a}, {b}], [{c}, {d}]]"
    )


def _check_same_points(prediction: PointFile, truth_points: np.ndarray, scale: float) -> None:
    if len(prediction) != len(truth_points):
        raise CliError(
            f"PREDICTION has {len(prediction):,} points but the truth has {len(truth_points):,}; "
            "evaluate needs every point in the original order (write without --drop)"
        )
    if not len(truth_points):
        return
    with np.errstate(invalid="ignore"):
        gap = np.abs(prediction.points - truth_points)
    both_nan = np.isnan(prediction.points) & np.isnan(truth_points)
    gap = np.where(both_nan, 0.0, gap)
    magnitude = float(np.nanmax(np.abs(truth_points))) if np.isfinite(truth_points).any() else 0.0
    tolerance = 0.5 * scale * 1.001 + 1e-9 * magnitude
    worst = float(np.nanmax(np.where(np.isnan(gap), np.inf, gap)))
    if worst > tolerance:
        row = int(np.argmax(np.where(np.isnan(gap), np.inf, gap).max(axis=1)))
        raise CliError(
            f"PREDICTION and truth hold different points (point {row} differs by {worst:.6g} m, "
            f"more than the {tolerance:.3g} m storage precision); they must be the same points "
            "in the same order"
        )


def _segment_ids(what: str, ids: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """`ids` as int64, or a CliError naming `what`: a cast would truncate 0.4 to 0 and
    make NaN some number without a word. Rows not `valid` (NaN coordinates: no command
    segments them) are -1 whatever they hold."""
    ids = np.asarray(ids)
    if ids.dtype.kind == "f":
        whole = whole_numbers(ids)
        if not whole[valid].all():
            raise CliError(
                f"{what} holds {np.count_nonzero(~whole[valid])} values that are not whole "
                "numbers (NaN among them?); segment ids must be whole"
            )
        ids = np.where(valid, ids, -1.0)
    elif ids.dtype.kind not in "iub":
        raise CliError(f"{what} is of dtype {ids.dtype}, not segment ids")
    if ids.dtype.kind == "u" and ids.size and ids.max() > np.iinfo(np.int64).max:
        raise CliError(f"{what} holds ids above 2**63 - 1")
    return ids.astype(np.int64)


def _truth_ids(args: argparse.Namespace, ids: np.ndarray) -> np.ndarray:
    """The truth field as int64 segment ids (>= 0), or a CliError naming the field."""
    field = f"--truth-field {args.truth_field!r} of {args.truth!r}"
    ids = _segment_ids(field, ids, np.ones(len(ids), bool))
    if ids.size and ids.min() < 0:
        raise CliError(
            f"{field} holds negative ids at {np.count_nonzero(ids < 0)} points (another "
            "segmentation's -1 for unassigned?); truth segment ids are >= 0, with 0 for "
            "points that have no truth segment"
        )
    return ids


def _evaluate_segments(args: argparse.Namespace, run: Run, prediction: PointFile) -> None:
    if args.truth is None:
        raise CliError("evaluate --segments needs --truth FILE with a truth segment field")
    labels = prediction.fields.get("segment_id")
    if labels is None:
        raise CliError(
            f"PREDICTION {args.prediction!r} has no segment_id field "
            "(write it with 'pcl-rg segment')"
        )
    truth = read(run, args.truth)
    segments = truth.fields.get(args.truth_field)
    if segments is None:
        raise CliError(
            f"--truth {args.truth!r} has no field {args.truth_field!r} "
            f"(fields: {', '.join(truth.fields) or 'none'})"
        )
    _check_same_points(prediction, truth.points, max(_scales(prediction), _scales(truth)))
    from ...evaluation import segmentation_scores

    scores = segmentation_scores(
        _truth_ids(args, np.asarray(segments)),
        _segment_ids("PREDICTION's segment_id", labels, valid_points(prediction.points)),
    )
    run.result.update(
        prediction=os.path.abspath(args.prediction),
        truth=os.path.abspath(args.truth),
        truth_field=args.truth_field,
        mean_iou=scores.mean_iou,
        over_segmented=scores.over_segmented,
        under_segmented=scores.under_segmented,
        adjusted_rand_index=scores.adjusted_rand_index,
        clusters=scores.n_clusters,
        truth_segments=int(len(scores.segment_ids)),
    )
    run.say(f"{'truth segments':<20}{len(scores.segment_ids):>10,}")
    run.say(f"{'clusters':<20}{scores.n_clusters:>10,}")
    run.say(f"{'mean IoU':<20}{_fixed(scores.mean_iou):>10}")
    run.say(f"{'over-segmented':<20}{scores.over_segmented:>10,}")
    run.say(f"{'under-segmented':<20}{scores.under_segmented:>10,}")
    run.say(f"{'adjusted Rand':<20}{_fixed(scores.adjusted_rand_index):>10}")


def _fixed(value: float) -> str:
    """Four decimals, or "-" for an undefined score, as the ground report writes it."""
    return "-" if math.isnan(value) else f"{value:.4f}"
