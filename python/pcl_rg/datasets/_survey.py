"""A seeded synthetic airborne survey written as a grid of tiles (see pcl_rg.datasets)."""

from __future__ import annotations

import os
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from .._params import check_number
from ..io import write_points
from . import _objects as objects
from ._objects import BUILDING, GROUND, NOISE, VEGETATION, Block
from ._terrain import Terrain, make_terrain

__all__ = ["SyntheticSurvey", "synthetic_survey"]

_FORMATS = ("laz", "las", "ply", "pcd")
_LAYOUT_STREAM = 2  # spawn keys: 0 terrain, 1 synthetic_scene, 2 layout, (3, row, col) tiles
_TILE_STREAM = 3
_MM = 1000.0  # coordinates are stored in whole millimetres (the LAS scale)
_LARGE_SHARE = 0.25  # share of the buildings with the large sides
_LARGE_SIDE = (20.0, 40.0)
_SMALL_SIDE = (8.0, 18.0)
_TREE_REACH = 1.0  # trunk and understory returns stay this close to the crown disc
_MAX_BUILDINGS_PER_KM2 = 500.0
_SCAN_STRIP = 2.0  # m: points are stored strip by strip along y, by x within a strip
# Mean and standard deviation of the 16-bit intensity, by ASPRS class code.
_INTENSITY = np.zeros((256, 2))
_INTENSITY[[GROUND, BUILDING, VEGETATION, NOISE]] = [
    (1200.0, 250.0),
    (1800.0, 300.0),
    (700.0, 250.0),
    (300.0, 200.0),
]


class SyntheticSurvey(NamedTuple):
    """The tiles written by :func:`synthetic_survey`.

    Attributes
    ----------
    paths : list of str
        The tile files, row-major: tile ``(row, col)`` is ``paths[row * cols + col]``.
    bounds : ndarray of float64, shape (rows * cols, 4)
        ``[xmin, ymin, xmax, ymax]`` of each tile in file coordinates, in the
        order of ``paths``; a tile holds the points with ``xmin <= x < xmax``
        and ``ymin <= y < ymax``.
    points : ndarray of int64, shape (rows * cols,)
        Number of points in each tile.
    tiles : tuple of 2 int
        ``(rows, cols)``; rows run along y, columns along x.
    origin : ndarray of float64, shape (3,)
        The offset added to every coordinate.
    terrain_size : float
        ``max(rows, cols) * tile_size``: ``terrain_height(x - origin[0],
        y - origin[1], seed=seed, size=terrain_size)`` is the true terrain.
    buildings : ndarray of float64, shape (B, 5)
        ``[xmin, ymin, xmax, ymax, height]`` per building, in file coordinates,
        as :attr:`SyntheticScene.buildings`.
    trees : ndarray of float64, shape (T, 4)
        ``[x, y, crown_radius, height]`` per tree, in file coordinates, as
        :attr:`SyntheticScene.trees`.
    """

    paths: list[str]
    bounds: NDArray[np.float64]
    points: NDArray[np.int64]
    tiles: tuple[int, int]
    origin: NDArray[np.float64]
    terrain_size: float
    buildings: NDArray[np.float64]
    trees: NDArray[np.float64]


class _Layout(NamedTuple):
    """What every tile is made from: the arguments and the objects of the whole survey."""

    seed: int
    tiles: tuple[int, int]
    tile_size: float
    density: float
    noise_fraction: float
    origin: NDArray[np.float64]
    terrain: Terrain
    edges_x: NDArray[np.float64]  # (cols + 1,) tile borders in file millimetres
    edges_y: NDArray[np.float64]  # (rows + 1,)
    buildings: NDArray[np.float64]  # (B, 6) local: xmin, ymin, xmax, ymax, base, height
    trees: NDArray[np.float64]  # (T, 4) local: x, y, crown radius, height
    semi_z: NDArray[np.float64]  # (T,) vertical semi-axis of each crown


