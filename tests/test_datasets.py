"""Tests of pcl_rg.datasets' seeded synthetic airborne-LiDAR scene (the tiled survey:
test_datasets_survey.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pcl_rg.datasets import (
    BUILDING,
    GROUND,
    NOISE,
    VEGETATION,
    PlacementError,
    SyntheticScene,
    synthetic_scene,
    terrain_height,
)

UTM = (500_000.0, 5_000_000.0, 100.0)


@pytest.fixture(scope="module")
def scene() -> SyntheticScene:
    """The default scene (200 m square, 4 pts/m^2, about 165k points)."""
    return synthetic_scene(seed=0)


def _terrain_at(s: SyntheticScene, mask: np.ndarray, *, seed: int = 0, size: float = 200.0):
    p = s.points[mask] - s.origin
    return p, terrain_height(p[:, 0], p[:, 1], seed=seed, size=size)


def _in_box(p: np.ndarray, box: np.ndarray, pad: float = 0.0) -> np.ndarray:
    return (
        (p[:, 0] >= box[0] - pad)
        & (p[:, 0] <= box[2] + pad)
        & (p[:, 1] >= box[1] - pad)
        & (p[:, 1] <= box[3] + pad)
    )


# --------------------------------------------------------------------------
# shapes, determinism, order


def test_constants_are_asprs_codes() -> None:
    assert (GROUND, VEGETATION, BUILDING, NOISE) == (2, 5, 6, 7)


def test_shapes_and_dtypes(scene: SyntheticScene) -> None:
    n = len(scene.points)
    assert scene.points.dtype == np.float64 and scene.points.shape == (n, 3)
    assert scene.points.flags.c_contiguous
    assert scene.labels.dtype == np.uint8 and scene.labels.shape == (n,)
    assert scene.origin.dtype == np.float64 and scene.origin.shape == (3,)
    np.testing.assert_array_equal(scene.origin, 0.0)
    assert scene.buildings.dtype == np.float64 and scene.buildings.shape == (6, 5)
    assert scene.trees.dtype == np.float64 and scene.trees.shape == (40, 4)
    assert set(np.unique(scene.labels).tolist()) == {GROUND, VEGETATION, BUILDING, NOISE}
    assert np.isfinite(scene.points).all()
    # "roughly 160k points" with the defaults; Poisson counts vary a little.
    assert 150_000 < n < 180_000


def test_same_seed_same_arrays() -> None:
    a = synthetic_scene(seed=11, size=120.0, n_buildings=3, n_trees=10)
    b = synthetic_scene(seed=11, size=120.0, n_buildings=3, n_trees=10)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def test_different_seeds_differ() -> None:
    a = synthetic_scene(seed=1, size=120.0, n_buildings=3, n_trees=10)
    b = synthetic_scene(seed=2, size=120.0, n_buildings=3, n_trees=10)
    assert not np.array_equal(a.buildings, b.buildings)
    assert not np.array_equal(a.trees, b.trees)
    n = min(len(a.points), len(b.points))
    assert not np.array_equal(a.points[:n], b.points[:n])


def test_points_are_shuffled(scene: SyntheticScene) -> None:
    # Blocks of classes in order would change label only 3 times; a random order
    # changes it about 2 p (1 - p) N times (p = ground share), tens of thousands.
    changes = np.count_nonzero(np.diff(scene.labels.astype(np.int16)))
    assert changes > 10_000
    head = scene.labels[: len(scene.labels) // 10]
    assert {GROUND, VEGETATION, BUILDING} <= set(np.unique(head).tolist())


def test_inside_area(scene: SyntheticScene) -> None:
    xy = scene.points[:, :2]
    # Canopy and trunk points may stray a few cm (trunk jitter); nothing leaves the square.
    assert xy.min() >= -1.0 and xy.max() <= 201.0
    ground = scene.points[scene.labels == GROUND]
    assert ground[:, :2].min() >= 0.0 and ground[:, :2].max() <= 200.0


# --------------------------------------------------------------------------
# classes and densities


def test_class_proportions(scene: SyntheticScene) -> None:
    n = len(scene.labels)
    classes = (GROUND, BUILDING, VEGETATION, NOISE)
    share = {c: np.count_nonzero(scene.labels == c) / n for c in classes}
    assert all(v > 0 for v in share.values())
    assert share[GROUND] > 0.8  # the majority: open ground covers most of the square
    assert 0.01 < share[BUILDING] < 0.15
    assert 0.01 < share[VEGETATION] < 0.15
    # The noise count is rounded from noise_fraction * N, so it is exact to 1/N.
    assert share[NOISE] == pytest.approx(0.002, abs=2.0 / n)


def test_noise_fraction_is_honoured() -> None:
    s = synthetic_scene(seed=4, size=80.0, n_buildings=1, n_trees=5, noise_fraction=0.1)
    frac = np.count_nonzero(s.labels == NOISE) / len(s.labels)
    assert frac == pytest.approx(0.1, abs=2.0 / len(s.labels))


def test_overall_density(scene: SyntheticScene) -> None:
    # Open ground, roofs and crowns are at `density`; walls and understory add
    # a few %, thinned ground under crowns removes a little.
    per_m2 = len(scene.points) / 200.0**2
    assert 4.0 * 0.95 < per_m2 < 4.0 * 1.15


def test_bare_ground_density() -> None:
    # Poisson count with mean 4 * 150^2 = 90000: sd 0.33 %, so 2 % is > 6 sd.
    s = synthetic_scene(seed=5, size=150.0, n_buildings=0, n_trees=0, noise_fraction=0.0)
    assert np.all(s.labels == GROUND)
    assert len(s.points) / 150.0**2 == pytest.approx(4.0, rel=0.02)
    assert s.buildings.shape == (0, 5) and s.trees.shape == (0, 4)


def test_density_parameter_scales_count() -> None:
    kw = dict(seed=6, size=100.0, n_buildings=2, n_trees=8, noise_fraction=0.0)
    n1 = len(synthetic_scene(density=1.0, **kw).points)
    n8 = len(synthetic_scene(density=8.0, **kw).points)
    assert n8 / n1 == pytest.approx(8.0, rel=0.05)


def test_roof_and_crown_density(scene: SyntheticScene) -> None:
    building_pts = scene.points[scene.labels == BUILDING]
    for box in scene.buildings:
        w, h = box[2] - box[0], box[3] - box[1]
        # Roof points: strictly inside, within 10 cm of the roof level.
        inner = _in_box(building_pts, box + np.array([0.01, 0.01, -0.01, -0.01, 0.0]))
        roof_z = np.median(building_pts[inner, 2])
        roof = inner & (np.abs(building_pts[:, 2] - roof_z) < 0.1)
        # >= 300 expected points per roof: a 20 % band is several Poisson sd.
        assert np.count_nonzero(roof) / (w * h) == pytest.approx(4.0, rel=0.2)
    veg = scene.points[scene.labels == VEGETATION]
    crown_area = np.pi * np.sum(scene.trees[:, 2] ** 2)
    # Canopy at density over the crown discs plus 10 % trunk/understory;
    # overlapping crowns make the union smaller, hence the wide band.
    assert len(veg) / crown_area == pytest.approx(4.0 * 1.1, rel=0.15)


def test_ground_thinned_under_crowns(scene: SyntheticScene) -> None:
    # Inner discs (70 % of the crown radius, well inside the generator's 0.5 m
    # canopy raster) of the trees whose inner disc overlaps no other one, so
    # the area is the plain sum of the disc areas.
    t = scene.trees
    reach = 0.7 * t[:, 2]
    dist = np.hypot(t[:, None, 0] - t[None, :, 0], t[:, None, 1] - t[None, :, 1])
    np.fill_diagonal(dist, np.inf)
    alone = np.all(dist > reach[:, None] + reach[None, :], axis=1)
    assert alone.sum() >= 20
    ground = scene.points[scene.labels == GROUND]
    count = sum(
        np.count_nonzero(np.hypot(ground[:, 0] - x, ground[:, 1] - y) < r)
        for (x, y), r in zip(t[alone, :2], reach[alone])
    )
    area = np.pi * np.sum(reach[alone] ** 2)
    # About 1000 expected points: 15 % is > 4 Poisson sd.
    assert count / area == pytest.approx(0.5 * 4.0, rel=0.15)


# --------------------------------------------------------------------------
# geometry against the true terrain


def test_ground_follows_terrain(scene: SyntheticScene) -> None:
    p, z = _terrain_at(scene, scene.labels == GROUND)
    resid = p[:, 2] - z
    assert abs(resid.mean()) < 0.005
    assert resid.std() == pytest.approx(0.03, rel=0.1)
    assert np.abs(resid).max() < 0.3  # 10 sd


def test_noise_below_and_above_terrain(scene: SyntheticScene) -> None:
    p, z = _terrain_at(scene, scene.labels == NOISE)
    dz = p[:, 2] - z
    low, high = dz[dz < 0], dz[dz > 0]
    assert low.size + high.size == dz.size
    assert abs(low.size - high.size) <= 1
    assert low.min() >= -20.0 and low.max() <= -1.0
    assert high.min() >= 20.0 and high.max() <= 100.0


def test_vegetation_above_terrain(scene: SyntheticScene) -> None:
    p, z = _terrain_at(scene, scene.labels == VEGETATION)
    height = p[:, 2] - z
    assert height.min() > 0.1
    assert height.max() <= 20.5
    # Canopy returns dominate, with a minority low (trunk/understory < 2 m).
    assert 0.02 < np.mean(height < 2.0) < 0.2


def test_buildings_inside_area_and_apart(scene: SyntheticScene) -> None:
    b = scene.buildings
    assert np.all(b[:, 0] >= 0.0) and np.all(b[:, 1] >= 0.0)
    assert np.all(b[:, 2] <= 200.0) and np.all(b[:, 3] <= 200.0)
    w, h = b[:, 2] - b[:, 0], b[:, 3] - b[:, 1]
    assert np.all(w >= 8.0) and np.all(h >= 8.0)
    assert np.all((b[:, 4] >= 4.0) & (b[:, 4] <= 15.0))
    for i in range(len(b)):
        for j in range(i + 1, len(b)):
            apart = b[i, 2] < b[j, 0] or b[j, 2] < b[i, 0] or b[i, 3] < b[j, 1] or b[j, 3] < b[i, 1]
            assert apart, (i, j)


def test_a_building_larger_than_20m_from_its_points(scene: SyntheticScene) -> None:
    b = scene.buildings
    big = np.flatnonzero((b[:, 2] - b[:, 0] > 20.0) & (b[:, 3] - b[:, 1] > 20.0))
    assert big.size >= 1
    pts = scene.points[scene.labels == BUILDING]
    mine = pts[_in_box(pts, b[big[0]])]
    extent = mine[:, :2].max(axis=0) - mine[:, :2].min(axis=0)
    assert np.all(extent > 20.0)
    # And small ones too: footprints span a range of sizes.
    assert (b[:, 2] - b[:, 0]).min() < 20.0


def test_building_points_on_roofs_and_walls(scene: SyntheticScene) -> None:
    pts = scene.points[scene.labels == BUILDING]
    owner = np.full(len(pts), -1)
    for i, box in enumerate(scene.buildings):
        owner[_in_box(pts, box)] = i
    assert np.all(owner >= 0)  # every building point belongs to a footprint
    for i, box in enumerate(scene.buildings):
        mine = pts[owner == i]
        ground = terrain_height(mine[:, 0], mine[:, 1], seed=0, size=200.0)
        top = mine[:, 2].max()
        assert np.all(mine[:, 2] >= ground - 1e-9)
        roof = np.abs(mine[:, 2] - np.median(mine[:, 2])) < 0.1
        assert np.mean(roof) > 0.6  # flat roof dominates; walls are sparser
        # Roof level is `height` above the highest terrain under the footprint.
        assert top - ground.max() == pytest.approx(box[4], abs=0.5)


def test_no_ground_under_buildings(scene: SyntheticScene) -> None:
    ground = scene.points[scene.labels == GROUND]
    for box in scene.buildings:
        assert not np.any(_in_box(ground, box))
        # ...while the ground right around it is sampled.
        assert np.any(_in_box(ground, box, pad=1.0))


def test_trees_clear_of_buildings(scene: SyntheticScene) -> None:
    for x, y, r, top in scene.trees:
        assert 2.0 <= r <= 5.0 and 5.0 <= top <= 20.0
        for box in scene.buildings:
            dx = max(box[0] - x, x - box[2], 0.0)
            dy = max(box[1] - y, y - box[3], 0.0)
            assert math.hypot(dx, dy) > r


# --------------------------------------------------------------------------
# terrain


@pytest.mark.parametrize("seed", [0, 7])
def test_terrain_has_slope_break(seed: int) -> None:
    step = 0.5
    g = np.arange(0.0, 200.0 + step / 2, step)
    gx, gy = np.meshgrid(g, g, indexing="ij")
    z = terrain_height(gx, gy, seed=seed, size=200.0)
    dzx, dzy = np.gradient(z, step)
    slope = np.degrees(np.arctan(np.hypot(dzx, dzy)))
    # A 15-25 degree ramp over part of the area, gentle rolling elsewhere.
    assert 15.0 <= slope.max() <= 30.0
    assert np.median(slope) < 7.0
    assert 0.05 < np.mean(slope > 12.0) < 0.3
    # Continuous height: no step between neighbours beyond the steepest slope.
    assert np.abs(np.diff(z, axis=0)).max() < step * math.tan(math.radians(30.0))
    assert np.abs(np.diff(z, axis=1)).max() < step * math.tan(math.radians(30.0))
    # Abrupt slope change: > 8 degrees within 1 m somewhere (rolling alone
    # changes by well under 1 degree per metre).
    jump = max(
        np.abs(slope[2:, :] - slope[:-2, :]).max(), np.abs(slope[:, 2:] - slope[:, :-2]).max()
    )
    assert jump > 8.0


def test_terrain_height_shapes_and_errors() -> None:
    z0 = terrain_height(3.0, 4.0, seed=2)
    assert z0.shape == () and z0.dtype == np.float64
    z = terrain_height(np.array([3.0, 5.0]), 4.0, seed=2)
    assert z.shape == (2,) and z[0] == z0
    with pytest.raises(ValueError, match="x must be finite"):
        terrain_height(np.array([np.nan]), np.array([0.0]))
    with pytest.raises(ValueError, match="size must be > 0"):
        terrain_height(0.0, 0.0, size=0.0)
    with pytest.raises(ValueError, match="seed must be >= 0"):
        terrain_height(0.0, 0.0, seed=-3)
    # Cast to float64, x = 1+5j was read as 1 with only a warning, and "1" as 1.
    with pytest.raises(TypeError, match="x must be real numbers .* complex128"):
        terrain_height(np.array([1 + 5j]), np.array([1.0]))
    with pytest.raises(TypeError, match="y must be real numbers .* <U1"):
        terrain_height(1.0, "2")


# --------------------------------------------------------------------------
# offset


def test_offset_does_not_change_geometry() -> None:
    kw = dict(seed=9, size=120.0, n_buildings=3, n_trees=12)
    local = synthetic_scene(**kw)
    utm = synthetic_scene(offset=UTM, **kw)
    np.testing.assert_array_equal(utm.origin, np.array(UTM))
    np.testing.assert_array_equal(utm.labels, local.labels)
    # float64 spacing at 5e6 is ~1e-9 m: the only difference is that rounding.
    np.testing.assert_allclose(utm.points - utm.origin, local.points, rtol=0.0, atol=1e-6)
    np.testing.assert_allclose(
        utm.buildings[:, :4] - utm.origin[[0, 1, 0, 1]], local.buildings[:, :4], atol=1e-6
    )
    np.testing.assert_array_equal(utm.buildings[:, 4], local.buildings[:, 4])
    np.testing.assert_allclose(utm.trees[:, :2] - utm.origin[:2], local.trees[:, :2], atol=1e-6)
    np.testing.assert_array_equal(utm.trees[:, 2:], local.trees[:, 2:])
    zero = synthetic_scene(offset=(0.0, 0.0, 0.0), **kw)
    np.testing.assert_array_equal(zero.points, local.points)


# --------------------------------------------------------------------------
# argument errors


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"size": 0.0}, r"size must be in \(0, 100000\], got 0"),
        ({"size": -5}, r"size must be in \(0, 100000\], got -5"),
        ({"size": float("nan")}, "size must be finite"),
        ({"size": float("inf")}, "size must be finite"),
        ({"density": 0.0}, "density must be > 0"),
        ({"density": -1.0}, "density must be > 0"),
        ({"n_buildings": -1}, "n_buildings must be >= 0, got -1"),
        ({"n_trees": -2}, "n_trees must be >= 0, got -2"),
        ({"noise_fraction": 0.5}, r"noise_fraction must be in \[0, 0.5\), got 0.5"),
        ({"noise_fraction": -0.01}, r"noise_fraction must be in \[0, 0.5\)"),
        ({"noise_fraction": float("nan")}, "noise_fraction must be finite"),
        ({"offset": (1.0, 2.0)}, "offset must have length 3"),
        ({"offset": (1.0, float("nan"), 0.0)}, "offset must be finite"),
        ({"seed": -1}, "seed must be >= 0"),
        ({"size": 30.0}, "n_buildings=6 .* do not fit in a 30 m square"),
        ({"size": 3.0, "n_buildings": 0, "n_trees": 1}, "n_trees=1"),
        # Absurd requests, refused before anything is drawn (they used to be killed for
        # want of memory, or to run for minutes first).
        ({"size": 100.0, "n_trees": 10**9}, "n_trees=1,000,000,000 ask for .* more than"),
        ({"size": 100.0, "density": 1e12}, "density=1e.12.* more than this machine's"),
        ({"size": 200.0, "n_buildings": 3000}, "3,000 buildings .* do not fit in a 200 m"),
        ({"size": 1e5, "n_buildings": 10**6}, "n_buildings must be <= 100,000"),
        ({"size": 1e200}, r"size must be in \(0, 100000\]"),
        ({"offset": (1e17, 0.0, 0.0)}, "too far from 0: beyond 1e.11 m"),
        ({"offset": (0.0, 0.0, 1.5e308)}, "too far from 0"),  # 2 x offset overflows
    ],
)
def test_value_errors(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match) as caught:
        synthetic_scene(**kwargs)
    # Objects that do not fit have an error of their own, which a caller can catch to
    # ask for fewer (the demo did it by matching the message); nothing else raises it.
    placement = "fit in a" in match or match == "n_trees=1"
    assert isinstance(caught.value, PlacementError) == placement


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_trees": 2.5}, "n_trees must be an integer"),
        ({"n_buildings": True}, "n_buildings must be an integer"),
        ({"seed": 1.0}, "seed must be an integer"),
        ({"size": "200"}, "size must be a real number"),
        ({"density": None}, "density must be a real number"),
        ({"offset": ("a", "b", "c")}, "offset must be real numbers .* got dtype <U1"),
        # Cast to float64, these lost their imaginary part with only a warning.
        ({"offset": np.array([1 + 1j, 0, 0])}, "offset must be real numbers .* complex128"),
        ({"offset": (True, False, True)}, "offset must be real numbers .* got dtype bool"),
    ],
)
def test_type_errors(kwargs: dict, match: str) -> None:
    with pytest.raises(TypeError, match=match):
        synthetic_scene(**kwargs)


def test_arguments_are_keyword_only() -> None:
    with pytest.raises(TypeError):
        synthetic_scene(0)  # type: ignore[misc]


def test_numpy_integer_arguments_accepted() -> None:
    a = synthetic_scene(seed=np.int64(3), size=60.0, n_buildings=np.int32(1), n_trees=np.uint8(2))
    b = synthetic_scene(seed=3, size=60.0, n_buildings=1, n_trees=2)
    np.testing.assert_array_equal(a.points, b.points)
