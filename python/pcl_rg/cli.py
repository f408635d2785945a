"""The `pcl-rg` command line (also `python -m pcl_rg`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

__all__ = ["main"]


def _demo(args: argparse.Namespace) -> int:
    from .demo import run_demo

    report = run_demo(args.output, seed=args.seed, size=args.size, plots=not args.no_plots)
    print(report.table())
    for path in report.files:
        print(f"wrote {path}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pcl-rg",
        description="LiDAR ground filtering and point-cloud segmentation (pcl_rg).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    demo = sub.add_parser("demo", help="run every algorithm on the built-in synthetic scene")
    demo.add_argument("--output", default="demo-output", help="folder for figures and files")
    demo.add_argument("--seed", type=int, default=0, help="scene seed")
    demo.add_argument("--size", type=float, default=300.0, help="scene side length (m)")
    demo.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    demo.set_defaults(run=_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    return args.run(args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
