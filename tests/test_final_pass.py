"""The final pass shared by the ground filters (final_pass.cpp): core vs reference,
its definition on hand-made cases, order independence, parameter errors. Thread
independence: both filters run the pass by default in tests/thread_probe.py."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import ISPRS_SAMPLES, shared_data

import pcl_rg
from pcl_rg import GridGroundParams, _core, reference
from pcl_rg.datasets import load_isprs, synthetic_scene
from pcl_rg.reference._final_pass import final_pass

# The grower without its own pass, then the final pass at a few settings.
WITHOUT = GridGroundParams(final_cell=0.0)
SETTINGS = [
    dict(final_cell=4.0, final_above=0.5, final_below=1.0, final_slope=1.0),
    dict(final_cell=2.0, final_above=0.2, final_below=0.5, final_slope=0.0),
    dict(final_cell=7.5, final_above=1.2, final_below=5.0, final_slope=3.0),
    dict(final_cell=0.9, final_above=0.0, final_below=0.0, final_slope=0.5),
]


@pytest.fixture(scope="module")
def scene():
    return synthetic_scene(seed=5, size=80.0, density=3.0, n_buildings=2, n_trees=8)


@pytest.mark.parametrize("setting", SETTINGS, ids=range(len(SETTINGS)))
def test_core_equals_reference(scene, setting):
    """Random XY: no four vertices are co-circular, the TIN is unique, so exact."""
    params = dataclasses.replace(WITHOUT, **setting)
    core = pcl_rg.grid_ground(scene.points, params=params)
    np.testing.assert_array_equal(core, reference.grid_ground(scene.points, params=params))
    # The pass changes the grower's result (else this test could not fail on it).
    assert (core != pcl_rg.grid_ground(scene.points, params=WITHOUT)).any()


@pytest.mark.parametrize("sample", ISPRS_SAMPLES)
def test_isprs_core_equals_reference(sample):
    """The ISPRS XY is gridded (y in 0.5 m steps), so co-circular vertices occur; the
    reference flips qhull's diagonals there to the core's (reference._delaunay): exact."""
    points, _ = load_isprs(
        shared_data("isprs", f"{sample}-utm.pcd"), shared_data("isprs", f"{sample}-utm-ground.pcd")
    )
    params = dataclasses.replace(WITHOUT, **SETTINGS[0])
    core = pcl_rg.grid_ground(points, params=params)
    np.testing.assert_array_equal(core, reference.grid_ground(points, params=params))


def test_definition_on_a_hand_made_case():
    """Four ground corners of a 10 m square plane tilted by 0.5 (gradient 0.5): with
    above 0.2 and slope 1 the limit is 0.2 + 0.5 = 0.7 m above, 0.3 below."""
    corners = np.array([[0, 0, 0], [10, 0, 5], [0, 10, 0], [10, 10, 5]], dtype=float)
    probes = np.array(
        [
            [5, 5, 2.5 + 0.69],  # just within the slope-adaptive limit
            [5, 5, 2.5 + 0.71],  # just above it
            [5, 5, 2.5 - 0.29],  # just within the depth below
            [5, 5, 2.5 - 0.31],  # too deep
            [2, 8, 1.0],  # on the plane
        ]
    )
    xyz = np.r_[corners, probes]
    ground = np.r_[np.ones(4, bool), np.zeros(5, bool)]
    got = final_pass(xyz, ground, cell=20.0 / 3, above=0.2, below=0.3, slope=1.0)
    assert got.tolist() == [True] * 4 + [True, False, True, False, True]
    flat = final_pass(xyz, ground, cell=20.0 / 3, above=0.2, below=0.3, slope=0.0)
    assert flat[4:].tolist() == [False, False, True, False, True]


def test_lowest_ground_point_per_cell_makes_the_surface():
    """Two ground points in one cell: the upper one is not a vertex and is classified
    against the surface of the lower ones, so it leaves the ground."""
    xyz = np.array([[0, 0, 0], [9, 0, 0], [0, 9, 0], [9, 9, 0], [1, 1, 3.0]], dtype=float)
    ground = np.ones(5, dtype=bool)
    assert final_pass(xyz, ground, 4.0, 0.5, 1.0, 1.0).tolist() == [True] * 4 + [False]
    # A cell of 1 m puts (1, 1) in a cell of its own: a vertex, so ground.
    assert final_pass(xyz, ground, 1.0, 0.5, 1.0, 1.0).all()


def test_no_ground_in_gives_no_ground_out():
    xyz = np.random.default_rng(0).uniform(0, 10, (50, 3))
    assert not final_pass(xyz, np.zeros(50, bool), 2.0, 0.5, 1.0, 1.0).any()
    # The core: a single ground point (the seed; slope 0 links nothing) gives a flat
    # surface at its height, so the points 10 m and more above it are not ground.
    assert not pcl_rg.grid_ground(
        np.c_[xyz[:, :2], np.arange(50) * 10.0],
        params=GridGroundParams.definition(slope=0.0, final_cell=2.0),
    )[1:].any()


def test_permutation_and_translation(scene):
    params = dataclasses.replace(WITHOUT, **SETTINGS[0])
    expected = pcl_rg.grid_ground(scene.points, params=params)
    order = np.random.default_rng(1).permutation(len(scene.points))
    np.testing.assert_array_equal(
        pcl_rg.grid_ground(scene.points[order], params=params), expected[order]
    )
    # By whole blocks of 30 m (whole cells of 4 m too: 120 m steps), at UTM size.
    shifted = scene.points + np.array([500_040.0 * 3, 5_000_040.0 * 3, 0.0])
    assert (pcl_rg.grid_ground(shifted, params=params) != expected).mean() < 0.001


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"final_cell": -1.0}, "final_cell must be >= 0"),
        ({"final_above": -0.1}, "final_above must be >= 0"),
        ({"final_below": np.inf}, "final_below must be finite"),
        ({"final_slope": -2.0}, "final_slope must be >= 0"),
    ],
)
def test_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        pcl_rg.grid_ground(np.zeros((3, 3)), **kwargs)
    with pytest.raises(ValueError, match=match):
        reference.grid_ground(np.zeros((3, 3)), **kwargs)
    core = GridGroundParams().to_core()
    name, value = next(iter(kwargs.items()))
    setattr(core, name, value)
    with pytest.raises(ValueError, match=match):
        _core.grid_ground(np.zeros((3, 3)), core)


def test_too_small_a_cell_for_the_extent():
    points = np.array([[0.0, 0.0, 0.0], [1e9, 1e9, 0.0], [5e8, 1.0, 0.0]])
    with pytest.raises(ValueError, match="final_cell is too small"):
        pcl_rg.grid_ground(points, block_size=1e9, cell_size=1e9, final_cell=1e-6)
    with pytest.raises(ValueError, match="final_cell is too small"):
        reference.grid_ground(points, block_size=1e9, cell_size=1e9, final_cell=1e-6)


@pytest.mark.parametrize("final_cell", [1e-320, 5e-324])
def test_subnormal_cells_on_a_subnormal_box(final_cell):
    """Final cells of subnormal size, whose reciprocal is infinite, over points within
    5e-320 m: grid_ground finds each point's final cell while building its grid
    (CellOf, by a multiplication), and must then take the division, not turn the NaN
    of 0 x inf into a cell number (undefined behaviour, which `make sanitize` reports),
    giving the reference's mask."""
    rng = np.random.default_rng(2)
    points = np.c_[rng.uniform(0.0, 5e-320, (400, 2)), rng.uniform(0.0, 1.0, 400)]
    got = pcl_rg.grid_ground(points, final_cell=final_cell, cell_size=1.0)
    np.testing.assert_array_equal(
        got, reference.grid_ground(points, final_cell=final_cell, cell_size=1.0)
    )
    assert 0 < got.sum() < len(points)


