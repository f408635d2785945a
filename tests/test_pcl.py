"""Tests of pcl_rg.pcl: PCL's own classes on our arrays, the baselines.

VoxelGrid and StatisticalOutlierRemoval against pcl_rg's own (equal where the
semantics agree; tests/test_voxel_grid.py and tests/test_statistical_outlier_removal.py
hold them to it on more clouds), NormalEstimation + RegionGrowing, and the
(approximate) progressive morphological filter.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import MOSD_SCENES, examples, point_arrays, run_in_threads, shared_data
from hypothesis import HealthCheck, given, settings
from test_region_growing import (
    assert_labels_or_value_error,
    assert_numbered_by_smallest_index,
    box_scene,
    matched_agreement,
    region_growing_keywords,
)

import pcl_rg
import pcl_rg.pcl
from pcl_rg import _pcl
from pcl_rg.datasets import load_mosd
from pcl_rg.pcl import ProgressiveMorphologicalFilterParams, RegionGrowingPclParams

region_growing_pcl = pcl_rg.pcl.region_growing
UTM = np.array([5e5, 5e6, 120.0])


def test_public_names() -> None:
    assert "pcl" in pcl_rg.__all__
    assert not hasattr(pcl_rg, "region_growing_pcl")
    assert pcl_rg.pcl.VoxelGridParams is pcl_rg.VoxelGridParams
    assert pcl_rg.pcl.StatisticalOutlierRemovalParams is pcl_rg.StatisticalOutlierRemovalParams
    for name in pcl_rg.pcl.__all__:
        assert getattr(pcl_rg.pcl, name).__doc__


# --- VoxelGrid ---------------------------------------------------------------------


def test_voxel_grid_equals_ours() -> None:
    # float32-exact points and a power-of-two leaf: the same voxels (see
    # tests/test_voxel_grid.py); PCL's float32 centroid sums off by a few ulps.
    rng = np.random.default_rng(30)
    pts = rng.uniform(-20, 20, (5000, 3)).astype(np.float32).astype(np.float64)
    ours = pcl_rg.voxel_grid(pts, leaf_size=2.0, min_points_per_voxel=2)
    theirs = pcl_rg.pcl.voxel_grid(pts, leaf_size=2.0, min_points_per_voxel=2)
    assert isinstance(theirs, pcl_rg.VoxelGridResult)
    assert theirs.voxel_of_point.dtype == np.intp and theirs.counts.dtype == np.int64
    np.testing.assert_array_equal(theirs.counts, ours.counts)
    np.testing.assert_array_equal(theirs.voxel_of_point, ours.voxel_of_point)
    np.testing.assert_allclose(theirs.centroids, ours.centroids, rtol=0, atol=1e-5)


def test_voxel_grid_translation_to_utm() -> None:
    # The shift is a multiple of the leaf and exact in float64: PCL sees the same cloud.
    rng = np.random.default_rng(31)
    pts = np.round(rng.uniform(0, 30, (4000, 3)) * 2**10) / 2**10
    near = pcl_rg.pcl.voxel_grid(pts, leaf_size=1.0)
    far = pcl_rg.pcl.voxel_grid(pts + UTM, leaf_size=1.0)
    np.testing.assert_array_equal(far.counts, near.counts)
    np.testing.assert_array_equal(far.voxel_of_point, near.voxel_of_point)
    np.testing.assert_allclose(far.centroids - UTM, near.centroids, rtol=0, atol=1e-9)


def test_voxel_grid_keeps_millimetres_beside_a_stray_point_far_below() -> None:
    # A record at z = -1e5 (a bad fix) set the float32 frame's origin: the other points
    # lost their millimetres, centroids moved by up to 1.3 cm and voxels split.
    rng = np.random.default_rng(32)
    tile = rng.uniform(0.0, 100.0, (20_000, 3)) * (1.0, 1.0, 0.3) + UTM
    stray = np.r_[tile, [[UTM[0] + 50.0, UTM[1] + 50.0, -1e5]]]
    ours = pcl_rg.voxel_grid(stray, leaf_size=2.0)
    theirs = pcl_rg.pcl.voxel_grid(stray, leaf_size=2.0)
    np.testing.assert_array_equal(theirs.counts, ours.counts)
    np.testing.assert_array_equal(theirs.voxel_of_point, ours.voxel_of_point)
    kept = np.arange(len(ours.counts)) != ours.voxel_of_point[-1]  # not the stray's voxel
    np.testing.assert_allclose(theirs.centroids[kept], ours.centroids[kept], rtol=0, atol=1e-4)


def test_voxel_grid_errors_and_empty() -> None:
    pts = np.zeros((3, 3))
    with pytest.raises(ValueError, match="leaf_size must be > 0, got 0"):
        pcl_rg.pcl.voxel_grid(pts, leaf_size=0.0)
    with pytest.raises(ValueError, match="min_points_per_voxel must be >= 1, got 0"):
        pcl_rg.pcl.voxel_grid(pts, leaf_size=1.0, min_points_per_voxel=0)
    with pytest.raises(TypeError, match="needs leaf_size"):
        pcl_rg.pcl.voxel_grid(pts)
    empty = pcl_rg.pcl.voxel_grid(np.empty((0, 3)), leaf_size=1.0)
    assert empty.centroids.shape == (0, 3) and empty.counts.shape == (0,)
    assert empty.voxel_of_point.shape == (0,)


# --- StatisticalOutlierRemoval ---------------------------------------------------------


def test_sor_bit_equal_to_ours_and_translation() -> None:
    rng = np.random.default_rng(32)
    pts = np.vstack([rng.normal(0, 1, (3000, 3)), rng.uniform(-15, 15, (60, 3))])
    theirs = pcl_rg.pcl.statistical_outlier_removal(pts, mean_k=10, std_mul=1.0)
    assert theirs.dtype == np.bool_ and theirs.shape == (len(pts),)
    np.testing.assert_array_equal(
        theirs, pcl_rg.statistical_outlier_removal(pts, mean_k=10, std_mul=1.0)
    )
    exact = np.round(pts * 2**16) / 2**16
    np.testing.assert_array_equal(
        pcl_rg.pcl.statistical_outlier_removal(exact, mean_k=10, std_mul=1.0),
        pcl_rg.pcl.statistical_outlier_removal(exact + UTM, mean_k=10, std_mul=1.0),
    )


def test_sor_errors_and_empty() -> None:
    pts = np.random.default_rng(33).uniform(0, 1, (20, 3))
    with pytest.raises(ValueError, match="mean_k must be >= 1, got 0"):
        pcl_rg.pcl.statistical_outlier_removal(pts, mean_k=0)
    with pytest.raises(ValueError, match=r"mean_k must be < the number of points \(20\), got 20"):
        pcl_rg.pcl.statistical_outlier_removal(pts, mean_k=20)
    with pytest.raises(ValueError, match="std_mul must be >= 0, got -1"):
        pcl_rg.pcl.statistical_outlier_removal(pts, std_mul=-1.0)
    empty = pcl_rg.pcl.statistical_outlier_removal(np.empty((0, 3)))
    assert empty.dtype == np.bool_ and empty.shape == (0,)


def test_many_copies_of_a_position_are_refused_before_pcl_searches() -> None:
    # FLANN's tree cannot split copies: 100k identical points took SOR and
    # NormalEstimation 73 s each and RegionGrowing more than 2 min, not interruptible.
    # Refused in a moment when the sum of copies^2 passes 1e10 (kPclCopiesWork).
    copies = np.repeat(np.random.default_rng(0).uniform(0, 9, (2, 3)), 80_000, axis=0)
    for function in (
        pcl_rg.pcl.statistical_outlier_removal,
        pcl_rg.pcl.normals,
        pcl_rg.pcl.region_growing,
    ):
        with pytest.raises(ValueError, match="up to 80000 copies of one position"):
            function(copies)
        assert pcl_rg.statistical_outlier_removal(copies).all()  # ours: at once
    # Below the bound: 50 positions of 1,000 copies (sum 5e7) and 60k other points run.
    rng = np.random.default_rng(1)
    mixed = np.r_[
        np.repeat(rng.uniform(0, 9, (50, 3)), 1_000, axis=0), rng.uniform(0, 9, (60_000, 3))
    ]
    assert pcl_rg.pcl.statistical_outlier_removal(mixed, mean_k=8).shape == (len(mixed),)


# --- NormalEstimation + RegionGrowing ------------------------------------------------


def test_result_and_numbering() -> None:
    pts = box_scene(seed=20)
    common = dict(k=12, smoothness_deg=12, curvature_threshold=0.05, min_cluster_size=50)
    with pcl_rg.collect_diagnostics() as diagnostics:
        labels = region_growing_pcl(pts, **common)
    n = len(pts)
    assert labels.dtype == np.int32 and labels.shape == (n,)
    record = diagnostics["pcl.region_growing"]
    assert record["normals_seconds"] >= 0 and record["growth_seconds"] >= 0
    assert record["clusters"] == labels.max() + 1
    assert_numbered_by_smallest_index(labels)
    assert np.unique(labels).size >= 6  # floor, 3 box faces, ball, pipe
    sizes = np.bincount(labels[labels >= 0])
    assert (sizes >= 50).all()
    np.testing.assert_array_equal(labels, region_growing_pcl(pts, **common))


def test_normals() -> None:
    pts = box_scene(seed=27)
    result = pcl_rg.pcl.normals(pts, k=12)
    n = len(pts)
    assert result.normals.dtype == np.float32 and result.normals.shape == (n, 3)
    assert result.curvature.dtype == np.float32 and result.curvature.shape == (n,)
    np.testing.assert_allclose(np.linalg.norm(result.normals, axis=1), 1.0, atol=1e-5)
    assert ((result.curvature >= 0) & (result.curvature <= 1 / 3 + 1e-6)).all()
    with pytest.raises(ValueError, match="k must be >= 3, got 2"):
        pcl_rg.pcl.normals(pts, k=2)
    with pytest.raises(ValueError, match=r"k must be < the number of points \(5\), got 5"):
        pcl_rg.pcl.normals(pts[:5], k=5)
    empty = pcl_rg.pcl.normals(np.empty((0, 3)))
    assert empty.normals.shape == (0, 3) and empty.curvature.shape == (0,)


def test_same_growth_as_the_curvature_seeded_method_with_pcl_measure() -> None:
    # With seed_measure="surface_variation" pcl_rg.region_growing follows PCL's
    # algorithm; the differences left are PCL's float32 normals and curvatures and its
    # unstable sort of equal curvatures. Those only move points where a decision sits
    # within float32 rounding (~1e-7) of a threshold, so nearly all points agree.
    pts = box_scene(seed=21)
    common = dict(k=12, smoothness_deg=10.0, curvature_threshold=0.02, min_cluster_size=20)
    ours = pcl_rg.region_growing(pts, seed_measure="surface_variation", **common)
    theirs = region_growing_pcl(pts, **common)
    assert matched_agreement(ours, theirs) >= 0.999


def test_real_scene_agrees_with_the_surface_variation_variant() -> None:
    # The same comparison on a voxelised Kinect scene: >= 99 % of the points.
    scene = load_mosd(shared_data("mosd", f"{MOSD_SCENES[2]}.pcd"))
    pts = pcl_rg.voxel_grid(scene.points, leaf_size=0.006).centroids
    common = dict(k=15, smoothness_deg=8.0, curvature_threshold=0.05, min_cluster_size=20)
    ours = pcl_rg.region_growing(pts, seed_measure="surface_variation", **common)
    theirs = region_growing_pcl(pts, **common)
    assert matched_agreement(ours, theirs) >= 0.99


def test_translation_to_utm_is_exact() -> None:
    # The local origin is subtracted in float64 before PCL sees float32: with an exact
    # shift PCL receives the very same cloud.
    pts = np.round(box_scene(seed=22) * 2**20) / 2**20
    common = dict(k=10, smoothness_deg=10.0, curvature_threshold=0.05)
    np.testing.assert_array_equal(
        region_growing_pcl(pts, **common),
        region_growing_pcl(pts + [5e5, 5e6, 120.0], **common),
    )


def test_threads_give_the_serial_result() -> None:
    pts = box_scene(seed=23)
    serial = region_growing_pcl(pts, k=10)
    results = run_in_threads(lambda: region_growing_pcl(pts, k=10), threads=3)
    for result in results:
        np.testing.assert_array_equal(result, serial)


def test_params_defaults_match_core() -> None:
    core = _pcl.RegionGrowingPclParams()
    for f in dataclasses.fields(RegionGrowingPclParams):
        assert getattr(RegionGrowingPclParams(), f.name) == getattr(core, f.name), f.name
        assert f.metadata["help"]
    shared = {f.name for f in dataclasses.fields(RegionGrowingPclParams)}
    assert shared < {f.name for f in dataclasses.fields(pcl_rg.RegionGrowingParams)}


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"k": 2}, "k must be >= 3, got 2"),
        ({"k": 40}, r"k must be < the number of points \(40\), got 40"),
        ({"smoothness_deg": 0.0}, r"smoothness_deg must be in \(0, 180\)"),
        ({"smoothness_deg": 190.0}, r"smoothness_deg must be in \(0, 180\)"),
        ({"curvature_threshold": -1.0}, "curvature_threshold must be >= 0"),
        ({"min_cluster_size": 5, "max_cluster_size": 4}, "max_cluster_size must be >= min"),
        (
            {"max_cluster_size": 2**32},
            "max_cluster_size must be in \\[1, 4294967295\\], got 4294967296",
        ),
    ],
)
def test_bad_parameters(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        region_growing_pcl(box_scene(seed=24)[:40], **kwargs)


def test_core_validates_too() -> None:
    core = RegionGrowingPclParams().to_core()
    core.max_cluster_size = 2**40
    with pytest.raises(ValueError, match=r"max_cluster_size must be in \[1, 4294967295\]"):
        _pcl.region_growing(box_scene(seed=25), core)


def test_bad_points_and_empty_input() -> None:
    pts = box_scene(seed=26)[:40]
    pts[0, 2] = np.inf
    with pytest.raises(ValueError, match="points has 1 point"):
        region_growing_pcl(pts, k=5)
    with pytest.raises(TypeError, match="seed_measure"):
        region_growing_pcl(pts, seed_measure="curvedness")  # type: ignore[call-arg]
    empty = region_growing_pcl(np.empty((0, 3)))
    assert empty.dtype == np.int32 and empty.shape == (0,)


@settings(max_examples=examples(100), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    points=point_arrays((0, 30), [0.0, 1.0, -2.0, 1e-6, 1e4], 5),
    keywords=region_growing_keywords(1.0),
)
def test_fuzz_only_value_errors(points, keywords) -> None:
    # Duplicates and collinear points included: PCL gives NaN or arbitrary normals
    # there, which its growth accepts; nothing may crash.
    assert_labels_or_value_error(region_growing_pcl, points, keywords)


# --- progressive morphological filter ----------------------------------------------


def _box_on_plane(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 40, (3000, 2))
    box = (np.abs(xy - 20) < 4).all(axis=1)
    return np.c_[xy, np.where(box, 5.0, 0.0)], box


@pytest.mark.parametrize("approximate", [False, True])
def test_pmf_box_on_plane_and_translation(approximate: bool) -> None:
    pts, box = _box_on_plane(40)
    ground = pcl_rg.pcl.progressive_morphological_filter(pts, approximate=approximate)
    assert ground.dtype == np.bool_ and ground.shape == (len(pts),)
    np.testing.assert_array_equal(ground, ~box)
    exact = np.round(pts * 2**10) / 2**10
    params = ProgressiveMorphologicalFilterParams(approximate=approximate)
    np.testing.assert_array_equal(
        pcl_rg.pcl.progressive_morphological_filter(exact, params=params),
        pcl_rg.pcl.progressive_morphological_filter(exact + UTM, params=params),
    )


def test_pmf_params() -> None:
    p = ProgressiveMorphologicalFilterParams()
    assert (p.max_window_size, p.slope, p.initial_distance, p.max_distance) == (20, 1.0, 0.5, 3.0)
    assert (p.cell_size, p.base, p.exponential, p.approximate) == (1.0, 2.0, True, False)
    core = _pcl.ProgressiveMorphologicalFilterParams()
    for f in dataclasses.fields(ProgressiveMorphologicalFilterParams):
        assert getattr(p, f.name) == getattr(core, f.name), f.name


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"max_window_size": 0}, "max_window_size must be >= 1, got 0"),
        ({"slope": -1.0}, "slope must be >= 0, got -1"),
        ({"initial_distance": float("nan")}, "initial_distance must be finite, got nan"),
        ({"max_distance": -0.5}, "max_distance must be >= 0, got -0.5"),
        ({"cell_size": 0.0}, "cell_size must be > 0, got 0"),
        ({"base": -2.0}, "base must be > 0, got -2"),
    ],
)
def test_pmf_bad_parameters(kwargs: dict, match: str) -> None:
    pts, _ = _box_on_plane(41)
    with pytest.raises(ValueError, match=match):
        pcl_rg.pcl.progressive_morphological_filter(pts, **kwargs)
    with pytest.raises(TypeError, match="exponential must be True or False"):
        pcl_rg.pcl.progressive_morphological_filter(pts, exponential=1)  # type: ignore[arg-type]


def test_pmf_core_validates_too() -> None:
    core = ProgressiveMorphologicalFilterParams().to_core()
    core.cell_size = -1.0
    with pytest.raises(ValueError, match="cell_size must be > 0, got -1"):
        _pcl.progressive_morphological_filter(np.zeros((3, 3)), core)


def test_pmf_empty() -> None:
    for approximate in (False, True):
        empty = pcl_rg.pcl.progressive_morphological_filter(
            np.empty((0, 3)), approximate=approximate
        )
        assert empty.dtype == np.bool_ and empty.shape == (0,)


# --- what PCL cannot run with: refused before it loops, aborts or exhausts memory -------

_KM = np.c_[np.random.default_rng(0).uniform(0.0, 1000.0, (3000, 2)), np.zeros(3000)]
_SPREAD = np.c_[np.random.default_rng(1).uniform(0.0, 100.0, (20_000, 2)), np.zeros(20_000)]
_DENSE = np.c_[np.random.default_rng(2).uniform(0.0, 1.0, (200_000, 2)), np.zeros(200_000)]


@pytest.mark.parametrize(
    ("points", "kwargs", "match"),
    [
        # PCL's `while (window < max_window_size)` never ends (memory grows ~0.4 GB/s).
        (None, {"base": 1.0}, "window series does not grow"),
        (None, {"base": 1 + 1e-8}, "window series does not grow"),  # 1 in float32
        (None, {"base": 1e-300, "exponential": False}, "window series does not grow"),
        (None, {"base": 1.0001}, "more than 64 steps"),  # ran for minutes
        (_KM, {"max_window_size": 10**6, "exponential": False}, "more than 64 steps"),
        (None, {"base": 1e10, "approximate": True}, "half size overflows int"),
        # Octree and Eigen assertions (SIGABRT).
        (None, {"cell_size": 1e-8}, "more than 2.24 cells on an axis"),
        (None, {"cell_size": 3e38}, "beyond float32"),
        (None, {"cell_size": 1e-45}, "float32, which cannot hold 1e-45"),
        (_KM, {"cell_size": 1e-7, "approximate": True}, "more than 2.24 cells on an axis"),
        # The approximate filter's dense grids and naive windows (120 GB, or hours).
        (
            _KM,
            {"cell_size": 1e-2, "approximate": True},
            r"grids would hold \d+ cells \(at most 2.28",
        ),
        (_KM, {"max_window_size": 10**6, "approximate": True}, "compare about .* at most 1e11"),
        # The point-wise filter's boxes: every window past 1 km holds all points (minutes,
        # with no way to interrupt PCL), or a dense cloud with PCL's own defaults (89 s).
        (_SPREAD, {"max_window_size": 2**31 - 1}, "collect up to about .* at most 1e10"),
        (_DENSE, {}, "collect up to about .* at most 1e10"),
        # A dense cluster beside one far point: counted from the extent, its points were
        # spread thin and it passed, then ran 209 s (found by a hunt).
        (np.r_[_DENSE[:40_000] * 0.01, [[1000.0, 1000.0, 0.0]]], {}, "at most 1e10"),
    ],
)
def test_pmf_refuses_what_pcl_cannot_run(points, kwargs, match) -> None:
    pts = _box_on_plane(41)[0] if points is None else points
    with pytest.raises(ValueError, match=match):
        pcl_rg.pcl.progressive_morphological_filter(pts, **kwargs)


def test_voxel_grid_and_lccp_refuse_what_float32_and_pcl_cannot_hold() -> None:
    # PCL's int64 voxel count wrapped for tiny leaves, and then the centroids came back
    # in an order that did not match voxel_of_point (up to 1000 m off).
    pts = np.array([[0, 0, 0], [1000.0, 1000.0, 10.0], [0, 0, 5.0], [3, 4, 0.1]])
    with pytest.raises(ValueError, match="numbers the voxels of the bounding box in 32 bits"):
        pcl_rg.pcl.voxel_grid(pts, 3e-7)
    # PCL counts trunc(extent / leaf) + 1 voxels per axis but numbers them from
    # floor(min / leaf) to floor(max / leaf): 2 x 2 x (2^30 + 1) numbers passed its count
    # of 2^30 + 1, wrapped in 32 bits, and two points got each other's centroid.
    leaf = 2.0**-10
    thin = np.array([[0.9 * leaf, 0.9 * leaf, 0], [1.1 * leaf, 1.1 * leaf, 5 * leaf]])
    with pytest.raises(ValueError, match="numbers the voxels of the bounding box in 32 bits"):
        pcl_rg.pcl.voxel_grid(np.r_[thin, [[1.1 * leaf, 1.1 * leaf, 2.0**20]]], leaf)
    np.testing.assert_array_equal(pcl_rg.pcl.voxel_grid(thin, leaf).counts, [1, 1])
    with pytest.raises(ValueError, match="cannot hold the inverse of 1e-40"):
        pcl_rg.pcl.voxel_grid([[0, 0, 0], [1, 1, 1]], 1e-40)  # one voxel for every point
    with pytest.raises(ValueError, match="min_points_per_voxel: pcl::VoxelGrid counts in 32"):
        pcl_rg.pcl.voxel_grid(pts, 1.0, min_points_per_voxel=2**32)
    viewpoint = tuple(pts.mean(axis=0))
    for kwargs, name in [
        ({"voxel_resolution": 3.5e38, "seed_resolution": 3.5e38}, "voxel_resolution"),  # abort
        ({"voxel_resolution": 0.5, "seed_resolution": 1e39}, "seed_resolution"),
        (
            {"voxel_resolution": 0.5, "seed_resolution": 2.0, "spatial_importance": 1e39},
            "spatial_importance",
        ),
    ]:
        with pytest.raises(ValueError, match=f"{name}: PCL computes in float32"):
            pcl_rg.pcl.lccp(pts, viewpoint=viewpoint, **kwargs)
