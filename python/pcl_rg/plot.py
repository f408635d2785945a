"""Pictures of point clouds: top views and vertical profiles, to PNG (matplotlib).

Needs the optional extra ``plot`` (``pip install 'pcl_rg[plot]'``); matplotlib is
imported only when a figure is drawn, with the non-interactive Agg backend.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from ._docstrings import Function, fill_docstring
from ._params import check_number
from ._validation import as_points, as_real

__all__ = ["CLASS_COLOURS", "profile", "segment_colours", "top_view"]

# ASPRS classes as used in pcl_rg's outputs and synthetic scenes, and the common
# others a file kept with --keep-classes may hold.
CLASS_COLOURS: dict[int, tuple[str, str]] = {
    0: ("never classified", "#7f7f7f"),
    1: ("unclassified / object", "#d62728"),
    2: ("ground", "#8c6d31"),
    3: ("low vegetation", "#98df8a"),
    4: ("medium vegetation", "#5ab65a"),
    5: ("vegetation", "#2ca02c"),
    6: ("building", "#1f77b4"),
    7: ("noise", "#e377c2"),
    9: ("water", "#17becf"),
    17: ("bridge deck", "#ff7f0e"),
    18: ("high noise", "#f7b6d2"),
}

# Classes without a colour of their own take one of these by their code, the same in
# every figure: none is a listed class's (eight and more of them share some).
_OTHER_CLASS_COLOURS = ("#9467bd", "#bcbd22", "#8c564b", "#393b79", "#e7ba52", "#843c39")

# Categorical colours for segments: Tableau 10 and its light variants (tab20),
# reordered so that consecutive labels (neighbouring regions are often numbered
# close together) get contrasting colours.
_SEGMENT_PALETTE = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#bcbd22",
    "#17becf",
    "#aec7e8",
    "#ffbb78",
    "#98df8a",
    "#ff9896",
    "#c5b0d5",
    "#c49c94",
    "#f7b6d2",
    "#dbdb8d",
    "#9edae5",
    "#393b79",
    "#637939",
)
_UNASSIGNED = "#c7c7c7"


def _pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
    except ImportError as error:  # pragma: no cover - depends on the environment
        raise ImportError("pcl_rg.plot needs matplotlib: pip install 'pcl_rg[plot]'") from error
    return plt


def segment_colours(labels: npt.ArrayLike) -> np.ndarray:
    """RGBA colours (N, 4) for segment labels: a fixed palette by label, grey for -1.

    Parameters
    ----------
    labels : array_like of int, shape (N,)
        Segment per point, negative for unassigned.

    Returns
    -------
    numpy.ndarray
        float64 (N, 4) RGBA in [0, 1]. Label ``l >= 0`` gets colour
        ``l % 20`` of a 20-colour categorical palette (the same label always
        gets the same colour); negative labels are light grey.

    Examples
    --------
    >>> from pcl_rg.plot import segment_colours
    >>> c = segment_colours([0, 1, -1, 20])
    >>> c.shape, bool((c[0] == c[3]).all()), bool((c[0] == c[1]).all())
    ((4, 4), True, False)
    """
    from matplotlib.colors import to_rgba_array

    values = _integer_labels("labels", labels)
    if values.dtype.kind not in "iu":
        raise TypeError(f"labels must be an integer array, got dtype {values.dtype}")
    if values.ndim != 1:
        raise ValueError(f"labels must be one-dimensional, got shape {values.shape}")
    palette = to_rgba_array(list(_SEGMENT_PALETTE))
    colours = np.empty((values.size, 4))
    flat = values.ravel()
    assigned = flat >= 0
    colours[assigned] = palette[flat[assigned] % len(palette)]
    colours[~assigned] = to_rgba_array([_UNASSIGNED])[0]
    return colours


_PLOT_ENTRIES = {
    "points_and_png": """\
points : array_like, shape (N, 3)
    Coordinates, in `units`.
path : str or path-like
    Output PNG file.""",
    "units": """\
units : str or (str, str), default "m"
    The unit of the coordinates, as the axis labels name it ("m", "ft",
    "US ft"): one for x, y and z, or a pair (x and y, z) when z has its own.""",
    "max_points": """\
max_points : int
    At most this many points are drawn (an even, seeded subsample); the
    legend counts every point all the same.""",
    "labels_type_error": """\
