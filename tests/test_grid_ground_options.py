"""grid_ground's improvements of issue 14: low outliers, final-pass rounds, and cells
crowded with points.

Each option: core == reference, the rule on a hand-made cloud, and its effect.
(tests/test_grid_ground.py holds the definition and the older options.)
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import examples
from grid_ground_helpers import assert_core_equals_reference, small_scene
from hypothesis import given, settings
from hypothesis import strategies as st

import pcl_rg
from pcl_rg import GridGroundParams
from pcl_rg.reference._final_pass import final_pass


@pytest.fixture(scope="module")
def scene():
    return small_scene()


def test_low_outliers_are_never_ground():
    """A point 3 m under a plane: the lowest of its block, so the plain rule's seed and,
    with a 5 m final_below, within the final pass's reach. As a low outlier (every
    point of its 3 x 3 cells more than 1 m above it) it is never ground, and the plane
    is, also with every point doubled. Two such points side by side have each other
    within the depth: kept, as the rule says; a lone point with no neighbour in its
    cells is no outlier either."""
    rng = np.random.default_rng(7)
    plane = np.c_[rng.uniform(0, 20, (400, 2)), np.zeros(400)]
    low = [[10.0, 10.0, -3.0]]
    points = np.vstack([plane, low])
    plain = GridGroundParams.definition(block_size=40, cell_size=2, slope=0.3)
    deep = dataclasses.replace(plain, final_cell=4.0, final_below=5.0)
    np.testing.assert_array_equal(assert_core_equals_reference(points, plain)[-1], True)
    assert assert_core_equals_reference(points, deep)[-1]
    for params in (plain, deep, dataclasses.replace(deep, filter_passes=2)):
        ground = assert_core_equals_reference(
            points, dataclasses.replace(params, outlier_depth=1.0)
        )
        np.testing.assert_array_equal(ground, np.r_[np.ones(400, bool), False])
        # Copies of a point do not count as its neighbours: a doubled cloud, doubled labels.
        doubled = assert_core_equals_reference(
            np.vstack([points, points]), dataclasses.replace(params, outlier_depth=1.0)
        )
        np.testing.assert_array_equal(doubled, np.r_[ground, ground])
    # Deeper than the point lies: not an outlier.
    assert pcl_rg.grid_ground(points, params=dataclasses.replace(deep, outlier_depth=3.5))[-1]
    pair = np.vstack([plane, low, [[10.2, 10.0, -3.0]]])
    ground = assert_core_equals_reference(pair, dataclasses.replace(deep, outlier_depth=1.0))
    assert ground[-2:].all()
    lone = np.array([[0.0, 0.0, 0.0], [50.0, 50.0, -5.0]])  # two blocks, no neighbours
    assert pcl_rg.grid_ground(lone, params=dataclasses.replace(plain, outlier_depth=1.0)).all()


@pytest.mark.parametrize("filter_passes", [0, 1])
def test_low_outliers_among_many_copies_equal_the_reference(scene, filter_passes):
    """Copies of 40 points (2 to 59 each) and of 5 low outliers 3 m below the terrain, in
    random order: the core decides each run of copies once (a cell's points by z, x,
    y), with or without the pre-filter that first sorted the cells; the reference tests
    every point."""
    rng = np.random.default_rng(11)
    points = scene.points[:3000]
    picked = rng.choice(len(points), 45, replace=False)
    sources = points[picked] - np.r_[np.zeros((40, 3)), np.tile([0.0, 0.0, 3.0], (5, 1))]
    copies = np.repeat(sources, rng.integers(2, 60, 45), axis=0)
    cloud = np.vstack([points, copies])[rng.permutation(len(points) + len(copies))]
    for params in (
        GridGroundParams(outlier_depth=1.0, filter_passes=filter_passes, cell_size=2.0),
        GridGroundParams.definition(outlier_depth=0.5, filter_passes=filter_passes),
    ):
        ground = assert_core_equals_reference(cloud, params)
        assert 0 < ground.sum() < len(cloud)


@pytest.mark.parametrize(
    "params",
    [
        GridGroundParams(cell_size=1.0),
        GridGroundParams(cell_size=0.5, filter_passes=3),
        GridGroundParams(cell_size=1.0, grow_across_blocks=False),
        GridGroundParams(cell_size=1.0, filter_passes=0, outlier_depth=0.0),
        GridGroundParams(cell_size=1.0, min_seed_component=50),
    ],
    ids=["defaults", "three passes", "per block", "no sorting", "seed component"],
)
def test_stacks_of_copies_equal_the_reference(params):
    """Stacks of 2 to 199 copies of 20 points, and returns rounded to a 10 cm lattice
    (a few hundred positions, each many times): a copy takes its predecessor's
    pre-filter verdict and links (CellGrid::copy_of_previous) instead of testing its
    whole neighbourhood; the components, so the mask, must stay the reference's."""
    rng = np.random.default_rng(5)
    terrain = np.c_[rng.uniform(0.0, 20.0, (800, 2)), rng.normal(0.0, 0.1, 800)]
    terrain[rng.random(800) < 0.2, 2] += 3.0  # objects
    stacks = np.repeat(terrain[rng.choice(800, 20, replace=False)], rng.integers(2, 200, 20), 0)
    lattice = np.round(rng.uniform(0.0, 0.5, (1500, 3)), 1) + [10.0, 10.0, 0.0]
    cloud = np.vstack([terrain, stacks, lattice])
    cloud = cloud[rng.permutation(len(cloud))]
    ground = assert_core_equals_reference(cloud, params)
    assert 0 < ground.sum() < len(cloud)


