"""tin_ground: each parameter's effect, on a lattice with probes whose outcome the
definition fixes, and on hand-made roofs and outliers."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from conftest import examples
from hypothesis import given, reject, settings
from hypothesis import strategies as st
from tin_ground_helpers import ISPRS, LIDAR360, isprs, run_core, scene

import pcl_rg
from pcl_rg import reference
from pcl_rg.datasets import synthetic_scene
from pcl_rg.evaluation import ground_errors
from pcl_rg.reference.tin_ground import QhullPrecisionError, seeds

# --------------------------------------------------------------------------
# each parameter's effect, on a lattice with probes whose outcome the definition fixes
#
# Ground: the integer lattice [0, 10]^2 at z = 0; with max_building_size = 1 every
# lattice point is the lowest of its cell, so all are seeds and the TIN is the
# lattice, each unit square cut by one diagonal. Probes at the square centres, at
# heights h, lie on that diagonal, at XY distance sqrt(0.5) from three vertices of
# either triangle: d = h, every angle is asin(h / sqrt(0.5 + h^2)), the longest edge
# is sqrt(2), and each probe is alone in its triangle, so it is accepted exactly when
# the test passes, whatever happens to the other probes.

LATTICE = np.array([(x, y, 0.0) for x in range(11) for y in range(11)], dtype=np.float64)
HEIGHTS = np.linspace(0.03, 0.97, 100)
PROBES = np.array(
    [(i % 10 + 0.5, i // 10 + 0.5, h) for i, h in enumerate(HEIGHTS)], dtype=np.float64
)
PROBE_CLOUD = np.vstack([LATTICE, PROBES])
ON_LATTICE = pcl_rg.TinGroundParams.lidar360(
    max_building_size=1.0,
    iteration_angle=89.0,
    iteration_distance=10.0,
    reduce_angle_edge=0.01,
    stop_edge=0.01,
)


def probes_accepted(**changes) -> np.ndarray:
    ground = pcl_rg.tin_ground(PROBE_CLOUD, params=dataclasses.replace(ON_LATTICE, **changes))
    assert ground[: len(LATTICE)].all()
    return ground[len(LATTICE) :]


def angle(h: np.ndarray) -> np.ndarray:
    return np.degrees(np.arcsin(h / np.sqrt(0.5 + h * h)))


@pytest.mark.parametrize("distance", [0.2, 0.5, 0.8])
def test_iteration_distance_bounds_the_distance_to_the_plane(distance: float) -> None:
    np.testing.assert_array_equal(probes_accepted(iteration_distance=distance), HEIGHTS <= distance)


@pytest.mark.parametrize("limit", [10.0, 25.0, 40.0])
def test_iteration_angle_bounds_the_angle_to_the_vertices(limit: float) -> None:
    np.testing.assert_array_equal(probes_accepted(iteration_angle=limit), angle(HEIGHTS) <= limit)


def test_acceptance_grows_with_distance_and_angle() -> None:
    counts = [probes_accepted(iteration_distance=d).sum() for d in (0.1, 0.3, 0.6, 0.9)]
    assert counts == sorted(counts) and counts[0] < counts[-1]
    counts = [probes_accepted(iteration_angle=a).sum() for a in (5.0, 15.0, 30.0, 45.0)]
    assert counts == sorted(counts) and counts[0] < counts[-1]


@pytest.mark.parametrize("edge", [1.0, 3.0, 6.0])
def test_reduce_angle_edge_scales_the_angle_by_the_longest_edge(edge: float) -> None:
    # Longest edge sqrt(2): the limit is 40 deg, times sqrt(2) / edge when edge > sqrt(2).
    limit = 40.0 * min(1.0, math.sqrt(2.0) / edge)
    np.testing.assert_array_equal(
        probes_accepted(iteration_angle=40.0, reduce_angle_edge=edge), angle(HEIGHTS) <= limit
    )


@pytest.mark.parametrize("steepest", [20.0, 45.0, 70.0])
def test_max_terrain_angle_rejects_points_forming_steep_triangles(steepest: float) -> None:
    # A probe forms triangles with two corners of its square side, h over 0.5 m.
    steep = np.degrees(np.arctan(HEIGHTS / 0.5)) > steepest
    np.testing.assert_array_equal(probes_accepted(max_terrain_angle=steepest), ~steep)


def test_stop_edge_accepts_without_inserting() -> None:
    accepted = int(probes_accepted(iteration_angle=40.0).sum())
    base = dataclasses.replace(ON_LATTICE, iteration_angle=40.0)
    dense = run_core(PROBE_CLOUD, dataclasses.replace(base, stop_edge=1.0))
    sparse = run_core(PROBE_CLOUD, dataclasses.replace(base, stop_edge=2.0))
    # Same ground either way; only triangles with a longest edge >= stop_edge grow.
    np.testing.assert_array_equal(dense[0], sparse[0])
    assert dense[1]["tin_vertices"] == 4 + len(LATTICE) + accepted
    assert sparse[1]["tin_vertices"] == 4 + len(LATTICE)


def test_stop_edge_bounds_the_density_of_the_tin() -> None:
    points = scene(3).points  # densify_cell off: the TIN of every point the stop edge lets in
    params = dataclasses.replace(ISPRS, stop_edge=0.01, densify_cell=0.0)
    vertices = [
        run_core(points, dataclasses.replace(params, stop_edge=e))[1]["tin_vertices"]
        for e in (0.01, 1.0, 2.0, 4.0)
    ]
    assert vertices == sorted(vertices, reverse=True) and vertices[-1] < vertices[0] / 2


def test_near_vertex_distance_judges_points_above_a_vertex_by_distance() -> None:
    # 5 cm above a lattice point: the angle to that vertex is 90 deg by definition.
    cloud = np.vstack([LATTICE, [[4.0, 6.0, 0.05], [7.0, 2.0, 0.9]]])
    params = dataclasses.replace(ON_LATTICE, iteration_angle=30.0)
    assert not pcl_rg.tin_ground(cloud, params=params)[-2:].any()
    ground = pcl_rg.tin_ground(cloud, params=dataclasses.replace(params, near_vertex_distance=1.0))
    # d <= sin(30 deg) * 1 m for the first, not for the second (0.9 m).
    assert ground[-2] and not ground[-1]


def flat_with_roof(roof_side: float) -> tuple[np.ndarray, np.ndarray]:
    """Flat ground 100 m square at z = 0 with a flat roof at 6 m, both noise-free."""
    rng = np.random.default_rng(11)
    xy = rng.uniform(0.0, 100.0, (20000, 2))
    lo, hi = 50.0 - roof_side / 2, 50.0 + roof_side / 2
    roof = ((xy >= lo) & (xy <= hi)).all(axis=1)
    return np.c_[xy, np.where(roof, 6.0, 0.0)], roof


def test_max_building_size_keeps_roofs_larger_than_it_off_the_ground() -> None:
    points, roof = flat_with_roof(30.0)
    params = pcl_rg.TinGroundParams.lidar360(
        iteration_angle=30.0, reduce_angle_edge=0.01, stop_edge=0.01
    )
    small_cells = pcl_rg.tin_ground(points, params=params, max_building_size=10.0)
    large_cells = pcl_rg.tin_ground(points, params=params, max_building_size=50.0)
    # Cells of 10 m inside the 30 m roof have roof seeds, and much of the roof becomes
    # ground (LiDAR360: "If this parameter is set too small, the flat roof of the
    # building may be mistaken for the terrain"); its rim stays off, as triangles
    # reaching down to the ground around it fail the angle test.
    assert small_cells[roof].mean() > 0.25
    assert not large_cells[roof].any()
    assert large_cells[~roof].mean() > 0.9  # flat, noise-free ground is all accepted
    # With LiDAR360's 8 deg angle, reduced below 5 m edges, less of the roof follows
    # its seeds, but still some.
    assert pcl_rg.tin_ground(points, params=LIDAR360, max_building_size=10.0)[roof].any()
    assert not pcl_rg.tin_ground(points, params=LIDAR360, max_building_size=50.0)[roof].any()


def test_seed_cell_seeds_open_ground_and_skips_roofs() -> None:
    points, roof = flat_with_roof(30.0)
    seeded = run_core(
        points, pcl_rg.TinGroundParams.lidar360(max_building_size=40.0, seed_cell=4.0)
    )
    plain = run_core(points, pcl_rg.TinGroundParams.lidar360(max_building_size=40.0))
    assert seeded[1]["seeds"] > 10 * plain[1]["seeds"]
    assert not seeded[0][roof].any()


def test_outlier_depth_keeps_low_outlier_clusters_out_of_the_seeds() -> None:
    rng = np.random.default_rng(12)
    ground = np.c_[rng.uniform(0.0, 60.0, (6000, 2)), rng.normal(0.0, 0.02, 6000)]
    pit = np.c_[rng.uniform(28.0, 32.0, (12, 2)), rng.uniform(-12.0, -10.0, 12)]
    points = np.vstack([ground, pit])
    # final_low_depth off too: the final pass's own test would take the pit out of the TIN.
    params = dataclasses.replace(ISPRS, outlier_depth=0.0, final_low_depth=0.0)
    without = pcl_rg.tin_ground(points, params=params)
    with_option = pcl_rg.tin_ground(points, params=dataclasses.replace(params, outlier_depth=3.0))
    assert without[-12:].any()  # the pit's lowest points are seeds
    assert not with_option[-12:].any()
    around = np.hypot(ground[:, 0] - 30.0, ground[:, 1] - 30.0) < 8.0
    assert with_option[: len(ground)][around].mean() > without[: len(ground)][around].mean()


@settings(max_examples=examples(60), deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(3, 400),
    rank=st.integers(1, 6),
    building=st.sampled_from([2.0, 5.0, 9.0, 30.0]),
    cell=st.sampled_from([0.5, 1.0, 2.5]),
    depth=st.sampled_from([0.0, 1.0]),
)
def test_rank_opening_seeds_equal_the_reference(seed, n, rank, building, cell, depth) -> None:
    # The core's rank erosion is van Herk's scans on lists of the rank lowest heights,
    # where a list must never take a cell twice; the reference asks scipy for the
    # rank-th lowest of each window. Windows from 1 cell to wider than the raster.
    rng = np.random.default_rng(seed)
    points = np.c_[
        rng.uniform(0.0, rng.uniform(1.0, 40.0), (n, 2)), rng.normal(0.0, 2.0, n).round(1)
    ]
    params = pcl_rg.TinGroundParams.lidar360(
        max_building_size=building, seed_cell=cell, outlier_depth=depth, opening_rank=rank
    )
    try:
        expected = seeds(points, params)
    except ValueError:  # collinear or too few points: the core refuses them too
        with pytest.raises(ValueError):
            run_core(points, params)
        return
    assert run_core(points, params)[1]["seeds"] == len(expected)


def test_opening_rank_keeps_the_seeds_that_a_few_kept_low_cells_take() -> None:
    # samp41 holds low ground cells at the foot of a step that outlier_depth 5 m drops
    # and 6 m keeps; with the plain opening they lower the opened surface over whole
    # windows, and 177 seeds of the upper level go (RESULTS.md, issue 14).
    points, truth = isprs("samp41")

    def run(rank: int, depth: float) -> tuple[int, float]:
        params = dataclasses.replace(ISPRS, opening_rank=rank, outlier_depth=depth)
        ground, stats = run_core(points, params.at_spacing(pcl_rg.point_spacing(points)))
        return stats["seeds"], ground_errors(truth, ground).total

    plain, ranked = run(1, 5.0), run(2, 5.0)
    plain_kept, ranked_kept = run(1, 6.0), run(2, 6.0)
    assert plain_kept[0] < 0.9 * plain[0]  # the cliff of the plain opening
    assert ranked_kept[0] > 0.9 * ranked[0] and ranked_kept[0] > plain_kept[0]
    assert ranked_kept[1] < plain_kept[1] - 0.01  # at least a point of total error less


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_opening_rank_keeps_the_seeds_around_single_multipath_points(seed: int) -> None:
    # Half of synthetic_scene's noise (0.2 % of the returns) lies 1-20 m below its
    # sloping terrain; outlier_depth drops the deep ones, not those less than 5 m deep.
    # The plain opening loses the seeds of whole windows around each of those; a single
    # low cell is never the second-lowest of its window.
    def seeds_of(noise: float, rank: int) -> int:
        points = synthetic_scene(seed=seed, size=150.0, density=4.0, noise_fraction=noise).points
        return run_core(points, dataclasses.replace(ISPRS, opening_rank=rank))[1]["seeds"]

    plain_loss = seeds_of(0.0, 1) - seeds_of(0.002, 1)
    ranked_loss = seeds_of(0.0, 2) - seeds_of(0.002, 2)
    assert plain_loss > 0.1 * seeds_of(0.0, 1)
    assert ranked_loss < 0.5 * plain_loss


# --------------------------------------------------------------------------
# densify_cell: the densification tests only the lowest point of each densify cell


@pytest.mark.parametrize(
    ("source", "cell"),
    [("scene 0", None), ("scene 1", None), ("scene 1", 0.4), ("samp21", None), ("samp41", None)],
)
def test_densify_cell_core_equals_reference(source: str, cell: float | None) -> None:
    # Which point is a cell's lowest is exact (heights as stored, ties by index), and
    # the rest is the definition's: equal masks, as without the option (None: the
    # preset's, following the spacing).
    kind, name = source.split(" ") if " " in source else ("isprs", source)
    points = scene(int(name), density=4.0).points if kind == "scene" else isprs(name)[0]
    params = dataclasses.replace(ISPRS, densify_cell=cell)
    core = pcl_rg.tin_ground(points, params=params)
    np.testing.assert_array_equal(core, reference.tin_ground(points, params=params))


def test_densify_cell_needs_the_final_pass() -> None:
    # Without a final pass nothing would classify the points it leaves untested: the
    # option is then ignored, as seed_tolerance is without seed_cell.
    points = scene(2, density=4.0).points
    alone = dataclasses.replace(ISPRS, final_cell=0.0)
    np.testing.assert_array_equal(
        pcl_rg.tin_ground(points, params=dataclasses.replace(alone, densify_cell=1.0)),
        pcl_rg.tin_ground(points, params=dataclasses.replace(alone, densify_cell=0.0)),
    )


def test_densify_cell_tests_fewer_points_for_nearly_the_same_ground() -> None:
    # The final TIN takes the lowest ground point of each final cell, nearly always the
    # lowest of one of its four half cells: the ground barely moves while the
    # densification tests a fraction of the points (8 pts/m^2, ~4 per half cell).
    points = scene(3, size=120.0, density=8.0).points
    plain, plain_stats = run_core(points, dataclasses.replace(ISPRS, densify_cell=0.0))
    thinned, thinned_stats = run_core(points, ISPRS)
    assert thinned_stats["tests"] < 0.5 * plain_stats["tests"], (thinned_stats, plain_stats)
    assert np.mean(thinned != plain) < 0.005


@pytest.mark.parametrize("density", [2.0, 8.0, 50.0])
def test_densify_cell_follows_the_spacing_when_unset(density: float) -> None:
    # Unset, it is half the unset final cell at every spacing, and it stays that when
    # the final cell is fixed at the ISPRS 3 m: the lowest of the ~110 points of a
    # 1.5 m cell at 50 pts/m^2 misses ground that the final pass cannot recover.
    points = scene(5, size=80.0, density=density).points
    spacing = pcl_rg.point_spacing(points)
    expected = ISPRS.at_spacing(spacing)
    assert expected.densify_cell == expected.final_cell / 2
    for fixed in ({}, {"final_cell": 3.0}):
        with pcl_rg.collect_diagnostics() as diagnostics:
            pcl_rg.tin_ground(points, **fixed)
        assert diagnostics["tin_ground"]["densify_cell"] == expected.densify_cell, fixed


def test_densify_cell_is_at_most_half_the_final_cell() -> None:
    points = scene(6, size=80.0).points
    with pcl_rg.collect_diagnostics() as diagnostics:
        pcl_rg.tin_ground(points, densify_cell=5.0, final_cell=2.0)
    assert diagnostics["tin_ground"]["densify_cell"] == 1.0
    with pcl_rg.collect_diagnostics() as diagnostics:
        pcl_rg.tin_ground(points, densify_cell=0.0)
    assert diagnostics["tin_ground"]["densify_cell"] == 0.0


@pytest.mark.parametrize(("final", "densify"), [(5e-324, None), (1e-300, None), (3.0, 1e-300)])
def test_densify_cell_refuses_cells_too_small_for_the_extent_in_both(final, densify) -> None:
    points = scene(4).points
    params = dataclasses.replace(ISPRS, final_cell=final, densify_cell=densify)
    for run in (pcl_rg.tin_ground, reference.tin_ground):
        with pytest.raises(
            ValueError, match=r"densify_cell is too small .* min\(densify_cell, final_cell / 2\)"
        ):
            run(points, params=params)


@settings(max_examples=examples(30), deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(20, 400),
    step=st.sampled_from([0.0, 0.01, 0.5]),
    cell=st.sampled_from([None, 0.5, 1.0, 3.0, 7.3]),
    densify=st.sampled_from([None, 0.3, 2.0]),
    far=st.booleans(),
)
def test_hypothesis_densify_cell_core_equals_reference(seed, n, step, cell, densify, far) -> None:
    # Quantised coordinates (equal heights, copies), UTM offsets, and a few points far
    # off, so that the half-cell lattice is sparse and the core sorts its cells.
    rng = np.random.default_rng(seed)
    points = np.c_[rng.uniform(0.0, 60.0, (n, 2)), rng.normal(0.0, 0.5, n)]
    points[: n // 10, 2] += rng.uniform(1.0, 8.0, n // 10)
    if step:
        points = np.round(points / step) * step
    if far:
        points[-3:, :2] += rng.uniform(2e3, 5e3, (3, 2))
    points += [4.5e5, 5.4e6, 100.0]
    params = dataclasses.replace(ISPRS, final_cell=cell, densify_cell=densify)
    try:
        expected = reference.tin_ground(points, params=params)
    except QhullPrecisionError:
        reject()  # qhull has no answer there; the core does
    except ValueError as error:  # the same refusal in both
        with pytest.raises(ValueError, match=re.escape(str(error).split(":")[0])):
            pcl_rg.tin_ground(points, params=params)
        return
    np.testing.assert_array_equal(pcl_rg.tin_ground(points, params=params), expected)
