"""Tests of pcl_rg.datasets.building_ids: per-building instance truth of the synthetic scenes."""

from __future__ import annotations

import numpy as np
import pytest

from pcl_rg.datasets import BUILDING, building_ids, isprs_like_scene, synthetic_scene

UTM = (500_000.0, 5_000_000.0, 100.0)


@pytest.mark.parametrize(
    "scene",
    [
        synthetic_scene(seed=2, size=120.0, n_buildings=3, n_trees=10, offset=UTM),
        isprs_like_scene(seed=1, size=250.0, density=1.0),
    ],
    ids=["synthetic", "isprs_like"],
)
def test_every_building_point_has_its_footprint(scene) -> None:
    ids = building_ids(scene.points, scene.labels, scene.buildings)
    assert ids.dtype == np.int64 and ids.shape == (len(scene.points),)
    is_building = scene.labels == BUILDING
    assert np.all(ids[~is_building] == 0)
    assert np.all(ids[is_building] > 0)  # roofs and walls alike
    assert np.unique(ids[is_building]).tolist() == list(range(1, len(scene.buildings) + 1))
    for i, (xmin, ymin, xmax, ymax, _) in enumerate(scene.buildings):
        mine = scene.points[ids == i + 1]
        assert mine[:, 0].min() >= xmin - 0.01 and mine[:, 0].max() <= xmax + 0.01
        assert mine[:, 1].min() >= ymin - 0.01 and mine[:, 1].max() <= ymax + 0.01


def test_walls_need_the_tolerance() -> None:
    # A wall point stands on the footprint's edge; one 5 cm outside needs the tolerance.
    points = np.array([[0.0, 5.0, 3.0], [-0.05, 5.0, 2.0], [5.0, 5.0, 6.0], [20.0, 20.0, 1.0]])
    labels = np.array([BUILDING, BUILDING, BUILDING, 2])
    boxes = np.array([[0.0, 0.0, 10.0, 10.0, 6.0]])
    assert building_ids(points, labels, boxes).tolist() == [1, 0, 1, 0]
    assert building_ids(points, labels, boxes, tolerance=0.1).tolist() == [1, 1, 1, 0]


@pytest.mark.parametrize(
    ("args", "kwargs", "error", "match"),
    [
        ((np.zeros((2, 3)), np.zeros(3, int), np.zeros((1, 4))), {}, ValueError, "labels"),
        # Text or bool labels matched no class code: every id came back 0, silently.
        ((np.zeros((2, 3)), np.array(["6", "6"]), np.zeros((1, 4))), {}, TypeError, "labels"),
        ((np.zeros((2, 3)), np.ones(2, bool), np.zeros((1, 4))), {}, TypeError, "labels"),
        (
            (np.zeros((2, 3)), np.zeros(2, int), np.zeros((1, 4)) + 1j),
            {},
            TypeError,
            "buildings must be real",
        ),
        ((np.zeros((2, 3)), np.zeros(2, int), np.zeros(4)), {}, ValueError, "buildings"),
        ((np.zeros((2, 3)), np.zeros(2, int), np.full((1, 4), np.nan)), {}, ValueError, "finite"),
        (
            (np.zeros((2, 3)), np.zeros(2, int), np.zeros((1, 4))),
            {"tolerance": -1.0},
            ValueError,
            "tolerance",
        ),
        ((np.zeros((2, 2)), np.zeros(2, int), np.zeros((1, 4))), {}, ValueError, "points"),
        (
            (np.zeros((2, 3)).astype(str), np.zeros(2, int), np.zeros((1, 4))),
            {},
            TypeError,
            "points",
        ),
        (
            (
                np.full((1, 3), 1.0),
                np.array([BUILDING]),
                np.array([[0.0, 0.0, 2.0, 2.0], [1.0, 1.0, 3.0, 3.0]]),
            ),
            {},
            ValueError,
            "overlaps",
        ),
    ],
)
def test_bad_input(args, kwargs, error, match) -> None:
    with pytest.raises(error, match=match):
        building_ids(*args, **kwargs)
