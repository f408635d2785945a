"""grid_ground: invariants (duplicates, order, translation, tiles, threads) and its
parameters' checks and errors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import run_in_threads
from grid_ground_helpers import DEFINITION, assert_core_equals_reference, small_scene

import pcl_rg
from pcl_rg import GridGroundParams, _core, reference
from pcl_rg.datasets import GROUND, synthetic_scene
from pcl_rg.evaluation import ground_errors
from pcl_rg.reference.grid_ground import grid_neighbours


@pytest.fixture(scope="module")
def scene():
    return small_scene()


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


@pytest.mark.parametrize("size", [-1.0, 0.0, np.inf, np.nan])
def test_lattice_floor_refuses_a_step_that_is_not_positive_and_finite(size: float) -> None:
    # A negative step looped for ever (each step down moved the corner up); 0 raised a
    # bare ZeroDivisionError, inf gave nan and nan gave `low` back.
    with pytest.raises(ValueError, match="size must be finite and > 0"):
        reference.lattice_floor(0.5, size)
    with pytest.raises(ValueError, match="low must be finite"):
        reference.lattice_floor(np.inf, 1.0)


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
        ({"filter_passes": -1}, ValueError, r"filter_passes must be in \[0, 64\]"),
        ({"filter_passes": 2**31}, ValueError, r"filter_passes must be in \[0, 64\]"),
        ({"filter_slope": -1}, ValueError, "filter_slope must be >= 0"),
        ({"filter_tolerance": -0.5}, ValueError, "filter_tolerance must be >= 0"),
        ({"final_passes": 0}, ValueError, r"final_passes must be in \[1, 64\]"),
        ({"final_passes": 65}, ValueError, r"final_passes must be in \[1, 64\], got 65"),
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
    with pytest.raises(ValueError, match=r"filter_passes must be in \[0, 64\], got -2"):
        _core.grid_ground(np.zeros((2, 3)), core)
    core = GridGroundParams().to_core()
    core.outlier_depth = -0.5
    with pytest.raises(ValueError, match="outlier_depth must be >= 0, got -0.5"):
        _core.grid_ground(np.zeros((2, 3)), core)
    core = GridGroundParams().to_core()
    core.final_passes = 2**40
    with pytest.raises(ValueError, match=r"final_passes must be in \[1, 64\], got 1099511627776"):
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
