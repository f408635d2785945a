"""What the commands share: file checks, reading and writing, ASPRS classes (the
figures are _figures's).

Commands classify rather than delete (ASPRS classes 2 ground, 1 other, 7 noise,
0 never classified; a ``segment_id`` dimension, -1 for none); ``--drop`` writes
only the kept points.
"""

from __future__ import annotations

import argparse
import copy
import os
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from .._classification import (
    GROUND,
    NEVER_CLASSIFIED,
    NOISE,
    NOISE_CLASSES,
    UNCLASSIFIED,
    class_array,
    existing_classes,
    noise_classes,
    noise_mask,
    valid_points,
    whole_numbers,
    withheld_mask,
)
from ..io import EXTENSIONS, PointFile, read_points, write_points
from ..io._atomic import special_file
from ..io._crs import GIVEN_UNITS, metre_factors
from ..io._las import las_coordinate_name
from ._figures import plots
from ._flags import EXIT_FAILURE, CliError, float_type, line_type
from ._run import Run

__all__ = [
    "GROUND",
    "NEVER_CLASSIFIED",
    "NOISE",
    "NOISE_CLASSES",
    "Input",
    "UNCLASSIFIED",
    "add_common_options",
    "add_io_arguments",
    "add_output_options",
    "add_plot_options",
    "add_units_option",
    "check_extension",
    "check_input",
    "check_paths",
    "check_plots",
    "class_array",
    "counts",
    "existing_classes",
    "finish_segments",
    "noise_classes",
    "noise_mask",
    "percent",
    "read",
    "read_input",
    "say_units",
    "say_written",
    "segments_summary",
    "valid_points",
    "write",
    "write_output",
]


# ----------------------------------------------------------------- options


def add_common_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("output")
    group.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    group.add_argument(
        "--json", action="store_true", help="print the results as one JSON object on stdout"
    )


def add_io_arguments(parser: argparse.ArgumentParser, drop: str | None) -> None:
    formats = "LAS/LAZ, PLY, PCD or XYZ text, by extension"
    parser.add_argument("input", metavar="INPUT", help=f"point file to read ({formats})")
    parser.add_argument(
        "output", metavar="OUTPUT", help=f"point file to write ({formats}); never the INPUT"
    )
    if drop is not None:
        parser.add_argument("--drop", action="store_true", help=drop)
    add_units_option(parser)


