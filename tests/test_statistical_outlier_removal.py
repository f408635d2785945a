"""StatisticalOutlierRemoval: bit-equal to pcl::StatisticalOutlierRemoval, near the
float64 reference, invariants, errors, real data."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import (
    ISPRS_SAMPLES,
    clustered_cloud,
    examples,
    point_arrays,
    run_in_threads,
    shared_data,
    uniform_cloud,
)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import pcl_rg
from pcl_rg import _core, reference
from pcl_rg.io import read_pcd
from pcl_rg.reference.statistical_outlier_removal import mean_neighbour_distance


def core_details(points, mean_k, std_mul):
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=mean_k, std_mul=std_mul)
    return _core.statistical_outlier_removal(np.ascontiguousarray(points, float), params.to_core())


def pcl_mask(points, mean_k, std_mul):
    """PCL's own class on the same float32 local cloud (points minus the minimum corner)."""
    return pcl_rg.pcl.statistical_outlier_removal(points, mean_k=mean_k, std_mul=std_mul)


def assert_near_reference(points, mean_k, std_mul):
    """Core (float32, like PCL) vs reference (float64): equal except near the threshold.

    The core's d_i come from float32 local coordinates of extent E: each coordinate is
    off by at most E * 2^-24, so each distance by at most sqrt(3) * E * 2^-23, and the
    float32 sqrt/mean roundings add a few ulps of d_i. The threshold inherits the same
    bound through mu and sigma (times 1 + std_mul). A point may flip only when its
    float64 d_i lies within that bound of the float64 threshold.
    """
    inlier = pcl_rg.statistical_outlier_removal(points, mean_k=mean_k, std_mul=std_mul)
    expected = reference.statistical_outlier_removal(points, mean_k=mean_k, std_mul=std_mul)
    d = mean_neighbour_distance(points, mean_k)
    threshold = d.mean() + std_mul * d.std(ddof=1)
    extent = float(np.ptp(points, axis=0).max())
    bound = (2 + std_mul) * (4 * extent * 2.0**-23 + 8 * threshold * 2.0**-24)
    differ = np.flatnonzero(inlier != expected)
    assert np.all(np.abs(d[differ] - threshold) <= bound), differ
    assert len(differ) <= max(2, len(points) // 1000)
    return inlier


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("mean_k", [1, 4, 8, 30])
@pytest.mark.parametrize("std_mul", [0.0, 0.5, 1.0, 3.0])
def test_core_near_reference_and_equal_to_pcl(seed, mean_k, std_mul):
    points = clustered_cloud(3000, seed)
    inlier = assert_near_reference(points, mean_k, std_mul)
    np.testing.assert_array_equal(inlier, pcl_mask(points, mean_k, std_mul))
    assert 0 < inlier.sum() < len(points)


def test_outliers_are_found():
    rng = np.random.default_rng(3)
    surface = np.column_stack([rng.uniform(0, 10, (5000, 2)), rng.normal(0, 0.01, 5000)])
    far = rng.uniform(-50, 60, (40, 3)) + [0, 0, 30]
    inlier = pcl_rg.statistical_outlier_removal(np.vstack([surface, far]), mean_k=10, std_mul=2.0)
    assert not inlier[-40:].any()
    assert inlier[:-40].mean() > 0.97


def test_duplicates_and_ties_match_pcl():
    """Exact duplicates (distance 0) and equidistant lattice neighbours."""
    grid = np.stack(np.meshgrid(np.arange(12), np.arange(12), np.arange(3)), -1).reshape(-1, 3)
    points = np.vstack([grid, grid[:50], grid[:50], [[30.0, 30, 30]]]).astype(float)
    for mean_k in (1, 3, 6, 26):
        for std_mul in (0.0, 1.0):
            np.testing.assert_array_equal(
                pcl_rg.statistical_outlier_removal(points, mean_k=mean_k, std_mul=std_mul),
                pcl_mask(points, mean_k, std_mul),
            )


def test_zero_spread_keeps_every_point_like_pcl():
    """All d_i equal: sigma is 0 or NaN by rounding; PCL and pcl_rg keep every point."""
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    inlier = pcl_rg.statistical_outlier_removal(points, mean_k=1, std_mul=0.0)
    assert inlier.all()
    np.testing.assert_array_equal(inlier, pcl_mask(points, 1, 0.0))


@pytest.mark.parametrize("spacing", [0.1, 0.3, 0.7])
@pytest.mark.parametrize("pairs", [3, 50])
def test_zero_spread_keeps_every_point_in_the_reference_too(spacing, pairs):
    # The mean of the equal d_i rounded below them (0.09999999999999999 for six 0.1s):
    # with std_mul = 0 the reference made every point an outlier.
    x = 10.0 * np.arange(pairs)
    points = np.r_[np.c_[x, 0 * x, 0 * x], np.c_[x, 0 * x + spacing, 0 * x]]
    for std_mul in (0.0, 1.0):
        expected = pcl_rg.statistical_outlier_removal(points, mean_k=1, std_mul=std_mul)
        assert expected.all()
        got = reference.statistical_outlier_removal(points, mean_k=1, std_mul=std_mul)
        np.testing.assert_array_equal(got, expected)


def test_more_inliers_as_std_mul_grows():
    points = clustered_cloud(4000, 8)
    previous = np.zeros(len(points), bool)
    for std_mul in (0.0, 0.25, 0.5, 1.0, 2.0, 4.0):
        inlier = pcl_rg.statistical_outlier_removal(points, mean_k=8, std_mul=std_mul)
        assert np.all(inlier[previous])  # a superset of the previous inliers
        previous = inlier


def test_permutation_changes_only_threshold_rounding():
    points = clustered_cloud(4000, 12)
    order = np.random.default_rng(12).permutation(len(points))
    _, d, threshold, _ = core_details(points, 8, 1.0)
    _, d_perm, threshold_perm, _ = core_details(points[order], 8, 1.0)
    # d_i depend only on the neighbour distances, never on the order.
    np.testing.assert_array_equal(d[order], d_perm)
    # The threshold's sums run in index order: rounding only.
    assert abs(threshold - threshold_perm) <= 1e-12 * threshold
    a = pcl_rg.statistical_outlier_removal(points, mean_k=8, std_mul=1.0)[order]
    b = pcl_rg.statistical_outlier_removal(points[order], mean_k=8, std_mul=1.0)
    differ = a != b
    assert np.all(np.abs(d_perm[differ] - threshold) <= 1e-12 * threshold)


def test_translation_to_utm_loses_nothing():
    """At (5e5, 5e6, 0) a naive float32 cast quantises y to 0.5 m; the local origin doesn't."""
    rng = np.random.default_rng(21)
    points = np.column_stack([rng.uniform(0, 5, (4000, 2)), rng.normal(0, 0.003, 4000)])
    points = np.vstack([points, [[2.5, 2.5, 0.05], [1.0, 1.0, -0.04]]])
    offset = np.array([5e5, 5e6, 0.0])
    base = pcl_rg.statistical_outlier_removal(points, mean_k=8, std_mul=1.0)
    moved = pcl_rg.statistical_outlier_removal(points + offset, mean_k=8, std_mul=1.0)
    _, d, threshold, _ = core_details(points, 8, 1.0)
    differ = base != moved
    # float64 rounding of the offset sum moves coordinates by < 1e-9 m.
    assert np.all(np.abs(d[differ] - threshold) <= 1e-6)
    assert differ.sum() <= 2
    # What the float32 cast without an origin would do: all distances collapse.
    naive = (points + offset).astype(np.float32).astype(np.float64)
    assert len(np.unique(naive[:, 1])) < 20


def test_empty_input():
    inlier = pcl_rg.statistical_outlier_removal(np.empty((0, 3)), mean_k=5)
    assert inlier.shape == (0,) and inlier.dtype == bool
    assert reference.statistical_outlier_removal(np.empty((0, 3)), mean_k=5).shape == (0,)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"mean_k": 0}, ValueError, "mean_k must be >= 1, got 0"),
        ({"mean_k": -3}, ValueError, "mean_k must be >= 1"),
        ({"mean_k": 10}, ValueError, r"mean_k must be < the number of points \(10\)"),
        ({"mean_k": 2.5}, TypeError, "mean_k must be an integer"),
        ({"mean_k": True}, TypeError, "mean_k must be an integer"),
        ({"mean_k": 3, "std_mul": -0.1}, ValueError, "std_mul must be >= 0"),
        ({"mean_k": 3, "std_mul": float("nan")}, ValueError, "std_mul must be finite"),
        ({"mean_k": 3, "std_mul": "1"}, TypeError, "std_mul must be a real number"),
    ],
)
def test_bad_parameters(kwargs, error, match):
    points = uniform_cloud(10, 0)
    with pytest.raises(error, match=match):
        pcl_rg.statistical_outlier_removal(points, **kwargs)


