"""final_low_depth, the final pass's test of ground points far below their surroundings
(final_pass_low.cpp): core vs reference, its effect on a patch of low points, order
independence. Thread independence: tests/thread_probe.py runs both filters with it."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import shared_data

import pcl_rg
from pcl_rg import reference
from pcl_rg.datasets import load_isprs, synthetic_scene
from pcl_rg.reference._final_pass import final_pass

FILTERS = [
    (pcl_rg.grid_ground, reference.grid_ground),
    (pcl_rg.tin_ground, reference.tin_ground),
]
IDS = ["grid", "tin"]


def plane_with_patch(
    depth: float,
    side: float = 6.0,
    count: int = 200,
    centre=(50.0, 50.0),
    seed: int = 1,
    size: float = 100.0,
) -> tuple[np.ndarray, int]:
    """A `size` m square plane rising 0.3 per m at 4 points per m^2, then a square patch
    of `count` points `depth` below it at `centre` (a cluster of multipath echoes)."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0.0, size, (int(4 * size * size), 2))
    plane = np.c_[xy, 0.3 * xy[:, 0] + rng.normal(0.0, 0.03, len(xy))]
    pxy = np.asarray(centre) + rng.uniform(-side / 2, side / 2, (count, 2))
    patch = np.c_[pxy, 0.3 * pxy[:, 0] - depth + rng.normal(0.0, 0.1, count)]
    return np.r_[plane, patch], len(plane)


@pytest.mark.parametrize("core", [core for core, _ in FILTERS], ids=IDS)
def test_a_deep_patch_of_low_points_is_no_ground(core):
    # The reference's verdicts on such a patch: test_core_equals_reference_on_a_scene.
    points, n = plane_with_patch(depth=12.0)
    without = core(points, final_low_depth=0.0)
    assert without[n:].mean() > 0.5  # the defect: the patch is taken as ground
    with_low = core(points)  # the defaults: final_low_depth 2 m
    assert not with_low[n:].any()
    assert with_low[:n].mean() >= without[:n].mean()  # the plane loses nothing
    # A patch as deep as final_below is ground by design, with the option or without.
    shallow, n = plane_with_patch(depth=3.0)
    assert core(shallow)[n:].mean() > 0.9


def test_a_deep_patch_away_from_the_edges_is_no_ground():
    """Two places on a 150 m plane, 18 m or more inside it, where a window of 7
    adjacent final cells (11 m of tin_ground's 1.6 m cells at 4 points per m^2) was
    filled by the patch and the ring of terrain the densification leaves as object
    around it, so that 100 and 109 of the patch's 200 points stayed ground (the
    reference with WINDOW_METRES = 0, a stride of 1); the window taken every
    second cell (window_stride) spans 21 m. Near an edge the window is cut off, and a
    patch there can stay ground."""
    for centre, seed in (((50.2, 26.0), 3), ((61.3, 18.5), 9)):
        points, n = plane_with_patch(depth=12.0, centre=centre, seed=seed, size=150.0)
        for core, _ in FILTERS:
            ground = core(points)
            assert not ground[n:].any(), (core.__name__, centre)
            assert ground[:n].mean() > 0.99, (core.__name__, centre)


@pytest.mark.parametrize(("core", "ref"), FILTERS, ids=IDS)
@pytest.mark.parametrize(("depth", "density"), [(0.5, 5.0), (2.0, 2.0)])
def test_core_equals_reference_on_a_scene(core, ref, depth, density):
    """Random XY: the TINs are unique, and the window medians are the same numbers.
    The scene gets a patch of 40 low points, 10 m below its lowest point near the middle.
    At 5 points per m^2 tin_ground's final cell is 1.4 m, and its window takes every
    second cell."""
    points = synthetic_scene(seed=7, size=90.0, density=density, n_buildings=2, n_trees=10).points
    middle = points[:, :2].mean(axis=0)
    below = points[np.abs(points[:, :2] - middle).max(axis=1) < 5.0, 2].min() - 10.0
    rng = np.random.default_rng(3)
    points = np.r_[points, np.c_[middle + rng.uniform(-1.5, 1.5, (40, 2)), np.full(40, below)]]
    got = core(points, final_low_depth=depth)
    np.testing.assert_array_equal(got, ref(points, final_low_depth=depth))
    assert (got != core(points, final_low_depth=0.0)).any()  # it acts (else this could not fail)
    order = rng.permutation(len(points))
    np.testing.assert_array_equal(core(points[order], final_low_depth=depth), got[order])


def rough_survey(
    seed: int = 18,
    n: int = 90_000,
    size: float = 120.0,
    tilt: tuple[float, float] = (0.2, -0.1),
    z_step: float = 0.0,
) -> np.ndarray:
    """A `size` m square sloping by `tilt` at about 6 points per m^2 with four buildings
    (30 % of the points under each left on the ground), five patches of multipath points
    3-9 m under the terrain, XY on a 0.25 m lattice (z too on a lattice of `z_step` when
    it is > 0) and 5,000 copies, shuffled."""
    rng = np.random.default_rng(seed)
    tilt = np.array(tilt)
    xy = rng.uniform(0.0, size, (n, 2))
    z = xy @ tilt + rng.normal(0.0, 0.05, n)
    for _ in range(4):
        centre, height, width = rng.uniform(0.0, size, 2), rng.uniform(3, 15), rng.uniform(4, 15)
        on_roof = (np.abs(xy - centre) < width / 2).all(axis=1) & (rng.random(n) < 0.7)
        z[on_roof] += height
    parts = [np.c_[xy, z]]
    for _ in range(5):
        centre, side = rng.uniform(0.0, size, 2), rng.uniform(2.0, 12.0)
        pxy = centre + rng.uniform(-side / 2, side / 2, (300, 2))
        depth = rng.uniform(3.0, 9.0)
        parts.append(np.c_[pxy, pxy @ tilt - depth + rng.normal(0.0, 0.1, len(pxy))])
    points = np.concatenate(parts)
    points[:, :2] = np.round(points[:, :2] / 0.25) * 0.25
    if z_step > 0.0:
        points[:, 2] = np.round(points[:, 2] / z_step) * z_step
    points = np.concatenate([points, points[rng.integers(0, len(points), 5000)]])
    return points[rng.permutation(len(points))]


