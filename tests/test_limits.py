"""Inputs beyond the core's index types are refused up front, naming the limit.

A zero-stride view of billions of rows costs no memory, so the refusal is tested
for real: it must come before any copy or conversion of the input. Coordinates
that the float32 local frame cannot hold are refused too, instead of becoming inf,
and masked arrays, whose masks np.asarray would drop.
"""

from __future__ import annotations

import numpy as np
import pytest

import pcl_rg
from pcl_rg import pipeline

UINT32 = 2**32 - 1
INT32 = 2**31 - 1


def rows(n: int) -> np.ndarray:
    return np.broadcast_to(np.zeros(3), (n, 3))  # n rows, 24 bytes of memory


CASES = [
    ("voxel_grid", lambda p: pcl_rg.voxel_grid(p, leaf_size=1.0), UINT32),
    ("statistical_outlier_removal", pcl_rg.statistical_outlier_removal, UINT32),
    ("normals", pcl_rg.normals, UINT32),
    ("grid_ground", pcl_rg.grid_ground, INT32),
    ("tin_ground", pcl_rg.tin_ground, INT32 - 8),
    ("region_growing", pcl_rg.region_growing, INT32),
    ("pcl.region_growing", pcl_rg.pcl.region_growing, INT32),
    ("pcl.normals", pcl_rg.pcl.normals, INT32),
    ("pcl.voxel_grid", lambda p: pcl_rg.pcl.voxel_grid(p, leaf_size=1.0), UINT32),
    ("pipeline.seed004", pipeline.seed004, UINT32),
]


@pytest.mark.parametrize(("name", "call", "limit"), CASES, ids=[c[0] for c in CASES])
def test_one_point_over_the_limit_is_refused_without_allocating(name, call, limit) -> None:
    with pytest.raises(ValueError, match=f"at most {limit:,} points are supported"):
        call(rows(limit + 1))


@pytest.mark.parametrize("limit", [INT32 - 8, INT32, UINT32])
def test_the_message_names_the_index_type_and_the_count(limit) -> None:
    from pcl_rg._validation import as_points

    with pytest.raises(ValueError, match=r"uint32|int32") as error:
        as_points(rows(limit + 1), max_points=limit)
    assert f"got {limit + 1:,}" in str(error.value)
    # At the limit itself the gate lets a (small) cloud through unchanged.
    assert as_points(np.ones((4, 3)), max_points=limit).shape == (4, 3)


FLOAT32_STEPS = [
    ("statistical_outlier_removal", pcl_rg.statistical_outlier_removal),
    ("normals", pcl_rg.normals),
    ("region_growing", pcl_rg.region_growing),
    ("convex_segmentation", pcl_rg.convex_segmentation),
    ("point_scale", pcl_rg.point_scale),
    ("pcl.voxel_grid", lambda p: pcl_rg.pcl.voxel_grid(p, leaf_size=1.0)),
    ("pcl.statistical_outlier_removal", pcl_rg.pcl.statistical_outlier_removal),
    ("pcl.normals", pcl_rg.pcl.normals),
    ("pcl.region_growing", pcl_rg.pcl.region_growing),
    ("pcl.progressive_morphological_filter", pcl_rg.pcl.progressive_morphological_filter),
]


@pytest.mark.parametrize("far", [-1e39, 1e39, -1e300, -1e9, 2e6])
@pytest.mark.parametrize(("name", "call"), FLOAT32_STEPS, ids=[c[0] for c in FLOAT32_STEPS])
def test_a_point_beyond_float32s_reach_is_refused(name, call, far) -> None:
    # One far point below the rest makes the minimum corner far, and every other point
    # minus it loses its precision in float32 (all inf beyond 3.4e38; at 1e9, steps of
    # 64 m): silently wrong before. Above the rest only the far point did.
    points = np.random.default_rng(0).random((300, 3)) * [50.0, 50.0, 5.0]
    points = np.r_[points, [[0.0, far, 0.0]]]
    with pytest.raises(ValueError, match=r"more than 2\^24 x 0.1"):
        call(points)
    call(points[:-1])  # the same cloud without it runs


@pytest.mark.parametrize(("name", "call"), FLOAT32_STEPS, ids=[c[0] for c in FLOAT32_STEPS])
def test_a_survey_within_float32s_reach_runs(name, call) -> None:
    # 1,600 km apart, at UTM-sized coordinates: within reach (2^24 x 0.1 = 1,677.7 km).
    points = np.random.default_rng(1).random((300, 3)) * [50.0, 50.0, 5.0] + [5e5, 5.4e6, 0]
    call(np.r_[points, points[:1] + [0.0, 1.6e6, 0.0]])


@pytest.mark.parametrize(("name", "call", "limit"), CASES, ids=[c[0] for c in CASES])
def test_masked_points_are_refused_not_unmasked(name, call, limit) -> None:
    # np.asarray drops a mask: the masked rows (here far away) would be used silently.
    points = np.ma.masked_array(np.random.default_rng(0).uniform(0.0, 10.0, (60, 3)))
    points[:5] = 1e3
    points[:5] = np.ma.masked
    with pytest.raises(ValueError, match="masked arrays are not accepted"):
        call(points)
