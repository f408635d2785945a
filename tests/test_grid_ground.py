"""grid_ground: core == reference point for point (synthetic scenes, hand-made clouds,
hypothesis, the ISPRS samples) and its scores on real data."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import ISPRS_SAMPLES, examples, shared_data
from grid_ground_helpers import DEFINITION, assert_core_equals_reference, small_scene
from hypothesis import HealthCheck, given, reject, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import pcl_rg
from pcl_rg import GridGroundParams, reference
from pcl_rg.datasets import load_isprs, synthetic_scene
from pcl_rg.evaluation import ground_errors
from pcl_rg.reference.tin_ground import QhullPrecisionError


@pytest.fixture(scope="module")
def scene():
    return small_scene()


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
    try:
        assert_core_equals_reference(points, params)
    except QhullPrecisionError:
        reject()  # no exact reference there: test_reference_refuses_what_qhull_cannot_resolve


def test_reference_refuses_what_qhull_cannot_resolve():
    # Found by make fuzz: 17 m of extent make the grid step 2^-24 m, and the points at 0
    # and -2^-24 m are one step apart. qhull (float64, lifted to x^2 + y^2) drops one of
    # them from the final pass's TIN; the reference used to index past its triangles.
    # Now it says why it has no answer, and the core, exact, classifies the flat cloud.
    points = np.array([[-17.0, 0.0, 0.0], [0.0, 0.0, 0.0], [-(2.0**-24), 0.0, 0.0]])
    params = GridGroundParams(block_size=5.0, cell_size=0.5, final_passes=1)
    with pytest.raises(QhullPrecisionError, match="cannot build that TIN exactly"):
        reference.grid_ground(points, params=params)
    assert pcl_rg.grid_ground(points, params=params).all()


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
    # Three pre-filter passes: on samp11, samp31, samp41 and samp52 the third pass's
    # candidates are not a superset of the second's, so the core labels its components
    # anew there instead of adding the new candidates' links (grid_ground.cpp).
    three_passes = GridGroundParams(final_cell=0.0, filter_passes=3)
    for params in (GridGroundParams(final_cell=0.0), three_passes, DEFINITION):
        assert_core_equals_reference(points, params)
    # Large cells: on samp11 at 6 m and samp31 at 10 m the second pass adds points with so
    # many cell-mates that the core labels anew rather than grows (the cost test in
    # grid_ground.cpp). The reference takes seconds with such cells, so only on the
    # lower-left part of those two samples (by x and y: 0.7 of samp11, 17k points, and
    # 0.49 of samp31, 7k), where the cost test still says "anew" (counted with the
    # reference's pre-filter: 1.0M cell-mates of the added points against a limit of
    # 0.54M, and 0.40M against 0.22M).
    large = {"samp11": (6.0, 0.7), "samp31": (10.0, 0.49)}.get(sample)
    if large:
        cell, share = large
        lower, upper = points[:, :2].min(axis=0), points[:, :2].max(axis=0)
        part = (points[:, :2] < lower + share * (upper - lower)).all(axis=1)
        assert_core_equals_reference(points[part], GridGroundParams(final_cell=0.0, cell_size=cell))
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
