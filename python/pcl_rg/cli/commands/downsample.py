"""``pcl-rg downsample``: one point per occupied voxel, at the centroid of its points."""

from __future__ import annotations

import argparse
import os

import numpy as np

import pcl_rg

from .._common import (
    add_io_arguments,
    add_output_options,
    plots,
    read_input,
    write,
)
from .._flags import add_param_flags, params_dict, params_from_args, show
from .._run import Run

__all__ = ["MEAN_ATTRIBUTES", "configure", "execute", "voxel_attributes"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Voxel grid downsampling (PCL's VoxelGrid): OUTPUT holds one point per "
        "occupied voxel, at the mean of its points. Attributes of a centroid: the mean (rounded "
        "for integers) of " + ", ".join(MEAN_ATTRIBUTES) + " and of every floating-point field; "
        "every other field (classification, return numbers, flags, ids) is taken from the "
        "voxel's first point in file order."
    )
    add_io_arguments(parser, None)
    flags = add_param_flags(parser, "voxel grid parameters", {"voxel": pcl_rg.VoxelGridParams})
    parser.set_defaults(flags=flags)
    add_output_options(parser, execute)


#: Attributes averaged over a voxel's points (rounded for integer types); every
#: other integer attribute (class, return numbers, flags, ids) is the first point's.
MEAN_ATTRIBUTES = ("intensity", "red", "green", "blue", "nir", "gps_time")


def voxel_attributes(
    fields: dict[str, np.ndarray], rows: np.ndarray, voxel: np.ndarray, counts: np.ndarray
) -> dict[str, np.ndarray]:
    """Per-voxel attributes: mean of float fields and MEAN_ATTRIBUTES, else the first point's."""
    m = len(counts)
    first = np.full(m, np.iinfo(np.int64).max, dtype=np.int64)
    np.minimum.at(first, voxel, rows)
    out = {}
    for name, values in fields.items():
        values = np.asarray(values)
        if values.dtype.kind == "f" or (name in MEAN_ATTRIBUTES and values.dtype.kind in "iu"):
            flat = values[rows].reshape(len(rows), -1).astype(np.float64)
            sums = np.stack(
                [np.bincount(voxel, weights=flat[:, j], minlength=m) for j in range(flat.shape[1])],
                axis=1,
            )
            mean = sums / counts[:, None]
            if values.dtype.kind in "iu":
                mean = np.round(mean)
            out[name] = mean.reshape((m,) + values.shape[1:]).astype(values.dtype)
        else:
            out[name] = values[first]
    return out


def execute(args: argparse.Namespace, run: Run) -> None:
    params = params_from_args(args, args.flags, "voxel", pcl_rg.VoxelGridParams)
    cloud, valid = read_input(args, run)
    points = cloud.points
    rows = np.flatnonzero(valid)
    with run.stage("downsample", f"voxel grid on {len(rows):,} points"):
        grid = pcl_rg.voxel_grid(points[rows], params=params)
    kept = grid.voxel_of_point >= 0
    with run.stage("attributes", "voxel attributes"):
        fields = voxel_attributes(cloud.fields, rows[kept], grid.voxel_of_point[kept], grid.counts)
    write(run, args.output, grid.centroids, fields, cloud)
    run.result.update(
        input=os.path.abspath(args.input),
        parameters=params_dict(params),
        points_in=len(cloud),
        voxels=len(grid.centroids),
        skipped_invalid=int((~valid).sum()),
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
        grid.centroids,
        classes=fields.get("classification"),
        title=f"voxel centroids: {os.path.basename(args.input)}",
    )
