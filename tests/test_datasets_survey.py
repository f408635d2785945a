"""Tests of pcl_rg.datasets' seeded tiled survey: tiles, borders, reproducibility,
formats and arguments."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from test_datasets import _in_box

from pcl_rg.datasets import (
    BUILDING,
    GROUND,
    NOISE,
    VEGETATION,
    PlacementError,
    SyntheticSurvey,
    _survey,
    synthetic_survey,
    terrain_height,
)
from pcl_rg.io import read_points

UTM = (500_000.0, 5_000_000.0, 100.0)


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
        (
            {"buildings_per_km2": -1.0},
            ValueError,
            r"buildings_per_km2 must be in \[0, 500\], got -1",
        ),
        (
            {"buildings_per_km2": 501.0},
            ValueError,
            r"buildings_per_km2 must be in \[0, 500\], got 501",
        ),
        ({"trees_per_km2": float("nan")}, ValueError, "trees_per_km2 must be finite"),
        ({"noise_fraction": 0.5}, ValueError, r"noise_fraction must be in \[0, 0.5\)"),
        ({"origin": (1.0, 2.0)}, ValueError, "origin must have length 3"),
        ({"origin": (0.0, float("inf"), 0.0)}, ValueError, "origin must be finite"),
        ({"format": "xyz"}, ValueError, "format must be one of laz, las, ply, pcd, got 'xyz'"),
        ({"format": None}, TypeError, "format must be a str"),
        # 2 buildings, at least 8 m wide, in a 10 m wide strip with 2 m margins.
        (
            {"tiles": (1, 50), "tile_size": 10.0, "buildings_per_km2": 500.0},
            PlacementError,
            "2 non-overlapping buildings .* do not fit in the 500 x 10 m survey",
        ),
        ({"origin": (1e306, 0.0, 0.0)}, ValueError, "origin .* is too far from 0"),
        (
            {"tiles": (100, 100), "tile_size": 1000.0, "buildings_per_km2": 20.0},
            ValueError,
            "200,000 buildings .* at most 100,000",
        ),
        ({"density": 1e12}, ValueError, "more than this machine's"),
        # Crowns at least 4 m across in a 3 m square.
        ({"tile_size": 3.0, "trees_per_km2": 1e6}, PlacementError, "could not place 9 trees"),
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