@pytest.mark.parametrize(
    "params",
    [
        GridGroundParams(cell_size=1.0, final_cell=0.0),
        GridGroundParams(cell_size=1.0, filter_passes=3, final_cell=0.0),
        GridGroundParams(cell_size=1.0, grow_across_blocks=False, final_cell=0.0),
        GridGroundParams.definition(cell_size=1.0),
        GridGroundParams(cell_size=1.0, height_tolerance=0.004, slope=0.1, final_cell=0.0),
        GridGroundParams(cell_size=1.0),
    ],
    ids=["defaults", "three passes", "per block", "unsorted cells", "tolerance", "final pass"],
)
def test_crowded_cells_equal_the_reference(params):
    """Cells of hundreds of distinct points (a dense spot on the ground, one floating
    above it, a pole of returns at one XY, a thin pole, a crown over a ground spot):
    in cells of more than 64 points (kCrowdedCell), sorted by height even where the
    others are not, the labelling samples near each point's height, bounds the heights
    by the cell's XY box and steps over runs that cannot link (grid_links.cpp); the
    components, so the mask, must stay the reference's. The final pass is off but in
    the last case: it would classify the points again and hide a missed link."""
    rng = np.random.default_rng(11)
    terrain = np.c_[rng.uniform(0.0, 20.0, (900, 2)), rng.normal(0.0, 0.05, 900)]
    terrain[rng.random(900) < 0.2, 2] += 2.5  # objects
    spot = rng.uniform(0.0, 0.02, (400, 3)) + [5.3, 5.3, 0.0]
    floating = rng.uniform(0.0, 0.02, (300, 3)) + [12.4, 7.6, 6.0]
    pole = np.c_[np.full((250, 2), [15.5, 15.5]), np.linspace(0.0, 4.0, 250)]
    thin_pole = np.c_[rng.normal([3.5, 16.5], 0.01, (250, 2)), rng.uniform(0.0, 3.0, 250)]
    # A tree's crown over a ground spot in one cell.
    mixed = np.c_[rng.uniform(9.1, 9.9, (300, 2)), np.where(np.arange(300) % 2, 0.0, 3.0)]
    mixed[:, 2] += rng.uniform(0.0, 0.3, 300)
    cloud = np.vstack([terrain, spot, floating, pole, thin_pole, mixed])
    cloud = cloud[rng.permutation(len(cloud))]
    ground = assert_core_equals_reference(cloud, params)
    assert 0 < ground.sum() < len(cloud)


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize(
    "params",
    [
        GridGroundParams.definition(cell_size=1.0, block_size=4.0, slope=0.1, outlier_depth=50.0),
        GridGroundParams.definition(
            cell_size=1.0, block_size=4.0, slope=0.1, outlier_depth=50.0, grow_across_blocks=True
        ),
        GridGroundParams.definition(cell_size=1.0, block_size=4.0, slope=0.1),
        GridGroundParams(
            cell_size=1.0, block_size=4.0, slope=0.1, filter_tolerance=2.0, final_cell=0.0
        ),
    ],
    ids=["per block", "across", "unsorted cells", "pre-filter"],
)
def test_sparse_links_in_crowded_cells_equal_the_reference(seed, params):
    """Crowded cells whose points rise over 5 m, so that few of them link (slope 0.1)
    and many links decide a component: a link the labelling missed in a crowded cell
    would change the mask."""
    rng = np.random.default_rng(seed)
    parts = [np.c_[rng.uniform(0.0, 8.0, (300, 2)), rng.uniform(0.0, 5.0, 300)]]
    for _ in range(6):
        corner = rng.integers(0, 8, 2) + rng.uniform(0.0, 0.5, 2)
        size = rng.uniform(0.0, 0.5, 2)
        count = int(rng.integers(70, 200))
        xy = corner + rng.uniform(0.0, 1.0, (count, 2)) * size
        parts.append(np.c_[xy, rng.uniform(0.0, 5.0, count)])
    cloud = np.vstack(parts)
    ground = assert_core_equals_reference(cloud, params)
    assert 0 < ground.sum() < len(cloud)


