"""What a LAS/LAZ file says of its coordinate system: EPSG codes and length units.

Two records may describe it (LAS 1.4, section 2.5): GeoTIFF keys (a
GeoKeyDirectory VLR, GeoTIFF 1.0 section 6.3) and OGC WKT (a VLR or EVLR, WKT 1 or
WKT 2, ESRI's dialect too). Every length parameter of the package is in metres, so
a tile in US survey feet must be scaled before it is filtered, and one in degrees
refused: :class:`CoordinateUnits` says which.

Only what the records state is read. A file that names its CRS by an EPSG code alone,
without a unit key or a WKT, has units only a CRS database knows (PROJ, through
pyproj): they are reported as not stated.
"""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["GIVEN_UNITS", "CoordinateUnits", "crs_codes_of", "metre_factors", "units_of"]


class CoordinateUnits(NamedTuple):
    """The units of a file's coordinates, as its CRS records state them.

    Attributes
    ----------
    xy : float or None
        Metres per unit of x and y (0.3048006096012192 for US survey feet); None
        when the file states no linear unit for them, or they are angles.
    z : float or None
        Metres per unit of z, from the vertical CRS; None when not stated.
    xy_name, z_name : str
        The units' names as the file gives them ("" when not stated).
    kind : str or None
        ``"projected"``, ``"geographic"`` (x, y are longitude and latitude in
        degrees), ``"geocentric"`` (x, y, z from the Earth's centre), or None when
        the file has no CRS record that says.
    source : str
        The record read: ``"WKT"``, ``"GeoTIFF keys"``, or ``""`` for none.
    problem : str
        Why a record present could not be read (``""`` when it could).
    """

    xy: float | None = None
    z: float | None = None
    xy_name: str = ""
    z_name: str = ""
    kind: str | None = None
    source: str = ""
    problem: str = ""


NOT_STATED = CoordinateUnits()

# WKT 1 (with ESRI's VERTCS) and WKT 2 keywords of each kind of CRS (ISO 19162).
# Local and engineering systems are planar in a length unit too: as projected ones.
_PROJECTED = {"PROJCS", "PROJCRS", "PROJECTEDCRS", "LOCAL_CS", "ENGCRS", "ENGINEERINGCRS"}
_GEOGRAPHIC = {"GEOGCS", "GEOGCRS", "GEOGRAPHICCRS"}
_GEODETIC = {"GEODCRS", "GEODETICCRS"}  # geographic or geocentric, by its CS
_GEOCENTRIC = {"GEOCCS"}
_VERTICAL = {"VERT_CS", "VERTCS", "VERTCRS", "VERTICALCRS"}
_UNITS = {"UNIT", "LENGTHUNIT"}
_IDS = {"AUTHORITY", "ID"}
_WRAPPERS = {"BOUNDCRS": "SOURCECRS"}  # a CRS with a transformation: its source CRS
_PLAUSIBLE = (1e-4, 1e5)  # metres per unit: from a tenth of a millimetre to 100 km
_MAX_DEPTH = 64  # far above any real CRS; deeper nesting is not a CRS

# GeoTIFF keys (GeoTIFF 1.0, section 6.3): model type (1 projected, 2 geographic,
# 3 geocentric), projected and geographic CRS codes, linear units and their size
# when user-defined, vertical units.
_MODEL_TYPE, _PROJECTED_KEY, _GEOGRAPHIC_KEY = 1024, 3072, 2048
_LINEAR_UNITS, _LINEAR_UNIT_SIZE, _VERTICAL_UNITS = 3076, 3077, 4099
_MODEL_KINDS = {1: "projected", 2: "geographic", 3: "geocentric"}
_USER_DEFINED = 32767
_GEO_DOUBLES = 34736  # the tag whose values a key with this location indexes
# EPSG's length units that GeoTIFF keys use (EPSG dataset, unit of measure codes).
_EPSG_LENGTHS = {
    9001: ("metre", 1.0),
    9002: ("foot", 0.3048),
    9003: ("US survey foot", 1200.0 / 3937.0),
    9005: ("Clarke's foot", 0.3047972654),
    9036: ("kilometre", 1000.0),
}


