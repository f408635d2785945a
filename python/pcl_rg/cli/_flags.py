"""Flags from parameter dataclasses: one flag per field, parsed back into params objects.

Help text, type, unit and default come from the dataclass (``pcl_rg._params.param``);
fields of a nested dataclass become ``--outer-inner``; a bool field is
``--x/--no-x``; a per-axis field takes ``X`` or ``X,Y[,Z]``. The flags' own
defaults are None ("not given"): the dataclass applies its defaults, and its
``__post_init__`` checks become ``pcl-rg: error: argument --flag: ...`` lines.
Nothing here reads files or runs algorithms.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import inspect
import math
import os
import sys
import typing
from collections.abc import Callable, Iterator
from typing import Any

__all__ = [
    "EXIT_FAILURE",
    "EXIT_INTERRUPTED",
    "EXIT_TERMINATED",
    "EXIT_OK",
    "EXIT_USAGE",
    "CliError",
    "Flag",
    "Method",
    "Parser",
    "add_method_flags",
    "add_param_flags",
    "add_preset_option",
    "float_type",
    "int_type",
    "keyword_params",
    "line_type",
    "method_params",
    "method_summaries",
    "params_dict",
    "params_dict_deep",
    "params_from_args",
    "print_out",
    "show",
]

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 128 + 15  # SIGTERM, as a shell reports a process it ended


def print_out(text: str) -> None:
    """Print to standard output. A reader that went away (``| head -1``) ends nothing:
    what is left to say is dropped, also by Python's flush at exit, which would fail."""
    try:
        print(text)
    except BrokenPipeError:
        with contextlib.suppress(OSError, ValueError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


class CliError(Exception):
    """An error reported as one ``pcl-rg: error: ...`` line."""

    def __init__(self, message: str, code: int = EXIT_USAGE) -> None:
        super().__init__(message)
        self.code = code


class Parser(argparse.ArgumentParser):
    """argparse that raises instead of printing usage and exiting on errors."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)  # --profile must not match --profile-line
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> typing.NoReturn:
        where = self.prog.split(" ", 1)[1] + ": " if " " in self.prog else ""
        raise CliError(f"{where}{message} (see '{self.prog} --help')")


class Flag(typing.NamedTuple):
    path: tuple[str, ...]  # dataclass field names, outer to inner (nested params)
    flag: str  # --field-name, or --outer-inner for a nested dataclass
    dest: str
    methods: tuple[str, ...]  # methods whose params class has the field

    @property
    def name(self) -> str:
        return self.path[-1]


def _kind(annotation: Any) -> tuple[str, Any]:
    """(kind, detail) of a field type: int, float, bool, str, choice, axes."""
    others = [a for a in typing.get_args(annotation) if a is not type(None)]
    if len(others) == 1 and len(typing.get_args(annotation)) == 2:
        annotation = others[0]  # an optional parameter: None is its default, "unset"
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


def _numbers(text: str) -> tuple[float, ...]:
    tokens = [t for t in text.replace(",", " ").split() if t]
    try:
        return tuple(_number(t) for t in tokens)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid number in {text!r}") from None


def _axes_type(n: int | None) -> Callable[[str], float | tuple[float, ...]]:
    def parse(text: str) -> float | tuple[float, ...]:
        values = _numbers(text)
        if len(values) == 1:
            return values[0]
        if n is not None and len(values) != n:
            raise argparse.ArgumentTypeError(
                f"expected 1 or {n} comma-separated numbers, got {len(values)} in {text!r}"
            )
        return values

    parse.__name__ = "numbers"
    return parse


def line_type(text: str) -> tuple[float, float, float, float]:
    """X0,Y0,X1,Y1: the ends of a line (``--profile-line``)."""
    values = _numbers(text)
    if len(values) != 4:
        raise argparse.ArgumentTypeError(
            f"expected 4 numbers X0,Y0,X1,Y1, got {len(values)} in {text!r}"
        )
    return values  # type: ignore[return-value]


def float_type(text: str) -> float:
    try:
        return _number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid number: {text!r}") from None


def int_type(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid integer: {text!r}") from None


def show(value: Any) -> str:
    """A default as typed on the command line: 30,30 for a tuple, 0.5 for a float."""
    if isinstance(value, tuple):
        return ",".join(show(v) for v in value)
    if isinstance(value, float):
        return f"{value:g}"
    if value is None:
        return "unset"
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
            yield prefix + (f.name,), hints[f.name], default, _help_with_unit(f)


def _help_with_unit(f: dataclasses.Field[Any]) -> str:
    """The field's help text, with its unit from the parameter declaration."""
    from .._params import unit_of

    text, unit = f.metadata.get("help", ""), unit_of(f)
    return f"{text} [{unit}]" if unit else text


def add_param_flags(
    parser: argparse.ArgumentParser, title: str, classes: dict[str, type]
) -> list[Flag]:
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
        shown = {m: show(d) for m, d in defaults.items() if d is not dataclasses.MISSING}
        if missing and not shown and path[0] in optional_off:
            text += f" (for the {path[0]} stage; without it, the description says what runs)"
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
            options.update(type=int_type, metavar="N")
        elif kind == "float":
            options.update(type=float_type, metavar="X")
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
        flags.append(Flag(path, flag, dest, tuple(per_method)))
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
            flags.append(Flag((f.name, ""), flag, f"param_skip__{f.name}", tuple(classes)))
    return flags


def add_preset_option(parser: argparse.ArgumentParser, classes: dict[str, type]) -> None:
    """``--preset NAME`` when a params class has presets (``pcl_rg._params.preset``)."""
    from .._params import presets

    names = {m: list(presets(cls)) for m, cls in classes.items()}
    if not any(names.values()):
        return
    several = len(classes) > 1
    listed = "; ".join(f"{m}: {', '.join(n) or 'none'}" for m, n in names.items())
    parser.add_argument(
        "--preset",
        metavar="NAME",
        help="start from a named parameter set"
        + (f" of the --method ({listed})" if several else f" ({listed.split(': ', 1)[1]})")
        + "; the flags given override single fields (default: the dataclass defaults)",
    )


def _preset(args: argparse.Namespace, method: str, cls: type) -> Any:
    """The params object of ``--preset`` for `method`, or None when none was given."""
    name = getattr(args, "preset", None)
    if name is None:
        return None
    from .._params import presets

    found = presets(cls)
    if name not in found:
        valid = ", ".join(found) or "none"
        where = f" for --method {method}" if getattr(args, "methods", None) else ""
        raise CliError(f"argument --preset: unknown preset {name!r}{where} (valid: {valid})")
    return found[name]()


def params_from_args(args: argparse.Namespace, flags: list[Flag], method: str, cls: type) -> Any:
    """The params object of `method` from ``--preset`` and the flags given.

    A flag of another method is an error; the flags given override single
    fields of the preset (or of the defaults).
    """
    given: dict[tuple[str, ...], Any] = {}
    for f in flags:
        value = getattr(args, f.dest)
        if value is None or (f.path[-1] == "" and value is False):
            continue
        if method not in f.methods:
            raise CliError(f"{f.flag} does not apply to --method {method}")
        given[f.path] = value
    return _build(cls, given, flags, (), _preset(args, method, cls))


def _build(
    cls: type,
    given: dict[tuple[str, ...], Any],
    flags: list[Flag],
    prefix: tuple[str, ...],
    base: Any = None,
) -> Any:
    """cls from the given leaves under `prefix`; the rest from `base` or the defaults.

    A nested dataclass field is rebuilt from its default (or `base`'s) value
    with the given leaves replaced, so the outer class's own default stays.
    """
    mine = [f for f in flags if f.path[: len(prefix)] == prefix]
    values: dict[str, Any] = {} if base is None else params_dict(base)
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


def _construct(cls: type, values: dict[str, Any], flags: list[Flag]) -> Any:
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


def _flag_message(message: str, flags: list[Flag]) -> str:
    for f in sorted(flags, key=lambda f: -len(f.name)):
        if message.startswith(f.name + " ") or message.startswith(f.name + ":"):
            return f"argument {f.flag}: {message}"
    return message


def params_dict(params: Any) -> dict[str, Any]:
    return {f.name: getattr(params, f.name) for f in dataclasses.fields(params)}


def params_dict_deep(params: Any) -> Any:
    """A params object as nested dicts (nested params objects included)."""
    if dataclasses.is_dataclass(params):
        return {
            f.name: params_dict_deep(getattr(params, f.name)) for f in dataclasses.fields(params)
        }
    return params


def keyword_params(function: Callable[..., Any], name: str) -> type:
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


class Method(typing.NamedTuple):
    """One algorithm of a subcommand with several (``--method NAME``)."""

    name: str
    function: Callable[..., Any]
    params: type
    summary: str


def add_method_flags(
    parser: argparse.ArgumentParser, title: str, what: str, methods: dict[str, Method]
) -> None:
    """``--method``, ``--preset`` and every params field of `methods` as flags.

    The parser's defaults get ``methods`` and ``flags``, which
    :func:`method_params` reads back.
    """
    first = next(iter(methods))
    parser.add_argument(
        "--method", choices=list(methods), default=first, help=f"{what} (default: {first})"
    )
    classes = {m.name: m.params for m in methods.values()}
    add_preset_option(parser, classes)
    flags = add_param_flags(parser, title, classes)
    parser.set_defaults(flags=flags, methods=methods)


def method_summaries(methods: dict[str, Method]) -> str:
    """ "Methods: a: ...; b: ...." for a command's description."""
    return "Methods: " + "; ".join(f"{m.name}: {m.summary}" for m in methods.values()) + "."


def method_params(args: argparse.Namespace) -> tuple[Method, Any]:
    """The method chosen with ``--method`` and its params object."""
    method = args.methods[args.method]
    return method, params_from_args(args, args.flags, method.name, method.params)