def _survey_sides(rng: np.random.Generator, placed: int) -> tuple[float, float]:
    """Footprint sides: a quarter of the buildings 20-40 m, the others 8-18 m."""
    sides = _LARGE_SIDE if rng.random() < _LARGE_SHARE else _SMALL_SIDE
    w, h = rng.uniform(*sides, 2)
    return w, h


def _layout(
    seed: int,
    tiles: tuple[int, int],
    tile_size: float,
    density: float,
    buildings_per_km2: float,
    trees_per_km2: float,
    noise_fraction: float,
    origin: NDArray[np.float64],
) -> _Layout:
    rows, cols = tiles
    area = (cols * tile_size, rows * tile_size)
    terrain = make_terrain(seed, max(area))
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(_LAYOUT_STREAM,)))
    km2 = area[0] * area[1] / 1e6
    n_buildings = int(round(buildings_per_km2 * km2))
    n_trees = int(round(trees_per_km2 * km2))
    if n_buildings > objects.MAX_BUILDINGS:
        raise ValueError(
            f"{n_buildings:,} buildings (buildings_per_km2={buildings_per_km2:g} over "
            f"{km2:g} km^2): at most {objects.MAX_BUILDINGS:,} are placed, each clear of every "
            "other; use fewer tiles or buildings_per_km2"
        )
    # The points are drawn one tile at a time (their crowns, roofs and walls included:
    # twice the open ground's count at most); the objects of the whole survey at once.
    objects.check_scene_budget(
        2.0 * density * tile_size * tile_size,
        n_trees + n_buildings,
        f"tile_size={tile_size:g}, density={density:g}, tiles={tiles}, "
        f"trees_per_km2={trees_per_km2:g}, buildings_per_km2={buildings_per_km2:g}",
    )
    buildings = objects.place_buildings(rng, n_buildings, area, terrain, _survey_sides)
    if len(buildings) < n_buildings:
        raise objects.PlacementError(
            f"{n_buildings} non-overlapping buildings (buildings_per_km2={buildings_per_km2:g}, "
            f"up to {_LARGE_SIDE[1]:g} m long) do not fit in the {area[0]:g} x {area[1]:g} m "
            "survey beside its sloped band; use more or larger tiles or fewer buildings_per_km2"
        )
    trees = objects.place_trees(rng, n_trees, area, buildings)
    if len(trees) < n_trees:
        raise objects.PlacementError(
            f"could not place {n_trees} trees (trees_per_km2={trees_per_km2:g}) clear of the "
            f"buildings in the {area[0]:g} x {area[1]:g} m survey; use more or larger tiles "
            "or fewer trees_per_km2/buildings_per_km2"
        )
    semi_z = objects.crown_semi_axes(rng, trees)
    edges_x = np.round((origin[0] + tile_size * np.arange(cols + 1)) * _MM)
    edges_y = np.round((origin[1] + tile_size * np.arange(rows + 1)) * _MM)
    return _Layout(
        seed,
        tiles,
        tile_size,
        density,
        noise_fraction,
        origin,
        terrain,
        edges_x,
        edges_y,
        buildings,
        trees,
        semi_z,
    )


def _in_tile(block: Block, layout: _Layout, row: int, col: int) -> Block:
    """The block's returns in file millimetres, those outside the tile dropped."""
    x, y, z, code = block
    origin = layout.origin
    xm = np.round((x + origin[0]) * _MM)
    ym = np.round((y + origin[1]) * _MM)
    keep = (xm >= layout.edges_x[col]) & (xm < layout.edges_x[col + 1])
    keep &= (ym >= layout.edges_y[row]) & (ym < layout.edges_y[row + 1])
    if keep.all():
        return xm, ym, np.round((z + origin[2]) * _MM), code
    return xm[keep], ym[keep], np.round((z[keep] + origin[2]) * _MM), code


