"""Tests of pcl_rg.datasets.isprs_like_scene: the hard scene with ISPRS-like class ratios."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pcl_rg.datasets import (
    BRIDGE_DECK,
    BUILDING,
    GROUND,
    LOW_VEGETATION,
    NOISE,
    VEGETATION,
    IsprsLikeScene,
    isprs_like_scene,
    isprs_like_terrain,
)


@pytest.fixture(scope="module")
def scene() -> IsprsLikeScene:
    """Seed 3 at 2 pts/m^2 on the default 300 m square (about 210k points)."""
    return isprs_like_scene(seed=3, density=2.0)


def _height_above_terrain(s: IsprsLikeScene, mask: np.ndarray, seed: int = 3) -> np.ndarray:
    p = s.points[mask] - s.origin
    return p[:, 2] - isprs_like_terrain(p[:, 0], p[:, 1], seed=seed)


def test_shapes_dtypes_and_classes(scene: IsprsLikeScene) -> None:
    n = len(scene.points)
    assert scene.points.shape == (n, 3) and scene.points.dtype == np.float64
    assert scene.labels.shape == (n,) and scene.labels.dtype == np.uint8
    assert np.isfinite(scene.points).all()
    codes = {GROUND, LOW_VEGETATION, VEGETATION, BUILDING, NOISE, BRIDGE_DECK}
    assert set(np.unique(scene.labels).tolist()) == codes
    # 1.1 x density x area, within Poisson and layout variation.
    assert 0.9 * 2.0 * 300.0**2 < n < 1.4 * 2.0 * 300.0**2
    xy = scene.points[:, :2]
    assert xy.min() >= 0.0 and xy.max() <= 300.0


@pytest.mark.parametrize("density", [2.0, 8.0])
@pytest.mark.parametrize("seed", [0, 5])
def test_the_object_share_is_isprs_like(seed: int, density: float) -> None:
    labels = isprs_like_scene(seed=seed, density=density).labels
    share = float(np.mean(labels != GROUND))
    assert 0.30 <= share <= 0.60, share
    # Every kind of object is a visible share, not a token.
    for code, least in [(BUILDING, 0.1), (VEGETATION, 0.03), (LOW_VEGETATION, 0.03)]:
        assert np.mean(labels == code) > least, code


def test_same_seed_same_arrays_and_seeds_differ() -> None:
    a = isprs_like_scene(seed=4, density=0.5)
    b = isprs_like_scene(seed=4, density=0.5)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    c = isprs_like_scene(seed=5, density=0.5)
    assert len(c.points) != len(a.points) or not np.array_equal(c.points, a.points)


def test_the_objects_do_not_depend_on_the_density() -> None:
    sparse = isprs_like_scene(seed=2, density=0.5)
    dense = isprs_like_scene(seed=2, density=2.0)
    np.testing.assert_array_equal(sparse.buildings, dense.buildings)
    assert 3.0 < len(dense.points) / len(sparse.points) < 5.0


def test_a_large_building_up_to_100_m() -> None:
    for seed in range(4):
        b = isprs_like_scene(seed=seed, density=0.2).buildings
        longest = np.maximum(b[:, 2] - b[:, 0], b[:, 3] - b[:, 1])
        assert 60.0 <= longest.max() <= 100.0
        assert (longest <= 100.0).all()


def test_labels_are_plausible(scene: IsprsLikeScene) -> None:
    ground = _height_above_terrain(scene, scene.labels == GROUND)
    assert np.abs(ground).max() < 0.25  # 3 cm Gaussian roughness
    roofs = _height_above_terrain(scene, scene.labels == BUILDING)
    assert np.median(roofs) > 3.0 and roofs.min() > -0.25  # walls start at the foot
    shrubs = _height_above_terrain(scene, scene.labels == LOW_VEGETATION)
    assert shrubs.min() >= 0.14 and shrubs.max() <= 2.6
    trees = _height_above_terrain(scene, scene.labels == VEGETATION)
    assert trees.min() > 0.2 and np.median(trees) > 3.0
    deck = _height_above_terrain(scene, scene.labels == BRIDGE_DECK)
    assert deck.min() > 0.4 and deck.max() > 4.0  # the channel is 4-6 m deep
    noise = np.abs(_height_above_terrain(scene, scene.labels == NOISE))
    assert noise.min() >= 0.9


def test_no_ground_under_roofs_or_deck(scene: IsprsLikeScene) -> None:
    p = scene.points[scene.labels == GROUND]
    for xmin, ymin, xmax, ymax, _ in scene.buildings:
        inside = (p[:, 0] > xmin) & (p[:, 0] < xmax) & (p[:, 1] > ymin) & (p[:, 1] < ymax)
        assert not inside.any()
    deck = scene.points[scene.labels == BRIDGE_DECK]
    tree = cKDTree(p[:, :2])
    distance, _ = tree.query(deck[:, :2])
    # Under the deck the ground is occluded: its points lie far from any ground return
    # except at the deck's rim.
    assert np.median(distance) > 1.0


def test_the_terrain_is_steep_with_break_lines() -> None:
    x, y = np.meshgrid(np.arange(0.0, 300.0, 1.0), np.arange(0.0, 300.0, 1.0))
    z = isprs_like_terrain(x, y, seed=3)
    gy, gx = np.gradient(z, 1.0)
    slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    assert (slope > 30.0).mean() > 0.03  # the band, the embankment and the channel banks
    assert np.percentile(slope, 50) < 10.0  # and mostly gentle between them


def test_offset_shifts_points_and_buildings_only() -> None:
    a = isprs_like_scene(seed=1, density=0.3)
    b = isprs_like_scene(seed=1, density=0.3, offset=(500_000.0, 5_000_000.0, 50.0))
    np.testing.assert_allclose(b.points - b.origin, a.points, atol=1e-6)
    np.testing.assert_array_equal(a.labels, b.labels)
    np.testing.assert_allclose(b.buildings[:, 0] - 500_000.0, a.buildings[:, 0], atol=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"size": 200.0}, ValueError, r"size must be in \[250, 1000\], got 200"),
        ({"size": 5000.0, "density": 1e-9}, ValueError, r"size must be in \[250, 1000\]"),
        ({"density": 1e12}, ValueError, "density=1e.12 ask for .* more than this machine's"),
        ({"offset": (1e300, 0.0, 0.0)}, ValueError, "offset .* is too far from 0"),
        ({"density": 0.0}, ValueError, "density must be > 0"),
        ({"seed": -1}, ValueError, "seed must be >= 0"),
        ({"seed": 1.5}, TypeError, "seed must be an integer"),
        ({"noise_fraction": 0.5}, ValueError, "noise_fraction"),
        ({"offset": (1.0, 2.0)}, ValueError, "offset"),
    ],
)
def test_bad_arguments(kwargs: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        isprs_like_scene(**kwargs)


def test_terrain_rejects_non_finite() -> None:
    with pytest.raises(ValueError, match="x must be finite"):
        isprs_like_terrain(np.array([np.nan]), np.array([0.0]))
