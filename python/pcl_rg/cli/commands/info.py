"""``pcl-rg info``: format, point count, bounds, fields and classes of a file.

Reads the file and nothing else: no algorithm and no compiled code is imported.
"""

from __future__ import annotations

import argparse
import os
from typing import TYPE_CHECKING, Any

import numpy as np

from ..._classification import whole_numbers
from ...io._las_header import LasRecord
from .._common import (
    add_output_options,
    check_extension,
    check_plots,
    counts,
    existing_classes,
    read,
    segments_summary,
    valid_points,
)
from .._figures import plots, stated_metres_per_unit
from .._flags import CliError
from .._run import Run

if TYPE_CHECKING:
    from ...io import CoordinateUnits

__all__ = ["configure", "execute"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.description = "Format, point count, bounds, fields and classes of a file."
    parser.add_argument("input", metavar="INPUT", help="point file (LAS/LAZ, PLY, PCD, XYZ text)")
    add_output_options(parser, execute)


def execute(args: argparse.Namespace, run: Run) -> None:
    check_extension(args.input, "INPUT")
    if not os.path.isfile(args.input):
        raise CliError(f"INPUT {args.input!r} does not exist or is not a file")
    check_plots(args.input, [args.plot, args.profile])
    cloud = read(run, args.input)
    points = cloud.points
    valid = valid_points(points)
    info: dict[str, Any] = {
        "input": os.path.abspath(args.input),
        "format": cloud.format,
        "points": len(cloud),
        "invalid_points": int((~valid).sum()),
    }
    if valid.any():
        info["bounds"] = {"min": points[valid].min(axis=0), "max": points[valid].max(axis=0)}
    header = cloud.header
    if cloud.format in ("las", "laz"):
        info["las"] = {
            "version": str(header.version),
            "point_format": int(header.point_format.id),
            "scales": np.asarray(header.scales),
            "offsets": np.asarray(header.offsets),
            "vlrs": _records(cloud.records, "VLR"),
            "evlrs": _records(cloud.records, "EVLR"),
            "extra_dimensions": list(header.point_format.extra_dimension_names),
        }
    elif header is not None:
        layout = header._asdict()
        layout["xyz_dtype"] = str(layout["xyz_dtype"])
        info[cloud.format] = layout
    stated = cloud.units
    info["units"] = stated._asdict()
    info["fields"] = {}
    for name, values in cloud.fields.items():
        entry: dict[str, Any] = {"dtype": str(values.dtype), "shape": list(values.shape[1:])}
        finite = values[np.isfinite(values)] if values.dtype.kind == "f" else values
        if finite.size:
            entry.update(min=finite.min(), max=finite.max())
        info["fields"][name] = entry
    try:
        codes = existing_classes(cloud)
    except ValueError as error:  # described, not refused: info is how one finds out
        codes = None
        info["classes_problem"] = str(error)
    if codes is not None:
        info["classes"] = counts(codes)
    if "segment_id" in cloud.fields:
        ids = np.asarray(cloud.fields["segment_id"])
        whole = ids.dtype.kind in "iu" or (ids.dtype.kind == "f" and whole_numbers(ids).all())
        if ids.ndim == 1 and whole:
            info["segmentation"] = segments_summary(ids)
        else:  # described, not refused, as classes are
            info["segmentation_problem"] = "segment_id is not one whole number per point"
    run.result.update(info)

    run.say(f"{'file':<14}{info['input']}")
    run.say(
        f"{'format':<14}{cloud.format.upper()}"
        + (
            f" {info['las']['version']}, point format {info['las']['point_format']}"
            if "las" in info
            else ""
        )
    )
    run.say(
        f"{'points':<14}{len(cloud):,}"
        + (
            f" ({info['invalid_points']:,} with NaN or Inf coordinates)"
            if info["invalid_points"]
            else ""
        )
    )
    if "bounds" in info:
        lo, hi = info["bounds"]["min"], info["bounds"]["max"]
        names = [stated.xy_name, stated.xy_name, stated.z_name]
        for i, axis in enumerate("xyz"):
            unit = names[i] or "units, not stated"
            run.say(
                f"{axis + ' range':<14}{lo[i]:.3f} .. {hi[i]:.3f}  ({hi[i] - lo[i]:.3f} {unit})"
            )
    if stated.source:
        run.say(
            f"{'units':<14}"
            + (
                stated.problem
                or f"x, y {stated.xy_name or 'not stated'}, "
                f"z {stated.z_name or _z_not_stated(stated)} ({stated.source})"
            )
        )
    if "las" in info:
        # Every digit (the shortest text that reads back as the stored double): %g
        # showed an offset of 512345.678 as 512346.
        run.say(f"{'scale':<14}{' '.join(repr(float(s)) for s in info['las']['scales'])}")
        run.say(f"{'offset':<14}{' '.join(repr(float(s)) for s in info['las']['offsets'])}")
        for kind in ("vlrs", "evlrs"):
            for record in info["las"][kind]:
                run.say(
                    f"{kind[:-1]:<14}{_shown(record['user_id'])} {record['record_id']}"
                    f" ({_shown(record['description']) or 'no description'}, "
                    f"{record['bytes']:,} bytes)"
                )
    elif header is not None:
        run.say(f"{'layout':<14}" + ", ".join(f"{k} {v}" for k, v in info[cloud.format].items()))
    run.say(
        f"{'fields':<14}"
        + (", ".join(f"{_shown(k)} ({v['dtype']})" for k, v in info["fields"].items()) or "none")
    )
    if "classes" in info:
        run.say(f"{'classes':<14}" + ", ".join(f"{k}: {v:,}" for k, v in info["classes"].items()))
    if "classes_problem" in info:
        run.say(f"{'classes':<14}none: {info['classes_problem']}")
    if "segmentation_problem" in info:
        run.say(f"{'segments':<14}none: {info['segmentation_problem']}")
    if "segmentation" in info:
        s = info["segmentation"]
        run.say(f"{'segments':<14}{s['segments']:,} ({s['assigned']:,} points assigned)")
    plots(
        run,
        args,
        points,
        # Invalid points of a float column may hold NaN or Inf; they are not drawn.
        classes=None if codes is None else np.where(np.isfinite(codes), codes, 0).astype(np.int64),
        segments=None,
        title=os.path.basename(args.input),
        metres_per_unit=stated_metres_per_unit(cloud),
    )


def _records(records: tuple[LasRecord, ...], kind: str) -> list[dict[str, Any]]:
    """Who wrote each VLR or EVLR, which record it is, and its size, from its header in
    the file, as lasinfo lists them."""
    return [
        {
            "user_id": r.user_id,
            "record_id": r.record_id,
            "description": r.description,
            "bytes": r.length,
        }
        for r in records
        if r.kind == kind
    ]


def _shown(text: str) -> str:
    """Text from the file as a terminal can show it: a control character (an escape
    sequence in a hostile file's description) becomes "?"."""
    return "".join(c if c.isprintable() else "?" for c in text)


def _z_not_stated(stated: CoordinateUnits) -> str:
    """What the commands make of z when the file states x and y only (io._crs)."""
    return "not stated, taken as x and y" if stated.xy_name else "not stated"
