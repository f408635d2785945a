"""The objects of the synthetic scenes and surveys: terrain returns, buildings, trees, noise.

Shared by :func:`pcl_rg.datasets.synthetic_scene` and
:func:`pcl_rg.datasets.synthetic_survey`: placement of footprints and crowns in a
rectangle, and the points each kind of object returns, with their ASPRS classes.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from .._params import check_number
from .._validation import as_real
from ._terrain import Terrain, ramp_coordinate, terrain_z

__all__ = ["BUILDING", "GROUND", "NOISE", "VEGETATION", "Block", "PlacementError"]


class PlacementError(ValueError):
    """The objects asked for do not fit in the area: the buildings apart from each
    other and from the sloped band, or the trees clear of the buildings. A larger
    area or fewer objects fits; a caller may retry with fewer (the demo does)."""


# ASPRS LAS 1.4 classification codes (Table 17 of the specification).
GROUND: int = 2
VEGETATION: int = 5  # "high vegetation"
BUILDING: int = 6
NOISE: int = 7  # "low point (noise)"

# Geometry of the scene, in metres unless stated otherwise.  Kept as module
# constants so the docstring, the generator and the tests agree.
_GROUND_ROUGHNESS = 0.03  # std of the Gaussian roughness added to the terrain
_ROOF_ROUGHNESS = 0.02  # std of the roof-point heights around the flat roof
_RAMP_CLEARANCE = 3.0  # buildings keep this far from the ramp band
LARGE_SIDES = ((25.0, 30.0), (20.5, 30.0))  # sides of the first, large building
SMALL_SIDE = (8.0, 18.0)  # sides of the other buildings
_BUILDING_HEIGHT = (4.0, 15.0)
BUILDING_MARGIN = 2.0  # from the area border
BUILDING_GAP = 4.0  # between two buildings
_WALL_DENSITY_RATIO = 0.15  # wall points per m^2 of wall, as a fraction of `density`
CROWN_RADIUS = (2.0, 5.0)
_TREE_HEIGHT = (5.0, 20.0)
_TREE_CLEARANCE = 1.0  # between a crown's edge and a building footprint
_CLEAR_REACH = CROWN_RADIUS[1] + _TREE_CLEARANCE + 1.0  # beyond: clear of a footprint
_UNDERSTORY_RATIO = 0.1  # trunk/understory returns, as a fraction of the canopy returns
_UNDER_CANOPY_KEEP = 0.5  # fraction of ground returns kept under a crown
_LOW_NOISE_DEPTH = (1.0, 20.0)  # below the terrain
_HIGH_NOISE_HEIGHT = (20.0, 100.0)  # above the terrain

# Limits that refuse an absurd request up front, instead of a run that the system kills
# for want of memory or that does not end. Placement compares a building with every one
# placed before it (quadratic: 60,000 in 5 s, a million would take hours); a scene's peak
# memory is about _BYTES_PER_POINT per point (synthetic_scene's docstring) and
# _BYTES_PER_OBJECT per tree or building drawn.
MAX_BUILDINGS = 100_000
MAX_SIZE = 1e5  # m: a square's side (its area squared stays far from overflow)
_BYTES_PER_POINT = 60
_BYTES_PER_OBJECT = 200
# The finest detail of the scenes (roughness 2-3 cm) needs coordinates resolved to 0.1
# mm; float64 does that within 1e11 m of 0 (its step there is 1.5e-5 m).
MAX_OFFSET = 1e11

# x, y, z and the ASPRS class of one kind of return.
Block = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], int]


def scene_sides(rng: np.random.Generator, placed: int) -> tuple[float, float]:
    """Footprint sides of synthetic_scene: the first building large, the others small."""
    if placed == 0:
        w = rng.uniform(*LARGE_SIDES[0])
        h = rng.uniform(*LARGE_SIDES[1])
        if rng.random() < 0.5:
            w, h = h, w
        return w, h
    w, h = rng.uniform(*SMALL_SIDE, 2)
    return w, h


def place_buildings(
    rng: np.random.Generator,
    n: int,
    area: tuple[float, float],
    terrain: Terrain,
    sides: Callable[[np.random.Generator, int], tuple[float, float]] = scene_sides,
) -> NDArray[np.float64]:
    """Seeded rejection sampling of non-overlapping boxes off the ramp.

    `area` is the (width, height) of the area, `sides(rng, placed)` draws the
    footprint of the next building. Returns (k, 6): xmin, ymin, xmax, ymax,
    base (max terrain under the footprint), height; k < n when the attempts ran
    out (the caller raises).
    """
    boxes = np.empty((n, 4))
    placed = 0
    max_attempts = 1000 + 500 * n
    for _ in range(max_attempts):
        if placed == n:
            break
        w, h = sides(rng, placed)
        u, v = rng.random(2)
        span_x = area[0] - 2.0 * BUILDING_MARGIN - w
        span_y = area[1] - 2.0 * BUILDING_MARGIN - h
        if span_x < 0.0 or span_y < 0.0:
            continue
        xmin = BUILDING_MARGIN + u * span_x
        ymin = BUILDING_MARGIN + v * span_y
        # Keep the sloped band clear: a roof above a 20-degree ramp would make
        # the slope-break test ambiguous.
        s_c = ramp_coordinate(terrain, xmin + 0.5 * w, ymin + 0.5 * h)
        extent = 0.5 * w * abs(terrain.ramp_cos) + 0.5 * h * abs(terrain.ramp_sin)
        if (s_c + extent > -_RAMP_CLEARANCE) and (
            s_c - extent < terrain.ramp_width + _RAMP_CLEARANCE
        ):
            continue
        prev = boxes[:placed]
        apart = (
            (xmin >= prev[:, 2] + BUILDING_GAP)
            | (xmin + w + BUILDING_GAP <= prev[:, 0])
            | (ymin >= prev[:, 3] + BUILDING_GAP)
            | (ymin + h + BUILDING_GAP <= prev[:, 1])
        )
        if not np.all(apart):
            continue
        boxes[placed] = (xmin, ymin, xmin + w, ymin + h)
        placed += 1
    boxes = boxes[:placed]
    # Flat roof above the highest terrain under the footprint (5 x 5 samples).
    g = np.linspace(0.0, 1.0, 5)
    gx = boxes[:, 0, None, None] + g[None, :, None] * (boxes[:, 2] - boxes[:, 0])[:, None, None]
    gy = boxes[:, 1, None, None] + g[None, None, :] * (boxes[:, 3] - boxes[:, 1])[:, None, None]
    base = terrain_z(terrain, gx, gy).reshape(placed, -1).max(axis=1) if placed else np.empty(0)
    height = rng.uniform(*_BUILDING_HEIGHT, placed)
    return np.column_stack([boxes, base, height])


def box_distance(
    x: NDArray[np.float64], y: NDArray[np.float64], box: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Distance of (x, y) from the footprint `box` ([xmin, ymin, xmax, ymax]); 0 inside."""
    dx = np.maximum(np.maximum(box[0] - x, x - box[2]), 0.0)
    dy = np.maximum(np.maximum(box[1] - y, y - box[3]), 0.0)
    return np.hypot(dx, dy)


