"""``pcl-rg segment``: segmentation, a ``segment_id`` per point (-1 for none)."""

from __future__ import annotations

import argparse

import numpy as np

import pcl_rg

from .._common import (
    add_io_arguments,
    add_output_options,
    finish_segments,
    read_input,
)
from .._flags import (
    Method,
    add_method_flags,
    method_params,
    method_summaries,
    params_dict,
)
from .._run import Run

__all__ = ["configure", "execute", "methods"]


def methods() -> dict[str, Method]:
    """The segmentation methods, the default (convex segmentation) first.

    PCL's own class (``pcl_rg.pcl``, a separately built extension) is offered
    only when it imports, so the command keeps working without it.
    """
    found = {
        # The default: objects rather than faces, with one default set for Kinect frames,
        # voxel grids and airborne tiles; it leads curvature growth in mean IoU on the mOSD
        # and airborne studies (benchmarks/RESULTS.md).
        "convex": Method(
            "convex",
            pcl_rg.convex_segmentation,
            pcl_rg.ConvexSegmentationParams,
            "smooth patches merged across convex edges, scale-free defaults (objects, not faces)",
        ),
        "curvature": Method(
            "curvature",
            pcl_rg.region_growing,
            pcl_rg.RegionGrowingParams,
            "curvature-seeded region growing (seed 004)",
        ),
    }
    try:
        from ... import pcl
    except ImportError:
        return found
    found["pcl"] = Method(
        "pcl",
        pcl.region_growing,
        pcl.RegionGrowingPclParams,
        "PCL's classic pcl::RegionGrowing (the baseline)",
    )
    return found


def configure(parser: argparse.ArgumentParser) -> None:
    segment_methods = methods()
    parser.description = (
        "Segmentation into objects (default: convex segmentation) or smooth regions: "
        "OUTPUT gets a segment_id dimension "
        "(int32; a LAS extra-bytes dimension), -1 for points in no kept region. "
        + method_summaries(segment_methods)
    )
    add_io_arguments(parser, "write only the points with a segment")
    add_method_flags(parser, "segmentation parameters", "segmentation method", segment_methods)
    add_output_options(parser, execute)


def execute(args: argparse.Namespace, run: Run) -> None:
    method, params = method_params(args)
    cloud, valid, points, scale, _ = read_input(args, run, ("k", params.k))
    n_valid = int(valid.sum())
    description = f"segmentation ({method.name}) on {n_valid:,} points"
    with run.stage("segment", description, source=args.input):
        labels = method.function(points[valid], params=params)
    segment = np.full(len(cloud), -1, dtype=np.int32)
    segment[valid] = labels
    finish_segments(run, args, cloud, segment, f"segment ({method.name})", scale)
    run.result.update(method=method.name, parameters=params_dict(params))
    if "preset" in args:
        run.result["preset"] = args.preset
