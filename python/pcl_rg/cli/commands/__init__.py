"""The subcommands, one module each, imported only when their subcommand runs.

A module ``commands/<name>.py`` has ``configure(parser)``, which adds its
arguments and sets ``run(args, run)`` as the parser's default; the table below
is all that ``pcl-rg --help`` needs.
"""

from __future__ import annotations

import argparse
import importlib

__all__ = ["COMMANDS", "configure"]

#: Subcommand -> its one-line help, in the order ``pcl-rg --help`` lists them.
COMMANDS = {
    "ground": "classify ground (2) and other (1) points",
    "denoise": "classify statistical outliers as noise (7)",
    "downsample": "replace the points of each voxel by their centroid",
    "segment": "segmentation (convex by default): a segment_id per point (-1 none)",
    "pipeline": "seed 004: SOR, voxel grid, normals, region growing",
    "batch": "a survey of many tiles on Dask: ground, denoise or downsample",
    "evaluate": "score a classified file against ground truth",
    "info": "describe a point file",
    "demo": "run every algorithm on the built-in synthetic scene",
}


def configure(name: str, parser: argparse.ArgumentParser) -> None:
    """Import the module of subcommand `name` and add its arguments to `parser`."""
    importlib.import_module(f".{name}", __name__).configure(parser)