def place_trees(
    rng: np.random.Generator,
    n: int,
    area: tuple[float, float],
    buildings: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Crowns inside the (width, height) area and clear of every footprint; may overlap.

    Returns (k, 4): x, y, crown radius, height; k < n when the draws ran out
    (the caller raises).
    """
    out = np.empty((0, 4))
    for _ in range(100):
        need = n - len(out)
        if need == 0:
            break
        m = max(2 * need, 16)
        r = rng.uniform(*CROWN_RADIUS, m)
        top = rng.uniform(*_TREE_HEIGHT, m)
        x = r + rng.random(m) * (area[0] - 2.0 * r)
        y = r + rng.random(m) * (area[1] - 2.0 * r)
        ok = (area[0] >= 2.0 * r) & (area[1] >= 2.0 * r)
        # Only the candidates in a footprint's x band can be too close to it.
        by_x = np.argsort(x, kind="stable")
        x_sorted = x[by_x]
        for box in buildings:
            lo, hi = np.searchsorted(x_sorted, (box[0] - _CLEAR_REACH, box[2] + _CLEAR_REACH))
            near = by_x[lo:hi]
            ok[near] &= box_distance(x[near], y[near], box) > r[near] + _TREE_CLEARANCE
        cand = np.column_stack([x, y, r, top])[ok][:need]
        out = np.concatenate([out, cand])
    return out


def crown_semi_axes(rng: np.random.Generator, trees: NDArray[np.float64]) -> NDArray[np.float64]:
    """Vertical semi-axis of each crown's half-ellipsoid."""
    return np.minimum(rng.uniform(0.8, 1.3, len(trees)) * trees[:, 2], 0.45 * trees[:, 3])


def canopy_raster(trees: NDArray[np.float64], size: float) -> tuple[NDArray[np.bool_], float]:
    """Boolean raster, True where a cell centre lies under some crown."""
    res = max(0.5, size / 4096.0)
    nx = max(1, math.ceil(size / res))
    raster = np.zeros((nx, nx), dtype=bool)
    for tx, ty, r, _ in trees:
        i0, i1 = max(0, int((tx - r) / res)), min(nx, int((tx + r) / res) + 1)
        j0, j1 = max(0, int((ty - r) / res)), min(nx, int((ty + r) / res) + 1)
        cx = (np.arange(i0, i1) + 0.5) * res - tx
        cy = (np.arange(j0, j1) + 0.5) * res - ty
        raster[i0:i1, j0:j1] |= cx[:, None] ** 2 + cy[None, :] ** 2 <= r * r
    return raster, res


# --------------------------------------------------------------------------
# returns of each kind, in the local coordinates of the area


def ground_points(
    rng: np.random.Generator,
    terrain: Terrain,
    density: float,
    corner: tuple[float, float],
    size: float,
    buildings: NDArray[np.float64],
    trees: NDArray[np.float64],
) -> Block:
    """Ground over the square of side `size` at `corner`: uniform candidates,
    dropped under the footprints, thinned under the crowns."""
    x0, y0 = corner
    n_cand = int(rng.poisson(density * size * size))
    gx = rng.uniform(x0, x0 + size, n_cand)
    gy = rng.uniform(y0, y0 + size, n_cand)
    thin = rng.random(n_cand) >= _UNDER_CANOPY_KEEP
    canopy, res = canopy_raster(trees - np.array([x0, y0, 0.0, 0.0]), size)
    last = canopy.shape[0] - 1
    ix = np.minimum(((gx - x0) / res).astype(np.intp), last)
    iy = np.minimum(((gy - y0) / res).astype(np.intp), last)
    drop = canopy[ix, iy]
    drop &= thin
    del thin
    # Only candidates in a raster cell a footprint touches (one cell of slack
    # around it) can be under it: test those alone against the footprints.
    roofed = np.zeros_like(canopy)
    for xmin, ymin, xmax, ymax, _, _ in buildings:
        i0, i1 = math.floor((xmin - x0) / res) - 1, math.floor((xmax - x0) / res) + 2
        j0, j1 = math.floor((ymin - y0) / res) - 1, math.floor((ymax - y0) / res) + 2
        roofed[max(i0, 0) : max(i1, 0), max(j0, 0) : max(j1, 0)] = True
    near = np.flatnonzero(roofed[ix, iy])
    del ix, iy
    near_x, near_y = gx[near], gy[near]
    for xmin, ymin, xmax, ymax, _, _ in buildings:
        inside = (near_x >= xmin) & (near_x <= xmax) & (near_y >= ymin) & (near_y <= ymax)
        drop[near[inside]] = True
    del near, near_x, near_y
    keep = ~drop
    del drop
    gx, gy = gx[keep], gy[keep]
    del keep
    gz = terrain_z(terrain, gx, gy)
    gz += rng.normal(0.0, _GROUND_ROUGHNESS, gz.size)
    return gx, gy, gz, GROUND


def building_points(
    rng: np.random.Generator,
    terrain: Terrain,
    buildings: NDArray[np.float64],
    roofs: NDArray[np.float64],
    density: float,
) -> list[Block]:
    """Roof returns over `roofs` (B, 4), the footprints or the parts of them to
    sample, and wall returns on the whole footprint edges."""
    if not len(buildings):
        return []
    xmin, ymin, xmax, ymax, base, height = buildings.T
    w, h = xmax - xmin, ymax - ymin
    roof_z = base + height
    rx0, ry0, rx1, ry1 = roofs.T
    rw, rh = rx1 - rx0, ry1 - ry0
    counts = rng.poisson(density * rw * rh)
    b = np.repeat(np.arange(len(buildings)), counts)
    rx = rx0[b] + rng.random(b.size) * rw[b]
    ry = ry0[b] + rng.random(b.size) * rh[b]
    rz = roof_z[b] + rng.normal(0.0, _ROOF_ROUGHNESS, b.size)

    perimeter = 2.0 * (w + h)
    counts = rng.poisson(_WALL_DENSITY_RATIO * density * perimeter * height)
    b = np.repeat(np.arange(len(buildings)), counts)
    t = rng.random(b.size) * perimeter[b]  # arc length along the footprint edge
    wb, hb = w[b], h[b]
    e1, e2, e3 = wb, wb + hb, 2.0 * wb + hb
    wx = np.select(
        [t < e1, t < e2, t < e3],
        [xmin[b] + t, xmax[b], xmax[b] - (t - e2)],
        xmin[b],
    )
    wy = np.select(
        [t < e1, t < e2, t < e3],
        [ymin[b], ymin[b] + (t - e1), ymax[b]],
        ymax[b] - (t - e3),
    )
    foot = terrain_z(terrain, wx, wy)
    wz = foot + rng.random(b.size) * (roof_z[b] - foot)
    return [(rx, ry, rz, BUILDING), (wx, wy, wz, BUILDING)]


def tree_points(
    rng: np.random.Generator,
    terrain: Terrain,
    trees: NDArray[np.float64],
    semi_z: NDArray[np.float64],
    density: float,
) -> list[Block]:
    """Crown surface with shallow penetration, then trunk and understory."""
    tx, ty, radius, top = trees.T
    tbase = terrain_z(terrain, tx, ty)
    centre_z = top - semi_z  # height of the crown ellipsoid's centre above the base
    area = np.pi * radius**2
    counts = rng.poisson(density * area)
    k = np.repeat(np.arange(len(trees)), counts)
    rho = np.sqrt(rng.random(k.size))  # uniform over the disc
    phi = rng.uniform(0.0, 2.0 * np.pi, k.size)
    cx = tx[k] + radius[k] * rho * np.cos(phi)
    cy = ty[k] + radius[k] * rho * np.sin(phi)
    surface = centre_z[k] + semi_z[k] * np.sqrt(1.0 - rho**2)
    depth = np.minimum(rng.exponential(0.2, k.size), 1.3) * semi_z[k]
    cz = tbase[k] + surface - depth
    cz = np.maximum(cz, terrain_z(terrain, cx, cy) + 0.5)  # crown edge on a slope

    counts = rng.poisson(_UNDERSTORY_RATIO * density * area)
    k = np.repeat(np.arange(len(trees)), counts)
    trunk = rng.random(k.size) < 0.5
    rho = np.where(trunk, 0.0, 0.8 * radius[k] * np.sqrt(rng.random(k.size)))
    phi = rng.uniform(0.0, 2.0 * np.pi, k.size)
    ux = tx[k] + rho * np.cos(phi) + np.where(trunk, rng.normal(0.0, 0.15, k.size), 0.0)
    uy = ty[k] + rho * np.sin(phi) + np.where(trunk, rng.normal(0.0, 0.15, k.size), 0.0)
    # Trunk returns anywhere between 0.3 m and the crown centre.
    lift = np.where(
        trunk,
        0.3 + rng.random(k.size) * (centre_z[k] - 0.3),
        rng.uniform(0.2, 2.0, k.size),
    )
    uz = terrain_z(terrain, ux, uy) + lift
    return [(cx, cy, cz, VEGETATION), (ux, uy, uz, VEGETATION)]


def noise_points(
    rng: np.random.Generator,
    terrain: Terrain,
    n_signal: int,
    noise_fraction: float,
    corner: tuple[float, float],
    size: float,
) -> list[Block]:
    """Outliers over the square at `corner`, as a fraction of the total including themselves."""
    n_noise = int(round(noise_fraction * n_signal / (1.0 - noise_fraction)))
    if not n_noise:
        return []
    x0, y0 = corner
    n_low = n_noise // 2
    nx_ = rng.uniform(x0, x0 + size, n_noise)
    ny_ = rng.uniform(y0, y0 + size, n_noise)
    dz = np.concatenate(
        [
            -rng.uniform(*_LOW_NOISE_DEPTH, n_low),
            rng.uniform(*_HIGH_NOISE_HEIGHT, n_noise - n_low),
        ]
    )
    return [(nx_, ny_, terrain_z(terrain, nx_, ny_) + dz, NOISE)]


def assemble(
    blocks: list[Block], order: NDArray[np.intp]
) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
    """Scatter the blocks straight into the positions `order` (no (N, 3) copy)."""
    points = np.empty((order.size, 3))
    labels = np.empty(order.size, dtype=np.uint8)
    start = 0
    for bx, by, bz, code in blocks:
        idx = order[start : start + bx.size]
        points[idx, 0] = bx
        points[idx, 1] = by
        points[idx, 2] = bz
        labels[idx] = code
        start += bx.size
    return points, labels


def object_rows(
    buildings: NDArray[np.float64], trees: NDArray[np.float64], origin: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Footprints ``[xmin, ymin, xmax, ymax, height]`` and trees ``[x, y, radius,
    height]`` in the coordinates of the points (``origin`` added)."""
    footprints = np.column_stack([buildings[:, :4], buildings[:, 5:6]])
    footprints[:, [0, 2]] += origin[0]
    footprints[:, [1, 3]] += origin[1]
    tree_rows = trees.copy()
    tree_rows[:, 0] += origin[0]
    tree_rows[:, 1] += origin[1]
    return footprints, tree_rows


# --------------------------------------------------------------------------
# the scene


def check_scene_budget(points: float, objects: float, what: str) -> None:
    """Refuse, before anything is drawn, a scene this machine's memory cannot hold.

    `points` is the expected number of points, `objects` the trees and buildings to
    place, `what` the arguments that set them (for the message).
    """
    need = _BYTES_PER_POINT * points + _BYTES_PER_OBJECT * objects
    try:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, OSError, ValueError):  # no such query here: no limit
        return
    if not need <= memory:
        raise ValueError(
            f"{what} ask for about {points:.3g} points and {objects:.3g} objects, about "
            f"{need / 2**30:.3g} GiB, more than this machine's {memory / 2**30:.3g} GiB; "
            "use smaller values"
        )


def check_offset(offset: object, name: str = "offset") -> NDArray[np.float64]:
    """A scene's offset (or origin) as 3 finite float64 values; None gives zeros.

    Refused beyond MAX_OFFSET, where float64 cannot resolve the scene's detail (0.1
    mm): the points would land on a coarse lattice, their geometry lost.
    """
    if offset is None:
        return np.zeros(3)
    arr = as_real(name, offset)
    if arr.shape != (3,):
        raise ValueError(f"{name} must have length 3, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr.tolist()}")
    if np.abs(arr).max() > MAX_OFFSET:
        raise ValueError(
            f"{name} {arr.tolist()} is too far from 0: beyond {MAX_OFFSET:g} m float64 cannot "
            "resolve the scene's 0.1 mm detail"
        )
    return arr.copy()


def check_noise_fraction(value: object) -> float:
    """A scene's outlier fraction, a real number in [0, 0.5)."""
    value = check_number("noise_fraction", value, float)
    if not 0.0 <= value < 0.5:
        raise ValueError(f"noise_fraction must be in [0, 0.5), got {value}")
    return value