# --------------------------------------------------------------------------
# the same pass as an option of tin_ground

TIN_WITHOUT = pcl_rg.TinGroundParams.isprs(final_cell=0.0)


@pytest.mark.parametrize("setting", SETTINGS[:3], ids=range(3))
def test_tin_core_equals_reference(setting):
    """Random XY: both TINs (the densification's and the pass's) are unique: exact."""
    points = synthetic_scene(seed=6, size=70.0, density=1.5, n_buildings=1, n_trees=5).points
    params = dataclasses.replace(TIN_WITHOUT, **setting)
    core = pcl_rg.tin_ground(points, params=params)
    np.testing.assert_array_equal(core, reference.tin_ground(points, params=params))
    assert (core != pcl_rg.tin_ground(points, params=TIN_WITHOUT)).any()


@pytest.mark.parametrize("sample", ["samp21", "samp41"])
def test_tin_isprs_core_agrees_with_reference(sample):
    """Gridded files, co-circular vertices: the reference takes the core's diagonals
    (reference._delaunay), so exact, as tests/test_tin_ground.py holds the
    densification."""
    points, _ = load_isprs(
        shared_data("isprs", f"{sample}-utm.pcd"), shared_data("isprs", f"{sample}-utm-ground.pcd")
    )
    params = dataclasses.replace(TIN_WITHOUT, **SETTINGS[0])
    core = pcl_rg.tin_ground(points, params=params)
    np.testing.assert_array_equal(core, reference.tin_ground(points, params=params))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"final_cell": -1.0}, "final_cell must be >= 0"),
        ({"final_above": np.nan}, "final_above must be finite"),
        ({"final_below": -1.0}, "final_below must be >= 0"),
        ({"final_slope": -0.5}, "final_slope must be >= 0"),
    ],
)
def test_tin_bad_parameters(kwargs, match):
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    with pytest.raises(ValueError, match=match):
        pcl_rg.tin_ground(points, **kwargs)
    with pytest.raises(ValueError, match=match):
        reference.tin_ground(points, **kwargs)
    core = pcl_rg.TinGroundParams().to_core()
    name, value = next(iter(kwargs.items()))
    setattr(core, name, value)
    with pytest.raises(ValueError, match=match):
        _core.tin_ground(points, core)


