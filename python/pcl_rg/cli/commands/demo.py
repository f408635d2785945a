"""``pcl-rg demo``: every algorithm on the built-in synthetic scene."""

from __future__ import annotations

import argparse
import os

from .._common import add_common_options, folder_type
from .._flags import CliError, float_type, int_type
from .._run import Run

__all__ = ["configure", "execute"]


def configure(parser: argparse.ArgumentParser) -> None:
    p = parser
    p.description = (
        "Run every algorithm on a seeded synthetic airborne scene with known "
        "classes; print one table of errors and times; write classified LAZ files and PNG "
        "figures to --output."
    )
    p.add_argument(
        "--output",
        default="demo-output",
        type=folder_type,
        metavar="DIR",
        help="folder for the files and figures (default: demo-output)",
    )
    p.add_argument("--seed", type=int_type, default=0, help="scene seed (default: 0)")
    p.add_argument(
        "--size", type=float_type, default=300.0, help="scene side length in metres (default: 300)"
    )
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    p.add_argument(
        "--no-survey",
        action="store_true",
        help="skip the small survey batch (4 tiles on 2 local Dask workers)",
    )
    add_common_options(p)
    p.set_defaults(run=execute)


def execute(args: argparse.Namespace, run: Run) -> None:
    from ...demo import run_demo

    try:
        report = run_demo(
            args.output,
            seed=args.seed,
            size=args.size,
            plots=not args.no_plots,
            survey=not args.no_survey,
            stage=run.stage,
        )
    except ValueError as error:
        raise CliError(str(error)) from None
    run.result.update(report.as_dict())
    run.say(report.table())
    run.say("")
    for path in report.files:
        run.say(f"wrote {path}")
    run.say(f"output folder: {os.path.abspath(args.output)}")
