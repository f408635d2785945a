"""Input gate shared by every public function: points, parameters, dataclass glue."""

from __future__ import annotations

import dataclasses
import math
import numbers
from typing import Any, TypeVar

import numpy as np
import numpy.typing as npt

__all__ = [
    "MAX_POINTS_INT32",
    "MAX_POINTS_UINT32",
    "as_points",
    "check_int",
    "check_float",
    "fill_core_params",
    "resolve_params",
    "per_axis",
]

P = TypeVar("P")
C = TypeVar("C")


# Largest clouds the core's index types can number: point ids are uint32 in the
# k-NN index, the radix sort and VoxelGrid; labels and triangle/vertex ids are int32.
MAX_POINTS_UINT32 = 2**32 - 1
MAX_POINTS_INT32 = 2**31 - 1


def as_points(
    points: npt.ArrayLike, name: str = "points", *, max_points: int = MAX_POINTS_INT32
) -> np.ndarray:
    """Return `points` as a C-contiguous float64 (N, 3) array, or raise.

    Accepts any real float or integer array-like of shape (N, 3) in C or F
    order. The input is never modified (a copy is made only when needed).
    `max_points` is the caller's index-type limit, checked before any copy.

    Raises
    ------
    TypeError
        For complex, boolean, object, string or other non-numeric dtypes.
    ValueError
        For a wrong shape, more than `max_points` rows, or non-finite values
        (the count and first indices are named).
    """
    array = np.asarray(points)
    kind = array.dtype.kind
    if kind not in "fiu":
        raise TypeError(
            f"{name} must be a real float or integer array, got dtype {array.dtype}"
        )
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {array.shape}")
    if array.shape[0] > max_points:
        index_type = "uint32" if max_points == MAX_POINTS_UINT32 else "int32"
        raise ValueError(
            f"{name}: at most {max_points:,} points are supported (the core numbers points "
            f"with {index_type}), got {array.shape[0]:,}; split the cloud into tiles"
        )
    array = np.ascontiguousarray(array, dtype=np.float64)
    if not np.isfinite(array).all():  # one pass in the common, clean case
        bad = np.flatnonzero(~np.isfinite(array).all(axis=1))
        first = ", ".join(str(i) for i in bad[:5])
        more = ", ..." if bad.size > 5 else ""
        raise ValueError(
            f"{name} has {bad.size} point(s) with NaN or Inf coordinates "
            f"(rows {first}{more}); drop or fill them first"
        )
    return array


def check_int(name: str, value: Any, *, minimum: int | None = None) -> int:
    """Return `value` as int if it is an integral number >= minimum, else raise."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    value = int(value)
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    return value


def check_float(
    name: str,
    value: Any,
    *,
    minimum: float | None = None,
    positive: bool = False,
    maximum: float | None = None,
) -> float:
    """Return `value` as a finite float within the bounds, else raise."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")
    if positive and value <= 0:
        raise ValueError(f"{name} must be > 0, got {value}")
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ValueError(f"{name} must be <= {maximum}, got {value}")
    return value


def per_axis(name: str, value: Any, axes: int = 3) -> tuple[float, ...]:
    """A positive scalar or sequence of `axes` positive numbers, as a tuple of floats."""
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be a real number or {axes} numbers, got {value!r}")
    if isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
        values = (value,) * axes
    else:
        try:
            values = tuple(np.asarray(value).ravel().tolist())
        except Exception:  # pragma: no cover - exotic objects
            raise TypeError(f"{name} must be a number or {axes} numbers, got {value!r}") from None
        if len(values) != axes or np.asarray(value).ndim != 1:
            raise ValueError(f"{name} must be a number or a sequence of {axes}, got {value!r}")
    return tuple(check_float(name, v, positive=True) for v in values)


def resolve_params(cls: type[P], params: P | None, **overrides: Any) -> P:
    """`params` (or the defaults of `cls`) with every non-None keyword applied."""
    if params is not None and not isinstance(params, cls):
        raise TypeError(f"params must be a {cls.__name__}, got {type(params).__name__}")
    given = {k: v for k, v in overrides.items() if v is not None}
    if params is None:
        return cls(**given)
    return dataclasses.replace(params, **given) if given else params


def fill_core_params(params: Any, core: C) -> C:
    """Copy every field of a Params dataclass onto its C++ struct `core` and return it.

    Field names match by construction (tests/test_params.py holds them to it);
    tuples become lists for std::array fields, and a string naming a member of a
    C++ enum becomes that member.
    """
    for field in dataclasses.fields(params):
        value = getattr(params, field.name)
        if isinstance(value, tuple):
            value = list(value)
        elif isinstance(value, str):
            value = type(getattr(core, field.name)).__members__[value]
        setattr(core, field.name, value)
    return core