TypeError
    Non-integer `classes` or `segments`.""",
}


def _fill_plot_docstring(function: Function) -> Function:
    return fill_docstring(function, _PLOT_ENTRIES)


def _class_names(given: Mapping[int, tuple[str, str]] | None) -> dict[int, tuple[str, str]]:
    """CLASS_COLOURS updated with `given`, each entry checked before anything is drawn."""
    if given is None:
        return dict(CLASS_COLOURS)
    if not isinstance(given, Mapping):
        raise TypeError(f"class_names must be a mapping, got {type(given).__name__}")
    for code, entry in given.items():
        if not (
            isinstance(code, (int, np.integer))
            and not isinstance(code, bool)
            and isinstance(entry, tuple)
            and len(entry) == 2
            and all(isinstance(text, str) for text in entry)
        ):
            raise TypeError(
                "class_names must map class codes (int) to (label, colour) pairs of str, "
                f"got {code!r}: {entry!r}"
            )
    return {**CLASS_COLOURS, **{int(code): entry for code, entry in given.items()}}


def _integer_labels(name: str, values: npt.ArrayLike) -> np.ndarray:
    """`values` as an array; an empty list as int64 (NumPy makes it float64). A masked
    array is refused: its hidden labels would be drawn."""
    if np.ma.is_masked(values):
        raise ValueError(f"{name}: masked arrays are not accepted; fill or select them first")
    array = np.asarray(values)
    return array.astype(np.int64) if array.size == 0 and array.dtype.kind == "f" else array


def _labels(name: str, values: npt.ArrayLike | None, n: int) -> np.ndarray | None:
    if values is None:
        return None
    array = _integer_labels(name, values)
    if array.dtype.kind not in "iu":
        raise TypeError(f"{name} must be an integer array, got dtype {array.dtype}")
    if array.ndim != 1:  # flattened, an (N/2, 2) array would pass as N labels
        raise ValueError(f"{name} must be one-dimensional, got shape {array.shape}")
    if len(array) != n:
        raise ValueError(f"{name} must have one entry per point ({n}), got {len(array)}")
    return array


def _colouring(
    n: int, max_points: object, classes: npt.ArrayLike | None, segments: npt.ArrayLike | None
) -> tuple[int, np.ndarray | None, np.ndarray | None]:
    """A figure's `max_points`, `classes` and `segments` for n points, checked."""
    max_points = check_number("max_points", max_points, int, minimum=1)
    return max_points, _labels("classes", classes, n), _labels("segments", segments, n)


def _subsample(n: int, max_points: int) -> np.ndarray | None:
    if n <= max_points:
        return None
    return np.sort(np.random.default_rng(0).choice(n, max_points, replace=False))


def _marker_size(n: int, width_in: float, height_in: float) -> float:
    """Marker diameter in points so that n points roughly tile the axes, within [0.5, 4]."""
    area = width_in * height_in * 72.0**2
    return float(np.clip(0.7 * np.sqrt(area / max(n, 1)), 0.5, 4.0))


def _unit_names(units: str | Sequence[str]) -> tuple[str, str]:
    """The unit names of x and y and of z, from `units` as top_view and profile take it."""
    pair = (units, units) if isinstance(units, str) else units
    if (
        not isinstance(pair, (tuple, list))
        or len(pair) != 2
        or not all(isinstance(name, str) and name.strip() for name in pair)
    ):
        raise ValueError(
            f"units must be a unit's name or a pair (x and y, z) of them, got {units!r}"
        )
    return pair[0].strip(), pair[1].strip()


def _draw(ax, fig, u, v, z, classes, segments, names, size, counted=None, z_unit="m"):
    """Draw u, v coloured by class (legend), segment (palette) or z (colour bar).

    Groups of one colour go through ``Axes.plot`` (markers without lines), which
    is several times faster than ``scatter`` for hundreds of thousands of points.
    `counted`, the classes or segments of every point the figure shows when only a
    subsample is drawn, gives the legend's counts (every class in it, drawn or not).
    """
    marker = {"linestyle": "none", "marker": "o", "markersize": size, "markeredgewidth": 0}
    if segments is not None:
        every = segments if counted is None else counted
        unassigned = segments < 0
        ax.plot(
            u[unassigned],
            v[unassigned],
            color=_UNASSIGNED,
            label=f"unassigned ({int((every < 0).sum()):,})",
            **marker,
        )
        slot = np.where(unassigned, -1, segments % len(_SEGMENT_PALETTE))
        for i, colour in enumerate(_SEGMENT_PALETTE):
            sel = slot == i
            if sel.any():
                ax.plot(u[sel], v[sel], color=colour, **marker)
        n_segments = len(np.unique(every[every >= 0]))
        ax.plot(
            [],
            [],
            color=_SEGMENT_PALETTE[0],
            label=f"{n_segments:,} segments (one colour each, repeating)",
            **marker,
        )
        ax.legend(loc="upper right", fontsize=8, markerscale=max(6 / size, 1))
    elif classes is not None:
        # Draw the most common class first so rarer ones stay visible on top.
        codes, counts = np.unique(classes if counted is None else counted, return_counts=True)
        order = np.argsort(-counts, kind="stable")
        for code, count in zip(codes[order], counts[order]):
            sel = classes == code
            other = _OTHER_CLASS_COLOURS[int(code) % len(_OTHER_CLASS_COLOURS)]
            label, colour = names.get(int(code), (f"class {code}", other))
            ax.plot(u[sel], v[sel], color=colour, label=f"{label} ({int(count):,})", **marker)
        if codes.size:  # no point, no legend (matplotlib warns of an empty one)
            ax.legend(markerscale=max(6 / size, 1), loc="upper right", fontsize=8)
    else:
        sc = ax.scatter(u, v, c=z, s=size * size, cmap="viridis", linewidths=0)
        fig.colorbar(sc, ax=ax, label=f"z ({z_unit})", shrink=0.8)


