"""A harder seeded scene with ISPRS-like class ratios (see pcl_rg.datasets)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from .._params import check_number
from . import _objects as objects
from ._objects import BUILDING, GROUND, NOISE, VEGETATION
from ._steep_terrain import (
    _ROAD_TOP_HALF,
    SteepTerrain,
    line_distance,
    make_steep_terrain,
    road_level,
    steep_z,
)
from ._terrain import fill_dataset_docstring

__all__ = ["BRIDGE_DECK", "LOW_VEGETATION", "IsprsLikeScene", "isprs_like_scene"]

# ASPRS LAS 1.4 classification codes (Table 17 of the specification).
LOW_VEGETATION: int = 3
BRIDGE_DECK: int = 17

_SCENE_STREAM = 11  # spawn key of the scene's random stream (10 is the terrain's)
_MIN_SIZE = 250.0  # the large building must fit between the road, the channel and the slope
# Placing the buildings, trees and shrubs is quadratic in their number: 0.5 s at 1 km,
# 7 s at 2 km; a larger area is a survey (synthetic_survey) or several seeds.
_MAX_SIZE = 1000.0
# Objects, in metres unless stated otherwise.
_LARGE_SIDES = ((60.0, 100.0), (30.0, 60.0))  # the one large hall
_MEDIUM_SIDE = (20.0, 40.0)
_N_MEDIUM = 3
_SMALL_SIDE = (8.0, 18.0)  # houses with gable roofs
_BUILDING_COVER = 0.22  # small houses are added until the footprints cover this share
_FLAT_HEIGHT = (6.0, 18.0)
_EAVE_HEIGHT = (3.0, 7.0)
_PITCH_DEG = (25.0, 40.0)
_BUILDING_MARGIN = 2.0
_BUILDING_GAP = 3.0
_ZONE_CLEARANCE = 3.0  # from the steep band, the embankment's toe and the channel's rim
_WALL_DENSITY_RATIO = 0.15
_ROOF_ROUGHNESS = 0.02
_GROUND_ROUGHNESS = 0.03
_TREE_COVER = 0.10  # crown discs per area (they may overlap)
_CROWN_RADIUS = (2.0, 6.0)
_TREE_HEIGHT = (6.0, 22.0)
_UNDER_CROWN_KEEP = 0.5  # share of ground returns kept under a crown
_SHRUB_COVER = 0.12  # low-vegetation patches per area
_SHRUB_RADIUS = (3.0, 10.0)
_SHRUB_HEIGHT = (0.5, 2.5)
_UNDER_SHRUB_KEEP = 0.25
_SHRUB_INNER_RATIO = 0.2  # returns inside the shrubs, per return on their top
_DECK_CLEARANCE = 0.5  # deck points lie at least this above the terrain under them
_RASTER = 0.25  # cell of the occlusion rasters


class IsprsLikeScene(NamedTuple):
    """A labelled point cloud returned by :func:`isprs_like_scene`.

    Attributes
    ----------
    points : ndarray of float64, shape (N, 3)
        x, y, z in metres, with ``origin`` added; in random order.
    labels : ndarray of uint8, shape (N,)
        ASPRS class of each point: :data:`GROUND` (2), :data:`LOW_VEGETATION`
        (3), :data:`VEGETATION` (5, high), :data:`BUILDING` (6), :data:`NOISE` (7)
        or :data:`BRIDGE_DECK` (17). Ground truth for a ground filter is
        ``labels == GROUND``.
    origin : ndarray of float64, shape (3,)
        The offset added to every point (zeros when none was given).
    buildings : ndarray of float64, shape (B, 5)
        ``[xmin, ymin, xmax, ymax, height]`` per building in the coordinates of
        ``points``; the height of the highest roof point above the highest
        terrain under the footprint.
    """

    points: NDArray[np.float64]
    labels: NDArray[np.uint8]
    origin: NDArray[np.float64]
    buildings: NDArray[np.float64]


Block = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], int]
Height = Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]


def _reach(normal: tuple[float, float], half_x: float, half_y: float) -> float:
    """Half the extent of an axis-aligned box of half-sides (half_x, half_y) along `normal`."""
    return half_x * abs(normal[0]) + half_y * abs(normal[1])


def _zones(t: SteepTerrain, x: float, y: float, half_x: float, half_y: float) -> bool:
    """True when the box of half-sides (half_x, half_y) at (x, y) is clear of the band,
    the embankment and the channel (with their clearance)."""
    reach = _reach(t.slope_normal, half_x, half_y) + _ZONE_CLEARANCE
    s = float(line_distance(t, t.slope_normal, -t.slope_offset, x, y))
    if -reach < s < t.slope_width + reach:
        return False
    reach = _reach(t.road_normal, half_x, half_y) + _ZONE_CLEARANCE
    road = abs(float(line_distance(t, t.road_normal, t.road_offset, x, y)))
    if road < _ROAD_TOP_HALF + t.road_run + reach:
        return False
    reach = _reach(t.channel_normal, half_x, half_y) + _ZONE_CLEARANCE
    channel = abs(float(line_distance(t, t.channel_normal, t.channel_offset, x, y)))
    return channel >= t.channel_bottom_half + t.channel_run + reach


def _place_buildings(rng: np.random.Generator, t: SteepTerrain, size: float) -> NDArray:
    """(B, 8): xmin, ymin, xmax, ymax, base, eave height, pitch tan, ridge along x (0/1).

    One large hall, a few medium flat-roofed buildings, then gable-roofed houses
    until the footprints cover _BUILDING_COVER of the area or the attempts run out.
    """
    rows: list[tuple[float, ...]] = []
    covered = 0.0
    for _ in range(20_000):
        placed = len(rows)
        if placed == 0:
            w, h = rng.uniform(*_LARGE_SIDES[0]), rng.uniform(*_LARGE_SIDES[1])
            if rng.random() < 0.5:
                w, h = h, w
        elif placed <= _N_MEDIUM:
            w, h = rng.uniform(*_MEDIUM_SIDE, 2)
        else:
            if covered >= _BUILDING_COVER * size * size:
                break
            w, h = rng.uniform(*_SMALL_SIDE, 2)
        u, v = rng.random(2)
        xmin = _BUILDING_MARGIN + u * (size - 2.0 * _BUILDING_MARGIN - w)
        ymin = _BUILDING_MARGIN + v * (size - 2.0 * _BUILDING_MARGIN - h)
        if not _zones(t, xmin + 0.5 * w, ymin + 0.5 * h, 0.5 * w, 0.5 * h):
            continue
        if any(
            xmin < r[2] + _BUILDING_GAP
            and r[0] < xmin + w + _BUILDING_GAP
            and ymin < r[3] + _BUILDING_GAP
            and r[1] < ymin + h + _BUILDING_GAP
            for r in rows
        ):
            continue
        if placed <= _N_MEDIUM:
            eave, pitch = rng.uniform(*_FLAT_HEIGHT), 0.0
        else:
            eave, pitch = (
                rng.uniform(*_EAVE_HEIGHT),
                math.tan(math.radians(rng.uniform(*_PITCH_DEG))),
            )
        rows.append((xmin, ymin, xmin + w, ymin + h, 0.0, eave, pitch, float(w >= h)))
        covered += w * h
    if not rows:
        raise ValueError(f"the large building does not fit in a {size:g} m square")
    b = np.array(rows)
    g = np.linspace(0.0, 1.0, 5)
    gx = b[:, 0, None, None] + g[None, :, None] * (b[:, 2] - b[:, 0])[:, None, None]
    gy = b[:, 1, None, None] + g[None, None, :] * (b[:, 3] - b[:, 1])[:, None, None]
    b[:, 4] = steep_z(t, gx, gy).reshape(len(b), -1).max(axis=1)
    return b


def _roof_height(b: NDArray, x: NDArray, y: NDArray, k: NDArray) -> NDArray:
    """Roof height above the base: flat at the eave, or a gable along the long side."""
    ridge_x = b[k, 7] > 0.5
    half = np.where(ridge_x, b[k, 3] - b[k, 1], b[k, 2] - b[k, 0]) * 0.5
    off = np.where(
        ridge_x, np.abs(y - 0.5 * (b[k, 1] + b[k, 3])), np.abs(x - 0.5 * (b[k, 0] + b[k, 2]))
    )
    return b[k, 5] + b[k, 6] * (half - off)


def _building_points(rng: np.random.Generator, height: Height, b: NDArray, density: float):
    w, h = b[:, 2] - b[:, 0], b[:, 3] - b[:, 1]
    k = np.repeat(np.arange(len(b)), rng.poisson(density * w * h))
    rx = b[k, 0] + rng.random(k.size) * w[k]
    ry = b[k, 1] + rng.random(k.size) * h[k]
    rz = b[k, 4] + _roof_height(b, rx, ry, k) + rng.normal(0.0, _ROOF_ROUGHNESS, k.size)
    perimeter = 2.0 * (w + h)
    k = np.repeat(
        np.arange(len(b)), rng.poisson(_WALL_DENSITY_RATIO * density * perimeter * b[:, 5])
    )
    s = rng.random(k.size) * perimeter[k]
    wk, hk = w[k], h[k]
    wx = np.select(
        [s < wk, s < wk + hk, s < 2 * wk + hk],
        [b[k, 0] + s, b[k, 2], b[k, 2] - (s - wk - hk)],
        b[k, 0],
    )
    wy = np.select(
        [s < wk, s < wk + hk, s < 2 * wk + hk],
        [b[k, 1], b[k, 1] + (s - wk), b[k, 3]],
        b[k, 3] - (s - 2 * wk - hk),
    )
    foot = height(wx, wy)
    wz = foot + rng.random(k.size) * (b[k, 4] + b[k, 5] - foot)
    return [(rx, ry, rz, BUILDING), (wx, wy, wz, BUILDING)]


def _place_discs(
    rng: np.random.Generator, t: SteepTerrain, size: float, cover: float, radius: tuple, b: NDArray
) -> NDArray:
    """(K, 3): x, y, r of discs clear of the footprints and of the road's crown, until
    their areas sum to `cover` of the area."""
    m = int(math.ceil(cover * size * size / (math.pi * np.mean(np.square(radius)))) * 3 + 16)
    r = rng.uniform(*radius, m)
    x = r + rng.random(m) * (size - 2.0 * r)
    y = r + rng.random(m) * (size - 2.0 * r)
    ok = np.ones(m, dtype=bool)
    for box in b[:, :4]:
        ok &= objects.box_distance(x, y, box) > r + 1.0
    ok &= np.abs(line_distance(t, t.road_normal, t.road_offset, x, y)) > _ROAD_TOP_HALF + r
    x, y, r = x[ok], y[ok], r[ok]
    keep = np.cumsum(np.pi * r * r) <= cover * size * size
    return np.column_stack([x, y, r])[keep]


def _disc_samples(rng: np.random.Generator, discs: NDArray, per_m2: float):
    k = np.repeat(np.arange(len(discs)), rng.poisson(per_m2 * np.pi * discs[:, 2] ** 2))
    rho = np.sqrt(rng.random(k.size))
    phi = rng.uniform(0.0, 2.0 * np.pi, k.size)
    return (
        k,
        rho,
        discs[k, 0] + discs[k, 2] * rho * np.cos(phi),
        discs[k, 1] + discs[k, 2] * rho * np.sin(phi),
    )


def _tree_points(rng, height: Height, trees: NDArray, tops: NDArray, density: float) -> list[Block]:
    """Half-ellipsoid crowns with shallow penetration, plus trunk returns."""
    semi = np.minimum(rng.uniform(0.8, 1.3, len(trees)) * trees[:, 2], 0.45 * tops)
    k, rho, x, y = _disc_samples(rng, trees, density)
    ground = height(x, y)
    base = height(trees[k, 0], trees[k, 1])
    depth = np.minimum(rng.exponential(0.2, k.size), 1.3) * semi[k]
    z = base + tops[k] - semi[k] + semi[k] * np.sqrt(1.0 - rho**2) - depth
    z = np.maximum(z, ground + 0.5)
    k, _, tx, ty = _disc_samples(rng, trees, 0.05 * density)
    tx = trees[k, 0] + rng.normal(0.0, 0.15, k.size)
    ty = trees[k, 1] + rng.normal(0.0, 0.15, k.size)
    tz = height(tx, ty) + 0.3 + rng.random(k.size) * (tops[k] - semi[k] - 0.3)
    return [(x, y, z, VEGETATION), (tx, ty, tz, VEGETATION)]


def _shrub_points(
    rng, height: Height, shrubs: NDArray, tops: NDArray, density: float
) -> list[Block]:
    """Dense low vegetation: a dome of shrub tops, and returns inside it."""
    k, rho, x, y = _disc_samples(rng, shrubs, density)
    z = height(x, y) + np.maximum(
        tops[k] * (0.5 + 0.5 * rng.random(k.size)) * np.sqrt(1.0 - rho**2), 0.2
    )
    k, rho, ix, iy = _disc_samples(rng, shrubs, _SHRUB_INNER_RATIO * density)
    top = tops[k] * np.sqrt(1.0 - rho**2)
    iz = height(ix, iy) + 0.15 + rng.random(k.size) * np.maximum(top - 0.15, 0.05)
    return [(x, y, z, LOW_VEGETATION), (ix, iy, iz, LOW_VEGETATION)]


def _deck(t: SteepTerrain, x: NDArray, y: NDArray) -> NDArray[np.bool_]:
    """Inside the deck's footprint and clear of the terrain under it."""
    across = np.abs(line_distance(t, t.road_normal, t.road_offset, x, y))
    along = np.abs(line_distance(t, t.channel_normal, t.channel_offset, x, y))
    inside = (across <= _ROAD_TOP_HALF) & (along <= t.gap_half + t.road_run)
    return inside & (road_level(t, x, y) - steep_z(t, x, y) >= _DECK_CLEARANCE)