def test_a_cloud_on_one_line_gives_the_cores_verdicts():
    """Found by make fuzz (seed 1515): every point on x = 0, so the pass's TIN joins
    the line to the box's corners through co-circular vertices, and qhull's diagonal
    put point 14 in another triangle than the core's (ground there, not in qhull's)."""
    points = np.zeros((18, 3))
    points[0, 1] = -7.8125e-03
    points[13], points[14], points[17] = [0.0, -9.0, 1.0], [0.0, 0.0, 1.0], [0.0, 9.0, 0.0]
    params = GridGroundParams(
        block_size=5.0, cell_size=0.5, slope=0.0, min_seed_component=1, outlier_depth=0.0,
        grow_across_blocks=False, filter_passes=0, final_passes=1,
    )  # fmt: skip
    core = pcl_rg.grid_ground(points, params=params)
    np.testing.assert_array_equal(core, reference.grid_ground(points, params=params))


def test_isprs_later_rounds_equal_the_reference():
    """A round after another locates again only the points near a triangle that the
    last round's TIN did not have (final_pass.cpp); the reference runs every round in
    full. The second round must change the result on some sample, else this test could
    not fail on it."""
    changed = []
    for sample in ISPRS_SAMPLES:
        points, _ = load_isprs(
            shared_data("isprs", f"{sample}-utm.pcd"),
            shared_data("isprs", f"{sample}-utm-ground.pcd"),
        )
        params = dataclasses.replace(WITHOUT, **SETTINGS[1], final_passes=3)
        rounds = [
            pcl_rg.grid_ground(points, params=dataclasses.replace(params, final_passes=r))
            for r in (1, 2, 3)
        ]
        changed.append((rounds[0] != rounds[1]).any())
        np.testing.assert_array_equal(rounds[2], reference.grid_ground(points, params=params))
    assert sum(changed) >= len(ISPRS_SAMPLES) // 2, changed


def test_later_rounds_on_small_random_clouds_equal_the_reference():
    """Small clouds on sloping, wavy ground with scattered objects, where a round's TIN
    differs from the last round's by a few vertices, each near the box's corners or the
    others: every way a triangle can be new (a vertex lost, one gained, a virtual
    corner's height changed) occurs among them. Each must mark where the round locates
    points again; before, dropping any one of the three went unseen by every other test."""
    rng = np.random.default_rng(20261204)
    changed = 0
    for _ in range(400):
        n = int(rng.integers(30, 200))
        xy = rng.uniform(0.0, 20.0, (n, 2))
        objects = rng.uniform(0.0, 1.0, n) * (rng.uniform(size=n) < 0.3)
        points = np.c_[xy, 0.1 * xy[:, 0] + 0.3 * np.sin(xy[:, 1]) + objects]
        params = GridGroundParams(
            block_size=10.0, cell_size=1.0, slope=float(rng.choice([0.3, 1.0])),
            height_tolerance=0.2, min_seed_component=3, outlier_depth=0.0,
            filter_passes=int(rng.integers(0, 2)), final_cell=float(rng.choice([2.0, 3.0, 5.0])),
            final_above=float(rng.choice([0.0, 0.1, 0.3])),
            final_below=float(rng.choice([0.0, 0.5, 2.0])),
            final_slope=float(rng.choice([0.0, 0.5])), final_passes=3,
        )  # fmt: skip
        core = pcl_rg.grid_ground(points, params=params)
        np.testing.assert_array_equal(core, reference.grid_ground(points, params=params))
        once = pcl_rg.grid_ground(points, params=dataclasses.replace(params, final_passes=1))
        changed += bool((core != once).any())
    assert changed >= 40, changed
