"""``pcl-rg downsample``: one point per occupied voxel, at the centroid of its points."""

from __future__ import annotations

import argparse
import os

import numpy as np

import pcl_rg

from ..._classification import (
    CATEGORY_ATTRIBUTES,
    MEAN_ATTRIBUTES,
    WAVEFORM_ATTRIBUTES,
    no_data_values,
    voxel_attributes,
)
from ...io._pcd import unorganized
from .._common import (
    add_io_arguments,
    add_output_options,
    read_input,
    write,
)
from .._figures import plots
from .._flags import add_param_flags, params_dict, params_from_args, show
from .._run import Run

__all__ = ["configure", "execute"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Voxel grid downsampling (PCL's VoxelGrid): OUTPUT holds one point per "
        "occupied voxel, at the mean of its points. Attributes of a centroid: the mean (rounded "
        "for integers) of " + ", ".join(MEAN_ATTRIBUTES) + " and of every floating-point field, "
        "PCL's packed rgb/rgba colours channel by channel; every other field (flags, ...) and "
        "every code or id, integer or float (" + ", ".join(CATEGORY_ATTRIBUTES) + ", id, *_id), "
        "and LAS's waveform descriptor (" + ", ".join(WAVEFORM_ATTRIBUTES) + ", which describe "
        "one pulse together) are taken from the voxel's first point in file order; an extra-bytes "
        'field\'s declared "no data" is left out of its mean.'
    )
    add_io_arguments(parser, None)
    flags = add_param_flags(parser, "voxel grid parameters", {"voxel": pcl_rg.VoxelGridParams})
    parser.set_defaults(flags=flags)
    add_output_options(parser, execute)


def execute(args: argparse.Namespace, run: Run) -> None:
    params = params_from_args(args, args.flags, "voxel", pcl_rg.VoxelGridParams)
    cloud, valid, points, scale, finite = read_input(args, run)
    rows = np.flatnonzero(valid)
    with run.stage("downsample", f"voxel grid on {len(rows):,} points", source=args.input):
        grid = pcl_rg.voxel_grid(points[rows], params=params)
    kept = grid.voxel_of_point >= 0
    with run.stage("attributes", "voxel attributes", source=args.input):
        fields = voxel_attributes(
            cloud.fields,
            rows[kept],
            grid.voxel_of_point[kept],
            grid.counts,
            no_data=no_data_values(cloud),
        )
    centroids = grid.centroids / scale  # in INPUT's units
    write(run, args.output, centroids, fields, unorganized(cloud))
    run.result.update(
        input=os.path.abspath(args.input),
        parameters=params_dict(params),
        points_in=len(cloud),
        voxels=len(grid.centroids),
        skipped_invalid=int((~finite).sum()),
        points_in_dropped_voxels=int((~kept).sum()),
    )
    run.say(
        f"downsample (voxel grid {show(params.leaf_size)} m): {len(rows):,} points -> "
        f"{len(grid.centroids):,} voxel centroids"
    )
    run.say(f"wrote {os.path.abspath(args.output)}")
    plots(
        run,
        args,
        centroids,
        classes=fields.get("classification"),
        title=f"voxel centroids: {os.path.basename(args.input)}",
        metres_per_unit=scale,
    )