@_fill_plot_docstring
def _save(fig: Any, path: str | os.PathLike[str]) -> None:
    """Save `fig` through a temporary file renamed into place: never a half-drawn file."""
    from .io._atomic import atomic_write

    name = os.fspath(path)
    kind = os.path.splitext(name)[1][1:].lower() or None  # None: matplotlib's default
    atomic_write(name, lambda stream: fig.savefig(stream, format=kind, bbox_inches="tight"))


def top_view(
    points: npt.ArrayLike,
    path: str | os.PathLike,
    *,
    classes: npt.ArrayLike | None = None,
    segments: npt.ArrayLike | None = None,
    class_names: Mapping[int, tuple[str, str]] | None = None,
    title: str = "",
    max_points: int = 400_000,
    units: str | Sequence[str] = "m",
) -> None:
    """Write a top view (x, y) of the points to a PNG file.

    Parameters
    ----------
    %(points_and_png)s
    classes : array_like of int, shape (N,), optional
        A class per point (ASPRS codes, see `CLASS_COLOURS`), drawn in its
        colour with a legend.
    segments : array_like of int, shape (N,), optional
        A segment label per point (-1 for none), drawn with a categorical
        palette (see :func:`segment_colours`); takes precedence over `classes`.
        Without either, points are coloured by height.
    class_names : mapping, optional
        Code -> (label, colour) overriding `CLASS_COLOURS`.
    title : str
        Figure title.
    %(max_points)s
    %(units)s

    Raises
    ------
    ValueError
        Wrong shapes, non-finite points, ``max_points < 1`` or empty `units`.
    %(labels_type_error)s

    Examples
    --------
    >>> import numpy as np, tempfile, os
    >>> from pcl_rg.plot import top_view
    >>> pts = np.random.default_rng(0).uniform(0, 10, (100, 3))
    >>> with tempfile.TemporaryDirectory() as d:
    ...     top_view(pts, os.path.join(d, "v.png"), classes=np.full(100, 2))
    ...     top_view(pts, os.path.join(d, "s.png"), segments=np.arange(100) % 7 - 1)
    ...     os.path.getsize(os.path.join(d, "v.png")) > 0
    True
    """
    xyz = as_points(points)
    max_points, classes, segments = _colouring(len(xyz), max_points, classes, segments)
    xy_unit, z_unit = _unit_names(units)
    plt = _pyplot()
    keep = _subsample(len(xyz), max_points)
    counted = segments if segments is not None else classes  # every point's, for the legend
    if keep is not None:
        xyz = xyz[keep]
        classes = None if classes is None else classes[keep]
        segments = None if segments is None else segments[keep]
    names = _class_names(class_names)
    fig, ax = plt.subplots(figsize=(8, 8), dpi=110)
    try:
        _draw(
            ax,
            fig,
            xyz[:, 0],
            xyz[:, 1],
            xyz[:, 2],
            classes,
            segments,
            names,
            _marker_size(len(xyz), 7.0, 7.0),
            counted,
            z_unit,
        )
        ax.set_aspect("equal")
        # Plain numbers: matplotlib's "+5e6" offset notation hides UTM coordinates.
        ax.ticklabel_format(useOffset=False, style="plain")
        ax.set_xlabel(f"x ({xy_unit})")
        ax.set_ylabel(f"y ({xy_unit})")
        if title:
            ax.set_title(title)
        _save(fig, path)
    finally:
        plt.close(fig)