class _Node(NamedTuple):
    keyword: str  # upper case
    args: list  # of str (quoted or bare) and _Node


def _parse_wkt(text: str) -> list[_Node]:
    """The WKT's top-level objects, parsed without recursion (a hostile file may nest
    deeply); ValueError when it is not well-formed."""
    text = text.split("\0", 1)[0]  # writers end the record with a NUL
    roots: list[_Node] = []
    stack: list[_Node] = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c.isspace() or c == ",":
            i += 1
        elif c == '"':  # "" inside a quoted text is one quote
            end = i + 1
            while True:
                end = text.find('"', end)
                if end < 0:
                    raise ValueError("a quoted text is not closed")
                if text.startswith('""', end):
                    end += 2
                    continue
                break
            if not stack:
                raise ValueError("text outside any object")
            stack[-1].args.append(text[i + 1 : end].replace('""', '"'))
            i = end + 1
        elif c in "])":
            if not stack:
                raise ValueError(f"an unopened {c!r}")
            stack.pop()
            i += 1
        else:
            end = i
            while end < n and text[end] not in '[](),"' and not text[end].isspace():
                end += 1
            token = text[i:end]
            j = end
            while j < n and text[j].isspace():
                j += 1
            if j < n and text[j] in "[(":
                if len(stack) >= _MAX_DEPTH:
                    raise ValueError(f"objects nested over {_MAX_DEPTH} deep")
                node = _Node(token.upper(), [])
                (stack[-1].args if stack else roots).append(node)
                stack.append(node)
                i = j + 1
            elif token and stack:
                stack[-1].args.append(token)
                i = end
            else:
                raise ValueError(f"unexpected {text[i : i + 20]!r}")
    if stack:
        raise ValueError(f"{stack[-1].keyword}[ is not closed")
    return roots


def _children(node: _Node, keywords: set[str]) -> list[_Node]:
    return [a for a in node.args if isinstance(a, _Node) and a.keyword in keywords]


def _walk(nodes: list[_Node]):
    """Every node, depth first, parents before their children."""
    stack = list(reversed(nodes))
    while stack:
        node = stack.pop()
        yield node
        stack.extend(reversed([a for a in node.args if isinstance(a, _Node)]))


def _first(nodes: list[_Node], keywords: set[str]) -> _Node | None:
    return next((node for node in _walk(nodes) if node.keyword in keywords), None)


def _length_unit(crs: _Node) -> tuple[str, float] | None:
    """A CRS's length unit: its own UNIT or LENGTHUNIT, else its first axis's (WKT 2
    may give each axis one). Units inside other objects (a parameter's) are not its."""
    for holder in [crs, *_children(crs, {"AXIS"})]:
        for unit in _children(holder, _UNITS):
            if len(unit.args) < 2:
                raise ValueError(f"{unit.keyword} without a factor")
            if isinstance(unit.args[0], str):
                try:
                    factor = float(unit.args[1])
                except (TypeError, ValueError):
                    raise ValueError(f"{unit.keyword} {unit.args[0]!r} has no factor") from None
                if not _PLAUSIBLE[0] <= factor <= _PLAUSIBLE[1]:
                    raise ValueError(f"{unit.keyword} {unit.args[0]!r} has factor {factor}")
                return unit.args[0], factor
    return None


def _horizontal(roots: list[_Node]) -> tuple[_Node | None, str | None]:
    """The horizontal CRS object and its kind: the first projected one, else the first
    geographic or geocentric one (a compound CRS holds it with a vertical one)."""
    for wrapper, part in _WRAPPERS.items():
        for node in _walk(roots):
            if node.keyword == wrapper:
                roots = _children(node, {part}) or roots
                break
    projected = _first(roots, _PROJECTED)
    if projected is not None:
        return projected, "projected"
    node = _first(roots, _GEOGRAPHIC | _GEODETIC | _GEOCENTRIC)
    if node is None:
        return None, None
    if node.keyword in _GEOCENTRIC:
        return node, "geocentric"
    if node.keyword in _GEODETIC:
        systems = _children(node, {"CS"})
        if systems and systems[0].args and str(systems[0].args[0]).lower() == "cartesian":
            return node, "geocentric"
    return node, "geographic"


