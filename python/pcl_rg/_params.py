"""Parameter declarations: the one Python source of every algorithm parameter.

Each parameter is a field of a frozen dataclass made with :func:`param`, which
carries its default, unit, bounds and help text. From that one declaration come:

- the checks of ``__post_init__`` (:func:`check_fields`), worded like the C++
  ``validate`` (``"<name> must be <rule>, got <value>"``; tests/test_params.py
  holds the two layers to the same values and words);
- the command line's flags, units and help (pcl_rg.cli);
- the copy onto the C++ struct (:func:`to_core`);
- named presets (:func:`preset`, :func:`presets`), reached as classmethods such as
  ``TinGroundParams.isprs()`` and by ``pcl-rg ground --preset isprs``.

The public functions' keyword lists, the references' signatures and the docstrings'
parameter lists are written out for readers and type checkers, and
tests/test_signatures.py holds each of them equal to the dataclass fields.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import warnings
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

import numpy as np

__all__ = [
    "Spec",
    "check_fields",
    "deprecated_preset",
    "format_value",
    "param",
    "preset",
    "presets",
    "resolve",
    "spacing_length",
    "spec_of",
    "to_core",
    "unit_of",
]

P = TypeVar("P")
C = TypeVar("C")
_SPEC = "pcl_rg.spec"


@dataclasses.dataclass(frozen=True)
class Spec:
    """What a parameter is: its kind, unit, bounds and help text."""

    kind: type
    """float, int, bool or str; a tuple of `axes` floats when `axes` is set."""
    help: str
    unit: str = ""
    minimum: float | None = None
    """Inclusive lower bound."""
    above: float | None = None
    """Exclusive lower bound."""
    maximum: float | None = None
    """Inclusive upper bound."""
    below: float | None = None
    """Exclusive upper bound."""
    choices: tuple[str, ...] | None = None
    axes: int | None = None
    """Number of per-axis values; one number is broadcast to all of them."""
    bits: int = 64
    """Width of the C++ signed integer an int parameter is stored in."""
    optional: bool = False
    """None is a value too: "unset" (a std::optional in C++), filled in by the algorithm."""

    def rule(self) -> str:
        """The bounds in words, the same words the C++ checks use."""
        if self.choices is not None:
            return "one of " + ", ".join(self.choices)
        low = high = None
        if self.above is not None:
            low = ("(", self.above)
        elif self.minimum is not None:
            low = ("[", self.minimum)
        if self.below is not None:
            high = (")", self.below)
        elif self.maximum is not None:
            high = ("]", self.maximum)
        if low and high:
            return f"in {low[0]}{format_value(low[1])}, {format_value(high[1])}{high[0]}"
        if low:
            return f"{'>' if low[0] == '(' else '>='} {format_value(low[1])}"
        if high:
            return f"{'<' if high[0] == ')' else '<='} {format_value(high[1])}"
        return ""

    def admits(self, value: float) -> bool:
        return (
            (self.minimum is None or value >= self.minimum)
            and (self.above is None or value > self.above)
            and (self.maximum is None or value <= self.maximum)
            and (self.below is None or value < self.below)
        )


def param(
    default: Any = dataclasses.MISSING,
    *,
    help: str,
    unit: str = "",
    minimum: float | None = None,
    above: float | None = None,
    maximum: float | None = None,
    below: float | None = None,
    choices: tuple[str, ...] | None = None,
    axes: int | None = None,
    kind: type | None = None,
    bits: int = 64,
    optional: bool = False,
) -> Any:
    """A dataclass field declaring one parameter (see the module docstring).

    `kind` defaults to the type of `default` (float for per-axis values). With
    `optional`, None is admitted as "unset" (the C++ field is a std::optional); the
    docstring of the field says what the algorithm then uses.
    """
    if kind is None:
        if axes is not None:
            kind = float
        elif default is dataclasses.MISSING or default is None:
            raise TypeError("param() needs kind= when there is no default")
        else:
            kind = type(default)
    spec = Spec(kind, help, unit, minimum, above, maximum, below, choices, axes, bits, optional)
    return dataclasses.field(default=default, metadata={_SPEC: spec, "help": help})


def spacing_length(
    *, help: str, minimum: float | None = None, above: float | None = None, axes: int | None = None
) -> Any:
    """A length parameter (m) that is unset (None) by default.

    When it is left unset the algorithm takes it from the measured point spacing
    (:func:`pcl_rg.point_spacing`); `help` ends by saying how.
    """
    bounds = {"minimum": minimum, "above": above, "axes": axes}
    return param(None, kind=float, optional=True, unit="m", help=help, **bounds)


def spec_of(field: dataclasses.Field[Any]) -> Spec:
    """The :class:`Spec` a field was declared with."""
    return field.metadata[_SPEC]


def unit_of(field: dataclasses.Field[Any]) -> str:
    """The unit a field was declared with ("" when none, or not a :func:`param`)."""
    spec = field.metadata.get(_SPEC)
    return spec.unit if spec is not None else ""


def format_value(value: Any) -> str:
    """A number as the C++ checks print it: shortest round-trip, no trailing ``.0``."""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value)).lower()
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        text = repr(float(value))
        return text[:-2] if text.endswith(".0") else text
    if isinstance(value, (tuple, list)):
        return "(" + ", ".join(format_value(v) for v in value) + ")"
    return repr(value)


def _number(name: str, value: Any, spec: Spec) -> Any:
    """One scalar of kind float or int, checked against the bounds."""
    if spec.kind is int:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
            raise TypeError(f"{name} must be an integer, got {value!r}")
        value = int(value)
        if abs(value) >= 2 ** (spec.bits - 1):  # the C++ field's width, not a bound
            raise ValueError(f"{name} must fit a {spec.bits}-bit integer, got {value}")
    else:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
            raise TypeError(f"{name} must be a real number, got {value!r}")
        try:
            value = float(value)
        except OverflowError:  # an int beyond float64's range (10**400)
            raise ValueError(
                f"{name} must be finite, got an integer of {value.bit_length()} bits"
            ) from None
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {format_value(value)}")
    if not spec.admits(value):
        raise ValueError(f"{name} must be {spec.rule()}, got {format_value(value)}")
    return value


def _per_axis(name: str, value: Any, spec: Spec) -> tuple[float, ...]:
    axes = spec.axes or 1
    # True is not a length, also inside a sequence (where np.asarray would make it 1.0).
    flags = (str, bytes, bool, np.bool_)
    if isinstance(value, flags) or (
        isinstance(value, (list, tuple)) and any(isinstance(v, flags) for v in value)
    ):
        raise TypeError(f"{name} must be a number or {axes} numbers, got {value!r}")
    if np.ma.is_masked(value):  # np.asarray drops the mask: a hidden value would be used
        raise ValueError(f"{name}: masked values are not accepted, got {value!r}")
    if isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
        values: tuple[Any, ...] = (value,) * axes
    else:
        try:
            array = np.asarray(value)
            values = tuple(array.ravel().tolist())
        except Exception:  # pragma: no cover - exotic objects
            raise TypeError(f"{name} must be a number or {axes} numbers, got {value!r}") from None
        if array.ndim == 0 and array.dtype.kind in "iuf":  # a 0-d array: one number
            values = (array.item(),) * axes
        elif array.ndim == 0:  # one value of no real number type (a Decimal, an object)
            raise TypeError(f"{name} must be a number or {axes} numbers, got {value!r}")
        elif len(values) != axes or array.ndim != 1:
            raise ValueError(f"{name} must be a number or a sequence of {axes}, got {value!r}")
    return tuple(_number(name, v, spec) for v in values)


def check_value(name: str, value: Any, spec: Spec) -> Any:
    """`value` converted to the parameter's kind, or TypeError/ValueError."""
    if value is None and spec.optional:
        return None
    if spec.axes is not None:
        return _per_axis(name, value, spec)
    if spec.kind is bool:
        if not isinstance(value, (bool, np.bool_)):
            raise TypeError(f"{name} must be True or False, got {value!r}")
        return bool(value)
    if spec.kind is str:
        if not isinstance(value, str):
            raise TypeError(f"{name} must be a str, got {value!r}")
        if spec.choices and value not in spec.choices:
            raise ValueError(f"{name} must be {spec.rule()}, got {value!r}")
        return value
    return _number(name, value, spec)