@st.composite
def crowded_clouds(draw):
    """A sparse cloud over 6 m x 6 m with one to three cells of 65 to 200 points (more
    than kCrowdedCell), each in a drawn part of its cell, its heights over a drawn range,
    on a few levels or not."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    sparse = draw(st.integers(0, 150))
    parts = [np.c_[rng.uniform(0.0, 6.0, (sparse, 2)), rng.uniform(0.0, 2.0, sparse)]]
    for _ in range(draw(st.integers(1, 3))):
        count = draw(st.integers(65, 200))
        corner = rng.integers(0, 6, 2) + rng.uniform(0.0, 0.5, 2)
        size = draw(st.sampled_from([0.0, 0.01, 0.2, 0.5]))
        rise = draw(st.sampled_from([0.01, 0.5, 3.0]))
        z = rng.uniform(0.0, rise, count)
        if draw(st.booleans()):
            z = np.round(z * 4 / rise) * rise / 4  # five levels
        parts.append(np.c_[corner + rng.uniform(0.0, size, (count, 2)), z])
    return np.vstack(parts)


crowded_params = st.builds(
    GridGroundParams,
    block_size=st.sampled_from([2.0, 4.0, 10.0]),
    cell_size=st.just(1.0),
    slope=st.sampled_from([0.0, 0.1, 0.3, 1.0]),
    height_tolerance=st.sampled_from([0.0, 0.05]),
    min_seed_component=st.sampled_from([1, 20]),
    grow_across_blocks=st.booleans(),
    filter_passes=st.integers(0, 2),
    filter_tolerance=st.sampled_from([0.1, 2.0]),
    outlier_depth=st.sampled_from([0.0, 2.0]),
    final_cell=st.just(0.0),
)


@settings(max_examples=examples(400), deadline=None)
@given(points=crowded_clouds(), params=crowded_params)
def test_hypothesis_crowded_cells_equal_the_reference(points, params):
    assert_core_equals_reference(points, params)


def test_final_passes_rerun_the_final_pass_on_its_own_ground(scene):
    """Round r + 1 is the final pass (the reference's) on round r's ground (without low
    outliers, which each round would mask afterwards)."""
    p = GridGroundParams(outlier_depth=0.0)
    once = pcl_rg.grid_ground(scene.points, params=dataclasses.replace(p, final_passes=1))
    twice = assert_core_equals_reference(scene.points, dataclasses.replace(p, final_passes=2))
    again = final_pass(
        scene.points, once, p.final_cell, p.final_above, p.final_below, p.final_slope,
        p.final_low_depth,
    )  # fmt: skip
    np.testing.assert_array_equal(twice, again)
    # Without the final pass there is nothing to repeat.
    off = GridGroundParams(final_cell=0.0)
    np.testing.assert_array_equal(
        pcl_rg.grid_ground(scene.points, params=off),
        pcl_rg.grid_ground(scene.points, params=dataclasses.replace(off, final_passes=3)),
    )


def test_second_final_round_runs_under_a_platform_the_growth_took():
    """A 0.6 m platform filling the 4 m final cells x in [8, 12) is climbed by the growth
    (slope 3); a terrain point seen through a hole in it (0.05 m, no platform point in
    its 3 x 3 cells, too small a component to seed) is not grown. Round 1's TIN has a
    platform point as that cell's vertex, yet takes the terrain point (0.55 m below
    the platform, within final_below); round 2's TIN has the terrain point as vertex
    and drops more of the platform. A third round changes nothing more."""
    axis_x, axis_y = np.arange(0, 24, 0.25), np.arange(0, 8, 0.25)
    x, y = (a.ravel() for a in np.meshgrid(axis_x, axis_y, indexing="ij"))
    platform = (x >= 8) & (x < 12)
    seen_through = (x == 10) & (y == 2)
    keep = ~(platform & (np.hypot(x - 10, y - 2) <= 0.7)) | seen_through
    z = np.where(seen_through, 0.05, np.where(platform, 0.6, 0.0))
    points = np.c_[x, y, z][keep]
    platform, seen_through = (platform & ~seen_through)[keep], seen_through[keep]
    params = GridGroundParams.definition(
        block_size=24,
        cell_size=0.25,
        slope=3.0,
        min_seed_component=5,
        final_cell=4.0,
        final_above=0.3,
        final_below=1.0,
        final_slope=0.0,
    )
    grown = pcl_rg.grid_ground(points, params=dataclasses.replace(params, final_cell=0.0))
    assert grown[platform].all() and not grown[seen_through].any()
    rounds = [
        assert_core_equals_reference(points, dataclasses.replace(params, final_passes=r))
        for r in (1, 2, 3)
    ]
    for ground in rounds:
        assert ground[seen_through].all() and ground[~platform].all()
    assert rounds[1][platform].sum() < rounds[0][platform].sum()
    assert not (rounds[1] & ~rounds[0]).any()
    np.testing.assert_array_equal(rounds[2], rounds[1])


def test_passes_stop_when_one_changes_nothing(scene):
    """Each pre-filter pass and final-pass round reads only the last one's ground, so
    one that gives it back ends them: 64 of each (the most allowed) run a few and give
    the mask of that many, core and reference alike."""
    many = GridGroundParams(filter_passes=64, final_passes=64)
    points = scene.points
    with pcl_rg.collect_diagnostics() as diagnostics:
        ground = assert_core_equals_reference(points, many)
    run = diagnostics["grid_ground"]
    filter_run, final_run = run["filter_passes_run"], run["final_passes_run"]
    assert 2 <= filter_run < 64 and 1 <= final_run < 64
    fewer = dataclasses.replace(many, filter_passes=filter_run, final_passes=final_run)
    np.testing.assert_array_equal(pcl_rg.grid_ground(points, params=fewer), ground)
    # The last pass run changed nothing: one fewer gives the same ground.
    last_but_one = dataclasses.replace(fewer, filter_passes=filter_run - 1)
    np.testing.assert_array_equal(pcl_rg.grid_ground(points, params=last_but_one), ground)
    # Asked for fewer than that, all of them run.
    with pcl_rg.collect_diagnostics() as diagnostics:
        pcl_rg.grid_ground(
            points, params=dataclasses.replace(many, filter_passes=1, final_passes=1)
        )
    assert diagnostics["grid_ground"]["filter_passes_run"] == 1
    assert diagnostics["grid_ground"]["final_passes_run"] == 1


def test_diagnostics_time_the_stages(scene):
    """The core's clock per stage: none negative, and none for a final pass that is off."""
    for final_cell in (4.0, 0.0):
        params = GridGroundParams(final_cell=final_cell)
        with pcl_rg.collect_diagnostics() as diagnostics:
            pcl_rg.grid_ground(scene.points, params=params)
        run = diagnostics["grid_ground"]
        stages = ("prepare_seconds", "growth_seconds", "final_pass_seconds")
        assert all(run[stage] >= 0.0 for stage in stages), run
        assert run["prepare_seconds"] + run["growth_seconds"] > 0.0
        assert (run["final_pass_seconds"] > 0.0) == (final_cell > 0.0), run
