"""``pcl-rg ground``: class 2 ground, class 1 everything else."""

from __future__ import annotations

import argparse
import os

import numpy as np

import pcl_rg

from ..._classification import ground_classes
from .._common import (
    add_io_arguments,
    add_output_options,
    existing_classes,
    noise_mask,
    percent,
    read_input,
    say_written,
    write_output,
)
from .._figures import plots
from .._flags import Method, add_method_flags, method_params, method_summaries, params_dict
from .._run import Run

__all__ = ["add_keep_classes_option", "configure", "execute", "methods"]


def methods() -> dict[str, Method]:
    """The ground filters, the default first."""
    return {
        "grid": Method(
            "grid",
            pcl_rg.grid_ground,
            pcl_rg.GridGroundParams,
            "grid region growing from the lowest point of each block (seed 000)",
        ),
        "tin": Method(
            "tin",
            pcl_rg.tin_ground,
            pcl_rg.TinGroundParams,
            "progressive TIN densification (seed 002, LiDAR360's parameters; default preset isprs)",
        ),
    }


def add_keep_classes_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--keep-classes",
        action="store_true",
        help="non-ground points keep their class (a vendor's buildings, vegetation, "
        "water...) instead of becoming 1; those of class 0, 1 or 2 become 1",
    )


def configure(parser: argparse.ArgumentParser) -> None:
    ground_methods = methods()
    parser.description = (
        "Classify ground points: class 2 ground, class 1 everything else. "
        "Points already classified as noise (7, 18) are left out and keep their class; "
        "points with NaN coordinates and LAS points flagged withheld are skipped (class 0 "
        "if the file had none). " + method_summaries(ground_methods)
    )
    add_io_arguments(parser, "write only the ground points")
    add_keep_classes_option(parser)
    add_method_flags(parser, "ground filter parameters", "ground filter", ground_methods)
    add_output_options(parser, execute)


def execute(args: argparse.Namespace, run: Run) -> None:
    method, params = method_params(args)
    cloud, valid, points, scale, finite = read_input(args, run)
    noise = noise_mask(existing_classes(cloud), len(cloud))
    work = valid & ~noise
    with run.stage(
        "ground", f"ground filter ({method.name}) on {int(work.sum()):,} points", source=args.input
    ):
        ground = method.function(points[work], params=params)
    classes = ground_classes(cloud, work, ground, args.keep_classes)
    n_ground = int(ground.sum())
    n_work = int(work.sum())
    kept = np.zeros(len(cloud), bool)
    kept[work] = ground
    n_written = write_output(run, args, cloud, dict(cloud.fields, classification=classes), kept)
    run.result.update(
        input=os.path.abspath(args.input),
        method=method.name,
        preset=args.preset,
        parameters=params_dict(params),
        points_in=len(cloud),
        filtered=n_work,
        ground=n_ground,
        object=n_work - n_ground,
        skipped_noise=int((valid & noise).sum()),
        skipped_invalid=int((~finite).sum()),
        dropped=bool(args.drop),
        keep_classes=bool(args.keep_classes),
    )
    run.say(
        f"ground ({method.name}): {n_work:,} points filtered, {n_ground:,} ground "
        f"({percent(n_ground, n_work)}), {n_work - n_ground:,} object"
        + (
            f"; {int((valid & noise).sum()):,} noise points left as they were"
            if (valid & noise).any()
            else ""
        )
        + (f"; {int((~finite).sum()):,} invalid (NaN) points skipped" if not finite.all() else "")
    )
    say_written(
        run, args, n_written, (", ground only" if args.drop else ", class 2 ground, 1 other")
    )
    plots(
        run,
        args,
        cloud.points,
        classes=classes,
        title=f"ground filter ({method.name}): {os.path.basename(args.input)}",
        metres_per_unit=scale,
    )
