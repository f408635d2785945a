"""The final pass's five settings, declared once for both ground filters.

The pass itself is C++ (``cpp/src/final_pass.cpp``, NumPy reference
``reference/_final_pass.py``); :class:`GridGroundParams` and
:class:`TinGroundParams` carry its settings as fields named ``final_<name>``,
each filter with its own defaults.
"""

from __future__ import annotations

from typing import Any

from ._params import param, spacing_length

__all__ = ["final_pass_param"]

_HELP = {
    "final_cell": "final pass (0: off): every point is classified again by its height above "
    "a TIN of the lowest ground point of each final_cell cell (TerraScan's distance to the "
    "ground TIN)",
    "final_above": "final pass: height above the TIN up to which a point is ground on flat terrain",
    "final_below": "final pass: depth below the TIN down to which a point is ground",
    "final_slope": "final pass: allowance per unit of the TIN's gradient, added to "
    "final_above (slope-adaptive threshold after Zhao et al. 2016)",
    "final_low_depth": "final pass (0: off): a ground point more than this below the median "
    "of the lowest ground heights of 7 x 7 final cells around its own (every k-th cell, "
    "spanning at least 14 m) gives no TIN vertex, so a patch of low points (multipath) "
    "pulls no surface down to it",
}


def final_pass_param(name: str, default: float | None, optional: bool = False) -> Any:
    """The dataclass field of the final-pass setting `name` (m, >= 0) with `default`.

    `optional`: None ("unset") is admitted too, the filter then takes the length from
    the point spacing (tin_ground's final_cell).
    """
    if optional:
        return spacing_length(minimum=0.0, help=_HELP[name] + "; unset: from the point spacing")
    return param(default, minimum=0.0, unit="m", help=_HELP[name])
