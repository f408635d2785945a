"""Docstring entries that every algorithm shares, written once.

A line of a docstring that holds only ``%(name)s`` is replaced by the entry
``name``, indented as that line was (the convention of SciPy's ``doccer``). The
entries describe what :func:`pcl_rg._validation.as_points` and
:func:`pcl_rg._params.resolve` do for every function, so they are worded there
once instead of in each docstring.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from typing import TypeVar

__all__ = ["ENTRIES", "fill_docstring"]

ENTRIES = {
    "points": """\
points : array_like, shape (N, 3)
    Coordinates in metres (any real float or integer dtype, C or F order).
    Read in place when float64 and C-ordered: no other thread may write to it
    during the call.""",
    # {params_type} is the function's own annotation of `params`, without "| None".
    "params": """\
params : {params_type}, optional
    All parameters at once; keywords given explicitly override it. A keyword
    given as None leaves the field as `params` has it: to unset a field that
    may be None, ``dataclasses.replace(params, name=None)``.""",
    "points_value_error": """\
ValueError
    Non-finite points or a wrong shape.""",
    "type_error": """\
TypeError
    Non-numeric points or parameters of the wrong type.""",
    # The k-nearest-neighbour steps' float32 frame (points.hpp, float32_frame).
    "far_points_value_error": """\
ValueError
    More than 1 % of the points (and more than one) far from the rest (see
    Notes): a cloud too wide for one float32 frame, to be split into tiles.""",
    # Both ground filters' final pass (final_pass.cpp, final_pass_low.cpp).
    "final_low_depth": """\
final_low_depth : float, optional
    Metres (default 2, the isprs preset's: the preset's search picks it on the
    ISPRS samples; left one sample out it lowers tin_ground's error, 4.19 to
    3.97 %, and leaves grid_ground's, 4.02 to 4.03 %; 0: off). With the final
    pass, a ground point more than this below the median of the lowest ground
    heights of a window of 7 x 7 final cells around its own gives no TIN
    vertex, so a patch of low points (multipath echoes, which vouch for each
    other in the low-outlier tests) pulls no surface down to it; its points,
    more than ``final_below`` below the TIN, are then no ground. The window
    takes every k-th cell, the least k >= 1 for which its 6k + 1 cells span
    14 m, so it spans 14-24 m whatever the final cell (tin_ground's follows
    the point spacing; k is 1 at 2 m and above). It works while the patch,
    with the ring of terrain the densification may leave as object around
    it, covers less than half of the window's cells
    (``benchmarks/studies/ground_low_patches.py``), and not near the cloud's
    edge, where the window is cut off. The bottom of a
    real ditch narrower than about half the window, or of a pit up to about
    two thirds of it across, deeper than ``final_below``, is lost the same
    way.""",
    "far_points": """\
Far points: the neighbour search runs in float32, relative to a float64
local origin (the minimum corner, stray points far below left out). A point
more than 2^24 x 0.1 = 1677721.6 m from that origin on some axis, where
float32 resolves no better than 0.125 m, is far: a stray point such as a bad
GPS fix, or a record at (0, 0, 0) in a UTM tile. Up to 1 % of the points (at
least one) may be far. They are left out: the other points get the result
of the cloud without them, and each far point gets that of a point without
neighbours. A call that leaves any out warns with their count
(:class:`pcl_rg.FarPointsWarning`), and its diagnostics record it as
``far_points``.""",
}

Function = TypeVar("Function", bound=Callable)
_PLACEHOLDER = re.compile(r"^(?P<indent>[ \t]*)%\((?P<name>\w+)\)s[ \t]*$", re.M)


def fill_docstring(function: Function, entries: Mapping[str, str] = ENTRIES) -> Function:
    """Replace each ``%(name)s`` line of ``function.__doc__`` by ``entries[name]``."""

    params_type = str(function.__annotations__.get("params", "")).removesuffix(" | None")

    def entry(match: re.Match[str]) -> str:
        indent = match.group("indent")
        text = entries[match.group("name")].replace("{params_type}", params_type)
        return "\n".join(indent + line for line in text.splitlines())

    if function.__doc__:
        function.__doc__ = _PLACEHOLDER.sub(entry, function.__doc__)
    return function
