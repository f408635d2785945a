"""VoxelGrid: core vs NumPy reference, vs pcl::VoxelGrid, invariants, errors, real data."""

from __future__ import annotations

from decimal import Decimal

import numpy as np
import pytest
from conftest import (
    clustered_cloud,
    examples,
    point_arrays,
    run_in_threads,
    shared_data,
    uniform_cloud,
)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import pcl_rg
from pcl_rg import _core, reference
from pcl_rg.io import read_pcd


def assert_same_grid(result, expected, coordinate_scale: float) -> None:
    """Counts and assignments exactly; centroids to float64 rounding of the sums.

    Core and reference both sum offsets from each voxel's first point, in a different
    order (the reference with bincount), so centroids may differ by a few ulps of the
    coordinate magnitude.
    """
    np.testing.assert_array_equal(result.counts, expected.counts)
    np.testing.assert_array_equal(result.voxel_of_point, expected.voxel_of_point)
    np.testing.assert_allclose(
        result.centroids, expected.centroids, rtol=0, atol=1e-12 * max(coordinate_scale, 1.0)
    )


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("leaf", [0.05, 0.37, 1.0, (0.2, 0.5, 3.0)])
@pytest.mark.parametrize("min_points", [1, 2, 5])
def test_core_equals_reference_on_synthetic(seed, leaf, min_points):
    points = clustered_cloud(5000, seed)
    result = pcl_rg.voxel_grid(points, leaf, min_points_per_voxel=min_points)
    expected = reference.voxel_grid(points, leaf, min_points_per_voxel=min_points)
    assert_same_grid(result, expected, 40.0)
    assert result.voxel_of_point.dtype == np.intp
    assert result.centroids.dtype == np.float64 and result.counts.dtype == np.int64


def test_result_properties():
    points = uniform_cloud(20000, 3)
    result = pcl_rg.voxel_grid(points, 0.5, min_points_per_voxel=3)
    assert result.counts.min() >= 3
    kept = result.voxel_of_point >= 0
    assert result.counts.sum() == kept.sum()
    # Every centroid is the mean of exactly the points mapped to it.
    sums = np.zeros_like(result.centroids)
    np.add.at(sums, result.voxel_of_point[kept], points[kept])
    np.testing.assert_allclose(sums / result.counts[:, None], result.centroids, atol=1e-12)
    # A centroid lies inside its voxel.
    cell = np.floor(points[kept] / 0.5)
    assert np.all(np.floor(result.centroids[result.voxel_of_point[kept]] / 0.5) == cell)


def assert_pcl_centroids(pcl, ours, points, leaf) -> None:
    """Same voxels in the same order; PCL's float32 running sums off by <= count ulps
    of the local coordinates (pcl_rg.pcl's origin: the minimum corner snapped down to
    the leaf grid)."""
    origin = np.floor(points.min(axis=0) / leaf) * leaf
    assert pcl.centroids.shape == ours.centroids.shape
    np.testing.assert_array_equal(pcl.counts, ours.counts)
    np.testing.assert_array_equal(pcl.voxel_of_point, ours.voxel_of_point)
    bound = ours.counts[:, None] * 2.0**-23 * (np.abs(ours.centroids - origin) + 1.0)
    assert np.all(np.abs(pcl.centroids - ours.centroids) <= bound)


# --- PCL equivalence -------------------------------------------------------------
# pcl::VoxelGrid computes floor(x * (1/leaf)) on float32 values of the local frame
# (x minus an origin that pcl_rg.pcl snaps to a multiple of the leaf). With points on
# a 2^-12 leaf grid of extent < 2^12 leaves, x - origin is exact in float32, and with
# power-of-two leaves x * (1/leaf) is exact in float32 and x / leaf in float64, so both
# assign every point to the same voxel; only PCL's float32 centroid sums differ, by at
# most about count * 2^-24 * |x|. (Without the snap to that grid a float32 shift of a
# point within rounding of a voxel boundary can move it: 2 points in 20000 here.)
@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("leaf", [0.25, 1.0, (0.5, 0.125, 2.0)])
@pytest.mark.parametrize("min_points", [1, 4])
def test_equals_pcl_voxel_grid(seed, leaf, min_points):
    step = np.min(leaf) * 2.0**-12
    points = np.round(clustered_cloud(20000, seed) / step) * step
    params = pcl_rg.VoxelGridParams(leaf_size=leaf, min_points_per_voxel=min_points)
    ours = pcl_rg.voxel_grid(points, params=params)
    pcl = pcl_rg.pcl.voxel_grid(points, params=params)
    assert_pcl_centroids(pcl, ours, points, leaf)


