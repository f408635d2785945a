"""Coordinate systems as LAS files state them, and LAS files in feet, for the units
tests (test_units.py, test_batch_units.py)."""

from __future__ import annotations

import numpy as np

US_FOOT = 1200.0 / 3937.0

# EPSG:6539, NAD83(2011) / New York Long Island (ftUS) + NAVD88 height (ftUS), in
# WKT 1 as GDAL writes a compound CRS (abridged: fewer parameters).
NEW_YORK_FTUS_WKT1 = (
    'COMPD_CS["NAD83 / New York Long Island (ftUS) + NAVD88 height (ftUS)",'
    'PROJCS["NAD83 / New York Long Island (ftUS)",GEOGCS["NAD83",DATUM["North_American_'
    'Datum_1983",SPHEROID["GRS 1980",6378137,298.257222101,AUTHORITY["EPSG","7019"]],'
    'AUTHORITY["EPSG","6269"]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433,'
    'AUTHORITY["EPSG","9122"]],AUTHORITY["EPSG","4269"]],PROJECTION["Lambert_Conformal_'
    'Conic_2SP"],PARAMETER["false_easting",984250],UNIT["US survey foot",'
    '0.304800609601219,AUTHORITY["EPSG","9003"]],AXIS["Easting",EAST],AXIS["Northing",'
    'NORTH],AUTHORITY["EPSG","2263"]],VERT_CS["NAVD88 height (ftUS)",VERT_DATUM["North '
    'American Vertical Datum 1988",2005],UNIT["US survey foot",0.304800609601219],'
    'AXIS["Gravity-related height",UP],AUTHORITY["EPSG","6360"]],AUTHORITY["EPSG","6539"]]'
)
# The same projected CRS in WKT 2: its units on the axes, a false easting in feet
# inside the conversion (a unit that is not the CRS's own), no vertical CRS.
NEW_YORK_FTUS_WKT2 = (
    'PROJCRS["NAD83 / New York Long Island (ftUS)",BASEGEOGCRS["NAD83",DATUM["North '
    'American Datum 1983",ELLIPSOID["GRS 1980",6378137,298.257222101,LENGTHUNIT["metre",'
    '1]]],ANGLEUNIT["degree",0.0174532925199433],ID["EPSG",4269]],CONVERSION["SPCS83 New '
    'York Long Island zone (US Survey feet)",METHOD["Lambert Conic Conformal (2SP)"],'
    'PARAMETER["Easting at false origin",984250,LENGTHUNIT["metre",1]]],CS[Cartesian,2],'
    'AXIS["easting (X)",east,ORDER[1],LENGTHUNIT["US survey foot",0.304800609601219]],'
    'AXIS["northing (Y)",north,ORDER[2],LENGTHUNIT["US survey foot",0.304800609601219]],'
    'ID["EPSG",2263]]'
)
# ESRI's dialect: x, y in US feet, heights in metres (a VERTCS beside the PROJCS).
ESRI_FEET_METRES = (
    'PROJCS["NAD_1983_StatePlane_Washington_North_FIPS_4601_Feet",GEOGCS["GCS_North_'
    'American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,'
    '298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],'
    'PROJECTION["Lambert_Conformal_Conic"],PARAMETER["False_Easting",1640416.666666667],'
    'UNIT["Foot_US",0.3048006096012192]],VERTCS["NAVD_1988",VDATUM["North_American_'
    'Vertical_Datum_1988"],PARAMETER["Vertical_Shift",0.0],UNIT["Meter",1.0]]'
)
WGS84_DEGREES = (
    'GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],'
    'PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433],AUTHORITY["EPSG","4326"]]'
)


def wkt_record(wkt: str):
    from laspy.vlrs.known import WktCoordinateSystemVlr

    return WktCoordinateSystemVlr(wkt)


def geokeys_record(keys: dict[int, int], doubles: dict[int, float] | None = None):
    """A GeoKeyDirectory VLR (and its GeoDoubleParams VLR when `doubles`): keys with a
    value in the directory, then keys indexing the doubles."""
    from laspy.vlrs.known import GeoDoubleParamsVlr, GeoKeyDirectoryVlr

    doubles = doubles or {}
    entries = [(k, 0, 1, v) for k, v in sorted(keys.items())]
    entries += [(k, 34736, 1, i) for i, k in enumerate(sorted(doubles))]
    data = np.array([(1, 1, 0, len(entries)), *entries], "<u2").tobytes()
    directory = GeoKeyDirectoryVlr()
    directory.parse_record_data(data)
    records = [directory]
    if doubles:
        values = GeoDoubleParamsVlr()
        values.parse_record_data(np.array([doubles[k] for k in sorted(doubles)], "<f8").tobytes())
        records.append(values)
    return records


def write_las(path, xyz: np.ndarray, records=(), fields: dict | None = None) -> None:
    """xyz to a LAS 1.2 file at 0.01 units, with the given CRS records."""
    import laspy

    header = laspy.LasHeader(point_format=1, version="1.2")
    header.scales = [0.01, 0.01, 0.01]
    header.offsets = np.floor(xyz.min(axis=0))
    header.vlrs.extend(records)
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz.T
    for name, values in (fields or {}).items():
        las[name] = values
    las.write(path)


def in_feet(source, target, wkt: str, z_in_feet: bool = True) -> None:
    """A copy of the LAS/LAZ/PLY `source` in US survey feet (z too, or kept in metres),
    stating `wkt`; classification and intensity kept."""
    from pcl_rg.io import read_points

    cloud = read_points(source)
    scale = np.array([US_FOOT, US_FOOT, US_FOOT if z_in_feet else 1.0])
    fields = {n: cloud.fields[n] for n in ("classification", "intensity") if n in cloud.fields}
    write_las(target, cloud.points / scale, [wkt_record(wkt)], fields)