@_fill_plot_docstring
def profile(
    points: npt.ArrayLike,
    path: str | os.PathLike,
    start: Sequence[float],
    end: Sequence[float],
    *,
    width: float = 2.0,
    classes: npt.ArrayLike | None = None,
    segments: npt.ArrayLike | None = None,
    class_names: Mapping[int, tuple[str, str]] | None = None,
    vertical_exaggeration: float = 1.0,
    title: str = "",
    max_points: int = 200_000,
    units: str | Sequence[str] = "m",
) -> int:
    """Write a vertical profile along a line to a PNG file.

    The points within a corridor of `width` centred on the segment
    from `start` to `end` (in XY) are drawn as distance along the line
    (horizontal axis) against z.

    Parameters
    ----------
    %(points_and_png)s
    start, end : sequence of 2 float
        x, y of the line's ends A and B, in the points' coordinates.
    width : float, default 2.0
        Corridor width in the unit of x and y (> 0): points at most
        ``width / 2`` from the line, and between its ends, are drawn.
    classes, segments, class_names : optional
        Colouring as in :func:`top_view`.
    vertical_exaggeration : float, default 1.0
        Ratio of the vertical to the horizontal scale (> 0).
    title : str
        Figure title; the default names A, B and the width.
    %(max_points)s
    %(units)s

    Returns
    -------
    int
        Number of points in the corridor (the figure is written even when 0).

    Raises
    ------
    ValueError
        Wrong shapes, non-finite values, ``start == end``, ``width <= 0``,
        empty `units`.
    %(labels_type_error)s

    Examples
    --------
    >>> import numpy as np, tempfile, os
    >>> from pcl_rg.plot import profile
    >>> rng = np.random.default_rng(0)
    >>> pts = np.c_[rng.uniform(0, 10, (500, 2)), rng.uniform(0, 1, 500)]
    >>> with tempfile.TemporaryDirectory() as d:
    ...     n = profile(pts, os.path.join(d, "p.png"), (0, 5), (10, 5), width=1.0,
    ...                 classes=np.full(500, 2))
    >>> 30 < n < 70   # about a tenth of the points lie within 0.5 m of y = 5
    True
    """
    xyz = as_points(points)
    a = as_real("start", start)
    b = as_real("end", end)
    for name, value in (("start", a), ("end", b)):
        if value.shape != (2,) or not np.isfinite(value).all():
            raise ValueError(f"{name} must be 2 finite numbers (x, y), got {value.tolist()!r}")
    (ax, ay), (bx, by) = a.tolist(), b.tolist()  # Python floats: overflow is inf, no warning
    length = math.hypot(bx - ax, by - ay)
    if length == 0.0:
        raise ValueError("start and end must differ")
    if not math.isfinite(length):  # b - a overflowed: the corridor has no direction
        raise ValueError(
            f"start and end are too far apart for float64 ({a.tolist()}, {b.tolist()})"
        )
    width = check_number("width", width, float, above=0.0)
    vertical_exaggeration = check_number(
        "vertical_exaggeration", vertical_exaggeration, float, above=0.0
    )
    max_points, classes, segments = _colouring(len(xyz), max_points, classes, segments)
    xy_unit, z_unit = _unit_names(units)
    direction = (b - a) / length
    rel = xyz[:, :2] - a
    along = rel @ direction
    across = rel[:, 0] * direction[1] - rel[:, 1] * direction[0]
    inside = (np.abs(across) <= width / 2) & (along >= 0) & (along <= length)
    selected = np.flatnonzero(inside)
    n_inside = len(selected)
    labels = segments if segments is not None else classes
    counted = None if labels is None else labels[selected]  # every inside point's, for the legend
    keep = _subsample(n_inside, max_points)
    if keep is not None:
        selected = selected[keep]
    plt = _pyplot()
    names = _class_names(class_names)
    fig, ax = plt.subplots(figsize=(12, 4.5), dpi=110)
    try:
        _draw(
            ax,
            fig,
            along[selected],
            xyz[selected, 2],
            xyz[selected, 2],
            None if classes is None else classes[selected],
            None if segments is None else segments[selected],
            names,
            min(2.0, _marker_size(len(selected), 11.0, 3.0)),
            counted,
            z_unit,
        )
        ax.set_aspect(vertical_exaggeration)
        ax.set_xlim(0, length)
        ax.set_xlabel(f"distance along the line from A ({xy_unit})")
        ax.set_ylabel(f"z ({z_unit})")
        ax.set_title(
            title
            or f"profile A ({a[0]:.2f}, {a[1]:.2f}) to B ({b[0]:.2f}, {b[1]:.2f}), "
            f"corridor {width:g} {xy_unit}, {n_inside:,} points"
        )
        _save(fig, path)
    finally:
        plt.close(fig)
    return n_inside