def _tile(
    layout: _Layout, row: int, col: int
) -> tuple[NDArray[np.float64], NDArray[np.uint8], NDArray[np.uint16]]:
    """Points (file coordinates), classes and intensities of tile (row, col).

    Made from the layout and the tile's own stream only, so a tile is the same
    whichever tiles are made before it, or whether they are made at all.
    """
    rng = np.random.default_rng(
        np.random.SeedSequence(layout.seed, spawn_key=(_TILE_STREAM, row, col))
    )
    size = layout.tile_size
    x0, y0 = col * size, row * size
    x1, y1 = x0 + size, y0 + size
    b = layout.buildings
    near = (b[:, 0] <= x1) & (b[:, 2] >= x0) & (b[:, 1] <= y1) & (b[:, 3] >= y0)
    buildings = b[near]
    t = layout.trees
    reach = t[:, 2] + _TREE_REACH
    near = (t[:, 0] + reach >= x0) & (t[:, 0] - reach <= x1)
    near &= (t[:, 1] + reach >= y0) & (t[:, 1] - reach <= y1)
    trees, semi_z = t[near], layout.semi_z[near]

    # Roofs are sampled over their part in the tile; the walls, crowns and
    # understory of an object straddling the border are made whole and clipped.
    roofs = buildings[:, :4].copy()
    roofs[:, [0, 2]] = np.clip(roofs[:, [0, 2]], x0, x1)
    roofs[:, [1, 3]] = np.clip(roofs[:, [1, 3]], y0, y1)
    terrain, density = layout.terrain, layout.density
    blocks = [objects.ground_points(rng, terrain, density, (x0, y0), size, buildings, trees)]
    blocks += objects.building_points(rng, terrain, buildings, roofs, density)
    blocks += objects.tree_points(rng, terrain, trees, semi_z, density)
    for i in range(len(blocks)):  # one block at a time: the ground is most of the tile
        blocks[i] = _in_tile(blocks[i], layout, row, col)
    n_signal = sum(blk[0].size for blk in blocks)
    noise = objects.noise_points(rng, terrain, n_signal, layout.noise_fraction, (x0, y0), size)
    blocks += [_in_tile(blk, layout, row, col) for blk in noise]

    # Stored strip by strip across the tile, like the lines of a scan (and
    # compressed far better than a random order).
    strip = np.concatenate(
        [np.floor((blk[1] - layout.edges_y[row]) / (_SCAN_STRIP * _MM)) for blk in blocks]
    )
    strip *= layout.edges_x[col + 1] - layout.edges_x[col] + 1.0
    strip += np.concatenate([blk[0] - layout.edges_x[col] for blk in blocks])
    order = np.empty(strip.size, dtype=np.intp)
    order[np.argsort(strip, kind="stable")] = np.arange(strip.size)
    del strip
    points, labels = objects.assemble(blocks, order)
    del blocks, order
    points /= _MM

    intensity = rng.normal(_INTENSITY[labels, 0], _INTENSITY[labels, 1])
    np.clip(intensity, 0.0, 65535.0, out=intensity)
    return points, labels, intensity.round().astype(np.uint16)


def _check_tiles(tiles: object) -> tuple[int, int]:
    try:
        rows, cols = tiles  # type: ignore[misc]
    except (TypeError, ValueError):
        raise ValueError(f"tiles must be a pair (rows, cols), got {tiles!r}") from None
    return (
        check_number("tiles[0]", rows, int, minimum=1),
        check_number("tiles[1]", cols, int, minimum=1),
    )


