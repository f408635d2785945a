"""The ``pcl-rg`` command line (also ``python -m pcl_rg``).

One subcommand per job; the algorithm flags are generated from the parameter
dataclasses (their fields, types, defaults and ``metadata["help"]``), so the
command line cannot drift from the Python API. Run ``pcl-rg --help`` or
``pcl-rg COMMAND --help``.

Commands that write a file take ``INPUT OUTPUT`` (LAS/LAZ, PLY, PCD or XYZ text,
by extension) and classify rather than delete: ``ground`` sets class 2 (ground)
or 1 (other), ``denoise`` class 7 (noise), ``segment`` and ``pipeline`` a
``segment_id`` dimension (int32, -1 for none); ``--drop`` writes only the kept
points. The output is written to a temporary file beside it and renamed into
place; an output that is the input (also through a link) is refused.

Exit status: 0 success, 1 the output could not be written (e.g. disk full),
2 bad usage, parameters or input files (one ``pcl-rg: error: ...`` line on
stderr), 130 interrupted.
"""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import json
import math
import os
import sys
import threading
import time
import typing
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import numpy as np

from .io import EXTENSIONS, PointFile, read_points, write_points

__all__ = ["build_parser", "main"]

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130

#: A stage shows progress on stderr once it has run this many seconds.
PROGRESS_DELAY = 1.0

# ASPRS classes written by the commands.
UNCLASSIFIED = 1
GROUND = 2
NOISE = 7
NOISE_CLASSES = (7, 18)  # low noise, high noise (LAS 1.4)
NEVER_CLASSIFIED = 0


class CliError(Exception):
    """An error reported as one ``pcl-rg: error: ...`` line."""

    def __init__(self, message: str, code: int = EXIT_USAGE) -> None:
        super().__init__(message)
        self.code = code