def check_number(
    name: str,
    value: Any,
    kind: type[int] | type[float],
    *,
    minimum: float | None = None,
    above: float | None = None,
    maximum: float | None = None,
) -> Any:
    """A plain argument (not a dataclass field) checked as a parameter would be."""
    return _number(name, value, Spec(kind, "", "", minimum, above, maximum, None, None, None))


def check_flag(name: str, value: Any) -> bool:
    """A plain True/False argument (not a dataclass field), or TypeError."""
    return check_value(name, value, Spec(bool, ""))


def check_fields(params: Any) -> None:
    """Check and normalise every field of a frozen params dataclass in place."""
    for field in dataclasses.fields(params):
        value = check_value(field.name, getattr(params, field.name), spec_of(field))
        object.__setattr__(params, field.name, value)


def resolve(cls: type[P], params: P | None, **overrides: Any) -> P:
    """`params` (or the defaults of `cls`) with every non-None keyword applied."""
    if params is not None and not isinstance(params, cls):
        raise TypeError(f"params must be a {cls.__name__}, got {type(params).__name__}")
    given = {k: v for k, v in overrides.items() if v is not None}
    if params is None:
        return cls(**given)
    return dataclasses.replace(params, **given) if given else params


def resolve_arguments(cls: type[P], arguments: Mapping[str, Any]) -> P:
    """:func:`resolve` for a public function, given its ``locals()`` on entry.

    Those hold ``params`` and one keyword per field of `cls` (tests/test_signatures.py
    holds every signature to that), so the body does not name each parameter again.
    """
    fields = dataclasses.fields(cls)  # type: ignore[arg-type]
    return resolve(cls, arguments["params"], **{f.name: arguments[f.name] for f in fields})