@pytest.mark.parametrize("mean_k", [0, -2])
def test_reference_mean_neighbour_distance_checks_mean_k(mean_k: int) -> None:
    with pytest.raises(ValueError, match="mean_k must be >= 1"):  # was an IndexError
        mean_neighbour_distance(uniform_cloud(10, 0), mean_k)


def test_core_validates_on_its_own():
    """The C++ gate holds even when the Python dataclass is bypassed."""
    params = _core.StatisticalOutlierRemovalParams()
    params.mean_k = 0
    with pytest.raises(ValueError, match="mean_k must be >= 1"):
        _core.statistical_outlier_removal(uniform_cloud(10, 0), params)
    params.mean_k = 3
    params.std_mul = -1.0
    with pytest.raises(ValueError, match="std_mul must be >= 0, got -1"):
        _core.statistical_outlier_removal(uniform_cloud(10, 0), params)


def test_bad_points():
    with pytest.raises(ValueError, match=r"2 point\(s\) with NaN or Inf"):
        pcl_rg.statistical_outlier_removal([[0, 0, np.nan], [0, 0, 0], [np.inf, 0, 0]], mean_k=1)
    with pytest.raises(TypeError, match="real float or integer"):
        pcl_rg.statistical_outlier_removal(np.ones((4, 3), complex), mean_k=1)


