"""The TIN of tin_ground: incremental Delaunay triangulation with exact predicates.

Every check is exact: the triangulation lives on an integer grid, and the tests
compute orientations and in-circle determinants with Python integers.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from conftest import examples
from hypothesis import given, settings
from hypothesis import strategies as st

from pcl_rg import _core
from pcl_rg.reference.tin_ground import triangulate as reference_triangulate


def orient(a, b, c):
    """Exact orientation (twice the signed area) with Python ints or Fractions."""
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def incircle(a, b, c, d) -> int:
    """Exact in-circle determinant with Python ints: > 0 when d is strictly inside."""
    rows = []
    for p in (a, b, c):
        dx, dy = int(p[0]) - int(d[0]), int(p[1]) - int(d[1])
        rows.append((dx, dy, dx * dx + dy * dy))
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = rows
    return a0 * (b1 * c2 - b2 * c1) - a1 * (b0 * c2 - b2 * c0) + a2 * (b0 * c1 - b1 * c0)


def check_triangulation(tin: _core.DelaunayTin) -> None:
    """Valid, counter-clockwise, covering the box, neighbours consistent, Delaunay."""
    v = tin.vertices.tolist()
    tri = tin.triangles.tolist()
    nbr = tin.neighbors.tolist()
    width, height = v[2]
    hull = sum(x in (0, width) or y in (0, height) for x, y in v)
    assert len(tri) == 2 * len(v) - hull - 2  # Euler: the box corners and border vertices
    twice_area = 0
    for t, (a, b, c) in enumerate(tri):
        area = orient(v[a], v[b], v[c])
        assert area > 0, f"triangle {t} is not counter-clockwise"
        twice_area += area
        for k in range(3):
            u = nbr[t][k]
            edge = {tri[t][(k + 1) % 3], tri[t][(k + 2) % 3]}
            if u < 0:  # on the box: both ends on the same box side
                p, q = (v[i] for i in edge)
                assert p[0] == q[0] in (0, width) or p[1] == q[1] in (0, height)
            else:
                # u links back across the same edge: opposite its vertex not on it.
                (j,) = (i for i in range(3) if tri[u][i] not in edge)
                assert nbr[u][j] == t and edge == set(tri[u]) - {tri[u][j]}
    assert twice_area == 2 * width * height
    # Global Delaunay property: no vertex strictly inside any circumcircle.
    for a, b, c in tri:
        assert all(incircle(v[a], v[b], v[c], p) <= 0 for p in v)


def located_in_closure(tin: _core.DelaunayTin, grid, triangles) -> None:
    v = tin.vertices.tolist()
    tri = tin.triangles.tolist()
    for p, t in zip(grid.tolist(), triangles.tolist()):
        a, b, c = (v[i] for i in tri[t])
        assert orient(a, b, p) >= 0 and orient(b, c, p) >= 0 and orient(c, a, p) >= 0


def build(points: np.ndarray, lower=(0.0, 0.0), upper=(10.0, 10.0)) -> tuple:
    tin = _core.DelaunayTin(lower[0], lower[1], upper[0], upper[1])
    ids = tin.insert(np.ascontiguousarray(points, dtype=np.float64))
    return tin, ids


def check_vertices(tin: _core.DelaunayTin, points: np.ndarray, ids: np.ndarray) -> None:
    """Each point sits on its vertex; equal grid positions share one vertex."""
    grid = tin.to_grid(np.ascontiguousarray(points, dtype=np.float64))
    np.testing.assert_array_equal(tin.vertices[ids], grid)
    assert len(tin.vertices) == 4 + len(np.unique(grid, axis=0))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_points(seed: int) -> None:
    points = np.random.default_rng(seed).uniform(0.0, 10.0, (150, 2))
    tin, ids = build(points)
    check_triangulation(tin)
    check_vertices(tin, points, ids)
    grid = tin.to_grid(points)
    located_in_closure(tin, grid, tin.locate(points))


def test_gridded_points_are_cocircular_everywhere() -> None:
    # A square lattice: every cell's four corners are co-circular, so the
    # triangulation is one of many valid ones; it must still be valid and Delaunay.
    xs = np.arange(1.0, 10.0)
    points = np.array([(x, y) for x in xs for y in xs])
    tin, _ = build(points[np.random.default_rng(4).permutation(len(points))])
    check_triangulation(tin)
    assert len(tin.vertices) == 4 + len(points)


def triangles_by_position(tin: _core.DelaunayTin) -> np.ndarray:
    """The triangles that hold one (T, 6): each row its vertices' grid x, y, from the
    lexicographically smallest on, counter-clockwise; rows sorted. Equal for two TINs
    exactly when they are the same triangulation, whatever the ids."""
    corners = tin.vertices[tin.triangles[tin.live]]  # (T, 3, 2)
    key = corners[..., 0] * (1 << 31) + corners[..., 1]
    turn = (np.argmin(key, axis=1)[:, None] + np.arange(3)) % 3
    rows = np.take_along_axis(corners, turn[..., None], axis=1).reshape(-1, 6)
    return rows[np.lexsort(rows.T[::-1])]


def cocircular_cloud(side: int, extra: int, seed: int) -> np.ndarray:
    """A side x side lattice (every cell's corners co-circular), `extra` points on a
    finer lattice, and repeats of some of both, shuffled."""
    rng = np.random.default_rng(seed)
    xs = np.arange(1.0, side + 1.0)
    lattice = np.stack(np.meshgrid(xs, xs), axis=-1).reshape(-1, 2)
    finer = np.round(rng.uniform(0.5, side + 0.5, (extra, 2)) * 2.0) / 2.0
    cloud = np.vstack([lattice, finer, lattice[: side * 2], finer[:50]])
    return np.ascontiguousarray(cloud[rng.permutation(len(cloud))])


def test_cocircular_points_give_one_triangulation_whatever_the_order() -> None:
    # The in-circle test breaks ties by the points' coordinates (a symbolic perturbation
    # of the lifted heights), not by which diagonal came first.
    cloud = cocircular_cloud(12, 60, seed=5)
    upper = (13.0, 13.0)
    first, _ = build(cloud, upper=upper)
    check_triangulation(first)
    for seed in (1, 2, 3):
        again, ids = build(cloud[np.random.default_rng(seed).permutation(len(cloud))], upper=upper)
        np.testing.assert_array_equal(triangles_by_position(again), triangles_by_position(first))


def test_insert_batch_builds_the_triangulation_of_insert() -> None:
    # Large enough for the parallel strips and the first sample (kBatchParallelMin);
    # co-circular everywhere, with repeated points, so ties and dead ids occur.
    cloud = cocircular_cloud(170, 8000, seed=6)
    assert len(cloud) >= 32768
    one_by_one = _core.DelaunayTin(0.0, 0.0, 171.0, 171.0)
    one_by_one.insert(cloud)
    batch = _core.DelaunayTin(0.0, 0.0, 171.0, 171.0)
    ids = batch.insert(cloud, batch=True)
    np.testing.assert_array_equal(triangles_by_position(batch), triangles_by_position(one_by_one))
    # Each point on its vertex; points of one XY share it; dead ids hold no vertex.
    grid = batch.to_grid(cloud)
    np.testing.assert_array_equal(batch.vertices[ids], grid)
    distinct = len(np.unique(grid, axis=0))
    assert len(batch.vertices) - batch.dead_vertices == 4 + distinct
    assert batch.dead_vertices > 0  # the repeats left some ids unused
    alive = np.flatnonzero(batch.live)
    assert len(alive) == 2 * (4 + distinct) - 6  # Euler, as in check_triangulation
    # Links only between live triangles, and back across the same edge.
    tri, nbr = batch.triangles, batch.neighbors
    for t in alive[:: max(1, len(alive) // 3000)].tolist():
        for k in range(3):
            u = nbr[t, k]
            if u < 0:
                continue
            assert batch.live[u]
            edge = {tri[t, (k + 1) % 3], tri[t, (k + 2) % 3]}
            (j,) = (i for i in range(3) if tri[u, i] not in edge)
            assert nbr[u, j] == t
    # Points located afterwards land in live triangles holding them.
    sample = np.ascontiguousarray(cloud[:: len(cloud) // 400])
    located = batch.locate(sample)
    assert batch.live[located].all()
    located_in_closure(batch, batch.to_grid(sample), located)


def test_insert_batch_into_a_tin_walks_from_hints() -> None:
    # A second large batch into a TIN that is not much coarser (no sample goes first)
    # and without starts: the strips start their walks from the old triangles.
    cloud = cocircular_cloud(250, 20000, seed=7)
    older, newer = cloud[:40000], cloud[40000:]
    assert len(newer) >= 32768 and len(newer) < 32 * len(older)
    one_by_one = _core.DelaunayTin(0.0, 0.0, 251.0, 251.0)
    one_by_one.insert(cloud)
    batch = _core.DelaunayTin(0.0, 0.0, 251.0, 251.0)
    batch.insert(older, batch=True)
    ids = batch.insert(newer, batch=True)
    np.testing.assert_array_equal(triangles_by_position(batch), triangles_by_position(one_by_one))
    np.testing.assert_array_equal(batch.vertices[ids], batch.to_grid(newer))


def test_collinear_points_then_one_off_the_line() -> None:
    line = np.c_[np.linspace(1.0, 9.0, 40), np.linspace(1.0, 9.0, 40)]
    tin, ids = build(line)
    check_triangulation(tin)  # the box corners make every step a proper triangulation
    ids2 = tin.insert(np.array([[2.0, 8.0]]))
    check_triangulation(tin)
    assert len(set(ids.tolist() + ids2.tolist())) == 41


def test_duplicates_are_located_on_their_vertex() -> None:
    points = np.random.default_rng(5).uniform(0.0, 10.0, (60, 2))
    tin, ids = build(np.vstack([points, points[::-1], points[:10]]))
    check_triangulation(tin)
    assert len(tin.vertices) == 64
    n = len(points)
    np.testing.assert_array_equal(ids[n : 2 * n], ids[:n][::-1])
    np.testing.assert_array_equal(ids[2 * n :], ids[:10])


def test_points_on_edges_and_box_sides() -> None:
    # Midpoints of a lattice lie on existing edges; bound points lie one grid step
    # inside the box sides.
    lattice = np.array([(x, y) for x in (2.0, 4.0, 6.0) for y in (2.0, 4.0, 6.0)])
    tin, _ = build(lattice)
    mids = np.array([(3.0, 2.0), (2.0, 3.0), (3.0, 3.0), (5.0, 5.0), (0.0, 0.0), (10.0, 5.0)])
    tin.insert(mids)
    check_triangulation(tin)


def test_border_vertices_split_the_box_sides_whatever_the_order() -> None:
    # Virtual vertices on the box's sides (tin_ground's border_vertices): each splits
    # the triangle on its stretch of the side. Before or after the points, the
    # triangulation is the same valid Delaunay one, and qhull's (with the reference's
    # flips) on the same vertices; a corner or a repeat gives the existing vertex.
    points = np.random.default_rng(8).uniform(0.0, 10.0, (80, 2))
    probe = _core.DelaunayTin(0.0, 0.0, 10.0, 10.0)
    width, height = probe.vertices[2]
    border = np.array(
        [(width // 3, 0), (width // 2, height), (0, height // 4), (width, 1), (width, height - 1)]
        + [(width // 3, 0), (0, 0), (width, height)],
        dtype=np.int32,
    )
    first, _ = build(np.empty((0, 2)))
    ids = first.insert_on_border(border)
    assert ids[5] == ids[0] and ids[6] == 0 and ids[7] == 2  # repeat and corners
    first.insert(points)
    last, _ = build(points)
    last.insert_on_border(border[::-1].copy())
    for tin in (first, last):
        check_triangulation(tin)
        assert len(tin.vertices) == 4 + 5 + len(points)
    assert triangles_by_position(first).tolist() == triangles_by_position(last).tolist()
    vertices = first.vertices.astype(np.int64)
    tri, _, _ = reference_triangulate(vertices[:, 0], vertices[:, 1], 1.0)
    corners = vertices[tri]
    assert as_sets(corners) == as_sets(vertices[first.triangles])
    with pytest.raises(ValueError, match="on the box"):
        first.insert_on_border(np.array([[1, 1]], dtype=np.int32))


def test_location_breaks_ties_by_the_perturbation() -> None:
    """A point on an edge or vertex is located where p + (eps, eps^2) lies."""
    points = np.random.default_rng(6).uniform(0.0, 10.0, (40, 2))
    tin, _ = build(points)
    v = tin.vertices.tolist()
    tri = tin.triangles.tolist()
    # Queries exactly on vertices and on edge midpoints (when representable).
    queries = [v[i] for i in range(4, len(v))]
    queries += [((v[a][0] + v[b][0]) // 2, (v[a][1] + v[b][1]) // 2) for a, b, _ in tri]
    q = tin.quantum
    xy = np.array([((gx - 1) * q, (gy - 1) * q) for gx, gy in queries])
    keep = (xy >= 0).all(axis=1) & (xy <= 10.0).all(axis=1)
    xy = xy[keep]
    grid = tin.to_grid(xy).tolist()
    eps = Fraction(1, 2**40)  # small enough for coordinates below 2^31 (see delaunay.cpp)
    for p, t in zip(grid, tin.locate(xy).tolist()):
        pp = (p[0] + eps, p[1] + eps * eps)
        a, b, c = (v[i] for i in tri[t])
        assert orient(a, b, pp) > 0 and orient(b, c, pp) > 0 and orient(c, a, pp) > 0


def test_the_grid_is_fine_and_exact() -> None:
    for extent in (1e-9, 1e-3, 1.0, 250.0, 4321.5, 3e6):
        tin = _core.DelaunayTin(5e5, 5e6, 5e5 + extent, 5e6 + extent)
        q = tin.quantum
        assert math.frexp(q)[0] == 0.5  # a power of two
        assert q >= extent / 2**29 and (q == 2.0**-40 or q / 2 < extent / 2**29)
        xy = np.array([[5e5, 5e6], [5e5 + extent, 5e6 + extent / 3]])
        grid = tin.to_grid(xy)
        assert grid.min() >= 1 and tin.vertices.max() <= 2**30
        back = (grid - 1) * q + np.array([5e5, 5e6])
        assert np.all(np.abs(back - xy) <= q / 2 + 1e-9 * np.abs(xy))


def test_delaunay_triangulate_indexes_input_rows() -> None:
    rng = np.random.default_rng(7)
    xy = rng.uniform(-50.0, 50.0, (300, 2))
    xy = np.vstack([xy, xy[:5]])  # duplicates come back as their first row
    tri = _core.delaunay_triangulate(xy)
    assert tri.dtype == np.int64 and tri.shape[1] == 3 and len(tri) > 0
    assert tri.max() < 300
    tin = _core.DelaunayTin(*xy.min(axis=0), *xy.max(axis=0))
    g = tin.to_grid(xy).tolist()
    for a, b, c in tri.tolist():
        assert orient(g[a], g[b], g[c]) > 0
    # Delaunay among the input points (the box corners were left out of the answer).
    sample = tri[rng.choice(len(tri), 60, replace=False)].tolist()
    for a, b, c in sample:
        assert all(incircle(g[a], g[b], g[c], p) <= 0 for p in g)
    assert _core.delaunay_triangulate(np.zeros((0, 2))).shape == (0, 3)


def test_delaunay_triangulate_of_many_points_names_each_vertex_by_its_first_row() -> None:
    # Enough rows for insert_batch's strips; repeats on a coarse lattice.
    rng = np.random.default_rng(8)
    xy = np.round(rng.uniform(0.0, 120.0, (40_000, 2)) * 2.0) / 2.0
    tri = _core.delaunay_triangulate(xy)
    tin = _core.DelaunayTin(*xy.min(axis=0), *xy.max(axis=0))
    g = tin.to_grid(xy).astype(np.int64)
    _, first_rows = np.unique(g, axis=0, return_index=True)
    np.testing.assert_array_equal(np.unique(tri), np.sort(first_rows))
    assert (orient(g[tri[:, 0]].T, g[tri[:, 1]].T, g[tri[:, 2]].T) > 0).all()
    # The same triangles as one-by-one insertion, less those of the box corners.
    tin.insert(np.ascontiguousarray(xy))
    corner = (tin.triangles < 4).any(axis=1)
    assert as_sets(g[tri]) == as_sets(tin.vertices[tin.triangles[~corner]])


def as_sets(corners: np.ndarray) -> set:
    """Triangles (T, 3, 2) as a set of vertex sets, whatever the rotation."""
    return {frozenset(map(tuple, row.tolist())) for row in corners}


def test_errors() -> None:
    with pytest.raises(ValueError, match="finite"):
        _core.DelaunayTin(0.0, float("nan"), 1.0, 1.0)
    with pytest.raises(ValueError, match="lower <= upper"):
        _core.DelaunayTin(2.0, 0.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="too large"):
        _core.DelaunayTin(-1e308, 0.0, 1e308, 1.0)
    tin = _core.DelaunayTin(0.0, 0.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="outside the bounds"):
        tin.insert(np.array([[0.5, 1.5]]))
    with pytest.raises(ValueError, match="outside the bounds"):
        tin.locate(np.array([[np.nan, 0.5]]))
    with pytest.raises(ValueError, match=r"shape \(M, 2\)"):
        tin.insert(np.zeros((3, 3)))
    with pytest.raises(TypeError):
        tin.insert(np.zeros((3, 2), dtype=np.float32))  # no silent conversion
    assert len(tin.vertices) == 4  # nothing was inserted by the failed calls


@settings(max_examples=examples(60), deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 6), st.integers(0, 6))
        | st.tuples(st.floats(0, 6), st.floats(0, 6)),
        min_size=1,
        max_size=40,
    )
)
def test_hypothesis_any_point_set_gives_a_valid_delaunay_tin(points) -> None:
    # Small integer lattices make duplicates, collinear and co-circular points common.
    xy = np.array(points, dtype=np.float64)
    tin, ids = build(xy, upper=(6.0, 6.0))
    check_triangulation(tin)
    check_vertices(tin, xy, ids)
    located_in_closure(tin, tin.to_grid(xy), tin.locate(xy))


@pytest.mark.parametrize("seed", [5, 6])
def test_the_reference_triangulation_is_the_cores_on_cocircular_points(seed: int) -> None:
    # qhull picks any diagonal where four vertices are co-circular; the reference then
    # flips to the core's choice (reference._delaunay): the same triangles, box included.
    tin, _ = build(cocircular_cloud(12, 60, seed=seed), upper=(13.0, 13.0))
    vertices = tin.vertices.astype(np.int64)
    tri, _, _ = reference_triangulate(vertices[:, 0], vertices[:, 1], 1.0)
    corners = vertices[tri]
    key = corners[..., 0] * (1 << 31) + corners[..., 1]
    turn = (np.argmin(key, axis=1)[:, None] + np.arange(3)) % 3
    rows = np.take_along_axis(corners, turn[..., None], axis=1).reshape(-1, 6)
    np.testing.assert_array_equal(rows[np.lexsort(rows.T[::-1])], triangles_by_position(tin))


def test_the_flips_end_on_many_points_on_one_circle() -> None:
    # The 16 lattice points with x^2 + y^2 = 125, without box corners: qhull's 14
    # triangles need up to 16 rounds of flips in some orders (a review found the former
    # bound of one round per triangle too tight). Any order ends in one triangulation.
    from scipy.spatial import Delaunay

    from pcl_rg.reference._delaunay import follow_perturbation

    circle = [(x, y) for x in range(-12, 13) for y in range(-12, 13) if x * x + y * y == 125]
    xy = np.array(circle, dtype=np.int64) + 100
    results = set()
    for seed in range(12):
        order = np.random.default_rng(seed).permutation(len(xy))
        tri = order[Delaunay(xy[order].astype(float)).simplices].astype(np.int64)
        flipped = orient(xy[tri[:, 0]].T, xy[tri[:, 1]].T, xy[tri[:, 2]].T) < 0
        tri[flipped] = tri[flipped][:, [0, 2, 1]]
        done = follow_perturbation(tri, xy[:, 0], xy[:, 1])
        results.add(tuple(sorted(tuple(sorted(row)) for row in done.tolist())))
    assert len(results) == 1