def test_large_extent_where_pcl_refuses():
    """2 km x 2 km x 200 m at 5 cm: 3.2e12 voxels overflow PCL's 32-bit index."""
    rng = np.random.default_rng(7)
    n = 200_000
    points = rng.uniform([0, 0, 0], [2000, 2000, 200], (n, 3)).astype(np.float32).astype(float)
    # Make some voxels hold several points, so downsampling really does something.
    points[: n // 2] = np.floor(points[n // 2 :] / 0.05) * 0.05 + 0.01
    params = pcl_rg.VoxelGridParams(leaf_size=0.05)
    # PCL would warn and return its input unchanged; pcl_rg.pcl raises instead.
    with pytest.raises(
        ValueError, match=r"pcl::VoxelGrid numbers the voxels of the bounding box in 32 bits"
    ):
        pcl_rg.pcl.voxel_grid(points, params=params)
    ours = pcl_rg.voxel_grid(points, params=params)
    assert len(ours.centroids) < n
    assert_same_grid(ours, reference.voxel_grid(points, params=params), 2000.0)


def test_beyond_64_bit_keys_uses_exact_fallback():
    """Extents whose voxel count exceeds 2^64 still give the reference's grid."""
    points = np.array(
        [[-1e6, -1e6, -1e6], [1e6, 1e6, 1e6], [1e6, 1e6, 1e6], [0.0, 0.0, 0.0], [2.5e-6, 0, 0]]
    )
    result = pcl_rg.voxel_grid(points, 1e-6)
    assert_same_grid(result, reference.voxel_grid(points, 1e-6), 1e6)
    assert result.counts.tolist() == [1, 1, 1, 2]


# --- invariants ------------------------------------------------------------------
def test_permutation_invariance():
    points = clustered_cloud(8000, 11)
    order = np.random.default_rng(11).permutation(len(points))
    a = pcl_rg.voxel_grid(points, 0.4)
    b = pcl_rg.voxel_grid(points[order], 0.4)
    np.testing.assert_array_equal(a.counts, b.counts)
    np.testing.assert_array_equal(a.voxel_of_point[order], b.voxel_of_point)
    np.testing.assert_allclose(a.centroids, b.centroids, atol=1e-12)


def test_translation_to_utm_keeps_precision():
    """At (5e5, 5e6, 0), with an offset that is a whole number of voxels."""
    points = clustered_cloud(6000, 5)
    offset = np.array([5e5, 5e6, 0.0])
    a = pcl_rg.voxel_grid(points, 0.25)
    b = pcl_rg.voxel_grid(points + offset, 0.25)
    np.testing.assert_array_equal(a.counts, b.counts)
    np.testing.assert_array_equal(a.voxel_of_point, b.voxel_of_point)
    # float64 holds UTM coordinates to ~1e-9 m: far below a millimetre.
    np.testing.assert_allclose(b.centroids - offset, a.centroids, rtol=0, atol=1e-8)


def test_grid_is_anchored_at_world_origin():
    """The same voxels come out whichever subset a point arrives in."""
    points = uniform_cloud(5000, 9)
    whole = pcl_rg.voxel_grid(points, 0.7)
    part = points[points[:, 0] > 5.0]
    sub = pcl_rg.voxel_grid(part, 0.7)
    whole_cells = {tuple(c) for c in np.floor(whole.centroids / 0.7).astype(int)}
    sub_cells = {tuple(c) for c in np.floor(sub.centroids / 0.7).astype(int)}
    assert sub_cells <= whole_cells


def test_input_not_modified_and_layouts_accepted():
    points = clustered_cloud(1000, 2)
    copy = points.copy()
    expected = pcl_rg.voxel_grid(points, 0.5)
    np.testing.assert_array_equal(points, copy)
    for variant in (
        np.asfortranarray(points),
        points.astype(np.float32).astype(np.float64),
        points.tolist(),
    ):
        result = pcl_rg.voxel_grid(variant, 0.5)
        np.testing.assert_array_equal(
            result.counts, pcl_rg.voxel_grid(np.asarray(variant, float), 0.5).counts
        )
    ints = np.arange(30, dtype=np.int32).reshape(10, 3)
    assert pcl_rg.voxel_grid(ints, 10).counts.sum() == 10
    assert expected.counts.sum() == len(points)


def test_empty_and_single_point():
    result = pcl_rg.voxel_grid(np.empty((0, 3)), 1.0)
    assert result.centroids.shape == (0, 3) and result.counts.shape == (0,)
    assert result.voxel_of_point.shape == (0,) and result.voxel_of_point.dtype == np.intp
    one = pcl_rg.voxel_grid([[1.5, -2.5, 3.0]], 1.0)
    np.testing.assert_array_equal(one.centroids, [[1.5, -2.5, 3.0]])
    dropped = pcl_rg.voxel_grid([[1.5, -2.5, 3.0]], 1.0, min_points_per_voxel=2)
    assert dropped.centroids.shape == (0, 3) and dropped.voxel_of_point.tolist() == [-1]


# --- errors ----------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"leaf_size": 0.0}, ValueError, "leaf_size must be > 0"),
        ({"leaf_size": -1.0}, ValueError, "leaf_size must be > 0"),
        ({"leaf_size": float("nan")}, ValueError, "leaf_size must be finite"),
        ({"leaf_size": float("inf")}, ValueError, "leaf_size must be finite"),
        ({"leaf_size": (1.0, 2.0)}, ValueError, "leaf_size must be a number or a sequence of 3"),
        ({"leaf_size": (1.0, 0.0, 1.0)}, ValueError, "leaf_size must be > 0"),
        ({"leaf_size": "big"}, TypeError, "leaf_size must be a number or 3 numbers"),
        ({"leaf_size": True}, TypeError, "leaf_size must be a number or 3 numbers"),
        ({"leaf_size": Decimal(1)}, TypeError, "leaf_size must be a number or 3 numbers"),
        ({"leaf_size": (0.5, True, 0.5)}, TypeError, "leaf_size must be a number or 3 numbers"),
        (
            {"leaf_size": 1.0, "min_points_per_voxel": 0},
            ValueError,
            "min_points_per_voxel must be >= 1",
        ),
        (
            {"leaf_size": 1.0, "min_points_per_voxel": 1.5},
            TypeError,
            "min_points_per_voxel must be an integer",
        ),
        ({}, TypeError, "needs leaf_size"),
    ],
)
def test_bad_parameters(kwargs, error, match):
    with pytest.raises(error, match=match):
        pcl_rg.voxel_grid(np.zeros((3, 3)), **kwargs)
    with pytest.raises(error, match=match):
        reference.voxel_grid(np.zeros((3, 3)), **kwargs)


