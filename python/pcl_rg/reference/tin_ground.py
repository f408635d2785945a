"""NumPy/SciPy reference for :func:`pcl_rg.tin_ground`.

Follows section 4 of the algorithms document and the choices stated in
``cpp/src/tin_ground.cpp`` step by step, but rebuilds the TIN with
:class:`scipy.spatial.Delaunay` (qhull) in every iteration instead of inserting
points, and tests every unclassified point in every iteration. The floating-point
formulas are the core's, operation for operation, on the same snapped grid, so
the two agree point for point. Where four or more vertices are co-circular
(frequent on gridded data such as the ISPRS samples) the Delaunay triangulation
is not unique: qhull's diagonals are then flipped to the core's, which follow a
symbolic perturbation (:mod:`pcl_rg.reference._delaunay`).
qhull works in floating point: vertices a few grid steps apart in a large
extent, which the core's exact predicates tell apart, it may merge, and then
:class:`QhullPrecisionError` is raised instead of an answer.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy.spatial import Delaunay, cKDTree

from .._params import format_value, resolve_arguments
from .._point_spacing import with_spacing_lengths
from .._tin_ground import TinGroundParams
from .._validation import as_points
from ._delaunay import follow_perturbation, triangle_neighbours
from ._lattice import lattice_floor, lowest_in_cells
from ._tin_seeds import seeds, seeds_of
from .point_spacing import point_spacing

__all__ = ["QhullPrecisionError", "grid_quantum", "locate", "seeds", "tin_ground", "triangulate"]

_DEG_TO_RAD = math.pi / 180.0


def grid_quantum(extent: float) -> float:
    """The core's grid step for an XY extent: the smallest power of two >= extent / 2^29
    and >= 2^-40 (``make_grid_frame`` in ``delaunay.cpp``)."""
    target = math.ldexp(extent, -29)
    quantum = math.ldexp(1.0, -40)
    if target > quantum:
        mantissa, exponent = math.frexp(target)
        quantum = math.ldexp(1.0, exponent - 1 if mantissa == 0.5 else exponent)
    return quantum


def _orient(ax, ay, bx, by, px, py):  # type: ignore[no-untyped-def]
    """Exact orientation on the integer grid (|coordinates| <= 2^30: fits int64)."""
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax)


def _orient_perturbed(ax, ay, bx, by, px, py):  # type: ignore[no-untyped-def]
    """Sign of orient(a, b, p + (eps, eps^2)): never 0 for a != b."""
    sign = np.sign(_orient(ax, ay, bx, by, px, py))
    tie = sign == 0
    sign[tie] = np.where(ay[tie] != by[tie], np.sign(ay[tie] - by[tie]), np.sign(bx[tie] - ax[tie]))
    return sign


class QhullPrecisionError(RuntimeError):
    """qhull left vertices out of the TIN: the reference has no exact answer there.

    qhull's Delaunay works on the lifted points (x, y, x^2 + y^2) in float64, so
    vertices a few grid steps apart in an extent of ~2^29 steps can be too close
    for it and one is dropped as "coplanar". The core's predicates are exact
    integer arithmetic and triangulate such points; tests that compare the two
    skip these inputs.
    """


def triangulate(vx: np.ndarray, vy: np.ndarray, quantum: float) -> tuple:
    """qhull's Delaunay triangulation of integer vertices (given to qhull in metres).

    Returns ``(tri, neighbors, vertex_to_simplex)``: the triangles (T, 3)
    counter-clockwise, each starting at its lexicographically smallest (x, y) vertex,
    the triangle across the edge opposite each vertex (-1 on the hull), and one
    triangle per vertex. Where four or more vertices are co-circular, qhull's
    diagonals are flipped to the core's (``follow_perturbation``).

    Raises
    ------
    QhullPrecisionError
        qhull dropped vertices closer to others than its precision resolves, or
        returned a triangulation with too many triangles or a flat one.
    """
    dt = Delaunay(np.c_[vx, vy].astype(np.float64) * quantum)
    if len(dt.coplanar):
        raise QhullPrecisionError(
            f"reference: qhull merged {len(dt.coplanar)} TIN vertex(es) into a neighbour "
            "closer than its float64 precision resolves (a few grid steps in a wide "
            "extent); this NumPy reference cannot build that TIN exactly (the core can)"
        )
    s = dt.simplices.astype(np.int64)
    o = _orient(vx[s[:, 0]], vy[s[:, 0]], vx[s[:, 1]], vy[s[:, 1]], vx[s[:, 2]], vy[s[:, 2]])
    # A triangulation of n points with h on its boundary has 2n - 2 - h triangles, none
    # flat: near-degenerate input (points a grid step apart in a wide box) can get
    # overlapping or flat triangles from qhull without a word.
    if len(s) != 2 * len(vx) - 2 - len(dt.convex_hull) or bool(np.any(o == 0)):
        raise QhullPrecisionError(
            f"reference: qhull returned {len(s)} triangles for {len(vx)} vertices, "
            f"{len(dt.convex_hull)} of them on the hull, or a flat one, at points closer "
            "than its float64 precision resolves; this NumPy reference cannot build that "
            "TIN exactly (the core can)"
        )
    cw = o < 0
    s[cw] = s[cw][:, [0, 2, 1]]
    # Co-circular vertices: the core's diagonals (its perturbed in-circle test).
    s = follow_perturbation(s, vx, vy)
    nb = triangle_neighbours(s)
    key = vx[s] * (1 << 31) + vy[s]  # lexicographic (x, y); vx < 2^31
    turn = (np.argmin(key, axis=1)[:, None] + np.arange(3)) % 3
    rows = np.arange(len(s))[:, None]
    vertex_to_simplex = np.full(len(vx), -1, dtype=np.int64)
    vertex_to_simplex[s.ravel()] = np.repeat(np.arange(len(s)), 3)
    return s[rows, turn], nb[rows, turn], vertex_to_simplex


def locate(
    tri: np.ndarray,
    neighbors: np.ndarray,
    vertex_to_simplex: np.ndarray,
    vx: np.ndarray,
    vy: np.ndarray,
    px: np.ndarray,
    py: np.ndarray,
) -> np.ndarray:
    """Row of the triangle holding each p + (eps, eps^2), found as the core finds it.

    A visibility walk, all points at once, from a triangle of each point's nearest
    vertex: step across the first edge (in the row's order) that has p + (eps, eps^2)
    strictly on its outer side, until none has.
    """
    _, near = cKDTree(np.c_[vx, vy].astype(np.float64)).query(np.c_[px, py].astype(np.float64))
    current = vertex_to_simplex[near]
    result = np.full(len(px), -1, dtype=np.int64)
    todo = np.arange(len(px))
    for _ in range(4 * len(tri) + 64):
        t = current[todo]
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        x, y = px[todo], py[todo]
        side = np.stack(
            [
                _orient_perturbed(vx[b], vy[b], vx[c], vy[c], x, y),
                _orient_perturbed(vx[c], vy[c], vx[a], vy[a], x, y),
                _orient_perturbed(vx[a], vy[a], vx[b], vy[b], x, y),
            ],
            axis=1,
        )
        inside = (side > 0).all(axis=1)
        result[todo[inside]] = t[inside]
        out = ~inside
        current[todo[out]] = neighbors[t[out], np.argmax(side[out] < 0, axis=1)]
        todo = todo[out]
        if todo.size == 0:
            return result
    raise RuntimeError("point location did not terminate")  # pragma: no cover


#: The most parts a side of the box is cut into (``kMaxBorderParts``, ground_tin.hpp).
MAX_BORDER_PARTS = 65536


def border_points(
    width: int, height: int, extent_x: float, extent_y: float, spacing: float
) -> tuple[np.ndarray, np.ndarray]:
    """Grid (x, y) of the virtual vertices on the box's sides besides its corners.

    The sides along x are cut into ``min(max(floor(extent_x / spacing), 1),
    MAX_BORDER_PARTS)`` equal parts, at grid x ``floor(j * width / parts)``, and so the
    sides along y; in
    the order of ``border_points`` in ground_tin.hpp, by cut with the two opposite
    sides in turn: (x_1, 0), (x_1, height), (x_2, 0), ..., then (0, y_1), (width, y_1),
    .... Positions on a corner or repeated are kept: the caller drops them, as the
    core's insertion does.
    """

    def cuts(extent: float, side: int) -> list[int]:
        parts = min(max(math.floor(extent / spacing), 1), MAX_BORDER_PARTS)
        return [j * side // parts for j in range(1, parts)]

    along_x, along_y = cuts(extent_x, width), cuts(extent_y, height)
    xs = [x for x in along_x for _ in (0, height)] + [x for _ in along_y for x in (0, width)]
    ys = [y for _ in along_x for y in (0, height)] + [y for y in along_y for _ in (0, width)]
    return np.array(xs, dtype=np.int64), np.array(ys, dtype=np.int64)


def with_corners(
    gx: np.ndarray,
    gy: np.ndarray,
    z: np.ndarray,
    nearest: np.ndarray,
    inserted: np.ndarray,
    width: int,
    height: int,
    border: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices (grid x, grid y, z) of a TIN over the box: its four corners, the `border`
    points (grid x, grid y) not on a corner nor repeated, then `inserted`.

    Each virtual vertex takes the height of the point of `nearest` closest to it (exact
    squared grid distance, ties: the lowest, then the smallest index, so the height does
    not depend on the points' order), so every point of the box lies inside the TIN.
    """
    # In order, each position once (a dict keeps the first of equal keys).
    positions = dict.fromkeys([(0, 0), (width, 0), (width, height), (0, height)])
    if border is not None:
        positions.update(dict.fromkeys(zip(border[0].tolist(), border[1].tolist(), strict=True)))
    vx, vy = (np.array(axis, dtype=np.int64).reshape(-1) for axis in zip(*positions, strict=True))
    vz = np.empty(len(vx))
    for c in range(len(vx)):
        d2 = (gx[nearest] - vx[c]) ** 2 + (gy[nearest] - vy[c]) ** 2
        vz[c] = z[nearest[np.lexsort((nearest, z[nearest], d2))[0]]]
    return np.r_[vx, gx[inserted]], np.r_[vy, gy[inserted]], np.r_[vz, z[inserted]]


def _evaluate(tri, vx, vy, vz, q, px, py, pz, p: TinGroundParams):  # type: ignore[no-untyped-def]
    """(accepted, stop, d) per point; the formulas of ``evaluate`` in tin_ground.cpp."""
    x = (vx[tri] - 1).astype(np.float64) * q
    y = (vy[tri] - 1).astype(np.float64) * q
    z = vz[tri]
    pxm = (px - 1).astype(np.float64) * q
    pym = (py - 1).astype(np.float64) * q
    longest2 = np.zeros(len(tri))
    for k in range(3):
        j = (k + 1) % 3
        dx = x[:, j] - x[:, k]
        dy = y[:, j] - y[:, k]
        longest2 = np.maximum(longest2, dx * dx + dy * dy)
    longest = np.sqrt(longest2)
    stop = longest < p.stop_edge

    ux, uy, uz = x[:, 1] - x[:, 0], y[:, 1] - y[:, 0], z[:, 1] - z[:, 0]
    wx, wy, wz = x[:, 2] - x[:, 0], y[:, 2] - y[:, 0], z[:, 2] - z[:, 0]
    nx = uy * wz - uz * wy
    ny = uz * wx - ux * wz
    nz = ux * wy - uy * wx
    num = nx * (pxm - x[:, 0]) + ny * (pym - y[:, 0]) + nz * (pz - z[:, 0])
    d = np.abs(num) / np.sqrt(nx * nx + ny * ny + nz * nz)
    accepted = d <= p.iteration_distance

    # math.sin, as the core calls the C library's sin (NumPy may use its own).
    sin_limit = np.full(len(tri), math.sin(p.iteration_angle * _DEG_TO_RAD))
    reduced = np.flatnonzero(longest < p.reduce_angle_edge)
    sin_limit[reduced] = [
        math.sin(p.iteration_angle * float(L) / p.reduce_angle_edge * _DEG_TO_RAD)
        for L in longest[reduced]
    ]
    for k in range(3):
        dx, dy, dz = pxm - x[:, k], pym - y[:, k], pz - z[:, k]
        r = np.maximum(np.sqrt(dx * dx + dy * dy + dz * dz), p.near_vertex_distance)
        accepted &= d <= sin_limit * r

    cos_terrain = math.cos(p.max_terrain_angle * _DEG_TO_RAD)
    for k in range(3):
        j = (k + 1) % 3
        a, b = tri[:, k], tri[:, j]
        flat = _orient(vx[a], vy[a], vx[b], vy[b], px, py) == 0
        ax, ay, az = x[:, k] - pxm, y[:, k] - pym, z[:, k] - pz
        bx, by, bz = x[:, j] - pxm, y[:, j] - pym, z[:, j] - pz
        mx = ay * bz - az * by
        my = az * bx - ax * bz
        mz = ax * by - ay * bx
        steep = np.abs(mz) < cos_terrain * np.sqrt(mx * mx + my * my + mz * mz)
        accepted &= flat | ~steep
    return accepted, stop, d


def _lowest_of_densify_cells(
    xyz: np.ndarray, gx: np.ndarray, gy: np.ndarray, q: float, p: TinGroundParams
) -> np.ndarray:
    """Mask of the lowest point (z less the minimum z; ties: index) of each cell of side
    min(densify_cell, final_cell / 2) on the world lattice of that size, each point
    placed at its TIN grid position, origin + (grid - 1) * q, as the core places it."""
    size = min(p.densify_cell, p.final_cell / 2.0)
    lowest, upper = xyz.min(axis=0), xyz.max(axis=0)
    x0 = lattice_floor(float(lowest[0]), size) if size > 0 else lowest[0]  # as the core:
    y0 = lattice_floor(float(lowest[1]), size) if size > 0 else lowest[1]  # 0 cells refused
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        fits = (upper[0] - x0) / size < 2.0**40 and (upper[1] - y0) / size < 2.0**40
    if not fits:
        raise ValueError(
            "densify_cell is too small for the extent of points: its cells, of side "
            "min(densify_cell, final_cell / 2), would number more than 2^40 per axis"
        )
    cx = np.floor((lowest[0] + (gx - 1).astype(np.float64) * q - x0) / size).astype(np.int64)
    cy = np.floor((lowest[1] + (gy - 1).astype(np.float64) * q - y0) / size).astype(np.int64)
    tested = np.zeros(len(xyz), dtype=bool)
    tested[lowest_in_cells(xyz[:, 2] - lowest[2], cx, cy)] = True
    return tested


def tin_ground(
    points: npt.ArrayLike,
    *,
    max_building_size: float | None = None,
    max_terrain_angle: float | None = None,
    iteration_angle: float | None = None,
    iteration_distance: float | None = None,
    reduce_angle_edge: float | None = None,
    stop_edge: float | None = None,
    near_vertex_distance: float | None = None,
    seed_cell: float | None = None,
    seed_tolerance: float | None = None,
    outlier_depth: float | None = None,
    opening_rank: int | None = None,
    border_vertices: bool | None = None,
    final_cell: float | None = None,
    final_above: float | None = None,
    final_below: float | None = None,
    final_slope: float | None = None,
    final_low_depth: float | None = None,
    densify_cell: float | None = None,
    params: TinGroundParams | None = None,
) -> np.ndarray:
    """Reference progressive TIN densification: same signature and result as the core.

    Raises
    ------
    ValueError, TypeError
        As :func:`pcl_rg.tin_ground`.
    QhullPrecisionError
        Where qhull cannot resolve the TIN's vertices (:func:`triangulate`); the
        core has an answer there, this reference does not.

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg import reference
    >>> rng = np.random.default_rng(1)
    >>> pts = np.c_[rng.uniform(0, 40, (500, 2)), rng.normal(0, 0.05, 500)]
    >>> pts[:20, 2] += 5.0  # twenty points well above a flat terrain
    >>> ground = reference.tin_ground(pts, iteration_angle=30.0, reduce_angle_edge=0.01)
    >>> bool(ground[:20].any()), bool(ground[20:].mean() > 0.95)
    (False, True)
    """
    p = resolve_arguments(TinGroundParams, locals())
    xyz = as_points(points)
    n = len(xyz)
    if n == 0:
        return np.zeros(0, dtype=bool)
    seed_cell_unset = p.seed_cell is None
    p = with_spacing_lengths(p, lambda: point_spacing(xyz))
    if n < 3:
        raise ValueError(f"points must hold at least 3 points for a TIN, got {n}")

    # 1. Local frame and integer grid.
    local = xyz - xyz.min(axis=0)
    ex, ey, ez = local.max(axis=0)
    if not (math.isfinite(ex) and math.isfinite(ey)):
        raise ValueError("points: the XY extent is too large (not finite in float64)")
    if not math.isfinite(ez):
        raise ValueError("points: the z extent is too large (not finite in float64)")
    q = grid_quantum(max(ex, ey))
    gx = np.rint(local[:, 0] / q).astype(np.int64) + 1
    gy = np.rint(local[:, 1] / q).astype(np.int64) + 1
    width, height = int(np.rint(ex / q)) + 2, int(np.rint(ey / q)) + 2
    pz = local[:, 2]
    other = np.flatnonzero((gx != gx[0]) | (gy != gy[0]))
    if other.size == 0 or not _orient(gx[0], gy[0], gx[other[0]], gy[other[0]], gx, gy).any():
        raise ValueError(
            "points are all collinear in XY (or fewer than 3 distinct XY positions on the "
            "TIN's grid, whose step is the power of two at or above the XY extent / 2^29: "
            f"{q:g} m here; points far from "
            "the rest coarsen it): a TIN needs 3 points not on one line"
        )

    # 2. Seeds: lowest point (ties: index) of each max_building_size cell.
    try:
        seed = seeds_of(xyz, ex, ey, p)
    except ValueError as error:
        if not seed_cell_unset:
            raise
        cap = TinGroundParams.SPACING_CAPS["seed_cell"]
        multiple = TinGroundParams.SPACING_MULTIPLES["seed_cell"]
        spacing = point_spacing(xyz)
        unset = (
            f" (seed_cell was left unset: a rung of its ladder at most the least of "
            f"{format_value(cap)} m and "
            f"{format_value(multiple)} x the measured point spacing, {format_value(spacing)} m, "
        )
        if multiple * spacing > cap:
            raise ValueError(
                f"{error}{unset}so the cap, made for airborne densities; at this spacing set "
                f"seed_cell to about {format_value(multiple * spacing)} m)"
            ) from None
        raise ValueError(
            f"{error}{unset}which many points at one XY position make small)"
        ) from None
    ground = np.zeros(n, dtype=bool)
    ground[seed] = True
    by_xy = seed[np.lexsort((seed, gy[seed], gx[seed]))]
    first = np.r_[True, (gx[by_xy][1:] != gx[by_xy][:-1]) | (gy[by_xy][1:] != gy[by_xy][:-1])]
    vertex_seeds = by_xy[first]

    # Virtual corners, and with border_vertices points along the sides, at the height of
    # the nearest seed (exact distance, ties: lowest).
    border = None
    if p.border_vertices:
        border = border_points(width, height, ex, ey, max(p.max_building_size, min(ex, ey)))
    vx, vy, vz = with_corners(gx, gy, pz, seed, vertex_seeds, width, height, border)

    # 3. Densify until an iteration adds no ground point; with densify_cell, only the
    # lowest point of each of its cells is tested (tin_densified.cpp).
    tested = np.ones(n, dtype=bool)
    if p.densify_cell > 0 and p.final_cell > 0:
        tested = _lowest_of_densify_cells(xyz, gx, gy, q, p)
    while True:
        unclassified = np.flatnonzero(~ground & tested)
        if unclassified.size == 0:
            break
        tri, neighbors, vertex_to_simplex = triangulate(vx, vy, q)
        px, py = gx[unclassified], gy[unclassified]
        t = locate(tri, neighbors, vertex_to_simplex, vx, vy, px, py)
        accepted, stop, d = _evaluate(tri[t], vx, vy, vz, q, px, py, pz[unclassified], p)
        stopped = unclassified[accepted & stop]
        cand = accepted & ~stop
        ci, ct, cd = unclassified[cand], t[cand], d[cand]
        order = np.lexsort((ci, cd, ct))
        chosen = ci[order][np.r_[True, ct[order][1:] != ct[order][:-1]]] if ci.size else ci
        if stopped.size == 0 and chosen.size == 0:
            break
        ground[stopped] = True
        ground[chosen] = True
        new = ~np.isin(gx[chosen] * (1 << 31) + gy[chosen], vx * (1 << 31) + vy)
        vx = np.r_[vx, gx[chosen[new]]]
        vy = np.r_[vy, gy[chosen[new]]]
        vz = np.r_[vz, pz[chosen[new]]]
    if p.final_cell > 0:
        from ._final_pass import final_pass  # here: it imports this module's TIN

        ground = final_pass(
            xyz, ground, p.final_cell, p.final_above, p.final_below, p.final_slope,
            p.final_low_depth,
        )  # fmt: skip
    return ground
