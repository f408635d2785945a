"""Tests of pcl_rg.datasets: the seeded synthetic airborne-LiDAR scene and tiled survey."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from pcl_rg.datasets import (
    BUILDING,
    GROUND,
    NOISE,
    VEGETATION,
    SyntheticScene,
    SyntheticSurvey,
    _survey,
    synthetic_scene,
    synthetic_survey,
    terrain_height,
)
from pcl_rg.io import read_points

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
            apart = (
                b[i, 2] < b[j, 0] or b[j, 2] < b[i, 0] or b[i, 3] < b[j, 1] or b[j, 3] < b[i, 1]
            )
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
        ({"size": 0.0}, "size must be > 0, got 0"),
        ({"size": -5}, "size must be > 0"),
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
        ({"offset": ("a", "b", "c")}, "offset must be a sequence of 3 finite numbers"),
        ({"seed": -1}, "seed must be >= 0"),
        ({"size": 30.0}, "n_buildings=6 .* do not fit in a 30 m square"),
        ({"size": 3.0, "n_buildings": 0, "n_trees": 1}, "n_trees=1"),
    ],
)
def test_value_errors(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        synthetic_scene(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_trees": 2.5}, "n_trees must be an integer"),
        ({"n_buildings": True}, "n_buildings must be an integer"),
        ({"seed": 1.0}, "seed must be an integer"),
        ({"size": "200"}, "size must be a real number"),
        ({"density": None}, "density must be a real number"),
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


# --------------------------------------------------------------------------
# the tiled survey

# 3 x 3 tiles of 80 m at 2 points/m^2: about 120 000 points, 9 buildings, 86 trees.
SURVEY = dict(tiles=(3, 3), tile_size=80.0, density=2.0, seed=3)
SURVEY_ORIGIN = np.array([500000.0, 5400000.0, 100.0])


@pytest.fixture(scope="module")
def survey(tmp_path_factory) -> SyntheticSurvey:
    return synthetic_survey(tmp_path_factory.mktemp("survey"), **SURVEY)


@pytest.fixture(scope="module")
def tiles(survey: SyntheticSurvey) -> list:
    return [read_points(path) for path in survey.paths]


def _tiles_of(survey: SyntheticSurvey, xy: np.ndarray) -> np.ndarray:
    """Row-major tile index of each (x, y), from the survey's geometry."""
    col, row = (np.floor((xy[:, i] - survey.origin[i]) / SURVEY["tile_size"]) for i in (0, 1))
    return (row * survey.tiles[1] + col).astype(int)


def _tiles_under(survey: SyntheticSurvey, xmin: float, ymin: float, xmax: float, ymax: float):
    """Row-major indices of the tiles a box overlaps, from the survey's geometry."""
    (c0, c1), (r0, r1) = (
        np.floor((np.array(span) - o) / SURVEY["tile_size"]).astype(int)
        for span, o in (((xmin, xmax), survey.origin[0]), ((ymin, ymax), survey.origin[1]))
    )
    return {r * survey.tiles[1] + c for r in range(r0, r1 + 1) for c in range(c0, c1 + 1)}


def test_survey_tiles_and_bounds(survey: SyntheticSurvey) -> None:
    assert survey.tiles == (3, 3)
    names = [os.path.basename(path) for path in survey.paths]
    assert names == [f"tile_{r}_{c}.laz" for r in range(3) for c in range(3)]
    assert all(os.path.isfile(path) for path in survey.paths)
    np.testing.assert_array_equal(survey.origin, SURVEY_ORIGIN)
    assert survey.terrain_size == 240.0
    expected = [
        [500000.0 + 80.0 * c, 5400000.0 + 80.0 * r, 500080.0 + 80.0 * c, 5400080.0 + 80.0 * r]
        for r in range(3)
        for c in range(3)
    ]
    np.testing.assert_array_equal(survey.bounds, expected)
    assert survey.points.dtype == np.int64 and survey.points.shape == (9,)
    # About density * tile area each (ground at 2/m^2, plus walls and understory).
    assert np.all(np.abs(survey.points / (2.0 * 80.0**2) - 1.0) < 0.15)
    # 150 buildings and 1500 trees per km^2 over 0.0576 km^2.
    assert survey.buildings.shape == (9, 5) and survey.trees.shape == (86, 4)


