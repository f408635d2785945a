"""Parameter sets whose lengths follow the point spacing, for the ISPRS searches.

A search candidate is a filter's frozen params plus, per length that scales, its
multiple of the point spacing (pcl_rg.point_spacing of the points it runs on). The
studies (tin_isprs_params.py, ground_isprs.py, ground_isprs_cv.py) search fixed
fields and multiples in one coordinate descent (_common.coordinate_descent with
replace=Scaled.replace): a grid key "name" sets a field in metres, "name/spacing" a
multiple of the spacing.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import pcl_rg
from pcl_rg.evaluation import ground_errors

#: Suffix of a grid key that sets a length as a multiple of the point spacing.
PER_SPACING = "/spacing"


@dataclasses.dataclass(frozen=True)
class Scaled:
    """`params` with the lengths named in `multiples` set from the spacing of the points.

    Hashable, so the searches can cache scores.
    """

    params: Any
    multiples: tuple[tuple[str, float], ...] = ()

    def resolve(self, spacing: float) -> Any:
        """The params a call uses on points of this spacing (m; NaN: 1 m, as the core)."""
        if not math.isfinite(spacing):
            spacing = 1.0
        multiples = dict(self.multiples)
        params = self.params
        if "cell_size" in multiples:  # whole cells per block: GridGroundParams.at_spacing
            params = dataclasses.replace(params, cell_size=None).at_spacing(
                spacing, {"cell_size": multiples.pop("cell_size")}
            )
        values = {name: multiple * spacing for name, multiple in multiples.items()}
        return dataclasses.replace(params, **values)

    def run(self, function, points):
        """`function` (pcl_rg.tin_ground or grid_ground) on `points` with this setting."""
        return function(points, params=self.resolve(pcl_rg.point_spacing(points)))

    def replace(self, name: str, value: Any) -> Scaled:
        """A copy with `name` (a field in metres) or `name/spacing` (a multiple) set."""
        multiples = dict(self.multiples)
        if name.endswith(PER_SPACING):
            multiples[name[: -len(PER_SPACING)]] = value
            params = self.params
        else:
            multiples.pop(name, None)
            params = dataclasses.replace(self.params, **{name: value})
        return Scaled(params, tuple(sorted(multiples.items())))

    def describe(self, preset: Scaled | None = None) -> str:
        """name=value of the fields (and multiples) unlike `preset`'s (all when None)."""
        scaled = dict(self.multiples)
        other = dict(preset.multiples) if preset is not None else {}
        parts = []
        for field in dataclasses.fields(self.params):
            name = field.name
            if name in scaled:
                if preset is None or other.get(name) != scaled[name]:
                    parts.append(f"{name}={scaled[name]:g} x spacing")
                continue
            value = getattr(self.params, name)
            if preset is None or name in other or getattr(preset.params, name) != value:
                parts.append(f"{name}={value}")
        return ", ".join(parts) or "= preset"


# (filter, sample, params used) -> errors, and sample -> spacing: a search meets the
# same set many times, and the cross-validation scores the searches' picks again.
_ERRORS: dict = {}
_SPACINGS: dict = {}


def sample_errors(function, samples: dict, setting) -> list:
    """Ground errors of `function` (pcl_rg.tin_ground or grid_ground) with `setting` (a
    Scaled, or params run as given) on each of `samples` (name -> (points, truth)),
    computed once per sample and resolved params."""
    if not isinstance(setting, Scaled):
        setting = Scaled(setting)
    out = []
    for name, (points, truth) in samples.items():
        if name not in _SPACINGS:
            _SPACINGS[name] = pcl_rg.point_spacing(points)
        params = setting.resolve(_SPACINGS[name])
        key = (function.__name__, name, params)
        if key not in _ERRORS:
            _ERRORS[key] = ground_errors(truth, function(points, params=params))
        out.append(_ERRORS[key])
    return out