@pytest.mark.parametrize(
    ("points", "error", "match"),
    [
        (
            np.array([[0.0, 0.0, np.nan], [1, 1, 1]]),
            ValueError,
            r"1 point\(s\) with NaN or Inf.*rows 0",
        ),
        (np.array([[0.0, 0.0, 0.0], [1, np.inf, 1]]), ValueError, r"rows 1"),
        (np.zeros((4, 2)), ValueError, r"shape \(N, 3\)"),
        (np.zeros(3), ValueError, r"shape \(N, 3\)"),
        (np.zeros((2, 3, 1)), ValueError, r"shape \(N, 3\)"),
        (np.zeros((2, 3), dtype=complex), TypeError, "real float or integer"),
        (np.zeros((2, 3), dtype=bool), TypeError, "real float or integer"),
        (np.array([[object()] * 3]), TypeError, "real float or integer"),
        (np.array([["a", "b", "c"]]), TypeError, "real float or integer"),
    ],
)
def test_bad_points(points, error, match):
    with pytest.raises(error, match=match):
        pcl_rg.voxel_grid(points, 1.0)


def test_leaf_size_as_numpy_values():
    # A NumPy scalar or 0-d array is one number; a Decimal is no real number type.
    points = uniform_cloud(500, 3)
    expected = pcl_rg.voxel_grid(points, 0.5).centroids
    for leaf in (np.float32(0.5), np.array(0.5), np.array([0.5, 0.5, 0.5])):
        np.testing.assert_array_equal(pcl_rg.voxel_grid(points, leaf).centroids, expected)
    with pytest.raises(TypeError, match="leaf_size must be a number or 3 numbers"):
        pcl_rg.voxel_grid(points, np.array(True))


def test_absurd_leaf_for_coordinates():
    with pytest.raises(ValueError, match="leaf_size is too small"):
        pcl_rg.voxel_grid([[0.0, 0.0, 0.0], [1e300, 0, 0]], 1e-300)