def test_survey_points_inside_their_tiles(survey: SyntheticSurvey, tiles: list) -> None:
    for tile, count, (xmin, ymin, xmax, ymax) in zip(tiles, survey.points, survey.bounds):
        x, y = tile.points[:, 0], tile.points[:, 1]
        assert len(tile) == count
        assert np.all((x >= xmin) & (x < xmax) & (y >= ymin) & (y < ymax))
        # Whole millimetres: the values the files store are the generated ones.
        mm = tile.points * 1000.0
        np.testing.assert_allclose(mm, np.round(mm), rtol=0.0, atol=1e-3)
        assert set(np.unique(tile.classification).tolist()) <= {GROUND, VEGETATION, BUILDING, NOISE}
        assert tile.fields["intensity"].dtype == np.uint16
    labels = np.concatenate([tile.classification for tile in tiles])
    share = {c: np.mean(labels == c) for c in (GROUND, BUILDING, VEGETATION, NOISE)}
    assert share[GROUND] > 0.7 and share[BUILDING] > 0.01 and share[VEGETATION] > 0.01
    assert share[NOISE] == pytest.approx(0.002, abs=0.001)


def test_survey_is_reproducible(survey: SyntheticSurvey, tiles: list, tmp_path) -> None:
    again = synthetic_survey(tmp_path / "again", **SURVEY)
    np.testing.assert_array_equal(again.points, survey.points)
    np.testing.assert_array_equal(again.buildings, survey.buildings)
    for tile, path in zip(tiles, again.paths):
        other = read_points(path)
        np.testing.assert_array_equal(other.points, tile.points)
        np.testing.assert_array_equal(other.classification, tile.classification)
        np.testing.assert_array_equal(other.fields["intensity"], tile.fields["intensity"])
    changed = synthetic_survey(tmp_path / "changed", **{**SURVEY, "seed": 4})
    assert not np.array_equal(changed.buildings, survey.buildings)
    assert not np.array_equal(read_points(changed.paths[0]).points[:100], tiles[0].points[:100])


def test_survey_objects_cross_tile_borders(survey: SyntheticSurvey, tiles: list) -> None:
    index = np.concatenate([np.full(len(t), i) for i, t in enumerate(tiles)])
    points = np.concatenate([t.points for t in tiles])
    labels = np.concatenate([t.classification for t in tiles])
    # Footprints 8-40 m, a large one among them.
    b = survey.buildings
    assert (b[:, 2] - b[:, 0]).max() > 20.0 or (b[:, 3] - b[:, 1]).max() > 20.0
    roofed = points[labels == BUILDING]
    roofed_tile = index[labels == BUILDING]
    crossing = 0
    for box in b:
        # A building's points lie in the tiles under its footprint; the same
        # building has points in two tiles or more for at least one of them.
        under = _tiles_under(survey, *box[:4])
        found = set(roofed_tile[_in_box(roofed, box)].tolist())
        assert found <= under
        crossing += len(found) > 1
    assert crossing >= 1
    # ...with no ground under any footprint, whichever tile the ground is in
    # (1 mm in from the edges: the points are stored in whole millimetres).
    ground = points[labels == GROUND]
    assert not any(np.any(_in_box(ground, box, pad=-0.001)) for box in b)
    veg = points[labels == VEGETATION]
    veg_tile = index[labels == VEGETATION]
    # A crown across a border is sampled on both sides at the same density:
    # the returns in the tiles other than the trunk's match their share of the
    # crown discs (canopy at density; understory, 10 % more, mostly near the trunk).
    grid = (np.arange(40) + 0.5) / 40 * 2.0 - 1.0  # unit-square cell centres
    gu, gv = (g.ravel() for g in np.meshgrid(grid, grid))
    disc = gu**2 + gv**2 < 1.0
    t = survey.trees
    gap = np.hypot(t[:, None, 0] - t[None, :, 0], t[:, None, 1] - t[None, :, 1])
    np.fill_diagonal(gap, np.inf)
    alone = np.all(gap > t[:, None, 2] + t[None, :, 2], axis=1)  # no other crown overlaps
    split = 0
    found_away, expected_away = 0, 0.0
    for (x, y, r, _), counted in zip(t, alone):
        mine = np.hypot(veg[:, 0] - x, veg[:, 1] - y) < r
        found = set(veg_tile[mine].tolist())
        assert found <= _tiles_under(survey, x - r, y - r, x + r, y + r)
        split += len(found) > 1
        if not counted:
            continue
        home = _tiles_of(survey, np.array([[x, y]]))[0]
        cells = _tiles_of(survey, np.column_stack([x + r * gu[disc], y + r * gv[disc]]))
        expected_away += SURVEY["density"] * math.pi * r**2 * np.mean(cells != home)
        found_away += np.count_nonzero(mine & (veg_tile != home))
    assert split >= 5
    assert found_away == pytest.approx(expected_away, rel=0.3)


def test_survey_ground_follows_terrain(survey: SyntheticSurvey, tiles: list) -> None:
    ground = np.concatenate([t.points[t.classification == GROUND] for t in tiles])
    local = ground - survey.origin
    z = terrain_height(local[:, 0], local[:, 1], seed=SURVEY["seed"], size=survey.terrain_size)
    resid = local[:, 2] - z
    assert abs(resid.mean()) < 0.005
    assert resid.std() == pytest.approx(0.03, rel=0.15)  # 3 cm roughness, 1 mm storage
    assert np.abs(resid).max() < 0.3


