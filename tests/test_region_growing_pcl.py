"""Tests of pcl_rg.region_growing_pcl: PCL's NormalEstimation + RegionGrowing baseline."""

from __future__ import annotations

import dataclasses
import threading

import numpy as np
import pytest
from conftest import examples, MOSD_SCENES, shared_data
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from test_region_growing import assert_numbered_by_smallest_index, box_scene, matched_agreement

import pcl_rg
from pcl_rg import _core
from pcl_rg.datasets import load_mosd
from pcl_rg._region_growing_pcl import PclRegionGrowingResult, RegionGrowingPclParams


def test_result_and_numbering() -> None:
    pts = box_scene(seed=20)
    result = pcl_rg.region_growing_pcl(pts, k=12, smoothness_deg=12, curvature_threshold=0.05,
                                       min_cluster_size=50, full_output=True)
    assert isinstance(result, PclRegionGrowingResult)
    n = len(pts)
    assert result.labels.dtype == np.int32 and result.labels.shape == (n,)
    assert result.normals.dtype == np.float32 and result.normals.shape == (n, 3)
    assert result.curvature.dtype == np.float32 and result.curvature.shape == (n,)
    assert result.normals_seconds >= 0 and result.growth_seconds >= 0
    assert_numbered_by_smallest_index(result.labels)
    assert np.unique(result.labels).size >= 6  # floor, 3 box faces, ball, pipe
    sizes = np.bincount(result.labels[result.labels >= 0])
    assert (sizes >= 50).all()
    np.testing.assert_array_equal(
        result.labels,
        pcl_rg.region_growing_pcl(pts, k=12, smoothness_deg=12, curvature_threshold=0.05,
                                  min_cluster_size=50),
    )


def test_same_growth_as_the_curvature_seeded_method_with_pcl_measure() -> None:
    # With seed_measure="surface_variation" pcl_rg.region_growing follows PCL's
    # algorithm; the differences left are PCL's float32 normals and curvatures and its
    # unstable sort of equal curvatures. Those only move points where a decision sits
    # within float32 rounding (~1e-7) of a threshold, so nearly all points agree.
    pts = box_scene(seed=21)
    common = dict(k=12, smoothness_deg=10.0, curvature_threshold=0.02, min_cluster_size=20)
    ours = pcl_rg.region_growing(pts, seed_measure="surface_variation", **common)
    theirs = pcl_rg.region_growing_pcl(pts, **common)
    assert matched_agreement(ours, theirs) >= 0.999


def test_real_scene_agrees_with_the_surface_variation_variant() -> None:
    # The same comparison on a voxelised Kinect scene: >= 99 % of the points.
    scene = load_mosd(shared_data("mosd", f"{MOSD_SCENES[2]}.pcd"))
    pts = pcl_rg.voxel_grid(scene.points, leaf_size=0.006).centroids
    common = dict(k=15, smoothness_deg=8.0, curvature_threshold=0.05, min_cluster_size=20)
    ours = pcl_rg.region_growing(pts, seed_measure="surface_variation", **common)
    theirs = pcl_rg.region_growing_pcl(pts, **common)
    assert matched_agreement(ours, theirs) >= 0.99


def test_translation_to_utm_is_exact() -> None:
    # The local origin is subtracted in float64 before PCL sees float32: with an exact
    # shift PCL receives the very same cloud.
    pts = np.round(box_scene(seed=22) * 2**20) / 2**20
    common = dict(k=10, smoothness_deg=10.0, curvature_threshold=0.05)
    np.testing.assert_array_equal(
        pcl_rg.region_growing_pcl(pts, **common),
        pcl_rg.region_growing_pcl(pts + [5e5, 5e6, 120.0], **common),
    )


def test_threads_give_the_serial_result() -> None:
    pts = box_scene(seed=23)
    serial = pcl_rg.region_growing_pcl(pts, k=10)
    results: list = [None] * 3

    def work(i: int) -> None:
        results[i] = pcl_rg.region_growing_pcl(pts, k=10)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for result in results:
        np.testing.assert_array_equal(result, serial)


def test_params_defaults_match_core() -> None:
    core = _core.RegionGrowingPclParams()
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
        ({"max_cluster_size": 2**32}, "max_cluster_size must be in \\[1, 4294967295\\], got 4294967296"),
    ],
)
def test_bad_parameters(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        pcl_rg.region_growing_pcl(box_scene(seed=24)[:40], **kwargs)


def test_core_validates_too() -> None:
    core = RegionGrowingPclParams().to_core()
    core.max_cluster_size = 2**40
    with pytest.raises(ValueError, match=r"max_cluster_size must be in \[1, 4294967295\]"):
        _core.region_growing_pcl(box_scene(seed=25), core)


def test_bad_points_and_empty_input() -> None:
    pts = box_scene(seed=26)[:40]
    pts[0, 2] = np.inf
    with pytest.raises(ValueError, match="points has 1 point"):
        pcl_rg.region_growing_pcl(pts, k=5)
    with pytest.raises(TypeError, match="seed_measure"):
        pcl_rg.region_growing_pcl(pts, seed_measure="curvedness")  # type: ignore[call-arg]
    empty = pcl_rg.region_growing_pcl(np.empty((0, 3)))
    assert empty.dtype == np.int32 and empty.shape == (0,)


@settings(max_examples=examples(100), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    points=hnp.arrays(
        np.float64,
        st.tuples(st.integers(0, 30), st.just(3)),
        elements=st.one_of(st.sampled_from([0.0, 1.0, -2.0, 1e-6, 1e4]), st.floats(-5, 5)),
    ),
    k=st.integers(1, 32),
    angle=st.floats(-10, 200),
    threshold=st.floats(-1, 1),
    sizes=st.tuples(st.integers(0, 40), st.integers(0, 40)),
)
def test_fuzz_only_value_errors(points, k, angle, threshold, sizes) -> None:
    # Duplicates and collinear points included: PCL gives NaN or arbitrary normals
    # there, which its growth accepts; nothing may crash.
    try:
        labels = pcl_rg.region_growing_pcl(
            points, k=k, smoothness_deg=angle, curvature_threshold=threshold,
            min_cluster_size=sizes[0], max_cluster_size=sizes[1],
        )
    except ValueError:
        return
    assert labels.dtype == np.int32 and labels.shape == (len(points),)
    assert_numbered_by_smallest_index(labels)