def add_units_option(parser: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    parser.add_argument(
        "--units",
        choices=sorted(GIVEN_UNITS),
        help="units of the input's x, y and z, for files that do not state them or state "
        "them wrongly (default: what a LAS/LAZ file's coordinate system says, else m); "
        "every method's length option is in metres, and the points are scaled to "
        "metres for the work; the figures' options and axes are in the file's units",
    )


def add_plot_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("figures (PNG, needs matplotlib)")
    group.add_argument("--plot", metavar="FILE.png", help="write a top view of the result")
    group.add_argument(
        "--profile",
        metavar="FILE.png",
        help="write a vertical profile: the points in a corridor --profile-width wide "
        "centred on --profile-line, distance along the line against z",
    )
    group.add_argument(
        "--profile-line",
        metavar="X0,Y0,X1,Y1",
        type=line_type,
        help="ends A and B of the profile line in the file's x, y coordinates and units "
        "(default: west to east through the middle of the cloud)",
    )
    group.add_argument(
        "--profile-width",
        metavar="WIDTH",
        type=float_type,
        default=2.0,
        help="corridor width, centred on the profile line, in the file's units (default: 2)",
    )


def add_output_options(parser: argparse.ArgumentParser, execute: Any) -> None:
    """The options after a command's own: figures (with a point file), --quiet, --json."""
    add_plot_options(parser)
    add_common_options(parser)
    parser.set_defaults(run=execute)


# ------------------------------------------------------------------ files


def folder_type(text: str) -> str:
    """An output folder flag's value (argparse type): "" would be the working folder,
    an unset shell variable most likely."""
    if not text:
        raise argparse.ArgumentTypeError("an empty folder name")
    return text


def check_extension(path: str, what: str) -> None:
    ext = os.path.splitext(path)[1].lower()
    if ext not in EXTENSIONS:
        raise CliError(
            f"{what} {path!r}: unknown extension {ext or '(none)'!r} "
            f"(supported: {', '.join(EXTENSIONS)})"
        )


def check_paths(source: str, target: str, plots: Sequence[str | None] = ()) -> None:
    """Refuse before any work: bad extensions, a missing folder, OUTPUT == INPUT."""
    check_extension(source, "INPUT")
    check_extension(target, "OUTPUT")
    check_input(source, "INPUT")
    if os.path.isdir(target):
        raise CliError(f"OUTPUT {target!r} is a folder, not a file")
    check_replaceable(target, "OUTPUT")
    folder = os.path.dirname(os.path.abspath(target))
    if not os.path.isdir(folder):
        raise CliError(f"the folder of OUTPUT {target!r} does not exist")
    if _same_file(source, target):
        raise CliError(f"OUTPUT {target!r} is the INPUT file; refusing to overwrite the input")
    check_plots(source, plots, target)


def check_replaceable(path: str, what: str) -> None:
    """Refuse a file to write that exists and is not a regular file: the atomic rename
    would replace a FIFO or a device (/dev/null, for root) by a file."""
    if special_file(path):
        raise CliError(f"{what} {path!r} is not a regular file; refusing to replace it")


def check_input(path: str, what: str) -> None:
    """Refuse a file to read that is missing, a folder, or not a regular file; `what`
    names it in the message ("INPUT", "--truth")."""
    if not os.path.exists(path):
        raise CliError(f"{what} {path!r} does not exist")
    if os.path.isdir(path):
        raise CliError(f"{what} {path!r} is a folder, not a file")
    if not os.path.isfile(path):  # a FIFO or a device would block the read for ever
        raise CliError(f"{what} {path!r} is not a regular file")


def _same_file(a: str, b: str) -> bool:
    """Whether paths `a` and `b` name one file: the same path once links are resolved,
    or, when both exist, one file under two names (hard links, bind mounts)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    return os.path.exists(a) and os.path.exists(b) and os.path.samefile(a, b)


def check_plots(source: str, plots: Sequence[str | None], target: str | None = None) -> None:
    """Refuse figures that cannot be written or would replace INPUT, OUTPUT (`target`,
    if any) or each other."""
    for plot in plots:
        if plot is None:
            continue
        if not plot.lower().endswith(".png"):
            raise CliError(f"plot file {plot!r} must end in .png")
        if not os.path.isdir(os.path.dirname(os.path.abspath(plot))):
            raise CliError(f"the folder of plot file {plot!r} does not exist")
        if os.path.isdir(plot):
            raise CliError(f"plot file {plot!r} is a folder, not a file")
        check_replaceable(plot, "plot file")
        if _same_file(source, plot):
            raise CliError(f"plot file {plot!r} is the INPUT file; refusing to overwrite it")
        if target is not None and _same_file(target, plot):
            raise CliError(f"plot file {plot!r} is the OUTPUT file; one would replace the other")
    named = [plot for plot in plots if plot is not None]
    for k, plot in enumerate(named):
        for other in named[:k]:  # one would silently replace the other
            if _same_file(plot, other):
                raise CliError(f"plot files {other!r} and {plot!r} are the same file")


def read(run: Run, path: str) -> PointFile:
    with run.stage("read", f"reading {path}"):
        return read_points(path)


def write(
    run: Run, path: str, points: np.ndarray, fields: dict[str, np.ndarray], template: PointFile
) -> None:
    with run.stage("write", f"writing {path}"):
        try:
            write_points(path, points, fields, template=template)
        except OSError as error:
            reason = error.strerror or str(error)
            raise CliError(f"cannot write {path!r}: {reason}", EXIT_FAILURE) from None
        except ValueError as error:  # what the format cannot hold, found after the work
            raise CliError(f"cannot write {path!r}: {error}", EXIT_FAILURE) from None
    run.result["output"] = os.path.abspath(path)
    run.result["points_out"] = int(len(points))


def write_output(
    run: Run,
    args: argparse.Namespace,
    cloud: PointFile,
    fields: dict[str, np.ndarray],
    keep: np.ndarray,
) -> int:
    """Write INPUT's points with `fields` to OUTPUT, only the `keep` ones with --drop.

    Returns the number of points written.
    """
    out = cloud.points
    if args.drop:
        out = out[keep]
        fields = {name: values[keep] for name, values in fields.items()}
    write(run, args.output, out, fields, cloud)
    return len(out)


class Input(NamedTuple):
    """INPUT as a command works on it."""

    cloud: PointFile
    valid: np.ndarray  # its rows to work on: finite coordinates, not withheld
    points: np.ndarray  # its points in metres (cloud.points when they are)
    scale: np.ndarray  # metres per unit of x, y, z
    finite: np.ndarray  # its rows with finite coordinates


def read_input(
    args: argparse.Namespace, run: Run, neighbours: tuple[str, int] | None = None
) -> Input:
    """INPUT after the checks of INPUT, OUTPUT and figures; its finite rows; and its
    points in metres, since every method's length option is in metres.

    Points whose LAS withheld flag is set are left out like NaN rows, keeping their
    class. `neighbours`, a (flag name, count) pair, is checked against the rows left:
    the count must leave a point out. Longitude and latitude, geocentric coordinates
    and coordinate-system records that cannot be read are refused, unless --units
    says what the units are.
    """
    check_paths(args.input, args.output, [args.plot, args.profile])
    cloud = read(run, args.input)
    existing_classes(cloud)  # a classification that is not class codes: said before the work
    finite = valid_points(cloud.points)
    writes_every_row = getattr(args, "drop", None) is False
    to_las = os.path.splitext(args.output)[1].lower() in (".las", ".laz")
    if writes_every_row and not finite.all() and to_las:
        # Said now, not after the work: LAS stores no NaN coordinates.
        raise CliError(
            f"{args.input}: {int((~finite).sum()):,} point(s) with NaN or Inf coordinates, "
            f"which {args.output!r} (LAS) cannot store; write PCD, PLY or XYZ, or pass --drop"
        )
    clashing = [key for key in cloud.fields if las_coordinate_name(key)]
    if clashing and to_las:  # said now, not after the work
        raise CliError(
            f"{args.input}: field {clashing[0]!r} would be taken for a coordinate in "
            f"{args.output!r} (LAS names X, Y and Z in any case); write PLY, PCD or XYZ"
        )
    withheld = finite & withheld_mask(cloud)
    valid = finite & ~withheld
    if cloud.format in ("las", "laz"):
        run.result["skipped_withheld"] = int(withheld.sum())
    if withheld.any():
        run.say(f"{int(withheld.sum()):,} withheld points left out (LAS: not to be processed)")
    if neighbours is not None:
        _check_neighbours(*neighbours, int(valid.sum()))
    try:
        factors, where = metre_factors(cloud.units, args.units)
    except ValueError as error:
        raise CliError(f"{args.input}: {error} (--units)") from None
    run.result["units"] = {"metres_per_unit": list(factors), "source": where}
    say_units(run, factors, where)
    scale = np.asarray(factors)
    if (scale == 1.0).all():
        return Input(cloud, valid, cloud.points, scale, finite)
    return Input(cloud, valid, cloud.points * scale, scale, finite)


def say_units(run: Run, factors: Sequence[float], where: str) -> None:
    """Tell the user when the input's points are scaled to metres for the work, or when
    their units were only assumed (`where` as metre_factors words it)."""
    if "assumed" in where:
        run.say(f"coordinates in {where}")
    elif any(factor != 1.0 for factor in factors):
        run.say(f"coordinates in {where}: the work is done in metres")


def say_written(run: Run, args: argparse.Namespace, n: int, what: str) -> None:
    run.say(f"wrote {os.path.abspath(args.output)} ({n:,} points{what})")


def _check_neighbours(name: str, value: int, n_valid: int) -> None:
    """A neighbour count must leave a point out: < the number of valid points."""
    if n_valid and value >= n_valid:
        raise CliError(
            f"argument --{name.replace('_', '-')}: {name} must be < the number of points "
            f"({n_valid}), got {value}"
        )


# ---------------------------------------------------------------- classes


def counts(codes: np.ndarray) -> dict[str, int]:
    """Points per class; in a float column only whole numbers count (NaN and the like
    may stand on its invalid points)."""
    if codes.dtype.kind == "f":
        codes = codes[whole_numbers(codes)]
    values, counts = np.unique(codes, return_counts=True)
    return {str(int(v)): int(c) for v, c in zip(values, counts, strict=True)}


def percent(part: int, whole: int) -> str:
    return f"{100.0 * part / whole:.1f} %" if whole else "-"


def segments_summary(labels: np.ndarray) -> dict[str, Any]:
    """Counts of the segments of `labels` (-1 or any negative: no segment)."""
    assigned = labels >= 0
    ids = labels[assigned]
    if ids.dtype.kind in "iu" and (not len(ids) or int(ids.max()) <= len(ids)):
        sizes = np.bincount(ids.astype(np.intp, copy=False))  # compact ids: fast
        sizes = sizes[sizes > 0]
    else:
        # Ids as large as 2**32 - 1 (another program's, any value it likes) would
        # make bincount allocate one counter per id: counted by value instead.
        sizes = np.unique(ids, return_counts=True)[1]
    return {
        "segments": int(len(sizes)),
        "assigned": int(assigned.sum()),
        "unassigned": int((~assigned).sum()),
        "largest_segment": int(sizes.max()) if len(sizes) else 0,
    }


def _int32_segments(cloud: PointFile) -> PointFile:
    """`cloud` as the template of segment's output: a LAS segment_id dimension of
    another type (another tool's, often unsigned: no -1) is replaced by the int32 one
    the command documents, rather than refused when the labels are written."""
    header = cloud.header
    if cloud.format not in ("las", "laz") or header is None:
        return cloud
    dims = {d.name: d for d in header.point_format.extra_dimensions}
    kept = dims.get("segment_id")
    if kept is None or (kept.dtype == np.int32 and kept.num_elements == 1):
        return cloud
    header = copy.deepcopy(header)
    header.remove_extra_dim("segment_id")
    return PointFile(cloud.points, cloud.fields, cloud.format, header, cloud.path, cloud.records)


def finish_segments(
    run: Run,
    args: argparse.Namespace,
    cloud: PointFile,
    segment: np.ndarray,
    what: str,
    metres_per_unit: Sequence[float],
    classes: np.ndarray | None = None,
) -> None:
    fields = dict(cloud.fields, segment_id=segment)
    if classes is not None:
        fields["classification"] = classes
    n_written = write_output(run, args, _int32_segments(cloud), fields, segment >= 0)
    summary = segments_summary(segment)
    run.result.update(
        input=os.path.abspath(args.input), points_in=len(cloud), dropped=bool(args.drop), **summary
    )
    run.say(
        f"{what}: {summary['segments']:,} segments holding {summary['assigned']:,} of "
        f"{len(cloud):,} points ({percent(summary['assigned'], len(cloud))})"
    )
    say_written(
        run,
        args,
        n_written,
        ", segment_id -1 = none" + (", segmented points only" if args.drop else ""),
    )
    plots(
        run,
        args,
        cloud.points,
        segments=segment,
        title=f"{what}: {os.path.basename(args.input)}",
        metres_per_unit=metres_per_unit,
    )