@settings(max_examples=examples(120), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    points=point_arrays((2, 80), [0.0, 1.0, 2.0], 100),
    mean_k=st.integers(1, 10),
    std_mul=st.floats(0, 5),
)
def test_fuzz_equal_to_pcl(points, mean_k, std_mul):
    if mean_k >= len(points):
        with pytest.raises(ValueError, match="mean_k must be <"):
            pcl_rg.statistical_outlier_removal(points, mean_k=mean_k, std_mul=std_mul)
        return
    np.testing.assert_array_equal(
        pcl_rg.statistical_outlier_removal(points, mean_k=mean_k, std_mul=std_mul),
        pcl_mask(points, mean_k, std_mul),
    )


def test_threads_give_the_serial_result():
    points = clustered_cloud(40000, 5)
    expected = pcl_rg.statistical_outlier_removal(points, mean_k=8)
    results = run_in_threads(lambda: pcl_rg.statistical_outlier_removal(points, mean_k=8))
    for r in results:
        np.testing.assert_array_equal(r, expected)


@pytest.mark.parametrize("sample", ISPRS_SAMPLES)
def test_isprs_equal_to_pcl_and_near_reference(sample):
    points = read_pcd(shared_data("isprs", f"{sample}-utm.pcd")).points
    for mean_k, std_mul in ((8, 1.0), (20, 2.0)):
        inlier = assert_near_reference(points, mean_k, std_mul)
        np.testing.assert_array_equal(inlier, pcl_mask(points, mean_k, std_mul))


@pytest.mark.parametrize(
    "name", ["region_growing_tutorial.pcd", "table_scene_mug_stereo_textured.pcd"]
)
def test_pcl_tutorial_clouds(name):
    cloud = read_pcd(shared_data("pcl", name))
    points = cloud.points[np.isfinite(cloud.points).all(axis=1)]
    # PCL's tutorial parameters.
    inlier = assert_near_reference(points, 50, 1.0)
    np.testing.assert_array_equal(inlier, pcl_mask(points, 50, 1.0))
    assert 0.8 < inlier.mean() < 1.0


@pytest.mark.parametrize("mean_k", [1, 8, 30])
def test_farthest_distance_is_the_kth_neighbour(mean_k):
    # Batch denoising trusts d_i of a tile's point only where this distance is below
    # the point's distance to the buffer's edge, so it must be the k-th distance.
    from scipy.spatial import cKDTree

    points = clustered_cloud(3000, 11)
    _, _, _, farthest = core_details(points, mean_k, 1.0)
    local = points - points.min(axis=0)
    distance, _ = cKDTree(local).query(local, k=mean_k + 1)
    np.testing.assert_allclose(farthest, distance[:, -1], rtol=1e-5, atol=1e-5)
