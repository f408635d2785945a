"""``pcl-rg batch ground|denoise|downsample INPUT... --out DIR``: a survey on Dask."""

from __future__ import annotations

import argparse
import os
import sys

import pcl_rg

from .._common import add_common_options, add_units_option, folder_type, say_units
from .._flags import (
    EXIT_FAILURE,
    EXIT_USAGE,
    add_method_flags,
    add_param_flags,
    float_type,
    int_type,
    method_params,
    params_from_args,
)
from .._run import Run
from .ground import add_keep_classes_option, methods

__all__ = ["configure"]

OPERATIONS = {
    "ground": "classify ground (2) and other (1) points of every tile",
    "denoise": "classify statistical outliers of every tile as noise (7)",
    "downsample": "voxel centroids of every tile, each voxel written once",
}


def _common_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "inputs",
        metavar="INPUT",
        nargs="+",
        help="LAS/LAZ, PCD, PLY or XYZ text files, folders (their point files) or quoted globs",
    )
    parser.add_argument(
        "--out",
        required=True,
        type=folder_type,
        metavar="DIR",
        help="output folder: DIR/<input file name>",
    )
    group = parser.add_argument_group("survey")
    group.add_argument(
        "--buffer",
        type=float_type,
        metavar="M",
        help="metres of neighbouring tiles each tile sees (default: the method's reach, "
        "see pcl_rg.batch.default_buffer)",
    )
    add_units_option(group)
    group.add_argument(
        "--workers", type=int_type, metavar="N", help="local worker processes (default: cores)"
    )
    group.add_argument(
        "--scheduler", metavar="ADDRESS", help="run on this Dask scheduler (tcp://host:8786)"
    )
    group.add_argument(
        "--no-resume",
        action="store_true",
        help="redo every tile, also those whose outputs are up to date",
    )
    add_common_options(parser)


def configure(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Process a survey of many tiles on Dask: each tile with a buffer of its "
        "neighbours' points, each input giving DIR/<its name> as the single-file command "
        "writes it. A rerun skips tiles that are up to date. Exit status 2 when a tile "
        "failed on its data, 1 when one could not be written (a full disk), 1 when both; the "
        "others are still written."
    )
    sub = parser.add_subparsers(dest="operation", required=True, metavar="OPERATION")
    operations = {
        name: sub.add_parser(name, help=text, description=text) for name, text in OPERATIONS.items()
    }
    for operation in operations.values():
        _common_arguments(operation)
    add_method_flags(operations["ground"], "ground filter parameters", "ground filter", methods())
    add_keep_classes_option(operations["ground"])
    for name, title, flag_group in (
        ("denoise", "outlier removal parameters", {"sor": pcl_rg.StatisticalOutlierRemovalParams}),
        ("downsample", "voxel grid parameters", {"voxel": pcl_rg.VoxelGridParams}),
    ):
        operations[name].set_defaults(flags=add_param_flags(operations[name], title, flag_group))
    parser.set_defaults(run=execute)


def execute(args: argparse.Namespace, run: Run) -> None:
    from ... import batch

    options = dict(
        buffer=args.buffer,
        units=args.units,
        workers=args.workers,
        scheduler=args.scheduler,
        progress=not (run.quiet or run.json),
        resume=not args.no_resume,
        on_dashboard=None if run.quiet else _show_dashboard,
    )
    if args.operation == "ground":
        method, params = method_params(args)
        report = batch.ground(
            args.inputs,
            args.out,
            method=method.name,
            params=params,
            keep_classes=args.keep_classes,
            **options,
        )
    elif args.operation == "denoise":
        params = params_from_args(args, args.flags, "sor", pcl_rg.StatisticalOutlierRemovalParams)
        report = batch.denoise(args.inputs, args.out, params=params, **options)
    else:
        params = params_from_args(args, args.flags, "voxel", pcl_rg.VoxelGridParams)
        report = batch.downsample(args.inputs, args.out, params=params, **options)
    run.result.update(report.to_dict())  # its parameters: those the tiles ran with
    if report.units:
        say_units(run, report.units["metres_per_unit"], report.units["source"])
    done = [t for t in report.tiles if t.status == "done"]
    skipped = [t for t in report.tiles if t.status == "skipped"]
    run.say(
        f"batch {args.operation}: {len(done)} tiles done, {len(skipped)} up to date, "
        f"{len(report.failed)} failed; {report.points:,} points in {report.seconds:.1f} s "
        f"({report.points_per_second / 1e6:.2f} M points/s) on {report.workers} workers, "
        f"buffer {report.buffer:g} m"
    )
    for tile in report.tiles:
        if tile.no_buffer_from and tile.status == "done":
            run.say(
                f"  {os.path.basename(tile.output)}: no buffer from "
                + ", ".join(tile.no_buffer_from)
            )
    if len(report.failed) < len(report.tiles):  # else nothing there is of this run
        run.say(f"wrote {os.path.abspath(args.out)}")
    if report.failed:
        names = "; ".join(f"{os.path.basename(t.input)} ({t.error})" for t in report.failed)
        print(
            f"pcl-rg: error: {len(report.failed)} of {len(report.tiles)} tiles failed: {names}",
            file=sys.stderr,
        )
        # A tile that could not be written is the machine's failure (exit 1, as for one
        # file: a full disk, no permission), not bad input (exit 2).
        failed_writing = any(t.cannot_write for t in report.failed)
        run.exit_status = EXIT_FAILURE if failed_writing else EXIT_USAGE


def _show_dashboard(address: str) -> None:
    print(f"pcl-rg: Dask dashboard at {address}", file=sys.stderr)