def _raster(discs: NDArray, size: float) -> NDArray[np.bool_]:
    n = max(1, math.ceil(size / _RASTER))
    raster = np.zeros((n, n), dtype=bool)
    for cx, cy, r in discs:
        i0, i1 = max(0, int((cx - r) / _RASTER)), min(n, int((cx + r) / _RASTER) + 1)
        j0, j1 = max(0, int((cy - r) / _RASTER)), min(n, int((cy + r) / _RASTER) + 1)
        dx = (np.arange(i0, i1) + 0.5) * _RASTER - cx
        dy = (np.arange(j0, j1) + 0.5) * _RASTER - cy
        raster[i0:i1, j0:j1] |= dx[:, None] ** 2 + dy[None, :] ** 2 <= r * r
    return raster


def _ground_points(rng, t: SteepTerrain, size: float, density: float, b, trees, shrubs) -> Block:
    n = int(rng.poisson(density * size * size))
    x = rng.uniform(0.0, size, n)
    y = rng.uniform(0.0, size, n)
    last = math.ceil(size / _RASTER) - 1
    ix = np.minimum((x / _RASTER).astype(np.intp), last)
    iy = np.minimum((y / _RASTER).astype(np.intp), last)
    u = rng.random(n)
    drop = _raster(trees, size)[ix, iy] & (u >= _UNDER_CROWN_KEEP)
    drop |= _raster(shrubs, size)[ix, iy] & (u >= _UNDER_SHRUB_KEEP)
    for xmin, ymin, xmax, ymax in b[:, :4]:
        drop |= (x >= xmin) & (x <= xmax) & (y >= ymin) & (y <= ymax)
    drop |= _deck(t, x, y)
    x, y = x[~drop], y[~drop]
    return x, y, steep_z(t, x, y) + rng.normal(0.0, _GROUND_ROUGHNESS, x.size), GROUND