def test_core_equals_reference_beyond_the_serial_size():
    """More than 64 Ki points: the core's parallel paths, where each thread gathers the
    kept points of the cells with a threshold, the least of which is the cell's vertex
    (final_pass_low.cpp), and the ground points of the outermost cells
    (final_pass_border.cpp). With 2 m final cells and a 0.5 m depth many cells have a
    threshold, and their kept points (ground beside a building, a roof taken for
    ground) differ in height, so a vertex other than the least kept point, or one lost
    with a thread's share, changes the mask."""
    points = rough_survey()
    assert len(points) > 65536
    options = {"final_cell": 2.0, "final_low_depth": 0.5, "final_passes": 3}
    got = pcl_rg.grid_ground(points, **options)
    np.testing.assert_array_equal(got, reference.grid_ground(points, **options))
    assert (got != pcl_rg.grid_ground(points, **{**options, "final_low_depth": 0.0})).any()


@pytest.mark.parametrize(
    ("final_cell", "by_position"), [(1.5, True), (0.75, False)], ids=["by-position", "by-input"]
)
@pytest.mark.parametrize("depth", [0.25, 0.0])
def test_grid_final_pass_scans_either_order_as_the_reference(final_cell, by_position, depth):
    """grid_ground hands the final pass each point's cell in its grid's order when the
    cells hold 8 points or more on average (final_cells_by_position), and the pass then
    scans that order; with smaller cells it scans the input. Both must be the
    reference's, with the low-point test on and off. The cloud rises towards every
    side but one (the side vertices' caps then matter), has low vegetation near the
    final pass's threshold above the TIN, and its XY lie on a 0.25 m lattice,
    so that many points lie on the edges of 1.5 and 0.75 m cells, where the grid's cell
    finding falls back on a division (CellOf), and its heights on a 0.25 m one, so that
    distinct points tie in height and with a cell's threshold, median - depth."""
    points = rough_survey(seed=19, n=70_000, size=100.0, tilt=(0.15, 0.25), z_step=0.25)
    # Low vegetation, 0.25-2 m up: points on either side of the final pass's threshold
    # above the TIN, whose verdicts a vertex a step higher or lower moves.
    rng = np.random.default_rng(20)
    shrubs = points[rng.integers(0, len(points), 4000)] + [0.0, 0.0, 0.0]
    shrubs[:, 2] += np.round(rng.uniform(0.25, 2.0, len(shrubs)) / 0.25) * 0.25
    points = np.concatenate([points, shrubs])
    assert len(points) > 65536  # the parallel paths
    cells = (np.ptp(points[:, 0]) / final_cell + 1) * (np.ptp(points[:, 1]) / final_cell + 1)
    assert (len(points) / cells >= 8) == by_position  # the side of the rule, about
    options = {"final_cell": final_cell, "final_low_depth": depth, "final_passes": 2}
    got = pcl_rg.grid_ground(points, **options)
    np.testing.assert_array_equal(got, reference.grid_ground(points, **options))
    if depth > 0.0:
        assert (got != pcl_rg.grid_ground(points, **{**options, "final_low_depth": 0.0})).any()


@pytest.mark.parametrize(("core", "ref"), FILTERS, ids=IDS)
def test_isprs_core_equals_reference(core, ref):
    """samp41: two ground levels 6 m apart, where the option acts most on ISPRS."""
    points, _ = load_isprs(
        shared_data("isprs", "samp41-utm.pcd"), shared_data("isprs", "samp41-utm-ground.pcd")
    )
    got = core(points, final_low_depth=2.0)
    np.testing.assert_array_equal(got, ref(points, final_low_depth=2.0))
    assert (got != core(points, final_low_depth=0.0)).any()


@pytest.mark.parametrize(("core", "ref"), FILTERS, ids=IDS)
def test_core_equals_reference_on_a_sparse_lattice(core, ref):
    """Two patches of terrain 5 km apart with 1 m final cells: more cells than the
    raster of cells takes (final_pass_low.cpp's sorted path); a cluster 4 m low in each."""
    rng = np.random.default_rng(4)
    parts = []
    for corner in (0.0, 5000.0):
        xy = corner + rng.uniform(0.0, 40.0, (4000, 2))
        parts.append(np.c_[xy, 0.2 * xy[:, 0] + rng.normal(0.0, 0.05, len(xy))])
        pxy = corner + 20.0 + rng.uniform(-1.5, 1.5, (40, 2))
        parts.append(np.c_[pxy, 0.2 * pxy[:, 0] - 4.0])
    points = np.concatenate(parts)
    got = core(points, final_cell=1.0, final_low_depth=1.0)
    np.testing.assert_array_equal(got, ref(points, final_cell=1.0, final_low_depth=1.0))
    assert (got != core(points, final_cell=1.0, final_low_depth=0.0)).any()


def test_the_reference_gives_no_ground_for_no_ground():
    xyz = np.random.default_rng(5).uniform(0.0, 10.0, (30, 3))
    assert not final_pass(xyz, np.zeros(30, bool), 3.0, 0.5, 5.0, 1.0, 2.0).any()
