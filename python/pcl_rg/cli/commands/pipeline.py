"""``pcl-rg pipeline``: the seed 004 chain (SOR, voxel grid, normals, region growing)."""

from __future__ import annotations

import argparse

import numpy as np

from ... import pipeline
from .._common import (
    add_io_arguments,
    add_output_options,
    finish_segments,
    noise_classes,
    read_input,
)
from .._flags import (
    add_param_flags,
    keyword_params,
    params_dict,
    params_dict_deep,
    params_from_args,
)
from .._run import Run, jsonable

__all__ = ["configure", "execute"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "The seed 004 chain (pcl_rg.pipeline.seed004): statistical outlier "
        "removal (--sor-*, on unless --no-sor), voxel grid (--voxel-*; without "
        "--voxel-leaf-size the leaf is chosen from the data's spacing and noise and the "
        "report says which, --no-auto-voxel skips the grid), normals, curvatures and "
        "region growing (--region-*). Every input point gets the segment_id of the point "
        "it was merged into (-1 for outliers and dropped regions); SOR outliers get class 7."
    )
    add_io_arguments(parser, "write only the points with a segment")
    options = keyword_params(pipeline.seed004, "PipelineOptions")
    flags = add_param_flags(parser, "pipeline parameters", {"pipeline": options})
    parser.add_argument(
        "--no-auto-voxel",
        dest="auto_voxel",
        action="store_false",
        help="without --voxel-leaf-size, segment every point instead of a grid whose leaf "
        "is chosen from the data",
    )
    parser.set_defaults(flags=flags, pipeline_params=options, pipeline=pipeline.seed004)
    add_output_options(parser, execute)


def execute(args: argparse.Namespace, run: Run) -> None:
    options = params_from_args(args, args.flags, "pipeline", args.pipeline_params)
    sor = None if options.sor is None else ("sor_mean_k", options.sor.mean_k)
    cloud, valid, points, scale, _ = read_input(args, run, sor)
    stages = "SOR, voxel grid, normals, region growing"
    with run.stage("pipeline", f"{stages} on {int(valid.sum()):,} points", source=args.input):
        result = args.pipeline(points[valid], **params_dict(options), auto_voxel=args.auto_voxel)
    segment = np.full(len(cloud), -1, dtype=np.int32)
    segment[valid] = np.asarray(result.labels)
    classes = None
    if options.sor is not None:
        outlier = np.zeros(len(cloud), bool)
        outlier[valid] = ~np.asarray(result.inlier)
        classes = noise_classes(cloud, valid, outlier)
    report = result.report
    run.result["stages"] = [
        {"name": s.name, "points_in": s.points_in, "points_out": s.points_out, "seconds": s.seconds}
        for s in report.stages
    ]
    run.say(report.table())
    finish_segments(run, args, cloud, segment, "pipeline", scale, classes)
    run.result.update(parameters=jsonable(params_dict_deep(options)))