class _Parser(argparse.ArgumentParser):
    """argparse that raises instead of printing usage and exiting on errors."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)  # --profile must not match --profile-line
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> typing.NoReturn:
        where = self.prog.split(" ", 1)[1] + ": " if " " in self.prog else ""
        raise CliError(f"{where}{message} (see '{self.prog} --help')")


# ------------------------------------------------------------- algorithms
#
# A method is registered only when its module imports, so the command line
# keeps working while an algorithm is being added.


class _Method(typing.NamedTuple):
    name: str
    function: Callable[..., Any]
    params: type
    summary: str


def _ground_methods() -> dict[str, _Method]:
    from ._grid_ground import GridGroundParams, grid_ground
    from ._tin_ground import TinGroundParams, tin_ground

    return {
        "grid": _Method(
            "grid",
            grid_ground,
            GridGroundParams,
            "grid region growing from the lowest point of each block (seed 000)",
        ),
        "tin": _Method(
            "tin",
            tin_ground,
            TinGroundParams,
            "progressive TIN densification (seed 002, LiDAR360's settings)",
        ),
    }


def _segment_methods() -> dict[str, _Method]:
    from ._region_growing import RegionGrowingParams, region_growing
    from ._region_growing_pcl import RegionGrowingPclParams, region_growing_pcl

    return {
        "curvature": _Method(
            "curvature",
            region_growing,
            RegionGrowingParams,
            "curvature-seeded region growing (seed 004)",
        ),
        "pcl": _Method(
            "pcl",
            region_growing_pcl,
            RegionGrowingPclParams,
            "PCL's classic pcl::RegionGrowing (the baseline)",
        ),
    }


# ------------------------------------------------- flags from dataclasses


class _Flag(typing.NamedTuple):
    path: tuple[str, ...]  # dataclass field names, outer to inner (nested params)
    flag: str  # --field-name, or --outer-inner for a nested dataclass
    dest: str
    methods: tuple[str, ...]  # methods whose params class has the field

    @property
    def name(self) -> str:
        return self.path[-1]


def _kind(annotation: Any) -> tuple[str, Any]:
    """(kind, detail) of a field type: int, float, bool, str, choice, axes."""
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if annotation is bool:
        return "bool", None
    if annotation is int:
        return "int", None
    if annotation is float:
        return "float", None
    if origin is typing.Literal:
        return "choice", args
    if origin is tuple and args and all(a is float for a in args):
        return "axes", len(args)
    if origin is tuple and len(args) == 2 and args[1] is Ellipsis:
        return "axes", None
    return "str", None


def _number(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(text)
    return value


def _axes_type(n: int | None) -> Callable[[str], float | tuple[float, ...]]:
    def parse(text: str) -> float | tuple[float, ...]:
        tokens = [t for t in text.replace(",", " ").split() if t]
        try:
            values = tuple(_number(t) for t in tokens)
        except ValueError:
            raise argparse.ArgumentTypeError(f"invalid number in {text!r}") from None
        if len(values) == 1:
            return values[0]
        if n is not None and len(values) != n:
            raise argparse.ArgumentTypeError(
                f"expected 1 or {n} comma-separated numbers, got {len(values)} in {text!r}"
            )
        return values

    parse.__name__ = "numbers"
    return parse


def _line_type(text: str) -> tuple[float, float, float, float]:
    tokens = [t for t in text.replace(",", " ").split() if t]
    try:
        values = tuple(_number(t) for t in tokens)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid number in {text!r}") from None
    if len(values) != 4:
        raise argparse.ArgumentTypeError(
            f"expected 4 numbers X0,Y0,X1,Y1, got {len(values)} in {text!r}"
        )
    return values  # type: ignore[return-value]


def _float_type(text: str) -> float:
    try:
        return _number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid number: {text!r}") from None


def _int_type(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid integer: {text!r}") from None


def _show(value: Any) -> str:
    if isinstance(value, tuple):
        return ",".join(_show(v) for v in value)
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def _nested(hint: Any) -> tuple[type | None, bool]:
    """(dataclass, optional) when `hint` is a dataclass or an Optional of one."""
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return hint, False
    args = typing.get_args(hint)
    others = [a for a in args if a is not type(None)]
    if len(args) == 2 and len(others) == 1 and dataclasses.is_dataclass(others[0]):
        return others[0], True
    return None, False


def _leaves(
    cls: type, prefix: tuple[str, ...] = ()
) -> Iterator[tuple[tuple[str, ...], Any, Any, str]]:
    """(path, type, default, help) of every field, nested dataclasses flattened.

    The default of a field of a nested dataclass is that of the outer field's
    default instance; when the outer default is None (an optional stage that
    is off), the nested class's own default.
    """
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        default = f.default
        if default is dataclasses.MISSING and f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        inner, _ = _nested(hints[f.name])
        if inner is not None:
            for path, inner_hint, inner_default, text in _leaves(inner, prefix + (f.name,)):
                if default is not dataclasses.MISSING and default is not None:
                    inner_default = getattr(default, path[-1])
                yield path, inner_hint, inner_default, text
        else:
            yield prefix + (f.name,), hints[f.name], default, f.metadata.get("help", "")


def _add_param_flags(
    parser: argparse.ArgumentParser, title: str, classes: dict[str, type]
) -> list[_Flag]:
    """Add one flag per dataclass field of every class (fields shared by name merge).

    Help text, type and default come from the dataclass (fields of a nested
    dataclass become ``--outer-inner``); defaults are applied by the dataclass
    itself (the flag's own default is None: "not given").
    """
    group = parser.add_argument_group(title)
    merged: dict[tuple[str, ...], dict[str, Any]] = {}
    for method, cls in classes.items():
        for path, hint, default, text in _leaves(cls):
            entry = merged.setdefault(path, {"per_method": {}, "kind": _kind(hint)})
            entry["per_method"][method] = (default, text)
    flags = []
    several = len(classes) > 1
    # Optional stages that are off by default (a `Params | None = None` field).
    optional_off = set()
    for cls in classes.values():
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            if _nested(hints[f.name])[1] and f.default is None:
                optional_off.add(f.name)
    for path, entry in merged.items():
        per_method = entry["per_method"]
        kind, detail = entry["kind"]
        helps = {h for _, h in per_method.values()}
        if len(helps) == 1:
            text = helps.pop()
        else:
            text = "; ".join(f"{m}: {h}" for m, (_, h) in per_method.items())
        defaults = {m: d for m, (d, _) in per_method.items()}
        missing = [m for m, d in defaults.items() if d is dataclasses.MISSING]
        shown = {m: _show(d) for m, d in defaults.items() if d is not dataclasses.MISSING}
        if missing and not shown and path[0] in optional_off:
            text += f" (required for the {path[0]} stage, which runs only when it is given)"
        elif missing and not shown:
            text += " (required)"
        elif len(set(shown.values())) == 1 and not missing:
            text += f" (default: {next(iter(shown.values()))})"
        else:
            text += " (default: " + ", ".join(f"{v} for {m}" for m, v in shown.items()) + ")"
        if several and len(per_method) < len(classes):
            text += f" [--method {'/'.join(per_method)} only]"
        flag = "--" + "-".join(path).replace("_", "-")
        dest = "param_" + "__".join(path)
        options: dict[str, Any] = {"dest": dest, "default": None, "help": text.replace("%", "%%")}
        if kind == "bool":
            options["action"] = argparse.BooleanOptionalAction
        elif kind == "int":
            options.update(type=_int_type, metavar="N")
        elif kind == "float":
            options.update(type=_float_type, metavar="X")
        elif kind == "axes":
            options.update(
                type=_axes_type(detail), metavar="X[,Y" + (",Z]" if detail == 3 else "]")
            )
        elif kind == "choice":
            options.update(choices=list(detail))
        else:
            options["metavar"] = "TEXT"
        if missing and not shown and not several and path[0] not in optional_off:
            options["required"] = True
        group.add_argument(flag, **options)
        flags.append(_Flag(path, flag, dest, tuple(per_method)))
    if not several:
        # An optional stage (a field typed `Params | None`): off by default unless one of
        # its flags is given, or on by default with a --no-<stage> switch.
        (cls,) = classes.values()
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            inner, optional = _nested(hints[f.name])
            if inner is None or not optional:
                continue
            flag = "--no-" + f.name.replace("_", "-")
            if f.default is None:
                continue  # off unless its flags are given; see the flags' help
            group.add_argument(
                flag,
                dest=f"param_skip__{f.name}",
                action="store_true",
                help=f"skip the {f.name} stage",
            )
            flags.append(_Flag((f.name, ""), flag, f"param_skip__{f.name}", tuple(classes)))
    return flags


def _params(args: argparse.Namespace, flags: list[_Flag], method: str, cls: type) -> Any:
    """The params object of `method` from the flags given; foreign flags are errors."""
    given: dict[tuple[str, ...], Any] = {}
    for f in flags:
        value = getattr(args, f.dest)
        if value is None or (f.path[-1] == "" and value is False):
            continue
        if method not in f.methods:
            raise CliError(f"{f.flag} does not apply to --method {method}")
        given[f.path] = value
    return _build(cls, given, flags, ())


def _build(
    cls: type,
    given: dict[tuple[str, ...], Any],
    flags: list[_Flag],
    prefix: tuple[str, ...],
    base: Any = None,
) -> Any:
    """cls from the given leaves under `prefix`; the rest from `base` or the defaults.

    A nested dataclass field is rebuilt from its default (or `base`'s) value
    with the given leaves replaced, so the outer class's own default stays.
    """
    mine = [f for f in flags if f.path[: len(prefix)] == prefix]
    values: dict[str, Any] = {} if base is None else _params_dict(base)
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        inner, _ = _nested(hints[f.name])
        path = prefix + (f.name,)
        if inner is not None:
            skip = path + ("",)
            nested_given = [k for k in given if k[: len(path)] == path and k != skip]
            if skip in given:
                if nested_given:
                    names = ", ".join(g.flag for g in flags if g.path in nested_given)
                    raise CliError(f"{names} cannot be combined with --no-{f.name}")
                values[f.name] = None
            elif nested_given:
                inner_base = values.get(f.name)
                if inner_base is None and f.default_factory is not dataclasses.MISSING:
                    inner_base = f.default_factory()
                elif inner_base is None and f.default is not dataclasses.MISSING:
                    inner_base = f.default
                values[f.name] = _build(inner, given, flags, path, inner_base)
        elif path in given:
            values[f.name] = given[path]
    return _construct(cls, values, mine)


def _construct(cls: type, values: dict[str, Any], flags: list[_Flag]) -> Any:
    try:
        return cls(**values)
    except TypeError as error:
        message = str(error)
        if "missing" in message and "required" in message:
            names = [f.flag for f in flags if f"'{f.name}'" in message]
            raise CliError(f"the following arguments are required: {', '.join(names)}") from None
        raise CliError(_flag_message(message, flags)) from None
    except ValueError as error:
        raise CliError(_flag_message(str(error), flags)) from None


def _flag_message(message: str, flags: list[_Flag]) -> str:
    for f in sorted(flags, key=lambda f: -len(f.name)):
        if message.startswith(f.name + " ") or message.startswith(f.name + ":"):
            return f"argument {f.flag}: {message}"
    return message


def _params_dict(params: Any) -> dict[str, Any]:
    return {f.name: getattr(params, f.name) for f in dataclasses.fields(params)}


# --------------------------------------------------------- run context


class _Run:
    """Progress on stderr, timings, and the result printed at the end."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.quiet = bool(getattr(args, "quiet", False))
        self.json = bool(getattr(args, "json", False))
        self.timings: dict[str, float] = {}
        self.result: dict[str, Any] = {"command": args.command}
        self.lines: list[str] = []
        self.start = time.perf_counter()

    @contextmanager
    def stage(self, key: str, description: str) -> Iterator[None]:
        """Time a stage; show a tqdm spinner on stderr if it runs past PROGRESS_DELAY."""
        start = time.perf_counter()
        done = threading.Event()
        outcome = ["done in"]  # how the spinner's last line reports the end of the stage
        thread = None
        if not self.quiet:
            thread = threading.Thread(
                target=self._spin, args=(description, done, time.time(), outcome), daemon=True
            )
            thread.start()
        try:
            yield
        except BaseException as error:
            interrupted = isinstance(error, KeyboardInterrupt)
            outcome[0] = "interrupted after" if interrupted else "failed after"
            raise
        finally:
            # The spinner wakes within 0.25 s and ends: nothing outlives the stage, also
            # on Ctrl-C.
            done.set()
            if thread is not None:
                thread.join()
            self.timings[key] = self.timings.get(key, 0.0) + time.perf_counter() - start

    @staticmethod
    def _spin(description: str, done: threading.Event, started: float, outcome: list[str]) -> None:
        """Show the stage once it has run PROGRESS_DELAY seconds, until it ends."""
        if done.wait(PROGRESS_DELAY):
            return
        stream = sys.stderr
        if not stream.isatty():
            # A log, not a terminal: one line when the stage is seen, one when it ends.
            stream.write(f"pcl-rg: {description} ...\n")
            stream.flush()
            done.wait()
            seconds = time.time() - started
            stream.write(f"pcl-rg: {description}: {outcome[0]} {seconds:.1f} s\n")
            stream.flush()
            return
        from tqdm import tqdm

        bar = tqdm(
            total=None,
            desc=f"pcl-rg: {description}",
            file=stream,
            bar_format="{desc}: {elapsed}",
            leave=True,
            dynamic_ncols=True,
        )
        bar.start_t = started
        try:
            while not done.wait(0.25):
                bar.refresh()
        finally:
            bar.close()

    def say(self, line: str) -> None:
        self.lines.append(line)

    def finish(self) -> None:
        self.timings["total"] = time.perf_counter() - self.start
        if self.json:
            self.result["timings_s"] = {k: round(v, 6) for k, v in self.timings.items()}
            print(json.dumps(_jsonable(self.result), indent=2, allow_nan=False))
        else:
            for line in self.lines:
                print(line)


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return _jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value


# ------------------------------------------------------------ file helpers


def _check_extension(path: str, what: str) -> None:
    ext = os.path.splitext(path)[1].lower()
    if ext not in EXTENSIONS:
        raise CliError(
            f"{what} {path!r}: unknown extension {ext or '(none)'!r} "
            f"(supported: {', '.join(EXTENSIONS)})"
        )


def _check_paths(source: str, target: str, plots: Sequence[str | None] = ()) -> None:
    """Refuse before any work: bad extensions, a missing folder, OUTPUT == INPUT."""
    _check_extension(source, "INPUT")
    _check_extension(target, "OUTPUT")
    if not os.path.exists(source):
        raise CliError(f"INPUT {source!r} does not exist")
    if os.path.isdir(source):
        raise CliError(f"INPUT {source!r} is a folder, not a file")
    if os.path.isdir(target):
        raise CliError(f"OUTPUT {target!r} is a folder, not a file")
    folder = os.path.dirname(os.path.abspath(target))
    if not os.path.isdir(folder):
        raise CliError(f"the folder of OUTPUT {target!r} does not exist")
    same = os.path.realpath(source) == os.path.realpath(target)
    if not same and os.path.exists(target):
        same = os.path.samefile(source, target)  # hard links, bind mounts
    if same:
        raise CliError(f"OUTPUT {target!r} is the INPUT file; refusing to overwrite the input")
    _check_plots(source, plots)


def _check_plots(source: str, plots: Sequence[str | None]) -> None:
    for plot in plots:
        if plot is None:
            continue
        if not plot.lower().endswith(".png"):
            raise CliError(f"plot file {plot!r} must end in .png")
        if not os.path.isdir(os.path.dirname(os.path.abspath(plot))):
            raise CliError(f"the folder of plot file {plot!r} does not exist")
        if os.path.exists(plot) and os.path.samefile(source, plot):
            raise CliError(f"plot file {plot!r} is the INPUT file; refusing to overwrite it")


def _read(run: _Run, path: str) -> PointFile:
    with run.stage("read", f"reading {path}"):
        return read_points(path)


def _write(
    run: _Run, path: str, points: np.ndarray, fields: dict[str, np.ndarray], template: PointFile
) -> None:
    with run.stage("write", f"writing {path}"):
        try:
            write_points(path, points, fields, template=template)
        except OSError as error:
            reason = error.strerror or str(error)
            raise CliError(f"cannot write {path!r}: {reason}", EXIT_FAILURE) from None
    run.result["output"] = os.path.abspath(path)
    run.result["points_out"] = int(len(points))


def _valid(points: np.ndarray) -> np.ndarray:
    return np.isfinite(points).all(axis=1)


def _existing_classes(cloud: PointFile) -> np.ndarray | None:
    codes = cloud.classification
    if codes is None:
        return None
    codes = np.asarray(codes)
    if codes.ndim != 1 or codes.dtype.kind not in "iuf":
        return None
    return codes


def _class_array(cloud: PointFile, fill: int) -> np.ndarray:
    """A writable classification column: the file's (as uint8 when possible) or `fill`."""
    codes = _existing_classes(cloud)
    n = len(cloud)
    if codes is None:
        return np.full(n, fill, dtype=np.uint8)
    if codes.dtype.kind in "iu" and codes.dtype.itemsize >= 1:
        return codes.copy()
    return codes.astype(np.int64)


def _counts(codes: np.ndarray) -> dict[str, int]:
    values, counts = np.unique(codes, return_counts=True)
    return {str(int(v)): int(c) for v, c in zip(values, counts)}


def _percent(part: int, whole: int) -> str:
    return f"{100.0 * part / whole:.1f} %" if whole else "-"


# ----------------------------------------------------------------- plots


def _add_plot_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("figures (PNG, needs matplotlib)")
    group.add_argument("--plot", metavar="FILE.png", help="write a top view of the result")
    group.add_argument(
        "--profile",
        metavar="FILE.png",
        help="write a vertical profile: points within --profile-width of --profile-line, "
        "distance along the line against z",
    )
    group.add_argument(
        "--profile-line",
        metavar="X0,Y0,X1,Y1",
        type=_line_type,
        help="ends A and B of the profile line in the file's x, y coordinates, metres "
        "(default: west to east through the middle of the cloud)",
    )
    group.add_argument(
        "--profile-width",
        metavar="M",
        type=_float_type,
        default=2.0,
        help="corridor width around the profile line in metres (default: 2)",
    )


def _plots(
    run: _Run,
    args: argparse.Namespace,
    points: np.ndarray,
    *,
    title: str,
    classes: np.ndarray | None = None,
    segments: np.ndarray | None = None,
) -> None:
    top, side = getattr(args, "plot", None), getattr(args, "profile", None)
    if top is None and side is None:
        return
    from . import plot

    keep = _valid(points)
    xyz = points[keep]
    cls = None if classes is None else np.asarray(classes)[keep].astype(np.int64)
    seg = None if segments is None else np.asarray(segments)[keep].astype(np.int64)
    files = []
    with run.stage("plot", "drawing figures"):
        if top is not None:
            plot.top_view(xyz, top, classes=cls, segments=seg, title=title)
            files.append(os.path.abspath(top))
        if side is not None:
            if args.profile_line is not None:
                x0, y0, x1, y1 = args.profile_line
            elif len(xyz):
                lower, upper = xyz.min(axis=0), xyz.max(axis=0)
                middle = (lower[1] + upper[1]) / 2
                x0, y0, x1, y1 = lower[0], middle, max(upper[0], lower[0] + 1.0), middle
            else:
                x0, y0, x1, y1 = 0.0, 0.0, 1.0, 0.0
            try:
                n = plot.profile(
                    xyz,
                    side,
                    (x0, y0),
                    (x1, y1),
                    width=args.profile_width,
                    classes=cls,
                    segments=seg,
                )
            except ValueError as error:
                raise CliError(f"--profile: {error}") from None
            run.result["profile_points"] = n
            files.append(os.path.abspath(side))
    run.result["figures"] = files
    for path in files:
        run.say(f"wrote {path}")


# --------------------------------------------------------------- commands


def _method_of(args: argparse.Namespace, methods: dict[str, _Method]) -> _Method:
    return methods[args.method]


def _cmd_ground(args: argparse.Namespace, run: _Run) -> None:
    method = _method_of(args, args.methods)
    params = _params(args, args.flags, method.name, method.params)
    _check_paths(args.input, args.output, [args.plot, args.profile])
    cloud = _read(run, args.input)
    points = cloud.points
    valid = _valid(points)
    existing = _existing_classes(cloud)
    noise = np.isin(existing, NOISE_CLASSES) if existing is not None else np.zeros(len(cloud), bool)
    work = valid & ~noise
    with run.stage("ground", f"ground filter ({method.name}) on {int(work.sum()):,} points"):
        ground = method.function(points[work], params=params)
    classes = _class_array(cloud, NEVER_CLASSIFIED)
    classes[work] = np.where(ground, GROUND, UNCLASSIFIED)
    n_ground = int(ground.sum())
    n_work = int(work.sum())
    kept = np.zeros(len(cloud), bool)
    kept[work] = ground
    fields = dict(cloud.fields, classification=classes)
    out = cloud.points
    if args.drop:
        out = points[kept]
        fields = {k: v[kept] for k, v in fields.items()}
    _write(run, args.output, out, fields, cloud)
    run.result.update(
        input=os.path.abspath(args.input),
        method=method.name,
        parameters=_params_dict(params),
        points_in=len(cloud),
        filtered=n_work,
        ground=n_ground,
        object=n_work - n_ground,
        skipped_noise=int((valid & noise).sum()),
        skipped_invalid=int((~valid).sum()),
        dropped=bool(args.drop),
    )
    run.say(
        f"ground ({method.name}): {n_work:,} points filtered, {n_ground:,} ground "
        f"({_percent(n_ground, n_work)}), {n_work - n_ground:,} object"
        + (
            f"; {int((valid & noise).sum()):,} noise points left as they were"
            if noise.any()
            else ""
        )
        + (f"; {int((~valid).sum()):,} invalid (NaN) points skipped" if not valid.all() else "")
    )
    run.say(
        f"wrote {os.path.abspath(args.output)} ({len(out):,} points"
        + (", ground only" if args.drop else ", class 2 ground, 1 other")
        + ")"
    )
    _plots(
        run,
        args,
        points,
        classes=classes,
        title=f"ground filter ({method.name}): {os.path.basename(args.input)}",
    )


def _cmd_denoise(args: argparse.Namespace, run: _Run) -> None:
    from ._statistical_outlier_removal import (
        StatisticalOutlierRemovalParams,
        statistical_outlier_removal,
    )

    params = _params(args, args.flags, "sor", StatisticalOutlierRemovalParams)
    _check_paths(args.input, args.output, [args.plot, args.profile])
    cloud = _read(run, args.input)
    points = cloud.points
    valid = _valid(points)
    n_valid = int(valid.sum())
    if n_valid and params.mean_k >= n_valid:
        raise CliError(
            f"argument --mean-k: mean_k must be < the number of points ({n_valid}), "
            f"got {params.mean_k}"
        )
    with run.stage("denoise", f"statistical outlier removal on {n_valid:,} points"):
        inlier = statistical_outlier_removal(points[valid], params=params)
    classes = _class_array(cloud, UNCLASSIFIED)
    if _existing_classes(cloud) is None:
        classes[~valid] = NEVER_CLASSIFIED
    keep = np.zeros(len(cloud), bool)
    keep[valid] = inlier
    outlier = valid & ~keep
    classes[outlier] = NOISE
    classes[keep & (classes == NOISE)] = UNCLASSIFIED  # an earlier run's noise, now inlier
    fields = dict(cloud.fields, classification=classes)
    out = points
    if args.drop:
        out = points[keep]
        fields = {k: v[keep] for k, v in fields.items()}
    _write(run, args.output, out, fields, cloud)
    n_noise = int(outlier.sum())
    run.result.update(
        input=os.path.abspath(args.input),
        parameters=_params_dict(params),
        points_in=len(cloud),
        filtered=n_valid,
        noise=n_noise,
        inliers=n_valid - n_noise,
        skipped_invalid=int((~valid).sum()),
        dropped=bool(args.drop),
    )
    run.say(f"denoise (SOR): {n_valid:,} points, {n_noise:,} noise ({_percent(n_noise, n_valid)})")
    run.say(
        f"wrote {os.path.abspath(args.output)} ({len(out):,} points"
        + (", inliers only" if args.drop else ", class 7 noise")
        + ")"
    )
    _plots(
        run,
        args,
        points,
        classes=classes,
        title=f"statistical outlier removal: {os.path.basename(args.input)}",
    )


#: Attributes averaged over a voxel's points (rounded for integer types); every
#: other integer attribute (class, return numbers, flags, ids) is the first point's.
MEAN_ATTRIBUTES = ("intensity", "red", "green", "blue", "nir", "gps_time")


def _voxel_attributes(
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


def _cmd_downsample(args: argparse.Namespace, run: _Run) -> None:
    from ._voxel_grid import VoxelGridParams, voxel_grid

    params = _params(args, args.flags, "voxel", VoxelGridParams)
    _check_paths(args.input, args.output, [args.plot, args.profile])
    cloud = _read(run, args.input)
    points = cloud.points
    valid = _valid(points)
    rows = np.flatnonzero(valid)
    with run.stage("downsample", f"voxel grid on {len(rows):,} points"):
        grid = voxel_grid(points[rows], params=params)
    kept = grid.voxel_of_point >= 0
    with run.stage("attributes", "voxel attributes"):
        fields = _voxel_attributes(cloud.fields, rows[kept], grid.voxel_of_point[kept], grid.counts)
    _write(run, args.output, grid.centroids, fields, cloud)
    run.result.update(
        input=os.path.abspath(args.input),
        parameters=_params_dict(params),
        points_in=len(cloud),
        voxels=len(grid.centroids),
        skipped_invalid=int((~valid).sum()),
        points_in_dropped_voxels=int((~kept).sum()),
    )
    run.say(
        f"downsample (voxel grid {_show(params.leaf_size)} m): {len(rows):,} points -> "
        f"{len(grid.centroids):,} voxel centroids"
    )
    run.say(f"wrote {os.path.abspath(args.output)}")
    _plots(
        run,
        args,
        grid.centroids,
        classes=fields.get("classification"),
        title=f"voxel centroids: {os.path.basename(args.input)}",
    )


def _segments_summary(labels: np.ndarray) -> dict[str, Any]:
    assigned = labels >= 0
    sizes = np.bincount(labels[assigned]) if assigned.any() else np.zeros(0, np.int64)
    sizes = sizes[sizes > 0]
    return {
        "segments": int(len(sizes)),
        "assigned": int(assigned.sum()),
        "unassigned": int((~assigned).sum()),
        "largest_segment": int(sizes.max()) if len(sizes) else 0,
    }


def _cmd_segment(args: argparse.Namespace, run: _Run) -> None:
    method = _method_of(args, args.methods)
    params = _params(args, args.flags, method.name, method.params)
    _check_paths(args.input, args.output, [args.plot, args.profile])
    cloud = _read(run, args.input)
    points = cloud.points
    valid = _valid(points)
    n_valid = int(valid.sum())
    if n_valid and params.k >= n_valid:
        raise CliError(
            f"argument --k: k must be < the number of points ({n_valid}), got {params.k}"
        )
    with run.stage("segment", f"region growing ({method.name}) on {n_valid:,} points"):
        labels = method.function(points[valid], params=params)
    segment = np.full(len(cloud), -1, dtype=np.int32)
    segment[valid] = labels
    _finish_segments(run, args, cloud, segment, f"segment ({method.name})")
    run.result.update(method=method.name, parameters=_params_dict(params))


def _finish_segments(
    run: _Run,
    args: argparse.Namespace,
    cloud: PointFile,
    segment: np.ndarray,
    what: str,
    classes: np.ndarray | None = None,
) -> None:
    fields = dict(cloud.fields, segment_id=segment)
    if classes is not None:
        fields["classification"] = classes
    out = cloud.points
    if args.drop:
        keep = segment >= 0
        out = out[keep]
        fields = {k: v[keep] for k, v in fields.items()}
    _write(run, args.output, out, fields, cloud)
    summary = _segments_summary(segment)
    run.result.update(
        input=os.path.abspath(args.input), points_in=len(cloud), dropped=bool(args.drop), **summary
    )
    run.say(
        f"{what}: {summary['segments']:,} segments holding {summary['assigned']:,} of "
        f"{len(cloud):,} points ({_percent(summary['assigned'], len(cloud))})"
    )
    run.say(
        f"wrote {os.path.abspath(args.output)} ({len(out):,} points, segment_id -1 = none"
        + (", segmented points only" if args.drop else "")
        + ")"
    )
    _plots(
        run, args, cloud.points, segments=segment, title=f"{what}: {os.path.basename(args.input)}"
    )


def _keyword_params(function: Callable[..., Any], name: str) -> type:
    """A dataclass of the keyword-only parameter-object arguments of `function`.

    ``seed004(points, *, sor=..., voxel=..., region=...)`` takes one params
    object per stage; this makes its flags (``--sor-mean-k``, ``--voxel-leaf-size``,
    ``--region-k``, ...) come from those dataclasses like every other command's.
    """
    signature = inspect.signature(function)
    hints = typing.get_type_hints(function)
    fields = []
    for key, parameter in signature.parameters.items():
        if parameter.kind is not inspect.Parameter.KEYWORD_ONLY:
            continue
        inner, optional = _nested(hints[key])
        if inner is None:
            continue
        default = parameter.default
        if default is inspect.Parameter.empty:
            fields.append((key, hints[key]))
        else:
            fields.append((key, hints[key], dataclasses.field(default=default)))
    return dataclasses.make_dataclass(name, fields, kw_only=True, frozen=True)


def _cmd_pipeline(args: argparse.Namespace, run: _Run) -> None:
    options = _params(args, args.flags, "pipeline", args.pipeline_params)
    _check_paths(args.input, args.output, [args.plot, args.profile])
    cloud = _read(run, args.input)
    points = cloud.points
    valid = _valid(points)
    stages = "SOR, voxel grid, normals, region growing"
    with run.stage("pipeline", f"{stages} on {int(valid.sum()):,} points"):
        result = args.pipeline(points[valid], **_params_dict(options))
    segment = np.full(len(cloud), -1, dtype=np.int32)
    segment[valid] = np.asarray(result.labels)
    classes = None
    if options.sor is not None:
        classes = _class_array(cloud, UNCLASSIFIED)
        if _existing_classes(cloud) is None:
            classes[~valid] = NEVER_CLASSIFIED
        outlier = np.zeros(len(cloud), bool)
        outlier[valid] = ~np.asarray(result.inlier)
        classes[outlier] = NOISE
        classes[valid & ~outlier & (classes == NOISE)] = UNCLASSIFIED
    report = result.report
    run.result["stages"] = [
        {"name": s.name, "points_in": s.points_in, "points_out": s.points_out, "seconds": s.seconds}
        for s in report.stages
    ]
    run.say(report.table())
    _finish_segments(run, args, cloud, segment, "pipeline", classes)
    run.result.update(parameters=_jsonable(_params_dict_deep(options)))


def _params_dict_deep(params: Any) -> Any:
    if dataclasses.is_dataclass(params):
        return {
            f.name: _params_dict_deep(getattr(params, f.name)) for f in dataclasses.fields(params)
        }
    return params


def _scales(cloud: PointFile) -> float:
    scales = getattr(cloud.header, "scales", None)
    return float(np.max(scales)) if scales is not None else 0.0


def _cmd_evaluate(args: argparse.Namespace, run: _Run) -> None:
    if (args.truth is None) == (args.isprs is None):
        raise CliError("evaluate needs exactly one of --truth FILE or --isprs ALL.pcd GROUND.pcd")
    _check_extension(args.prediction, "PREDICTION")
    prediction = _read(run, args.prediction)
    if args.segments:
        _evaluate_segments(args, run, prediction)
        return
    predicted_codes = _existing_classes(prediction)
    if predicted_codes is None:
        raise CliError(
            f"PREDICTION {args.prediction!r} has no classification field "
            "(write it with 'pcl-rg ground')"
        )
    if args.isprs is not None:
        from .datasets import load_isprs

        all_pcd, ground_pcd = args.isprs
        with run.stage("truth", "reading the ISPRS reference"):
            sample = load_isprs(all_pcd, ground_pcd)
        truth_points, truth_ground = sample.points, sample.ground
        scored = np.ones(len(truth_points), bool)
        truth_scale = 0.0
        source = {"isprs": [os.path.abspath(all_pcd), os.path.abspath(ground_pcd)]}
    else:
        truth = _read(run, args.truth)
        codes = _existing_classes(truth)
        if codes is None:
            raise CliError(f"--truth {args.truth!r} has no classification field")
        truth_points, truth_ground = truth.points, codes == GROUND
        noise = np.isin(codes, NOISE_CLASSES)
        scored = np.ones(len(codes), bool) if args.include_noise else ~noise
        truth_scale = _scales(truth)
        source = {"truth": os.path.abspath(args.truth)}
    _check_same_points(prediction, truth_points, max(_scales(prediction), truth_scale))
    from .evaluation import ground_errors

    errors = ground_errors(truth_ground[scored], (predicted_codes == GROUND)[scored])
    (a, b), (c, d) = errors.confusion.tolist()
    run.result.update(
        prediction=os.path.abspath(args.prediction),
        **source,
        points=len(prediction),
        scored=int(scored.sum()),
        excluded_noise=int((~scored).sum()),
        type_i=errors.type_i,
        type_ii=errors.type_ii,
        total=errors.total,
        kappa=errors.kappa,
        confusion={
            "ground_as_ground": a,
            "ground_as_object": b,
            "object_as_ground": c,
            "object_as_object": d,
        },
    )

    def pct(v: float) -> str:
        return "-" if math.isnan(v) else f"{100 * v:.2f} %"

    run.say(
        f"{'points scored':<16}{int(scored.sum()):>12,}"
        + (f"  ({int((~scored).sum()):,} noise points excluded)" if (~scored).any() else "")
    )
    run.say(f"{'Type I':<16}{pct(errors.type_i):>12}  ground classified as object / all ground")
    run.say(f"{'Type II':<16}{pct(errors.type_ii):>12}  object classified as ground / all object")
    run.say(f"{'total':<16}{pct(errors.total):>12}  misclassified / all points")
    kappa = "-" if math.isnan(errors.kappa) else f"{errors.kappa:.4f}"
    run.say(f"{'kappa':<16}{kappa:>12}  Cohen's kappa")
    run.say(
        f"confusion (rows truth ground/object, columns predicted ground/object): "
        f"[[{a}, {b}], [{c}, {d}]]"
    )


def _check_same_points(prediction: PointFile, truth_points: np.ndarray, scale: float) -> None:
    if len(prediction) != len(truth_points):
        raise CliError(
            f"PREDICTION has {len(prediction):,} points but the truth has {len(truth_points):,}; "
            "evaluate needs every point in the original order (write without --drop)"
        )
    if not len(truth_points):
        return
    with np.errstate(invalid="ignore"):
        gap = np.abs(prediction.points - truth_points)
    both_nan = np.isnan(prediction.points) & np.isnan(truth_points)
    gap = np.where(both_nan, 0.0, gap)
    magnitude = float(np.nanmax(np.abs(truth_points))) if np.isfinite(truth_points).any() else 0.0
    tolerance = 0.5 * scale * 1.001 + 1e-9 * magnitude
    worst = float(np.nanmax(np.where(np.isnan(gap), np.inf, gap)))
    if worst > tolerance:
        row = int(np.argmax(np.where(np.isnan(gap), np.inf, gap).max(axis=1)))
        raise CliError(
            f"PREDICTION and truth hold different points (point {row} differs by {worst:.6g} m, "
            f"more than the {tolerance:.3g} m storage precision); they must be the same points "
            "in the same order"
        )


def _evaluate_segments(args: argparse.Namespace, run: _Run, prediction: PointFile) -> None:
    if args.truth is None:
        raise CliError("evaluate --segments needs --truth FILE with a truth segment field")
    labels = prediction.fields.get("segment_id")
    if labels is None:
        raise CliError(
            f"PREDICTION {args.prediction!r} has no segment_id field "
            "(write it with 'pcl-rg segment')"
        )
    truth = _read(run, args.truth)
    segments = truth.fields.get(args.truth_field)
    if segments is None:
        raise CliError(
            f"--truth {args.truth!r} has no field {args.truth_field!r} "
            f"(fields: {', '.join(truth.fields) or 'none'})"
        )
    _check_same_points(prediction, truth.points, max(_scales(prediction), _scales(truth)))
    try:
        from .evaluation import segmentation_scores
    except ImportError:  # until evaluation re-exports it
        from .evaluation import segmentation_scores

    scores = segmentation_scores(
        np.asarray(segments).astype(np.int64), np.asarray(labels).astype(np.int64)
    )
    run.result.update(
        prediction=os.path.abspath(args.prediction),
        truth=os.path.abspath(args.truth),
        truth_field=args.truth_field,
        mean_iou=scores.mean_iou,
        over_segmented=scores.over_segmented,
        under_segmented=scores.under_segmented,
        adjusted_rand_index=scores.adjusted_rand_index,
        clusters=scores.n_clusters,
        truth_segments=int(len(scores.segment_ids)),
    )
    run.say(f"{'truth segments':<20}{len(scores.segment_ids):>10,}")
    run.say(f"{'clusters':<20}{scores.n_clusters:>10,}")
    run.say(f"{'mean IoU':<20}{scores.mean_iou:>10.4f}")
    run.say(f"{'over-segmented':<20}{scores.over_segmented:>10,}")
    run.say(f"{'under-segmented':<20}{scores.under_segmented:>10,}")
    run.say(f"{'adjusted Rand':<20}{scores.adjusted_rand_index:>10.4f}")


def _cmd_info(args: argparse.Namespace, run: _Run) -> None:
    _check_extension(args.input, "INPUT")
    if not os.path.isfile(args.input):
        raise CliError(f"INPUT {args.input!r} does not exist or is not a file")
    _check_plots(args.input, [args.plot, args.profile])
    cloud = _read(run, args.input)
    points = cloud.points
    valid = _valid(points)
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
            "vlrs": [type(v).__name__ for v in header.vlrs],
            "extra_dimensions": list(header.point_format.extra_dimension_names),
        }
    elif header is not None:
        layout = header._asdict()
        layout["xyz_dtype"] = str(layout["xyz_dtype"])
        info[cloud.format] = layout
    info["fields"] = {}
    for name, values in cloud.fields.items():
        entry: dict[str, Any] = {"dtype": str(values.dtype), "shape": list(values.shape[1:])}
        finite = values[np.isfinite(values)] if values.dtype.kind == "f" else values
        if finite.size:
            entry.update(min=finite.min(), max=finite.max())
        info["fields"][name] = entry
    codes = _existing_classes(cloud)
    if codes is not None:
        info["classes"] = _counts(codes)
    if "segment_id" in cloud.fields:
        info["segmentation"] = _segments_summary(
            np.asarray(cloud.fields["segment_id"]).astype(np.int64)
        )
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
        + (f" ({info['invalid_points']:,} with NaN coordinates)" if info["invalid_points"] else "")
    )
    if "bounds" in info:
        lo, hi = info["bounds"]["min"], info["bounds"]["max"]
        for i, axis in enumerate("xyz"):
            run.say(f"{axis + ' range':<14}{lo[i]:.3f} .. {hi[i]:.3f}  ({hi[i] - lo[i]:.3f} m)")
    if "las" in info:
        run.say(f"{'scale':<14}{' '.join(f'{s:g}' for s in info['las']['scales'])}")
        run.say(f"{'offset':<14}{' '.join(f'{s:g}' for s in info['las']['offsets'])}")
    elif header is not None:
        run.say(f"{'layout':<14}" + ", ".join(f"{k} {v}" for k, v in info[cloud.format].items()))
    run.say(
        f"{'fields':<14}"
        + (", ".join(f"{k} ({v['dtype']})" for k, v in info["fields"].items()) or "none")
    )
    if "classes" in info:
        run.say(f"{'classes':<14}" + ", ".join(f"{k}: {v:,}" for k, v in info["classes"].items()))
    if "segmentation" in info:
        s = info["segmentation"]
        run.say(f"{'segments':<14}{s['segments']:,} ({s['assigned']:,} points assigned)")
    _plots(
        run,
        args,
        points,
        classes=None if codes is None else codes.astype(np.int64),
        segments=None,
        title=os.path.basename(args.input),
    )


def _cmd_demo(args: argparse.Namespace, run: _Run) -> None:
    from .demo import run_demo

    try:
        report = run_demo(
            args.output, seed=args.seed, size=args.size, plots=not args.no_plots, stage=run.stage
        )
    except ValueError as error:
        raise CliError(str(error)) from None
    run.result.update(report.as_dict())
    run.say(report.table())
    run.say("")
    for path in report.files:
        run.say(f"wrote {path}")
    run.say(f"output folder: {os.path.abspath(args.output)}")


# ---------------------------------------------------------------- parser


def _common(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("output")
    group.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    group.add_argument(
        "--json", action="store_true", help="print the results as one JSON object on stdout"
    )


def _io_arguments(parser: argparse.ArgumentParser, drop: str | None) -> None:
    formats = "LAS/LAZ, PLY, PCD or XYZ text, by extension"
    parser.add_argument("input", metavar="INPUT", help=f"point file to read ({formats})")
    parser.add_argument(
        "output", metavar="OUTPUT", help=f"point file to write ({formats}); never the INPUT"
    )
    if drop is not None:
        parser.add_argument("--drop", action="store_true", help=drop)


def build_parser() -> argparse.ArgumentParser:
    """The argparse parser of ``pcl-rg`` (subcommands as available)."""
    from . import __version__

    parser = _Parser(
        prog="pcl-rg",
        description="LiDAR ground filtering and point-cloud segmentation (pcl_rg). "
        "Files: LAS/LAZ, PLY, PCD, XYZ text (.xyz/.txt/.pts), by extension.",
        epilog="Commands classify rather than delete (ASPRS classes 2 ground, 1 other, "
        "7 noise; segment_id -1 none); --drop writes only the kept points. "
        "Exit status: 0 ok, 1 output not written, 2 bad usage or input, 130 interrupted.",
    )
    parser.add_argument("--version", action="version", version=f"pcl-rg {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    ground_methods = _ground_methods()
    p = sub.add_parser(
        "ground",
        help="classify ground (2) and other (1) points",
        description="Classify ground points: class 2 ground, class 1 everything else. "
        "Points already classified as noise (7, 18) are left out and keep their class; "
        "points with NaN coordinates are skipped (class 0 if the file had none). Methods: "
        + "; ".join(f"{m.name}: {m.summary}" for m in ground_methods.values())
        + ".",
    )
    _io_arguments(p, "write only the ground points")
    p.add_argument(
        "--method",
        choices=list(ground_methods),
        default=next(iter(ground_methods)),
        help=f"ground filter (default: {next(iter(ground_methods))})",
    )
    flags = _add_param_flags(
        p, "ground filter parameters", {m.name: m.params for m in ground_methods.values()}
    )
    _add_plot_options(p)
    _common(p)
    p.set_defaults(run=_cmd_ground, flags=flags, methods=ground_methods)

    from ._statistical_outlier_removal import StatisticalOutlierRemovalParams

    p = sub.add_parser(
        "denoise",
        help="classify statistical outliers as noise (7)",
        description="Statistical outlier removal (PCL's StatisticalOutlierRemoval): a point "
        "whose mean distance to its mean_k nearest neighbours exceeds the mean of all such "
        "distances by more than std_mul standard deviations is classified 7 (noise); the other "
        "points keep their class (1 if the file had none).",
    )
    _io_arguments(p, "write only the inliers")
    flags = _add_param_flags(
        p, "outlier removal parameters", {"sor": StatisticalOutlierRemovalParams}
    )
    _add_plot_options(p)
    _common(p)
    p.set_defaults(run=_cmd_denoise, flags=flags)

    from ._voxel_grid import VoxelGridParams

    p = sub.add_parser(
        "downsample",
        help="replace the points of each voxel by their centroid",
        description="Voxel grid downsampling (PCL's VoxelGrid): OUTPUT holds one point per "
        "occupied voxel, at the mean of its points. Attributes of a centroid: the mean (rounded "
        "for integers) of " + ", ".join(MEAN_ATTRIBUTES) + " and of every floating-point field; "
        "every other field (classification, return numbers, flags, ids) is taken from the "
        "voxel's first point in file order.",
    )
    _io_arguments(p, None)
    flags = _add_param_flags(p, "voxel grid parameters", {"voxel": VoxelGridParams})
    _add_plot_options(p)
    _common(p)
    p.set_defaults(run=_cmd_downsample, flags=flags)

    segment_methods = _segment_methods()
    p = sub.add_parser(
        "segment",
        help="region growing: a segment_id per point (-1 none)",
        description="Region growing segmentation: OUTPUT gets a segment_id dimension "
        "(int32; a LAS extra-bytes dimension), -1 for points in no kept region. Methods: "
        + "; ".join(f"{m.name}: {m.summary}" for m in segment_methods.values())
        + ".",
    )
    _io_arguments(p, "write only the points with a segment")
    p.add_argument(
        "--method",
        choices=list(segment_methods),
        default=next(iter(segment_methods)),
        help=f"region growing variant (default: {next(iter(segment_methods))})",
    )
    flags = _add_param_flags(
        p, "region growing parameters", {m.name: m.params for m in segment_methods.values()}
    )
    _add_plot_options(p)
    _common(p)
    p.set_defaults(run=_cmd_segment, flags=flags, methods=segment_methods)

    p = sub.add_parser(
        "pipeline",
        help="seed 004: SOR, voxel grid, normals, region growing",
        description="The seed 004 chain (pcl_rg.pipeline.seed004): statistical outlier "
        "removal (--sor-*, on unless --no-sor), voxel grid (--voxel-*, only when "
        "--voxel-leaf-size is given: the leaf depends on the data), normals, curvatures and "
        "region growing (--region-*). Every input point gets the segment_id of the point "
        "it was merged into (-1 for outliers and dropped regions); SOR outliers get class 7.",
    )
    _io_arguments(p, "write only the points with a segment")
    from .pipeline import seed004

    options = _keyword_params(seed004, "PipelineOptions")
    flags = _add_param_flags(p, "pipeline parameters", {"pipeline": options})
    _add_plot_options(p)
    _common(p)
    p.set_defaults(run=_cmd_pipeline, flags=flags, pipeline_params=options, pipeline=seed004)

    p = sub.add_parser(
        "evaluate",
        help="score a classified file against ground truth",
        description="Score the ground classification of PREDICTION (class 2 = ground, anything "
        "else = object) against the truth: Type I (ground rejected / all ground), Type II "
        "(object accepted / all object), total error and Cohen's kappa (Sithole & Vosselman "
        "2004). PREDICTION must hold the truth's points in the same order (an output written "
        "without --drop). With --segments, score its segment_id against a truth segment field.",
    )
    p.add_argument("prediction", metavar="PREDICTION", help="classified point file")
    truth = p.add_argument_group("truth (one of)")
    truth.add_argument(
        "--truth",
        metavar="FILE",
        help="a file with the true classification (class 2 = ground); points "
        "of class 7 or 18 (noise) are left out unless --include-noise",
    )
    truth.add_argument(
        "--isprs",
        nargs=2,
        metavar=("ALL.pcd", "GROUND.pcd"),
        help="an ISPRS sample: all points, and the ground points only",
    )
    p.add_argument(
        "--include-noise", action="store_true", help="score truth noise points too, as object"
    )
    p.add_argument(
        "--segments",
        action="store_true",
        help="score segment_id against the truth's --truth-field instead "
        "(mean IoU, over/under-segmentation, adjusted Rand index)",
    )
    p.add_argument(
        "--truth-field",
        default="label",
        help="truth segment field for --segments, 0 = no truth (default: label, as in mOSD)",
    )
    _common(p)
    p.set_defaults(run=_cmd_evaluate)

    p = sub.add_parser(
        "info",
        help="describe a point file",
        description="Format, point count, bounds, fields and classes of a file.",
    )
    p.add_argument("input", metavar="INPUT", help="point file (LAS/LAZ, PLY, PCD, XYZ text)")
    _add_plot_options(p)
    _common(p)
    p.set_defaults(run=_cmd_info)

    p = sub.add_parser(
        "demo",
        help="run every algorithm on the built-in synthetic scene",
        description="Run every algorithm on a seeded synthetic airborne scene with known "
        "classes; print one table of errors and times; write classified LAZ files and PNG "
        "figures to --output.",
    )
    p.add_argument(
        "--output",
        default="demo-output",
        metavar="DIR",
        help="folder for the files and figures (default: demo-output)",
    )
    p.add_argument("--seed", type=_int_type, default=0, help="scene seed (default: 0)")
    p.add_argument(
        "--size", type=_float_type, default=300.0, help="scene side length in metres (default: 300)"
    )
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    _common(p)
    p.set_defaults(run=_cmd_demo)
    return parser


def _check_common(args: argparse.Namespace) -> None:
    """Checks of the shared options, before any work."""
    width = getattr(args, "profile_width", None)
    if width is not None and not width > 0:
        raise CliError(f"argument --profile-width: must be > 0, got {width:g}")


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``pcl-rg`` with `argv` (default ``sys.argv[1:]``); return the exit status."""
    json_mode = "--json" in (sys.argv[1:] if argv is None else argv)
    if os.environ.get("PCL_RG_TRACEBACK"):  # developers: let exceptions through
        args = build_parser().parse_args(argv)
        _check_common(args)
        run = _Run(args)
        args.run(args, run)
        run.finish()
        return EXIT_OK
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        _check_common(args)
        run = _Run(args)
        args.run(args, run)
        run.finish()
        return EXIT_OK
    except SystemExit as exit_:  # --help and --version
        return exit_.code if isinstance(exit_.code, int) else EXIT_USAGE
    except CliError as error:
        return _fail(str(error), error.code, json_mode)
    except KeyboardInterrupt:
        return _fail("interrupted", EXIT_INTERRUPTED, json_mode)
    except (ValueError, TypeError) as error:
        # Bad input files and parameters; the message names the file or argument.
        return _fail(str(error), EXIT_USAGE, json_mode)
    except OSError as error:
        where = f" {error.filename!r}" if error.filename else ""
        return _fail(f"cannot access{where}: {error.strerror or error}", EXIT_USAGE, json_mode)
    except (ImportError, MemoryError, RuntimeError) as error:
        # Missing optional dependency, or a failure inside the compiled core.
        return _fail(f"{type(error).__name__}: {error}", EXIT_FAILURE, json_mode)
    except Exception as error:  # a bug: one line here, the traceback on request
        return _fail(
            f"internal error: {type(error).__name__}: {error} (run with PCL_RG_TRACEBACK=1 "
            "for the traceback, and please report it)",
            EXIT_FAILURE,
            json_mode,
        )


def _fail(message: str, code: int, json_mode: bool) -> int:
    line = " ".join(message.split())  # one line, whatever the message held
    print(f"pcl-rg: error: {line}", file=sys.stderr)
    if json_mode:
        print(json.dumps({"error": line, "exit_status": code}))
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