def test_pcl_voxel_grid_blames_a_leaf_that_moves_its_frame_out_of_reach():
    # PCL anchors its voxels at multiples of the leaf: for points just below 0, the one
    # below them is -2e6, beyond float32's reach; the message blamed a stray point.
    points = np.random.default_rng(0).uniform(-5.0, 5.0, (100, 3))
    with pytest.raises(ValueError, match="leaf_size: pcl::VoxelGrid anchors its voxels"):
        pcl_rg.pcl.voxel_grid(points, 2e6)
    assert pcl_rg.voxel_grid(points, 2e6).counts.sum() == 100  # ours has no such limit
    points[0] = 1e9  # a stray point is still named as one
    with pytest.raises(ValueError, match="stray point"):
        pcl_rg.pcl.voxel_grid(points, 2e6)


def test_coordinates_near_the_float64_limit_have_a_finite_centroid():
    # The reference summed plain coordinates: 1e308 + 1.5e308 overflowed to inf.
    points = np.array([[1e308, 0.0, -1e308], [1.5e308, 1.0, -1.5e308]])
    for function in (pcl_rg.voxel_grid, reference.voxel_grid):
        grid = function(points, 1.7e308)
        np.testing.assert_array_equal(grid.counts, [2])
        np.testing.assert_allclose(grid.centroids, [[1.25e308, 0.5, -1.25e308]], rtol=1e-15)


def test_core_rejects_unconverted_arrays():
    """The binding never converts: float32 or F-order must go through the gate."""
    params = pcl_rg.VoxelGridParams(leaf_size=1.0).to_core()
    with pytest.raises(TypeError):
        _core.voxel_grid(np.zeros((3, 3), np.float32), params)
    with pytest.raises(TypeError):
        _core.voxel_grid(np.asfortranarray(np.zeros((3, 3))), params)


# --- fuzzing and threads ---------------------------------------------------------
@settings(max_examples=examples(80), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    points=point_arrays((0, 60), [0.0, 0.5, -0.5, 1.0], 1e3),
    leaf=st.one_of(
        st.floats(1e-3, 1e3),
        st.tuples(st.floats(1e-3, 50), st.floats(1e-3, 50), st.floats(1e-3, 50)),
    ),
    min_points=st.integers(1, 4),
)
def test_fuzz_core_equals_reference(points, leaf, min_points):
    result = pcl_rg.voxel_grid(points, leaf, min_points_per_voxel=min_points)
    assert_same_grid(
        result, reference.voxel_grid(points, leaf, min_points_per_voxel=min_points), 1e3
    )


@settings(max_examples=examples(100), deadline=None)
@given(
    points=hnp.arrays(
        st.sampled_from([np.float64, np.float32, np.int16, np.float16]),
        st.tuples(st.integers(0, 8), st.integers(1, 4)),
    ),
    leaf=st.one_of(st.floats(allow_nan=True), st.integers(-3, 3)),
)
def test_fuzz_only_clean_errors(points, leaf):
    try:
        pcl_rg.voxel_grid(points, leaf)
    except (ValueError, TypeError):
        pass


def test_threads_give_the_serial_result():
    points = clustered_cloud(50000, 4)
    expected = pcl_rg.voxel_grid(points, 0.3)
    results = run_in_threads(lambda: pcl_rg.voxel_grid(points, 0.3))
    for r in results:
        np.testing.assert_array_equal(r.centroids, expected.centroids)
        np.testing.assert_array_equal(r.voxel_of_point, expected.voxel_of_point)


# --- real data -------------------------------------------------------------------
@pytest.mark.parametrize("sample", ["samp11", "samp52", "samp61"])
def test_isprs_core_equals_reference(sample):
    points = read_pcd(shared_data("isprs", f"{sample}-utm.pcd")).points
    for leaf in (1.0, 2.5):
        assert_same_grid(pcl_rg.voxel_grid(points, leaf), reference.voxel_grid(points, leaf), 6e6)


@pytest.mark.parametrize(
    "name", ["region_growing_tutorial.pcd", "table_scene_mug_stereo_textured.pcd"]
)
def test_pcl_tutorial_clouds_equal_reference_and_pcl(name):
    cloud = read_pcd(shared_data("pcl", name))
    points = cloud.points[np.isfinite(cloud.points).all(axis=1)]
    # A power of two near 1/200 of the extent, and points on a 2^-12 leaf grid: PCL's
    # float32 local coordinates and voxel indices are exact (see above).
    leaf = 2.0 ** np.round(np.log2(np.ptp(points, axis=0).max() / 200))
    points = np.round(points / (leaf * 2.0**-12)) * (leaf * 2.0**-12)
    ours = pcl_rg.voxel_grid(points, leaf)
    assert_same_grid(ours, reference.voxel_grid(points, leaf), 10.0)
    pcl = pcl_rg.pcl.voxel_grid(points, leaf)
    assert_pcl_centroids(pcl, ours, points, leaf)