def _stated(
    xy: tuple[str, float] | None, z: tuple[str, float] | None, kind: str | None, source: str
) -> CoordinateUnits:
    """CoordinateUnits from (name, metres) pairs of x, y and of z, found in `source`."""
    return CoordinateUnits(
        xy=xy[1] if xy else None,
        z=z[1] if z else None,
        xy_name=xy[0] if xy else ("degree" if kind == "geographic" else ""),
        z_name=z[0] if z else "",
        kind=kind,
        source=source,
    )


def _wkt_units(text: str) -> CoordinateUnits:
    roots = _parse_wkt(text)
    horizontal, kind = _horizontal(roots)
    xy = _length_unit(horizontal) if kind in ("projected", "geocentric") else None
    vertical = _first(roots, _VERTICAL)
    z = _length_unit(vertical) if vertical is not None else None
    if kind == "geocentric" and z is None:
        z = xy
    return _stated(xy, z, kind, "WKT")


def _wkt_epsg(text: str) -> int | None:
    """The EPSG code of a WKT's horizontal CRS: its own AUTHORITY (WKT 1) or ID
    (WKT 2) clause."""
    horizontal, _ = _horizontal(_parse_wkt(text))
    if horizontal is None:
        return None
    for clause in _children(horizontal, _IDS):
        if len(clause.args) >= 2 and str(clause.args[0]).upper() == "EPSG":
            code = str(clause.args[1])
            return int(code) if code.isdigit() else None
    return None


def _key_values(record) -> dict[int, int]:
    """The GeoTIFF keys stored in the directory itself (location 0), by id."""
    return {
        int(key.id): int(key.value_offset) for key in record.geo_keys if key.tiff_tag_location == 0
    }


def _key_length(code: int | None, size: float | None) -> tuple[str, float] | None:
    if code is None:
        return None
    if code == _USER_DEFINED:
        if size is None or not _PLAUSIBLE[0] <= size <= _PLAUSIBLE[1]:
            raise ValueError("a user-defined linear unit without a valid size")
        return "user-defined", float(size)
    if code not in _EPSG_LENGTHS:
        raise ValueError(f"length unit code {code} is not one this package knows")
    return _EPSG_LENGTHS[code]


def _geokey_units(record, doubles: list[float]) -> CoordinateUnits:
    values = _key_values(record)
    size = None
    for key in record.geo_keys:
        if key.id == _LINEAR_UNIT_SIZE and key.tiff_tag_location == _GEO_DOUBLES:
            if not 0 <= key.value_offset < len(doubles):
                raise ValueError("the linear unit size points outside the GeoTIFF doubles")
            size = doubles[key.value_offset]
    kind = _MODEL_KINDS.get(values.get(_MODEL_TYPE, 0))
    if kind is None and _PROJECTED_KEY in values:
        kind = "projected"
    elif kind is None and _GEOGRAPHIC_KEY in values:
        kind = "geographic"
    xy = _key_length(values.get(_LINEAR_UNITS), size) if kind != "geographic" else None
    z = _key_length(values.get(_VERTICAL_UNITS), None)
    return _stated(xy, z, kind, "GeoTIFF keys")


def _records(header) -> list:
    return [*getattr(header, "vlrs", []), *(getattr(header, "evlrs", None) or [])]


def units_of(header) -> CoordinateUnits:
    """The units a laspy header's CRS records state: the WKT's when there is one (LAS
    1.4 makes it the CRS of the newer point formats), else the GeoTIFF keys'."""
    from laspy.vlrs.known import GeoDoubleParamsVlr, GeoKeyDirectoryVlr, WktCoordinateSystemVlr

    records = _records(header)
    wkt = [r for r in records if isinstance(r, WktCoordinateSystemVlr)]
    keys = [r for r in records if isinstance(r, GeoKeyDirectoryVlr)]
    doubles = [
        float(getattr(d, "value", d))  # laspy keeps ctypes doubles
        for r in records
        if isinstance(r, GeoDoubleParamsVlr)
        for d in r.doubles
    ]
    for record in records:  # laspy keeps a record it cannot parse as a plain VLR
        if (
            getattr(record, "user_id", "") == "LASF_Projection"
            and getattr(record, "record_id", 0) in (2112, 34735)
            and not isinstance(record, (WktCoordinateSystemVlr, GeoKeyDirectoryVlr))
        ):
            name = "WKT" if record.record_id == 2112 else "GeoTIFF keys"
            return CoordinateUnits(source=name, problem=f"its {name} cannot be read")
    source = ""
    try:
        if wkt:
            source = "WKT"
            stated = _wkt_units(wkt[0].string)
            if stated.kind is not None or not keys:
                return stated
        if keys:  # also when the WKT names no horizontal system (empty, vertical only)
            source = "GeoTIFF keys"
            return _geokey_units(keys[0], doubles)
    except ValueError as error:
        return CoordinateUnits(source=source, problem=f"its {source} cannot be read: {error}")
    return NOT_STATED


