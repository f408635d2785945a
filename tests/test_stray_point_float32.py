"""One stray point far from a dense cloud (a bad GPS fix, a sensor glitch) must not
change the float32 neighbourhoods of the others: the k-nearest-neighbour steps take
as their local origin the minimum corner of the points that are not far below the rest
(reference._local.float32_origin), not the minimum corner of all (with that, one point
100 km away cost a Kinect scene its millimetres: convex segmentation's mean IoU on mOSD
fell from 0.99 to 0.67, PCL's region growing to 0.00; our region growing's adjusted Rand
index against its run without the point was 0.997, and is 1.0)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MOSD_SCENES, shared_data

import pcl_rg
import pcl_rg.pcl
from pcl_rg.datasets import load_mosd
from pcl_rg.evaluation import segmentation_scores
from pcl_rg.reference._local import float32_origin

STRAY = [-1e5, -1e5, -1e5]  # 100 km below and behind the scene, in metres


@pytest.fixture(scope="module")
def scene():
    """An mOSD Kinect frame on a 5 mm grid (about 30k points, 1.5-5 mm apart)."""
    frame = load_mosd(shared_data("mosd", f"{MOSD_SCENES[0]}.pcd"))
    return pcl_rg.voxel_grid(frame.points, leaf_size=0.005).centroids


def with_stray(points: np.ndarray) -> np.ndarray:
    return np.vstack([points, STRAY])


def test_normals_of_the_others_stay(scene):
    alone = pcl_rg.normals(scene, k=15).normals
    beside = pcl_rg.normals(with_stray(scene), k=15).normals[:-1]
    cosine = np.abs((alone * beside).sum(axis=1))
    assert np.mean(cosine < 0.999) < 0.001


@pytest.mark.parametrize(
    "segment",
    [
        # Without the voxel grid, whose leaf follows the measured noise, which the stray
        # point's own neighbourhood moves a little (4e-7 m here, a slightly other grid).
        lambda p: pcl_rg.convex_segmentation(p, viewpoint=(0.0, 0.0, 0.0), noise_leaves=0),
        lambda p: pcl_rg.region_growing(p),
        lambda p: pcl_rg.pcl.region_growing(p),
    ],
    ids=["convex_segmentation", "region_growing", "pcl.region_growing"],
)
def test_segments_of_the_others_stay(segment, scene):
    alone = segment(scene)
    beside = segment(with_stray(scene))[:-1]
    # The scores take ids >= 0 as truth (0: none), so the labels are shifted by one.
    assert segmentation_scores(alone + 1, beside).adjusted_rand_index > 0.999


def test_point_scale_of_the_others_stays(scene):
    # (Outlier removal is left out: its mean and deviation include the stray point by
    # definition, which moves every threshold.)
    spacing = pcl_rg.point_scale(scene).spacing
    assert pcl_rg.point_scale(with_stray(scene)).spacing == pytest.approx(spacing, rel=0.01)


def test_the_origin_is_the_minimum_corner_of_all_but_far_strays_whatever_the_order():
    rng = np.random.default_rng(3)
    points = rng.normal(size=(1001, 3))
    # Ordinary clouds keep the minimum corner, and with it every float32 coordinate.
    np.testing.assert_array_equal(float32_origin(points), points.min(axis=0))
    # 100 km below on x, among the rest on y, 50 standard deviations below on z: the
    # fence (4 interquartile ranges below the first quartile) leaves out x's and z's.
    stray = np.vstack([points, [-1e5, 0.0, -50.0]])
    expected = [points[:, 0].min(), points[:, 1].min(), points[:, 2].min()]
    for order in (np.arange(1002), rng.permutation(1002)):
        np.testing.assert_array_equal(float32_origin(stray[order]), expected)
    np.testing.assert_array_equal(float32_origin(points[:2]), points[:2].min(axis=0))
