"""Coordinates in other units than metres: what LAS files state (OGC WKT, GeoTIFF
keys), and the command line scaling to metres, or refusing degrees."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_helpers import run
from conftest import examples, run_pcl_rg
from hypothesis import given, settings
from hypothesis import strategies as st
from plot_helpers import read_saved_figures
from units_files import (
    ESRI_FEET_METRES,
    NEW_YORK_FTUS_WKT1,
    NEW_YORK_FTUS_WKT2,
    US_FOOT,
    WGS84_DEGREES,
    geokeys_record,
    in_feet,
    wkt_record,
    write_las,
)

import pcl_rg
from pcl_rg.datasets import synthetic_scene
from pcl_rg.io import CoordinateUnits, read_points
from pcl_rg.io._crs import crs_codes_of, metre_factors


class Header:
    """What units_of and crs_codes_of read of a laspy header: its records."""

    def __init__(self, records) -> None:
        self.vlrs, self.evlrs = list(records), []


def units(records) -> CoordinateUnits:
    from pcl_rg.io._crs import units_of

    return units_of(Header(records))


# ---------------------------------------------------------------- what files state


def test_wkt1_compound_feet_gives_both_units_and_the_projected_code():
    stated = units([wkt_record(NEW_YORK_FTUS_WKT1)])
    assert stated.kind == "projected" and stated.source == "WKT"
    assert stated.xy == stated.z == pytest.approx(US_FOOT, rel=1e-12)
    assert stated.xy_name == stated.z_name == "US survey foot"
    assert crs_codes_of(Header([wkt_record(NEW_YORK_FTUS_WKT1)])) == [2263]


def test_wkt2_takes_the_axes_unit_not_a_parameters():
    # The conversion's false easting has its own LENGTHUNIT (metre): not the CRS's.
    stated = units([wkt_record(NEW_YORK_FTUS_WKT2)])
    assert stated.xy == pytest.approx(US_FOOT, rel=1e-12) and stated.z is None
    factors, where = metre_factors(stated)
    assert factors == pytest.approx((US_FOOT,) * 3, rel=1e-12)  # z as x and y
    assert "z as x and y" in where
    assert crs_codes_of(Header([wkt_record(NEW_YORK_FTUS_WKT2)])) == [2263]


def test_esri_feet_with_metre_heights():
    stated = units([wkt_record(ESRI_FEET_METRES)])
    assert (stated.xy_name, stated.z_name) == ("Foot_US", "Meter")
    assert metre_factors(stated)[0] == pytest.approx((US_FOOT, US_FOOT, 1.0), rel=1e-12)


def test_geotiff_keys_units_and_a_user_defined_size():
    # Projected (model type 1), EPSG:2263, x, y in US survey feet (9003), z in metres.
    stated = units(geokeys_record({1024: 1, 3072: 2263, 3076: 9003, 4099: 9001}))
    assert (stated.xy, stated.z, stated.source) == (1200.0 / 3937.0, 1.0, "GeoTIFF keys")
    user = units(geokeys_record({1024: 1, 3076: 32767}, {3077: 0.5}))
    assert user.xy == 0.5 and user.xy_name == "user-defined"
    # An EPSG code alone: its units are in a CRS database, not in the file. Taken
    # as metres, as before, and said to be assumed.
    assert units(geokeys_record({1024: 1, 3072: 2263})).xy is None
    factors, where = metre_factors(units(geokeys_record({1024: 1, 3072: 2263})))
    assert factors == (1.0, 1.0, 1.0) and "assumed" in where


@pytest.mark.parametrize(
    "records",
    [[wkt_record(WGS84_DEGREES)], "keys"],
    ids=["wkt", "geotiff-keys"],
)
def test_longitude_and_latitude_are_refused(records):
    if records == "keys":
        records = geokeys_record({1024: 2, 2048: 4326})
    stated = units(records)
    assert stated.kind == "geographic" and stated.xy is None
    with pytest.raises(ValueError, match="longitude and latitude in degrees"):
        metre_factors(stated)
    assert metre_factors(stated, "m")[0] == (1.0, 1.0, 1.0)  # the caller knows better


@pytest.mark.parametrize(
    "text",
    [
        'PROJCS["a",UNIT["foot",0.3048]',  # not closed
        'PROJCS["a",UNIT["foot",x]]',  # no factor
        'PROJCS["a",UNIT["foot",-0.3]]',  # a factor that is no length
        'PROJCS["a]',  # an open quote
        "[" * 100_000,  # nested beyond any CRS: no recursion, a clear refusal
        'PROJCS["a"]]',
    ],
)
def test_a_wkt_that_cannot_be_read_is_said_so(text):
    stated = units([wkt_record(text)])
    assert stated.problem.startswith("its WKT cannot be read")
    with pytest.raises(ValueError, match="cannot be read"):
        metre_factors(stated)
    assert crs_codes_of(Header([wkt_record(text)])) == []


# Pieces of CRS records, in any order: a hostile or broken WKT is one of these strings.
WKT_PIECES = [
    *("PROJCS[", "GEOGCS[", "COMPD_CS[", "VERT_CS[", "VERTCRS[", "PROJCRS[", "GEODCRS["),
    *("BOUNDCRS[", "SOURCECRS[", "LOCAL_CS[", "UNIT[", "LENGTHUNIT[", "AXIS[", "CS["),
    *("AUTHORITY[", "ID[", '"EPSG"', "2263", '"foot"', "0.3048", "-1", "1e308", "x"),
    *(",", "]", "[", "(", ")", '"', '""', "Cartesian", "\0", " "),
]


@settings(max_examples=examples(300), deadline=None)
@given(st.lists(st.sampled_from(WKT_PIECES), max_size=80))
def test_any_wkt_gives_units_or_says_it_cannot_be_read(pieces):
    text = "".join(pieces)
    stated = units([wkt_record(text)])
    assert stated.source == "WKT"
    try:
        factors, _ = metre_factors(stated)
    except ValueError as error:
        assert str(error)
    else:
        assert all(1e-4 <= f <= 1e5 for f in factors)
    assert all(isinstance(code, int) for code in crs_codes_of(Header([wkt_record(text)])))


def test_unknown_geotiff_unit_codes_are_said_so():
    stated = units(geokeys_record({1024: 1, 3076: 9999}))
    assert "9999" in stated.problem


def test_files_without_records_state_nothing():
    assert units([]) == CoordinateUnits()
    assert metre_factors(CoordinateUnits()) == ((1.0, 1.0, 1.0), "metre (the file states no units)")
    with pytest.raises(ValueError, match="units must be one of"):
        metre_factors(CoordinateUnits(), "yard")


def test_point_file_units_from_a_las_file(tmp_path):
    write_las(tmp_path / "a.las", np.zeros((3, 3)), [wkt_record(NEW_YORK_FTUS_WKT1)])
    assert read_points(tmp_path / "a.las").units.xy == pytest.approx(US_FOOT)
    np.savetxt(tmp_path / "a.xyz", np.zeros((3, 3)))
    assert read_points(tmp_path / "a.xyz").units == CoordinateUnits()


# ---------------------------------------------------------------- the command line


@pytest.fixture(scope="module")
def scene_files(tmp_path_factory):
    """A synthetic scene in metres, the same in US survey feet stating so, and in feet
    stating nothing."""
    folder = tmp_path_factory.mktemp("units")
    points = synthetic_scene(seed=2, size=120.0, density=4).points
    write_las(folder / "metres.las", points)
    in_feet(folder / "metres.las", folder / "feet.las", NEW_YORK_FTUS_WKT1)
    feet = read_points(folder / "feet.las").points
    write_las(folder / "bare.las", feet)
    return folder


@pytest.mark.parametrize("method", ["grid", "tin"])
def test_ground_on_feet_is_the_filter_on_metres(method, scene_files, tmp_path):
    feet = read_points(scene_files / "feet.las").points
    function = pcl_rg.grid_ground if method == "grid" else pcl_rg.tin_ground
    expected = np.where(function(feet * US_FOOT), 2, 1)
    unscaled = np.where(function(feet), 2, 1)
    assert (expected != unscaled).sum() > 100  # what a run in feet gave before
    for source, extra in (("feet", []), ("bare", ["--units", "us-ft"])):
        out = tmp_path / f"{source}.las"
        result = run_pcl_rg(
            "ground", scene_files / f"{source}.las", out, "--method", method, "--json", *extra
        )
        assert result.returncode == 0, result.stderr
        report = json.loads(result.stdout)["units"]
        assert report["metres_per_unit"] == pytest.approx([US_FOOT] * 3, rel=1e-12)
        written = read_points(out)
        np.testing.assert_array_equal(written.classification, expected)
        np.testing.assert_allclose(written.points, feet, rtol=0, atol=0.006)  # its own units
    # The file without a CRS and no --units: taken as metres, and said so.
    result = run_pcl_rg("ground", scene_files / "bare.las", tmp_path / "m.las", "--json")
    assert "states no units" in json.loads(result.stdout)["units"]["source"]


def test_downsample_on_feet_writes_feet(scene_files, tmp_path):
    cloud = read_points(scene_files / "feet.las")
    feet, factor = cloud.points, cloud.units.xy  # the WKT's digits: voxel borders are exact
    grid = pcl_rg.voxel_grid(feet * factor, params=pcl_rg.VoxelGridParams(leaf_size=2.0))
    result = run_pcl_rg(
        "downsample", scene_files / "feet.las", tmp_path / "d.las", "--leaf-size", "2"
    )
    assert result.returncode == 0, result.stderr
    written = read_points(tmp_path / "d.las")
    assert len(written) == len(grid.centroids)
    # The centroids in feet, as LAS stores them (at the file's scale and offset).
    offsets, scales = written.header.offsets, written.header.scales
    expected = np.round((grid.centroids / factor - offsets) / scales) * scales + offsets
    got = written.points
    np.testing.assert_allclose(
        got[np.lexsort(got.T[::-1])], expected[np.lexsort(expected.T[::-1])], rtol=0, atol=1e-6
    )


def test_degrees_are_refused_and_nothing_is_written(tmp_path):
    write_las(
        tmp_path / "lonlat.las", np.array([[13.4, 52.5, 40.0]] * 20), [wkt_record(WGS84_DEGREES)]
    )
    result = run_pcl_rg("ground", tmp_path / "lonlat.las", tmp_path / "out.las")
    assert result.returncode == 2
    assert "longitude and latitude" in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "out.las").exists()


def test_info_gives_the_units_and_a_broken_record_stops_the_work(scene_files, tmp_path):
    result = run_pcl_rg("info", scene_files / "feet.las", "--json")
    assert json.loads(result.stdout)["units"]["xy_name"] == "US survey foot"
    text = run_pcl_rg("info", scene_files / "feet.las").stdout
    assert "US survey foot" in text and " m)" not in text
    points = read_points(scene_files / "feet.las").points[:100]
    write_las(tmp_path / "broken.las", points, [wkt_record('PROJCS["a",UNIT["foot",x]]')])
    result = run_pcl_rg("ground", tmp_path / "broken.las", tmp_path / "out.las")
    assert result.returncode == 2 and "WKT cannot be read" in result.stderr
    assert "--units" in result.stderr and not (tmp_path / "out.las").exists()
    given = run_pcl_rg("ground", tmp_path / "broken.las", tmp_path / "out.las", "--units", "ft")
    assert given.returncode == 0, given.stderr


def test_info_says_how_an_unstated_z_is_taken(scene_files, tmp_path):
    # WKT 2 of a projected CRS alone: x and y in US feet, no vertical CRS. The commands
    # take z as x and y, and info says so instead of only "not stated".
    points = read_points(scene_files / "feet.las").points[:100]
    write_las(tmp_path / "xy.las", points, [wkt_record(NEW_YORK_FTUS_WKT2)])
    text = run_pcl_rg("info", tmp_path / "xy.las").stdout
    assert "x, y US survey foot, z not stated, taken as x and y (WKT)" in text
    ground = run_pcl_rg("ground", tmp_path / "xy.las", tmp_path / "out.las", "--json")
    assert "z as x and y" in json.loads(ground.stdout)["units"]["source"]


def test_an_empty_wkt_leaves_the_geotiff_keys_their_say():
    keys = geokeys_record({1024: 1, 3072: 2263, 3076: 9003})
    for text in ("", 'VERT_CS["NAVD88",UNIT["US survey foot",0.304800609601219]]'):
        stated = units([wkt_record(text), *keys])
        assert stated.source == "GeoTIFF keys" and stated.xy == 1200.0 / 3937.0


def test_a_unit_for_z_alone_or_an_implausible_factor_is_refused():
    with pytest.raises(ValueError, match="unit for z"):
        metre_factors(units(geokeys_record({1024: 1, 3072: 2263, 4099: 9003})))
    for text in ('PROJCS["a",UNIT["ft"]]', 'PROJCS["a",UNIT["ft",1e-320]]'):
        assert units([wkt_record(text)]).problem
    assert units(geokeys_record({1024: 1, 3076: 32767}, {3077: 1e308})).problem


def test_local_systems_in_feet_are_feet():
    for text in (
        'LOCAL_CS["site",UNIT["foot",0.3048]]',
        'ENGCRS["site",LENGTHUNIT["foot",0.3048]]',
    ):
        assert metre_factors(units([wkt_record(text)]))[0] == (0.3048,) * 3


def test_a_record_laspy_cannot_parse_is_unreadable(tmp_path):
    import laspy

    raw = laspy.VLR("LASF_Projection", 2112, "wkt", 'PROJCS["caf\xe9"]'.encode("cp1252"))
    write_las(tmp_path / "latin.las", np.zeros((3, 3)), [raw])
    stated = read_points(tmp_path / "latin.las").units
    assert stated.problem == "its WKT cannot be read"


@pytest.mark.parametrize("command", [["info"], ["ground", "OUT"], ["segment", "OUT"]])
def test_figures_of_feet_data_say_feet(command, scene_files, tmp_path, monkeypatch, capsys):
    # Their axes said "m" while the points drawn are the file's, in feet.
    seen = read_saved_figures(
        monkeypatch, lambda fig: [t for ax in fig.axes for t in (ax.get_xlabel(), ax.get_ylabel())]
    )
    argv = [command[0], scene_files / "feet.las"] + [tmp_path / "o.las"] * (len(command) - 1)
    code, _, err = run(capsys, *argv, "--plot", tmp_path / "t.png", "--profile", tmp_path / "p.png")
    assert code == 0, err
    labels = [label for texts in seen for label in texts]
    assert labels[:2] == ["x (US ft)", "y (US ft)"]
    assert "distance along the line from A (US ft)" in labels and "z (US ft)" in labels
    assert not any(label.endswith("(m)") for label in labels)
