"""grid_ground: core == reference point for point, invariants, errors, real data."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import ISPRS_SAMPLES, examples, run_in_threads, shared_data
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import pcl_rg
from pcl_rg import GridGroundParams, _core, reference
from pcl_rg.datasets import GROUND, load_isprs, synthetic_scene
from pcl_rg.evaluation import ground_errors
from pcl_rg.reference.grid_ground import grid_neighbours

DEFINITION = GridGroundParams.definition()


def assert_core_equals_reference(points, params):
    core = pcl_rg.grid_ground(points, params=params)
    expected = reference.grid_ground(points, params=params)
    assert core.dtype == np.bool_ and core.shape == (len(points),)
    np.testing.assert_array_equal(core, expected)
    return core


@pytest.fixture(scope="module")
def scene():
    """A small synthetic scene (70 m square, about 12k points) with its labels."""
    return synthetic_scene(seed=3, size=70.0, density=2.5, n_buildings=2, n_trees=6)


# --------------------------------------------------------------------------
# core vs reference


PARAMETER_GRID = [
    DEFINITION,
    GridGroundParams.definition(block_size=10, cell_size=1, slope=0.3),
    GridGroundParams.definition(block_size=(25, 12), cell_size=(2.5, 1.5), slope=0.6),
    GridGroundParams.definition(block_size=7, cell_size=3, slope=1.5, height_tolerance=0.2),
    GridGroundParams.definition(block_size=20, cell_size=0.7, slope=0.0, height_tolerance=0.05),
    GridGroundParams.definition(min_seed_component=20),
    GridGroundParams.definition(grow_across_blocks=True, block_size=15, cell_size=2),
    GridGroundParams.definition(filter_passes=1),
    GridGroundParams(),
    GridGroundParams(cell_size=1.0, filter_passes=2, min_seed_component=5),
    GridGroundParams(block_size=12, cell_size=(2, 4), filter_slope=0.5, filter_tolerance=0.1),
    GridGroundParams(grow_across_blocks=False, filter_passes=4),
    GridGroundParams(final_passes=2),
    GridGroundParams(outlier_depth=1.0, final_below=5.0),
    GridGroundParams.definition(outlier_depth=0.5, filter_passes=1),
    GridGroundParams(final_passes=3, final_cell=3.0, final_above=0.5),
]


@pytest.mark.parametrize("params", PARAMETER_GRID, ids=range(len(PARAMETER_GRID)))
def test_core_equals_reference_on_synthetic_scenes(scene, params):
    assert_core_equals_reference(scene.points, params)


@pytest.mark.parametrize("seed", [1, 2])
def test_core_equals_reference_on_other_seeds(seed):
    s = synthetic_scene(seed=seed, size=70.0, density=1.5, n_buildings=1, n_trees=4)
    for params in (DEFINITION, GridGroundParams()):
        assert_core_equals_reference(s.points, params)


def test_sparse_grids_equal_reference():
    """Clusters far apart: the cell and block grids are far larger than the cloud, so the
    core numbers occupied cells and blocks by sorting instead of a dense array."""
    rng = np.random.default_rng(5)
    clusters = [
        rng.uniform(0, 8, (300, 3)) + offset
        for offset in ([0, 0, 0], [2000, 0, 5], [0, 1500, -3], [2000, 1500, 1])
    ]
    points = np.vstack(clusters)
    for params in (
        GridGroundParams.definition(block_size=1.0, cell_size=0.5, slope=0.8),
        GridGroundParams(block_size=3.0, cell_size=0.4),
    ):
        ground = assert_core_equals_reference(points, params)
        assert ground.any()


def test_huge_extent_with_tiny_cells():
    points = np.array([[0.0, 0.0, 0.0], [1e9, 1e9, 0.0], [1.0, 0.0, 0.0]])
    params = GridGroundParams.definition(block_size=1e-3, cell_size=1e-3)
    np.testing.assert_array_equal(pcl_rg.grid_ground(points, params=params), [True, True, True])
    with pytest.raises(ValueError, match="cell_size is too small"):
        pcl_rg.grid_ground(
            points, params=dataclasses.replace(params, cell_size=1e-5, block_size=1e-5)
        )


# --------------------------------------------------------------------------
# the definition on hand-made clouds


def test_one_point_is_ground():
    for params in (DEFINITION, GridGroundParams()):
        np.testing.assert_array_equal(pcl_rg.grid_ground([[1.0, 2.0, 3.0]], params=params), [True])


def test_empty_input():
    ground = pcl_rg.grid_ground(np.empty((0, 3)))
    assert ground.dtype == np.bool_ and ground.shape == (0,)
    assert reference.grid_ground(np.empty((0, 3))).shape == (0,)


def test_flat_plane_is_all_ground():
    rng = np.random.default_rng(0)
    points = np.c_[rng.uniform(0, 100, (5000, 2)), np.full(5000, 7.0)]
    for params in (DEFINITION, GridGroundParams(), GridGroundParams.definition(slope=0.0)):
        assert pcl_rg.grid_ground(points, params=params).all()


def test_vertical_wall():
    """A wall x = 0 of points every 0.5 m, 10 m wide and 10 m high.

    With 0.5 m cells a point's neighbours are at most 0.5 m away along the wall, where
    the slope rule (0.3) allows 0.15 m: only the foot links. With 3 m cells the rule
    reaches 6 m and zig-zags up the wall (dz 0.5 over dy 2): the plain rule takes the
    whole wall. The defaults' slope filter drops every point standing more than its
    0.5 m tolerance over the one below it, so only the foot and the row 0.5 m above it
    are left (the final pass, 0.8 m above the foot, adds no other)."""
    y, z = np.meshgrid(np.arange(0, 10, 0.5), np.arange(0, 10.5, 0.5))
    points = np.c_[np.zeros(y.size), y.ravel(), z.ravel()]
    foot = points[:, 2] == 0.0
    fine = GridGroundParams.definition(block_size=10, cell_size=0.5, slope=0.3)
    np.testing.assert_array_equal(assert_core_equals_reference(points, fine), foot)
    coarse = dataclasses.replace(fine, cell_size=3.0)
    assert assert_core_equals_reference(points, coarse).all()
    lowest_rows = points[:, 2] <= 0.5
    np.testing.assert_array_equal(
        assert_core_equals_reference(points, GridGroundParams()), lowest_rows
    )


def test_box_on_a_slope():
    """The docstring scene: a 6 m box on a 5 % slope is object, all terrain is ground."""
    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 60, (8000, 2))
    z = 0.05 * xy[:, 0]
    roof = (np.abs(xy - 30) < 6).all(axis=1)
    z[roof] += 6.0
    points = np.c_[xy, z]
    plain = GridGroundParams.definition(block_size=60, cell_size=1, slope=0.3)
    for params in (plain, GridGroundParams()):
        np.testing.assert_array_equal(pcl_rg.grid_ground(points, params=params), ~roof)


def test_link_rule_boundary_is_inclusive():
    """|dz| <= S * d + t links: exactly on the bound is linked, just above is not."""
    plain = GridGroundParams.definition(block_size=10, cell_size=2, slope=0.5)
    on = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.5]])
    above = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, np.nextafter(0.5, 1)]])
    np.testing.assert_array_equal(pcl_rg.grid_ground(on, params=plain), [True, True])
    np.testing.assert_array_equal(pcl_rg.grid_ground(above, params=plain), [True, False])


def test_links_reach_only_the_neighbouring_cells():
    # Cells of 1 m: x = 0.5 (cell 0) and x = 2.5 (cell 2) are not neighbours; 1.5 bridges.
    plain = GridGroundParams.definition(block_size=10, cell_size=1, slope=1.0)
    gap = np.array([[0.5, 0.5, 0.0], [2.5, 0.5, 0.0]])
    np.testing.assert_array_equal(pcl_rg.grid_ground(gap, params=plain), [True, False])
    bridged = np.vstack([gap, [[1.5, 0.5, 0.0]]])
    assert pcl_rg.grid_ground(bridged, params=plain).all()


def test_blocks_have_their_own_seed_and_no_links_between_them():
    # Two terraces 5 m apart in height, each in its own 10 m block (anchored at x = 0).
    x = np.arange(0.25, 20, 0.5)
    points = np.c_[x, np.zeros_like(x), np.where(x < 10, 0.0, 5.0)]
    points = np.vstack([points, [[15.0, 0.0, 9.0]]])  # a roof point over the 2nd terrace
    plain = GridGroundParams.definition(block_size=10, cell_size=1, slope=0.2)
    expected = np.r_[np.ones(len(x), bool), False]
    np.testing.assert_array_equal(pcl_rg.grid_ground(points, params=plain), expected)
    # One block for all: the upper terrace is not reachable from the lowest point.
    one_block = dataclasses.replace(plain, block_size=40)
    np.testing.assert_array_equal(
        pcl_rg.grid_ground(points, params=one_block), np.r_[x < 10, False]
    )


def test_seed_ties_go_to_the_lowest_index():
    # Two isolated points at the same lowest height: the first index seeds.
    points = np.array([[0.0, 0.0, 1.0], [8.0, 0.0, 1.0], [0.5, 0.0, 1.0]])
    plain = GridGroundParams.definition(block_size=10, cell_size=1, slope=0.0)
    np.testing.assert_array_equal(pcl_rg.grid_ground(points, params=plain), [True, False, True])
    np.testing.assert_array_equal(
        pcl_rg.grid_ground(points[[1, 0, 2]], params=plain), [True, False, False]
    )


def test_robust_seed_skips_a_low_outlier():
    rng = np.random.default_rng(2)
    plane = np.c_[rng.uniform(0, 20, (400, 2)), np.zeros(400)]
    points = np.vstack([plane, [[10.0, 10.0, -8.0]]])  # multipath echo below the terrain
    plain = GridGroundParams.definition(block_size=40, cell_size=2, slope=0.3)
    np.testing.assert_array_equal(
        pcl_rg.grid_ground(points, params=plain), np.r_[np.zeros(400, bool), True]
    )
    robust = dataclasses.replace(plain, min_seed_component=2)
    np.testing.assert_array_equal(
        pcl_rg.grid_ground(points, params=robust), np.r_[np.ones(400, bool), False]
    )
    # No component large enough: back to the lowest point's component.
    too_large = dataclasses.replace(plain, min_seed_component=10_000)
    np.testing.assert_array_equal(
        pcl_rg.grid_ground(points, params=too_large), pcl_rg.grid_ground(points, params=plain)
    )


def test_slope_filter_removes_a_roof_the_growth_would_reach():
    # A 3 m roof reached through a 1.5 m "stair" of points: linked with slope 3, but each
    # step is far above its lower neighbour for the filter. Blocks [0, 15) and [15, 30)
    # each have ground to seed from.
    x = np.arange(0, 30, 0.5)
    z = np.where((x >= 10) & (x < 20), 3.0, 0.0)
    z[(x >= 9) & (x < 10)] = 1.5
    points = np.c_[x, np.zeros_like(x), z]
    plain = GridGroundParams.definition(block_size=15, cell_size=1, slope=3.0)
    assert pcl_rg.grid_ground(points, params=plain).all()
    filtered = dataclasses.replace(plain, filter_passes=1, filter_slope=1.0, filter_tolerance=0.3)
    ground = assert_core_equals_reference(points, filtered)
    np.testing.assert_array_equal(ground, z == 0.0)


def test_across_blocks_reaches_ground_the_blocks_split():
    # A gentle ramp over two 10 m blocks (the grid starts at x = 0 on the world lattice,
    # below the minimum 0.25); the second block's lowest point is an isolated pit 1 m
    # down. Per block, that block's ground is the pit alone; across blocks, the first
    # seed's component takes the ramp.
    x = np.arange(0.25, 20, 0.5)
    z = 0.01 * x
    pit = x > 17
    z[pit] = -1.0
    points = np.c_[x, np.zeros_like(x), z]
    plain = GridGroundParams.definition(block_size=10, cell_size=1, slope=0.05)
    np.testing.assert_array_equal(assert_core_equals_reference(points, plain), (x < 10) | pit)
    across = dataclasses.replace(plain, grow_across_blocks=True)
    assert assert_core_equals_reference(points, across).all()


# --------------------------------------------------------------------------
# invariants


def test_duplicated_points_share_their_label(scene):
    # A fixed cell: doubling every point halves the spacing an unset cell follows.
    points = scene.points[:4000]
    for params in (
        dataclasses.replace(DEFINITION, cell_size=3.0),
        GridGroundParams(min_seed_component=1, cell_size=3.0),
    ):
        single = pcl_rg.grid_ground(points, params=params)
        doubled = pcl_rg.grid_ground(np.vstack([points, points]), params=params)
        np.testing.assert_array_equal(doubled, np.r_[single, single])


def test_permutation_invariance(scene):
    """z is continuous (no tied seeds), so the result moves with the points."""
    assert len(np.unique(scene.points[:, 2])) == len(scene.points)
    order = np.random.default_rng(1).permutation(len(scene.points))
    for params in (DEFINITION, GridGroundParams()):
        ground = pcl_rg.grid_ground(scene.points, params=params)
        np.testing.assert_array_equal(
            pcl_rg.grid_ground(scene.points[order], params=params), ground[order]
        )


def test_translation_by_whole_blocks_gives_the_same_result(scene):
    """Shift by whole 30 m blocks (and 4 m final-pass cells: 60 m multiples) to UTM-sized
    coordinates. The points are first rounded
    to multiples of 2^-10 m, so p + offset and (p + offset) - origin are exact in
    float64 (at most 33 significant bits): the local coordinates, hence every test, are
    bit for bit the same. Without the rounding a few points within float64 rounding of a
    threshold could flip."""
    points = np.round(scene.points * 1024) / 1024
    offset = np.array([8_334 * 60.0, 83_334 * 60.0, 7.0])  # about (5e5, 5e6)
    shifted = points + offset
    for params in (DEFINITION, GridGroundParams()):
        assert params.block_size == (30.0, 30.0)
        moved, here = grid_neighbours(shifted, params), grid_neighbours(points, params)
        np.testing.assert_array_equal(moved.origin - here.origin, offset)
        np.testing.assert_array_equal(moved.block_xy, here.block_xy)
        np.testing.assert_array_equal(
            pcl_rg.grid_ground(shifted, params=params), pcl_rg.grid_ground(points, params=params)
        )


def test_blocks_lie_on_the_world_lattice_not_at_the_minimum_corner():
    """The terraces of test_blocks_have_their_own_seed_and_no_links_between_them moved by
    3 m: blocks stay [0, 10), [10, 20), [20, 30) in world x, so the block [10, 20) now
    holds the end of the lower terrace (x < 13), its seed, and the start of the upper
    one, which is 5 m up and not linked to it. Blocks anchored at the minimum corner
    (3.25) would cut at the terrace edge and keep every terrace point ground."""
    x = np.arange(0.25, 20, 0.5) + 3.0
    points = np.c_[x, np.zeros_like(x), np.where(x < 13, 0.0, 5.0)]
    points = np.vstack([points, [[18.0, 0.0, 9.0]]])
    plain = GridGroundParams.definition(block_size=10, cell_size=1, slope=0.2)
    ground = assert_core_equals_reference(points, plain)
    np.testing.assert_array_equal(ground, np.r_[(x < 13) | (x >= 20), False])
    np.testing.assert_array_equal(grid_neighbours(points, plain).origin, [0, 0, 0])


def test_a_tile_cut_at_block_boundaries_keeps_the_blocks_and_labels(scene):
    """Move the scene to start at (7, 13), inside a block, and cut it at x = 30 and
    y = 30 (block boundaries): the tile's minimum corner is inside a block too, at
    another place in it, yet its points keep the block membership they have in the whole
    scene, their block indices differing by one constant. Under the definition links and
    seeds stay within a block, so the tile's labels are the whole scene's. Points on the
    2^-10 m grid make every local coordinate and difference exact in both runs."""
    points = np.round(scene.points * 1024) / 1024 + [7.0, 13.0, 0.0]
    tile = (points[:, 0] >= 30.0) & (points[:, 1] >= 30.0)
    corner = points[tile].min(axis=0)
    assert (corner[:2] > 30.0).all() and (corner[:2] % 30.0 > 0.0).all()  # off the lattice
    whole = grid_neighbours(points, DEFINITION)
    part = grid_neighbours(points[tile], DEFINITION)
    offset = whole.block_xy[tile] - part.block_xy
    assert len(np.unique(part.block)) >= 4
    np.testing.assert_array_equal(offset, np.broadcast_to(offset[0], offset.shape))
    np.testing.assert_array_equal(part.origin[:2], [30.0, 30.0])
    for params in (DEFINITION, GridGroundParams.definition(min_seed_component=10)):
        np.testing.assert_array_equal(
            assert_core_equals_reference(points[tile], params),
            pcl_rg.grid_ground(points, params=params)[tile],
        )


def test_lattice_corner_never_lies_above_the_minimum():
    """floor(3.4999999999999996 / 0.7) is 5, and 5 * 0.7 = 3.5 lies above the minimum:
    the origin must be one block lower, or the lowest point would get block -1."""
    low = 3.4999999999999996
    assert np.floor(low / 0.7) * 0.7 > low
    corner = reference.lattice_floor(low, 0.7)
    assert corner <= low < corner + 0.7
    rng = np.random.default_rng(4)
    points = np.c_[low + rng.uniform(0, 5, (300, 2)), rng.uniform(0, 1, 300)]
    points[0, :2] = low
    params = GridGroundParams.definition(block_size=0.7, cell_size=0.7, slope=0.5)
    nb = grid_neighbours(points, params)
    assert (nb.origin[:2] == corner).all() and nb.block_xy.min() == 0
    for p in (params, GridGroundParams(block_size=0.7, cell_size=0.35)):
        assert_core_equals_reference(points, p)


def test_input_is_not_modified_and_any_layout_works(scene):
    points = scene.points[:3000]
    fortran = np.asfortranarray(points.astype(np.float32))
    copy = fortran.copy()
    ground = pcl_rg.grid_ground(fortran)
    np.testing.assert_array_equal(fortran, copy)
    np.testing.assert_array_equal(
        ground, pcl_rg.grid_ground(np.ascontiguousarray(fortran, dtype=np.float64))
    )
    integers = np.round(points).astype(np.int32)
    np.testing.assert_array_equal(
        pcl_rg.grid_ground(integers), pcl_rg.grid_ground(integers.astype(float))
    )


def test_threads_give_the_serial_result():
    """Large enough (250k points) for the core's OpenMP loops, run from 4 threads at
    once with the GIL released."""
    s = synthetic_scene(seed=4, size=250.0, density=4.0, n_buildings=4, n_trees=20)
    assert len(s.points) > 200_000
    expected = pcl_rg.grid_ground(s.points)
    results = run_in_threads(lambda: pcl_rg.grid_ground(s.points))
    for result in results:
        np.testing.assert_array_equal(result, expected)


def test_scores_on_the_synthetic_scene(scene):
    """Defaults separate the synthetic terrain well; the plain rule loses blocks to low
    noise (its seeds), which the options fix. Thresholds: measured values (Type I
    0.4 %, Type II 1.5 %) with generous margins."""
    truth = scene.labels == GROUND
    e = ground_errors(truth, pcl_rg.grid_ground(scene.points))
    assert e.type_i < 0.03 and e.type_ii < 0.08 and e.kappa > 0.8
    plain = ground_errors(truth, pcl_rg.grid_ground(scene.points, params=DEFINITION))
    assert e.total < plain.total


# --------------------------------------------------------------------------
# parameters and errors


def test_dataclass_defaults_match_the_core_struct():
    core = _core.GridGroundParams()
    for field in dataclasses.fields(GridGroundParams):
        assert getattr(core, field.name) == field.default, field.name


def test_keywords_override_params_and_scalars_expand():
    params = GridGroundParams(block_size=12, cell_size=(1, 2))
    assert params.block_size == (12.0, 12.0) and params.cell_size == (1.0, 2.0)
    rng = np.random.default_rng(3)
    points = np.c_[rng.uniform(0, 30, (500, 2)), rng.uniform(0, 3, 500)]
    np.testing.assert_array_equal(
        pcl_rg.grid_ground(points, params=params, slope=0.9),
        pcl_rg.grid_ground(points, params=dataclasses.replace(params, slope=0.9)),
    )
    np.testing.assert_array_equal(
        pcl_rg.grid_ground(points, block_size=12, cell_size=(1, 2)),
        pcl_rg.grid_ground(points, params=params),
    )
    definition = GridGroundParams.definition()
    assert (
        definition.min_seed_component,
        definition.outlier_depth,
        definition.grow_across_blocks,
        definition.filter_passes,
        definition.height_tolerance,
        definition.final_cell,
        definition.final_passes,
    ) == (1, 0.0, False, 0, 0.0, 0.0, 1)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"block_size": 0}, ValueError, "block_size must be > 0"),
        ({"block_size": -5}, ValueError, "block_size must be > 0"),
        ({"block_size": (10, 0)}, ValueError, "block_size must be > 0"),
        ({"block_size": (1, 2, 3)}, ValueError, "block_size must be a number or a sequence of 2"),
        ({"block_size": np.nan}, ValueError, "block_size must be finite"),
        ({"cell_size": 0.0}, ValueError, "cell_size must be > 0"),
        ({"cell_size": 50.0}, ValueError, "cell_size must be <= block_size"),
        ({"block_size": 10, "cell_size": (5, 11)}, ValueError, "cell_size must be <= block_size"),
        ({"slope": -0.1}, ValueError, "slope must be >= 0"),
        ({"slope": np.inf}, ValueError, "slope must be finite"),
        ({"height_tolerance": -1}, ValueError, "height_tolerance must be >= 0"),
        ({"min_seed_component": 0}, ValueError, "min_seed_component must be >= 1"),
        ({"min_seed_component": 2.5}, TypeError, "min_seed_component must be an integer"),
        ({"filter_passes": -1}, ValueError, "filter_passes must be >= 0"),
        ({"filter_slope": -1}, ValueError, "filter_slope must be >= 0"),
        ({"filter_tolerance": -0.5}, ValueError, "filter_tolerance must be >= 0"),
        ({"final_passes": 0}, ValueError, "final_passes must be >= 1"),
        ({"outlier_depth": -1.0}, ValueError, "outlier_depth must be >= 0"),
        ({"outlier_depth": np.inf}, ValueError, "outlier_depth must be finite"),
        ({"final_passes": 1.5}, TypeError, "final_passes must be an integer"),
        ({"grow_across_blocks": 1}, TypeError, "grow_across_blocks must be True or False"),
        ({"slope": "steep"}, TypeError, "slope must be a real number"),
        ({"params": {"slope": 1}}, TypeError, "params must be a GridGroundParams"),
    ],
)
def test_bad_parameters(kwargs, error, match):
    points = np.zeros((3, 3))
    with pytest.raises(error, match=match):
        pcl_rg.grid_ground(points, **kwargs)
    with pytest.raises(error, match=match):
        reference.grid_ground(points, **kwargs)


def test_core_validates_too():
    core = GridGroundParams().to_core()
    core.cell_size = (40.0, 1.0)
    with pytest.raises(ValueError, match="cell_size must be <= block_size"):
        _core.grid_ground(np.zeros((2, 3)), core)
    core = GridGroundParams().to_core()
    core.filter_passes = -2
    with pytest.raises(ValueError, match="filter_passes must be >= 0, got -2"):
        _core.grid_ground(np.zeros((2, 3)), core)
    core = GridGroundParams().to_core()
    core.outlier_depth = -0.5
    with pytest.raises(ValueError, match="outlier_depth must be >= 0, got -0.5"):
        _core.grid_ground(np.zeros((2, 3)), core)
    core = GridGroundParams().to_core()
    core.final_passes = 0
    with pytest.raises(ValueError, match="final_passes must be >= 1, got 0"):
        _core.grid_ground(np.zeros((2, 3)), core)
    with pytest.raises(TypeError):
        _core.grid_ground(np.zeros((2, 3), dtype=np.float32), GridGroundParams().to_core())


@pytest.mark.parametrize(
    ("points", "error", "match"),
    [
        (np.array([[0.0, 0.0, np.nan], [1, 1, 1]]), ValueError, "1 point.*NaN or Inf.*rows 0"),
        (np.array([[0.0, np.inf, 0.0]]), ValueError, "NaN or Inf"),
        (np.zeros((4, 2)), ValueError, r"shape \(N, 3\)"),
        (np.zeros(3), ValueError, r"shape \(N, 3\)"),
        (np.zeros((2, 3), dtype=complex), TypeError, "real float or integer"),
        (np.zeros((2, 3), dtype=bool), TypeError, "real float or integer"),
        ([["a", "b", "c"]], TypeError, "real float or integer"),
    ],
)
def test_bad_points(points, error, match):
    with pytest.raises(error, match=match):
        pcl_rg.grid_ground(points)


# --------------------------------------------------------------------------
# hypothesis


coordinate = st.floats(-50, 50, allow_nan=False, width=64)


@st.composite
def small_clouds(draw):
    n = draw(st.integers(1, 60))
    points = draw(hnp.arrays(np.float64, (n, 3), elements=coordinate))
    # Duplicates, shared x/y (walls, collinear rows) and coarse values that tie exactly.
    if draw(st.booleans()):
        points = np.vstack([points, points[: draw(st.integers(1, n))]])
    if draw(st.booleans()):
        points[:, draw(st.integers(0, 1))] = draw(coordinate)
    if draw(st.booleans()):
        points = np.round(points)
    return points


param_sets = st.builds(
    GridGroundParams,
    block_size=st.sampled_from([5.0, 10.0, (20.0, 7.5), 100.0]),
    cell_size=st.sampled_from([0.5, 1.0, 2.5, (5.0, 1.5)]),
    slope=st.sampled_from([0.0, 0.3, 1.0, 5.0]),
    height_tolerance=st.sampled_from([0.0, 0.5]),
    min_seed_component=st.integers(1, 8),
    grow_across_blocks=st.booleans(),
    filter_passes=st.integers(0, 3),
    filter_slope=st.sampled_from([0.0, 0.7]),
    filter_tolerance=st.sampled_from([0.0, 0.4]),
    final_passes=st.integers(1, 3),
    outlier_depth=st.sampled_from([0.0, 0.5, 2.0]),
).filter(lambda p: all(c <= b for c, b in zip(p.cell_size, p.block_size)))


@settings(max_examples=examples(150), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(points=small_clouds(), params=param_sets)
def test_hypothesis_core_equals_reference(points, params):
    assert_core_equals_reference(points, params)


@settings(max_examples=examples(100), deadline=None)
@given(
    points=small_clouds(),
    block=st.one_of(st.floats(allow_nan=True), st.integers(-3, 3), st.none()),
    cell=st.one_of(st.floats(allow_nan=True), st.integers(-3, 3), st.none()),
    slope=st.one_of(st.floats(allow_nan=True), st.text(max_size=2), st.none()),
    seeds=st.one_of(st.integers(-2, 5), st.floats(0, 3), st.none()),
    passes=st.one_of(st.integers(-2, 3), st.booleans(), st.none()),
)
def test_hypothesis_bad_parameters_only_raise_value_or_type_errors(
    points, block, cell, slope, seeds, passes
):
    try:
        ground = pcl_rg.grid_ground(
            points,
            block_size=block,
            cell_size=cell,
            slope=slope,
            min_seed_component=seeds,
            filter_passes=passes,
        )
    except (ValueError, TypeError):
        return
    assert ground.dtype == np.bool_ and ground.shape == (len(points),)


# --------------------------------------------------------------------------
# real data


@pytest.fixture(scope="module")
def isprs():
    return {
        s: load_isprs(
            shared_data("isprs", f"{s}-utm.pcd"), shared_data("isprs", f"{s}-utm-ground.pcd")
        )
        for s in ISPRS_SAMPLES
    }


@pytest.mark.parametrize("sample", ISPRS_SAMPLES)
def test_isprs_core_equals_reference(isprs, sample):
    points, _ = isprs[sample]
    for params in (GridGroundParams(final_cell=0.0), DEFINITION):
        assert_core_equals_reference(points, params)
    # The final pass triangulates the cells' lowest points; on this gridded XY (y in
    # 0.5 m steps) four of them may be co-circular, and qhull and the core's TIN may then
    # choose other diagonals, which moves the surface under a few points
    # (tests/test_final_pass.py). Bound: 1 point in 1000.
    # The defaults' second round can carry such a difference into its TIN; same bound.
    for final in (GridGroundParams(final_cell=3.0), GridGroundParams()):
        core = pcl_rg.grid_ground(points, params=final)
        expected = reference.grid_ground(points, params=final)
        assert np.count_nonzero(core != expected) <= len(points) // 1000


def test_isprs_errors_with_the_defaults(isprs):
    """Mean total error over the seven samples with the defaults: 4.43 % when they were
    chosen (benchmarks/studies/ground_isprs.py --search; the cell size in multiples of each
    sample's point spacing); PCL's ProgressiveMorphologicalFilter with its tutorial
    parameters scores 8.87 % on the same files. The bound leaves room for nothing but
    rounding; every sample stays under 20 % and kappa above 0.5."""
    errors = [ground_errors(truth, pcl_rg.grid_ground(points)) for points, truth in isprs.values()]
    assert np.mean([e.total for e in errors]) < 0.0445
    assert all(e.total < 0.20 and e.kappa > 0.5 for e in errors)
    plain = [
        ground_errors(truth, pcl_rg.grid_ground(points, params=DEFINITION)).total
        for points, truth in isprs.values()
    ]
    assert np.mean(plain) > np.mean([e.total for e in errors]) + 0.05


def test_pcl_pmf_baseline():
    """The benchmarks' PCL baseline: a plane is ground, a 5 m box on it is not."""
    rng = np.random.default_rng(8)
    xy = rng.uniform(0, 40, (3000, 2))
    box = (np.abs(xy - 20) < 4).all(axis=1)
    points = np.c_[xy + [5e5, 5e6], np.where(box, 105.0, 100.0)]
    ground = pcl_rg.pcl.progressive_morphological_filter(points)
    assert ground.dtype == np.bool_ and ground.shape == (3000,)
    np.testing.assert_array_equal(ground, ~box)
    with pytest.raises(ValueError, match="max_window_size must be >= 1, got 0"):
        pcl_rg.pcl.progressive_morphological_filter(points, max_window_size=0)
    with pytest.raises(ValueError, match="cell_size must be > 0, got 0"):
        pcl_rg.pcl.progressive_morphological_filter(points, cell_size=0.0)
    empty = pcl_rg.pcl.progressive_morphological_filter(np.empty((0, 3)))
    assert empty.shape == (0,)