def synthetic_survey(
    folder: str | os.PathLike[str],
    *,
    tiles: tuple[int, int] = (5, 5),
    tile_size: float = 200.0,
    density: float = 4.0,
    seed: int = 0,
    buildings_per_km2: float = 150.0,
    trees_per_km2: float = 1500.0,
    noise_fraction: float = 0.002,
    origin: tuple[float, float, float] = (500000.0, 5400000.0, 100.0),
    format: str = "laz",
) -> SyntheticSurvey:
    """Write a seeded synthetic airborne survey as a grid of labelled tiles.

    The survey is one scene of :func:`synthetic_scene`'s kind (terrain,
    buildings, trees, noise) over ``rows * tile_size`` by ``cols * tile_size``
    metres, delivered as one file per tile, as surveys are. Buildings and trees
    straddle the tile borders, so processing the tiles with buffers can be
    checked against processing the merged cloud.

    Parameters
    ----------
    folder : str or os.PathLike
        Where the tiles are written (created if missing); files of the same
        names are replaced.
    tiles : tuple of 2 int, default (5, 5)
        ``(rows, cols)``: rows along y, columns along x.
    tile_size : float, default 200.0
        Side of the square tiles in metres (>= 1).
    density : float, default 4.0
        Points per m^2 on the open ground, the roofs and the crowns, as in
        :func:`synthetic_scene`; a tile holds about ``density * tile_size**2``
        points (160 000 with the defaults, 4 million over the 25 tiles).
    seed : int, default 0
        Seed of every random draw; the same arguments write the same points.
    buildings_per_km2 : float, default 150.0
        Buildings per km^2 of the survey, in [0, 500]: axis-aligned boxes at
        least 4 m apart, a quarter of them with sides of 20-40 m, the others
        8-18 m; heights 4-15 m.
    trees_per_km2 : float, default 1500.0
        Trees per km^2 (>= 0): crown radius 2-5 m, tree top 5-20 m.
    noise_fraction : float, default 0.002
        Fraction of each tile's points that are outliers, in [0, 0.5).
    origin : tuple of 3 float, default (500000.0, 5400000.0, 100.0)
        Added to every coordinate: tile ``(row, col)`` covers ``x`` from
        ``origin[0] + col * tile_size`` and ``y`` from
        ``origin[1] + row * tile_size``.
    format : {"laz", "las", "ply", "pcd"}, default "laz"
        File format, also the files' extension.

    Returns
    -------
    SyntheticSurvey
        ``paths`` (row-major), ``bounds`` (T, 4) ``[xmin, ymin, xmax, ymax]``
        (half-open), ``points`` per tile, ``tiles``, ``origin``,
        ``terrain_size``, and the survey's ``buildings`` and ``trees`` in file
        coordinates.

    Raises
    ------
    ValueError
        If a number is out of its range, ``tiles`` is not a pair, ``origin``
        is not 3 finite numbers or farther than 1e11 m from 0, ``format`` is
        unknown, the buildings or trees do not fit in the survey
        (:class:`PlacementError`, a ValueError), it would
        hold more than 100,000 buildings, or a tile with the survey's objects
        would need more memory than the machine has.
    TypeError
        If ``folder`` is not a path, ``format`` not a str, a count or the seed
        not an integer, or another number not a real number.

    See Also
    --------
    synthetic_scene : one labelled scene in memory.
    terrain_height : the true terrain (with ``size=terrain_size``).

    Notes
    -----
    Tile ``(row, col)`` is written to ``tile_<row>_<col>.<format>`` with the
    fields ``classification`` (the ASPRS class, the truth: GROUND 2,
    VEGETATION 5, BUILDING 6, NOISE 7) and ``intensity`` (uint16, drawn by
    class). Coordinates are whole millimetres, the LAS scale, so every format
    stores the same values, and every point lies in exactly one tile:
    ``xmin <= x < xmax`` and ``ymin <= y < ymax``. Within a tile the points are
    stored in 2 m strips along y, by x within a strip, like scan lines (LAZ
    compresses that order well).

    The terrain, building footprints and heights and tree crowns are drawn
    for the whole survey first (a few thousand objects). Each tile is then made
    alone, from those objects and its own random stream, derived from
    ``(seed, row, col)``: the same whatever the order the tiles are made in,
    and memory stays bounded by one tile (about 100 bytes a point at the peak:
    some 0.4 GB and 4 s for 4 million points), whatever the number of tiles. The
    ground, roofs and noise of a tile are sampled over the tile; walls, crowns
    and understory of the objects reaching into it are made whole and clipped
    to it. Counts are Poisson draws, so they vary slightly with the seed.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from pcl_rg.datasets import synthetic_survey
    >>> from pcl_rg.io import read_points
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     survey = synthetic_survey(folder, tiles=(2, 3), tile_size=50.0, density=1.0)
    ...     names = [os.path.basename(path) for path in survey.paths]
    ...     tile = read_points(survey.paths[4])
    >>> names
    ['tile_0_0.laz', 'tile_0_1.laz', 'tile_0_2.laz', 'tile_1_0.laz', 'tile_1_1.laz', 'tile_1_2.laz']
    >>> survey.bounds[4].tolist()
    [500050.0, 5400050.0, 500100.0, 5400100.0]
    >>> xmin, ymin, xmax, ymax = survey.bounds[4]
    >>> x, y = tile.points[:, 0], tile.points[:, 1]
    >>> inside = (x >= xmin) & (x < xmax) & (y >= ymin) & (y < ymax)
    >>> len(tile) == int(survey.points[4]), bool(inside.all())
    (True, True)
    >>> sorted(tile.fields)[:2], tile.fields["intensity"].dtype
    (['classification', 'edge_of_flight_line'], dtype('uint16'))
    """
    if not isinstance(folder, (str, os.PathLike)):
        raise TypeError(f"folder must be a str or os.PathLike, got {type(folder).__name__}")
    folder = os.fspath(folder)
    rows, cols = _check_tiles(tiles)
    tile_size = check_number("tile_size", tile_size, float, minimum=1.0)
    density = check_number("density", density, float, above=0.0)
    seed = check_number("seed", seed, int, minimum=0)
    buildings_per_km2 = check_number(
        "buildings_per_km2", buildings_per_km2, float, minimum=0.0, maximum=_MAX_BUILDINGS_PER_KM2
    )
    trees_per_km2 = check_number("trees_per_km2", trees_per_km2, float, minimum=0.0)
    noise_fraction = objects.check_noise_fraction(noise_fraction)
    offset = objects.check_offset(origin, "origin")
    if not isinstance(format, str):
        raise TypeError(f"format must be a str, got {type(format).__name__}")
    if format not in _FORMATS:
        raise ValueError(f"format must be one of {', '.join(_FORMATS)}, got {format!r}")

    layout = _layout(
        seed,
        (rows, cols),
        tile_size,
        density,
        buildings_per_km2,
        trees_per_km2,
        noise_fraction,
        offset,
    )
    os.makedirs(folder, exist_ok=True)
    paths, counts = [], []
    for row in range(rows):
        for col in range(cols):
            points, labels, intensity = _tile(layout, row, col)
            path = os.path.join(folder, f"tile_{row}_{col}.{format}")
            write_points(path, points, {"intensity": intensity}, classification=labels)
            paths.append(path)
            counts.append(len(points))
            del points, labels, intensity
    bounds = (
        np.column_stack(
            [
                np.repeat(layout.edges_x[None, :-1], rows, axis=0).ravel(),
                np.repeat(layout.edges_y[:-1], cols),
                np.repeat(layout.edges_x[None, 1:], rows, axis=0).ravel(),
                np.repeat(layout.edges_y[1:], cols),
            ]
        )
        / _MM
    )
    buildings, trees = objects.object_rows(layout.buildings, layout.trees, offset)
    return SyntheticSurvey(
        paths,
        bounds,
        np.array(counts, dtype=np.int64),
        (rows, cols),
        offset,
        max(rows, cols) * tile_size,
        buildings,
        trees,
    )