def crs_codes_of(header) -> list[int]:
    """The EPSG codes a laspy header gives its horizontal CRS, in its GeoTIFF keys and
    its WKT; none when it has no such record or no code in them (or cannot be read)."""
    from laspy.vlrs.known import GeoKeyDirectoryVlr, WktCoordinateSystemVlr

    codes = set()
    for record in _records(header):
        if isinstance(record, GeoKeyDirectoryVlr):
            values = _key_values(record)
            for key_id in (_PROJECTED_KEY, _GEOGRAPHIC_KEY):
                if key_id in values:
                    if 0 < values[key_id] < _USER_DEFINED:
                        codes.add(values[key_id])
                    break
        elif isinstance(record, WktCoordinateSystemVlr):
            try:
                code = _wkt_epsg(record.string)
            except ValueError:
                code = None
            if code is not None:
                codes.add(code)
    return sorted(codes)


# Units a caller may give for files whose records state none or state them wrongly.
GIVEN_UNITS = {
    "m": ("metre", 1.0),
    "ft": ("foot", 0.3048),
    "us-ft": ("US survey foot", 1200.0 / 3937.0),
}


def metre_factors(
    units: CoordinateUnits, given: str | None = None
) -> tuple[tuple[float, float, float], str]:
    """Metres per unit of x, y and z, to scale points before a method whose lengths are
    metres, and a few words on where they come from.

    `given` (a key of GIVEN_UNITS) overrides the file. Otherwise: what the records
    state; z in the unit of x and y when only those are stated (the common case of a
    projected CRS without a vertical one); metres when nothing is stated. ValueError
    for longitude and latitude, geocentric coordinates, and records that cannot be read.
    """
    if given is not None:
        if given not in GIVEN_UNITS:
            raise ValueError(f"units must be one of {sorted(GIVEN_UNITS)}, got {given!r}")
        name, factor = GIVEN_UNITS[given]
        return (factor, factor, factor), f"{name} (given)"
    if units.problem:
        raise ValueError(f"the file's coordinate system: {units.problem}; give its units")
    if units.kind == "geographic":
        raise ValueError(
            f"x and y are longitude and latitude in degrees (the file's {units.source}); "
            "every length here is in metres: reproject the file to a projected system first"
        )
    if units.kind == "geocentric":
        raise ValueError(
            f"x, y and z are geocentric, from the Earth's centre (the file's {units.source}); "
            "reproject the file to a projected system first"
        )
    if units.xy is None:
        if units.z is None and units.kind == "projected":  # a code, not its unit
            return (1.0, 1.0, 1.0), (
                f"metre, assumed: the file's {units.source} name a projected system but "
                "not its unit (give the units if they are not metres)"
            )
        if units.z is None:
            return (1.0, 1.0, 1.0), "metre (the file states no units)"
        raise ValueError(
            f"the file's {units.source} state a unit for z ({units.z_name}) but none for "
            "x and y; give its units"
        )
    z, z_name = (units.z, units.z_name) if units.z is not None else (units.xy, units.xy_name)
    where = f"the file's {units.source}" + ("" if units.z is not None else "; z as x and y")
    if z_name == units.xy_name and z == units.xy:
        return (units.xy, units.xy, z), f"{units.xy_name} ({where})"
    return (units.xy, units.xy, z), f"x, y {units.xy_name}, z {z_name} ({where})"