@fill_dataset_docstring
def isprs_like_scene(
    *,
    seed: int = 0,
    size: float = 300.0,
    density: float = 8.0,
    noise_fraction: float = 0.001,
    offset: tuple[float, float, float] | None = None,
) -> IsprsLikeScene:
    """Generate a hard labelled airborne scene with ISPRS-like class ratios.

    Parameters
    ----------
    %(scene_seed)s
    size : float, default 300.0
        Side of the square area in metres, 250 (so that the large building fits
        between the road, the channel and the steep band) to 1000; the scene covers
        ``[0, size] x [0, size]`` before ``offset``.
    density : float, default 8.0
        First returns per m^2 on every surface (open ground, roofs, crowns, shrub
        tops, the deck). The total is about ``1.1 * density * size**2``.
    noise_fraction : float, default 0.001
        Fraction of the points that are outliers, in [0, 0.5): half 1-20 m below
        the terrain, half 20-100 m above it.
    %(scene_offset)s

    Returns
    -------
    IsprsLikeScene
        ``points`` float64 (N, 3) in random order, ``labels`` uint8 (N,) ASPRS
        codes (ground truth: ``labels == GROUND``), ``origin`` and ``buildings``.

    Raises
    ------
    ValueError
        If ``size`` is not in [250, 1000], ``density`` is not finite and > 0,
        ``seed`` is negative, ``noise_fraction`` is not in [0, 0.5),
        ``offset`` is not 3 finite numbers or farther than 1e11 m from 0
        (where float64 cannot resolve 0.1 mm), or the scene would need more
        memory than the machine has.
    TypeError
        If the seed is not an integer, or another number is not a real number.

    See Also
    --------
    isprs_like_terrain : the true terrain surface of the same scene.
    synthetic_scene : an easier scene (mostly open ground).

    Notes
    -----
    :func:`synthetic_scene` is about 90 % ground on gentle terrain; the ISPRS
    filter-test samples are 30-60 % object points over steep terrain with
    break lines, bridges and dense low vegetation. This scene has those:

    * Terrain (:func:`isprs_like_terrain`): a 30-40 degree band, a 3-5 m road
      embankment with 33-45 degree sides, and a 4-6 m deep channel across it.
      Embankment and channel banks are ground, as in the ISPRS reference.
    * A bridge: the road crosses the channel on a deck (class 17, not ground) at
      the road's level; the deck's points are those at least 0.5 m above the
      terrain under it, and that terrain returns nothing (occluded).
    * Buildings: one hall of 60-100 by 30-60 m and three of 20-40 m with flat
      roofs 6-18 m high, then houses of 8-18 m with 25-40 degree gable roofs
      (eaves 3-7 m) until the footprints cover 22 % of the area; walls at 0.15 x
      ``density`` per m^2 of wall. None on the band, the embankment or the
      channel (3 m clearance). No ground returns under a footprint.
    * High vegetation: crowns of radius 2-6 m, 6-22 m high, covering 10 % of the
      area (overlaps allowed), with trunk returns; half the ground returns under
      a crown are kept.
    * Low vegetation (class 3): patches of radius 3-10 m covering 12 % of the
      area, also on the embankment's sides, shrub tops 0.2-2.5 m above the
      terrain plus 20 % returns inside the shrubs; a quarter of the ground
      returns under them are kept.

    Object points are about 40 % of the total at any density (39-43 % over
    seeds 0-7 at 0.5 and 8 points per m^2; a test holds them in 30-60 %).
    Counts are Poisson draws, so N varies slightly with the seed; the geometry
    does not depend on ``density``, so scenes of one seed at several densities
    show the same objects.

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg.datasets import GROUND, isprs_like_scene
    >>> scene = isprs_like_scene(seed=1, density=1.0)
    >>> scene.points.shape[1], scene.labels.dtype
    (3, dtype('uint8'))
    >>> share = float(np.mean(scene.labels != GROUND))
    >>> 0.3 < share < 0.6
    True
    >>> float(scene.buildings[:, 2:4].max()) <= 300.0
    True
    """
    seed = check_number("seed", seed, int, minimum=0)
    size = check_number("size", size, float, minimum=_MIN_SIZE, maximum=_MAX_SIZE)
    density = check_number("density", density, float, above=0.0)
    noise_fraction = objects.check_noise_fraction(noise_fraction)
    origin = objects.check_offset(offset)
    objects.check_scene_budget(
        1.2 * density * size * size, 0.0, f"size={size:g}, density={density:g}"
    )

    terrain = make_steep_terrain(seed, size)

    def height(x: NDArray, y: NDArray) -> NDArray:
        return steep_z(terrain, x, y)

    # The objects come from one stream drawn in a fixed order, before any point,
    # so that they do not depend on the density; the points from a second one.
    layout = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(_SCENE_STREAM, 0)))
    buildings = _place_buildings(layout, terrain, size)
    trees = _place_discs(layout, terrain, size, _TREE_COVER, _CROWN_RADIUS, buildings)
    tree_tops = layout.uniform(*_TREE_HEIGHT, len(trees))
    shrubs = _place_discs(layout, terrain, size, _SHRUB_COVER, _SHRUB_RADIUS, buildings)
    shrub_tops = layout.uniform(*_SHRUB_HEIGHT, len(shrubs))

    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(_SCENE_STREAM, 1)))
    blocks = [_ground_points(rng, terrain, size, density, buildings, trees, shrubs)]
    blocks += _building_points(rng, height, buildings, density)
    blocks += _tree_points(rng, height, trees, tree_tops, density)
    blocks += _shrub_points(rng, height, shrubs, shrub_tops, density)
    # The deck: returns over a square around the crossing of the road and the channel,
    # kept where the deck is.
    (nrx, nry), (ncx, ncy) = terrain.road_normal, terrain.channel_normal
    det = nrx * ncy - nry * ncx
    cross_x = terrain.half + (terrain.road_offset * ncy - nry * terrain.channel_offset) / det
    cross_y = terrain.half + (nrx * terrain.channel_offset - ncx * terrain.road_offset) / det
    span = 2.0 * (_ROAD_TOP_HALF + terrain.gap_half + terrain.road_run)
    n_deck = int(rng.poisson(density * 4.0 * span * span))
    deck_x = cross_x + rng.uniform(-span, span, n_deck)
    deck_y = cross_y + rng.uniform(-span, span, n_deck)
    on_deck = _deck(terrain, deck_x, deck_y)
    deck_x, deck_y = deck_x[on_deck], deck_y[on_deck]
    deck_z = road_level(terrain, deck_x, deck_y) + rng.normal(0.0, _ROOF_ROUGHNESS, deck_x.size)
    blocks.append((deck_x, deck_y, deck_z, BRIDGE_DECK))
    n_signal = sum(blk[0].size for blk in blocks)
    n_noise = int(round(noise_fraction * n_signal / (1.0 - noise_fraction)))
    nx, ny = rng.uniform(0.0, size, n_noise), rng.uniform(0.0, size, n_noise)
    dz = np.where(
        np.arange(n_noise) < n_noise // 2,
        -rng.uniform(1.0, 20.0, n_noise),
        rng.uniform(20.0, 100.0, n_noise),
    )
    blocks.append((nx, ny, height(nx, ny) + dz, NOISE))

    points, labels = objects.assemble(blocks, rng.permutation(sum(b[0].size for b in blocks)))
    points += origin
    roof = buildings[:, 5] + buildings[:, 6] * 0.5 * np.minimum(
        buildings[:, 2] - buildings[:, 0], buildings[:, 3] - buildings[:, 1]
    )
    rows = np.column_stack([buildings[:, :4], roof])
    rows[:, [0, 2]] += origin[0]
    rows[:, [1, 3]] += origin[1]
    return IsprsLikeScene(points, labels, origin, rows)