def to_core(params: Any, core: C) -> C:
    """Copy every field of a params dataclass onto its C++ struct `core` and return it.

    Field names match by construction (tests/test_params.py); tuples become lists
    for std::array fields, and a string naming a member of a C++ enum becomes
    that member.
    """
    for field in dataclasses.fields(params):
        value = getattr(params, field.name)
        if isinstance(value, tuple):
            value = list(value)
        elif isinstance(value, str):
            value = type(getattr(core, field.name)).__members__[value]
        setattr(core, field.name, value)
    return core


def preset(method: Callable[[type[P]], P]) -> classmethod:  # type: ignore[type-arg]
    """Mark a classmethod as a named preset (its name is the preset's name)."""
    method.__pcl_rg_preset__ = True  # type: ignore[attr-defined]
    return classmethod(method)


def presets(cls: type[P]) -> dict[str, Callable[[], P]]:
    """The named presets of a params class, by name, in declaration order."""
    found = {}
    for name, attribute in vars(cls).items():
        if isinstance(attribute, classmethod) and getattr(
            attribute.__func__, "__pcl_rg_preset__", False
        ):
            found[name] = getattr(cls, name)
    return found


def deprecated_preset(old: str, new: str) -> classmethod:  # type: ignore[type-arg]
    """A classmethod `old` that warns and returns the preset `new`."""

    def alias(cls: type[P], **overrides: Any) -> P:
        warnings.warn(
            f"{cls.__name__}.{old}() is deprecated; use {cls.__name__}.{new}()",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(cls, new)(**overrides)

    alias.__name__ = old
    alias.__doc__ = f"Deprecated alias of :meth:`{new}`."
    return classmethod(alias)
