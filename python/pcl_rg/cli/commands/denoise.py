"""``pcl-rg denoise``: statistical outliers become class 7 (noise)."""

from __future__ import annotations

import argparse
import os

import numpy as np

import pcl_rg

from .._common import (
    add_io_arguments,
    add_output_options,
    noise_classes,
    percent,
    read_input,
    say_written,
    write_output,
)
from .._figures import plots
from .._flags import add_param_flags, params_dict, params_from_args
from .._run import Run

__all__ = ["configure", "execute"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Statistical outlier removal (PCL's StatisticalOutlierRemoval): a point "
        "whose mean distance to its mean_k nearest neighbours exceeds the mean of all such "
        "distances by more than std_mul standard deviations is classified 7 (noise); the other "
        "points keep their class (1 if the file had none), except that a point of class 7 "
        "(an earlier run's noise, or the vendor's) is judged again and becomes 1 when it is "
        "an inlier now, so that a rerun with other parameters replaces the earlier noise "
        "class. Points with NaN coordinates and LAS points flagged withheld are skipped "
        "(class 0 if the file had none)."
    )
    add_io_arguments(parser, "write only the inliers")
    flags = add_param_flags(
        parser, "outlier removal parameters", {"sor": pcl_rg.StatisticalOutlierRemovalParams}
    )
    parser.set_defaults(flags=flags)
    add_output_options(parser, execute)


def execute(args: argparse.Namespace, run: Run) -> None:
    params = params_from_args(args, args.flags, "sor", pcl_rg.StatisticalOutlierRemovalParams)
    cloud, valid, points, scale, finite = read_input(args, run, ("mean_k", params.mean_k))
    n_valid = int(valid.sum())
    with run.stage(
        "denoise", f"statistical outlier removal on {n_valid:,} points", source=args.input
    ):
        inlier = pcl_rg.statistical_outlier_removal(points[valid], params=params)
    keep = np.zeros(len(cloud), bool)
    keep[valid] = inlier
    outlier = valid & ~keep
    classes = noise_classes(cloud, valid, outlier)
    n_written = write_output(run, args, cloud, dict(cloud.fields, classification=classes), keep)
    n_noise = int(outlier.sum())
    run.result.update(
        input=os.path.abspath(args.input),
        parameters=params_dict(params),
        points_in=len(cloud),
        filtered=n_valid,
        noise=n_noise,
        inliers=n_valid - n_noise,
        skipped_invalid=int((~finite).sum()),
        dropped=bool(args.drop),
    )
    run.say(f"denoise (SOR): {n_valid:,} points, {n_noise:,} noise ({percent(n_noise, n_valid)})")
    say_written(run, args, n_written, (", inliers only" if args.drop else ", class 7 noise"))
    plots(
        run,
        args,
        cloud.points,
        classes=classes,
        title=f"statistical outlier removal: {os.path.basename(args.input)}",
        metres_per_unit=scale,
    )