def test_survey_tiles_are_order_independent(survey: SyntheticSurvey, tiles: list) -> None:
    # A tile is made from the survey's layout and its own stream only: made in
    # reverse order, or alone from a fresh layout, it is the file's tile.
    args = (SURVEY["seed"], (3, 3), 80.0, 2.0, 150.0, 1500.0, 0.002, SURVEY_ORIGIN)
    layout = _survey._layout(*args)
    for i in (8, 4, 0):
        points, labels, intensity = _survey._tile(layout, i // 3, i % 3)
        np.testing.assert_allclose(points, tiles[i].points, rtol=0.0, atol=1e-6)
        np.testing.assert_array_equal(labels, tiles[i].classification)
        np.testing.assert_array_equal(intensity, tiles[i].fields["intensity"])
    points, _, _ = _survey._tile(_survey._layout(*args), 1, 2)
    np.testing.assert_allclose(points, tiles[5].points, rtol=0.0, atol=1e-6)


def test_survey_formats_store_the_same_points(tmp_path) -> None:
    kw = dict(tiles=(1, 2), tile_size=40.0, density=1.0, seed=5, origin=(0.0, 0.0, 0.0))
    laz = synthetic_survey(tmp_path / "laz", **kw)
    ply = synthetic_survey(tmp_path / "ply", format="ply", **kw)
    assert [os.path.basename(p) for p in ply.paths] == ["tile_0_0.ply", "tile_0_1.ply"]
    for a, b in zip(laz.paths, ply.paths):
        fa, fb = read_points(a), read_points(b)
        np.testing.assert_allclose(fa.points, fb.points, rtol=0.0, atol=1e-9)
        np.testing.assert_array_equal(fa.classification, fb.classification)
    np.testing.assert_array_equal(laz.bounds, [[0.0, 0.0, 40.0, 40.0], [40.0, 0.0, 80.0, 40.0]])


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"tiles": (0, 2)}, ValueError, r"tiles\[0\] must be >= 1, got 0"),
        ({"tiles": 3}, ValueError, r"tiles must be a pair \(rows, cols\), got 3"),
        ({"tiles": (1, 2, 3)}, ValueError, "tiles must be a pair"),
        ({"tiles": (2, 1.5)}, TypeError, r"tiles\[1\] must be an integer"),
        ({"tile_size": 0.5}, ValueError, "tile_size must be >= 1"),
        ({"tile_size": "200"}, TypeError, "tile_size must be a real number"),
        ({"density": 0.0}, ValueError, "density must be > 0"),
        ({"seed": -1}, ValueError, "seed must be >= 0"),
        ({"seed": 1.5}, TypeError, "seed must be an integer"),
        ({"buildings_per_km2": -1.0}, ValueError,
         r"buildings_per_km2 must be in \[0, 500\], got -1"),
        ({"buildings_per_km2": 501.0}, ValueError,
         r"buildings_per_km2 must be in \[0, 500\], got 501"),
        ({"trees_per_km2": float("nan")}, ValueError, "trees_per_km2 must be finite"),
        ({"noise_fraction": 0.5}, ValueError, r"noise_fraction must be in \[0, 0.5\)"),
        ({"origin": (1.0, 2.0)}, ValueError, "origin must have length 3"),
        ({"origin": (0.0, float("inf"), 0.0)}, ValueError, "origin must be finite"),
        ({"format": "xyz"}, ValueError, "format must be one of laz, las, ply, pcd, got 'xyz'"),
        ({"format": None}, TypeError, "format must be a str"),
        # 2 buildings, at least 8 m wide, in a 10 m wide strip with 2 m margins.
        ({"tiles": (1, 50), "tile_size": 10.0, "buildings_per_km2": 500.0}, ValueError,
         "2 non-overlapping buildings .* do not fit in the 500 x 10 m survey"),
        # Crowns at least 4 m across in a 3 m square.
        ({"tile_size": 3.0, "trees_per_km2": 1e6}, ValueError, "could not place 9 trees"),
    ],
)
def test_survey_argument_errors(kwargs: dict, error: type, match: str, tmp_path) -> None:
    base = {"tiles": (1, 1), "tile_size": 20.0, "density": 0.5}
    with pytest.raises(error, match=match):
        synthetic_survey(tmp_path, **{**base, **kwargs})
    assert os.listdir(tmp_path) == []  # nothing written when an argument is wrong


def test_survey_folder_type_and_keywords(tmp_path) -> None:
    with pytest.raises(TypeError, match="folder must be a str or os.PathLike, got int"):
        synthetic_survey(3)  # type: ignore[arg-type]
    with pytest.raises(TypeError):
        synthetic_survey(tmp_path, (1, 1))  # type: ignore[misc]
