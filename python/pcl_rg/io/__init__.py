"""Point-cloud file input and output.

:func:`read_points` and :func:`write_points` handle LAS/LAZ (through laspy and
lazrs), PLY, PCD and XYZ text, chosen by the file extension (`EXTENSIONS`) and
checked against the file's first bytes; they keep every per-point attribute and,
given the file read as a template, its layout (LAS scale, offset, point format,
VLRs; PCD encoding and organized shape; PLY encoding and comments).
:func:`read_pcd` and :func:`write_pcd` are PCD's own conveniences: PCL's three
encodings ``ascii``, ``binary`` and ``binary_compressed`` (v0.7, also reading
v0.5/v0.6 headers), in plain NumPy.

Every reader returns one container, :class:`PointFile`:

- ``points``: float64 (N, 3), x, y, z in the file's coordinates;
- ``fields``: every other per-point attribute by name, (N,) or (N, count), in
  the dtype the file stores;
- ``format``: ``"las"``, ``"laz"``, ``"ply"``, ``"pcd"`` or ``"xyz"``;
- ``header``: what the file stores besides its values, the layout
  :func:`write_points` writes back in: a ``laspy.LasHeader``, a
  :class:`PcdLayout` (encoding, x/y/z dtype, width, height, viewpoint), a
  :class:`PlyLayout` (encoding, x/y/z dtype, comments), or None for XYZ text;
- ``path``: the file read; ``records``: a LAS/LAZ file's (E)VLR headers.

``PointFile.units`` tells what a LAS/LAZ file's coordinate-system records (OGC
WKT, GeoTIFF keys) say of its units: every length of the package is in metres.

Every writer goes through a temporary file in the destination folder, renamed over
the target when complete. The formats live in private modules (``_las``, ``_pcd``,
``_ply``, ``_xyz``) this module dispatches to; ``_formats`` tells a file's format.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from . import _las, _pcd, _ply, _xyz
from ._columns import check_columns, check_path, check_xyz
from ._crs import CoordinateUnits, units_of
from ._extent import Extent, read_extent
from ._formats import EXTENSIONS, check_magic, format_of
from ._las_header import LasRecord
from ._pcd import write_pcd

__all__ = [
    "EXTENSIONS",
    "CoordinateUnits",
    "PcdLayout",
    "PlyLayout",
    "PointFile",
    "Extent",
    "read_extent",
    "read_pcd",
    "read_points",
    "write_pcd",
    "write_points",
]


class PcdLayout(NamedTuple):
    """What a PCD file stores besides its values (``PointFile.header`` of a PCD)."""

    encoding: str
    """``ascii``, ``binary`` or ``binary_compressed``."""
    xyz_dtype: np.dtype
    """Storage type of x, y, z (float32 or float64)."""
    width: int
    """WIDTH of the header: points per row."""
    height: int
    """HEIGHT of the header: rows; > 1 for organized clouds, whose points are
    row-major (``points.reshape(height, width, 3)``)."""
    viewpoint: tuple[float, ...]
    """The 7 VIEWPOINT numbers: translation tx ty tz, then quaternion qw qx qy qz."""


class PlyLayout(NamedTuple):
    """What a PLY file stores besides its values (``PointFile.header`` of a PLY)."""

    encoding: str
    """``ascii``, ``binary_little_endian`` or ``binary_big_endian``."""
    xyz_dtype: np.dtype
    """Storage type of x, y, z (float32 or float64)."""
    comments: tuple[str, ...]
    """The header's ``comment`` lines."""


class PointFile:
    """Points and every per-point attribute of a file, plus what is needed to write it back.

    Attributes
    ----------
    points : numpy.ndarray
        float64 (N, 3): x, y, z in the file's coordinates (LAS scale and offset
        applied). NaN rows (invalid points of organized PCD clouds) are kept.
    fields : dict of str to numpy.ndarray
        Every other per-point attribute by name, shape (N,) or (N, count), in
        the dtype the file stores. LAS: every dimension of the point format
        by laspy's name (``intensity``, ``return_number``, ``classification``,
        ``synthetic``, ``gps_time``, ``red``, ...) and every extra-bytes
        dimension.
    format : str
        ``"las"``, ``"laz"``, ``"ply"``, ``"pcd"`` or ``"xyz"``.
    header : object or None
        The layout to write back in: a ``laspy.LasHeader`` (version, point
        format, scale, offset, VLRs, CRS) for LAS/LAZ, a :class:`PcdLayout`, a
        :class:`PlyLayout`, or None for XYZ text.
    path : str or None
        The file read, if any.
    records : tuple of LasRecord
        LAS/LAZ: the VLRs, then the EVLRs, as their headers in the file give them
        (laspy's header re-encodes known records and drops LASzip's); else empty.
    """

    __slots__ = ("points", "fields", "format", "header", "path", "records")

    def __init__(
        self,
        points: np.ndarray,
        fields: dict[str, np.ndarray],
        format: str,
        header: object | None = None,
        path: str | None = None,
        records: tuple[LasRecord, ...] = (),
    ) -> None:
        self.points = points
        self.fields = fields
        self.format = format
        self.header = header
        self.path = path
        self.records = records

    def __len__(self) -> int:
        return len(self.points)

    def __repr__(self) -> str:
        where = f" from {self.path!r}" if self.path else ""
        return (
            f"<PointFile {self.format}{where}: {len(self.points)} points, "
            f"fields {list(self.fields)}>"
        )

    @property
    def units(self) -> CoordinateUnits:
        """The units of ``points`` as the file's coordinate-system records state them.

        LAS/LAZ: its OGC WKT, else its GeoTIFF keys (US survey feet, say, or
        longitude and latitude). PLY, PCD and XYZ text state none: every field of
        the result is then empty. The package's lengths are metres: scale points
        in other units before filtering them (the command line does it).

        Examples
        --------
        >>> import numpy as np
        >>> from pcl_rg.io import PointFile
        >>> PointFile(np.zeros((1, 3)), {}, "xyz").units.xy is None
        True
        """
        if self.format in ("las", "laz") and self.header is not None:
            return units_of(self.header)
        return CoordinateUnits()

    @property
    def classification(self) -> np.ndarray | None:
        """The ``classification`` field, or None when the file has none."""
        return self.fields.get("classification")

    def take(self, index: ArrayLike) -> PointFile:
        """The rows selected by `index` (bool mask or integer indices), same header."""
        idx = np.asarray(index)
        if idx.dtype == np.bool_ and idx.shape != (len(self.points),):
            raise ValueError(f"index mask must have shape ({len(self.points)},), got {idx.shape}")
        return PointFile(
            self.points[idx],
            {name: values[idx] for name, values in self.fields.items()},
            self.format,
            self.header,
            self.path,
            self.records,
        )


def read_points(path: str | os.PathLike[str], *, format: str | None = None) -> PointFile:
    """Read a LAS/LAZ, PLY, PCD or XYZ text file into float64 points and fields.

    Parameters
    ----------
    path : str or os.PathLike
        File to read. The format comes from the extension (see `EXTENSIONS`:
        ``.las``, ``.laz``, ``.ply``, ``.pcd``, ``.xyz``, ``.txt``, ``.pts``),
        and the file's first bytes must agree with it.
    format : {"las", "laz", "ply", "pcd", "xyz"}, optional
        Read as this format whatever the extension.

    Returns
    -------
    PointFile
        ``points`` float64 (N, 3), ``fields`` (every other attribute, stored
        dtype), ``format``, and ``header`` (the layout :func:`write_points`
        copies when given the result as `template`).

    Raises
    ------
    FileNotFoundError, PermissionError, IsADirectoryError
        If the file cannot be opened.
    TypeError
        If `path` is not a str or path-like object.
    ValueError
        If the extension is unknown, the file is empty, its first bytes show
        another format than the extension says, or it is corrupt or truncated.
        The message names the file and the problem.

    Warns
    -----
    UserWarning
        If a LAS file holds room for more point records after the ones its
        header counts, or a LAZ file's chunk table more points than the count
        (a damaged count would otherwise go unnoticed); the counted points are
        returned.

    Notes
    -----
    LAS 1.0-1.4 and LAZ come through laspy (with the lazrs backend for LAZ);
    coordinates are the stored integers times the header's scale plus its
    offset, in float64, so nothing is lost. Scaled extra-bytes dimensions come
    back scaled (float64).

    PLY: ``ascii``, ``binary_little_endian`` and ``binary_big_endian``; the
    ``vertex`` element's scalar properties are read (x, y, z must be among
    them); other elements such as faces are skipped (elements with list
    properties only after ``vertex``). The data must hold what the header's
    element counts give (ascii: one row per entry; binary: the entries' bytes,
    checked where the elements after ``vertex`` have entries of one size, such
    as triangles), so that a vertex count short of the vertex data is refused.

    XYZ text (UTF-8, a byte order mark allowed): one point per line, ``x y z``
    and optional further columns, split on whitespace; blank lines and lines
    starting with ``#`` or ``//`` are skipped. A comment line right before the
    data that names every column (``# x y z intensity``) names the fields;
    otherwise they are ``column_4``, ``column_5``, ... (``.pts``:
    ``intensity``, then ``red green blue``, Leica's layout, whose optional
    first line holding the point count is checked).
    Columns of whole numbers with at least one written as an integer (``7``,
    not ``7.0``) come back as int64 (uint64 when beyond int64 and none is
    negative; float64 beyond both), others as float64: a float64 field that
    :func:`write_points` wrote comes back float64, bit for bit.

    PLY, PCD and XYZ: a field named ``Classification`` (or any other case of
    it, as CloudCompare writes it) is returned as ``classification``, the name
    the classes are read by, unless the file has several such names.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from pcl_rg.io import read_points, write_points
    >>> xyz = np.array([[500000.125, 5400000.5, 12.25], [500001.0, 5400001.0, 13.0]])
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = os.path.join(folder, "two.ply")
    ...     write_points(path, xyz, {"classification": np.array([2, 1], np.uint8)})
    ...     cloud = read_points(path)
    >>> cloud.format, cloud.points.tolist()
    ('ply', [[500000.125, 5400000.5, 12.25], [500001.0, 5400001.0, 13.0]])
    >>> cloud.classification.tolist()
    [2, 1]
    """
    name = check_path(path)
    fmt = format_of(name, format)
    check_magic(name, fmt)
    return _read(name, fmt)


_READERS = {"ply": _ply.read, "pcd": _pcd.read, "xyz": _xyz.read}
_LAYOUTS = {"ply": PlyLayout, "pcd": PcdLayout}


def _read(name: str, fmt: str) -> PointFile:
    if fmt in ("las", "laz"):
        points, fields, header, records = _las.read(name)
        return PointFile(points, fields, fmt, header, name, records)
    points, fields, header = _READERS[fmt](name)
    if fmt in _LAYOUTS:
        header = _LAYOUTS[fmt](*header)
    return PointFile(points, _classification_named(fields), fmt, header, name)


def _classification_named(fields: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """`fields` with the one field named classification in another case (CloudCompare
    writes ``Classification``) named ``classification``, the name every command reads
    the classes by; as it is when the name is exact or several cases are present."""
    matches = [key for key in fields if key.lower() == "classification"]
    if len(matches) != 1 or matches[0] == "classification":
        return fields
    return {"classification" if key == matches[0] else key: v for key, v in fields.items()}


def read_pcd(path: str | os.PathLike[str]) -> PointFile:
    """Read a PCD file (any of PCL's three encodings).

    Parameters
    ----------
    path : str or os.PathLike
        File to read.

    Returns
    -------
    PointFile
        ``points`` (float64, shape (N, 3), NaN kept: the invalid points of
        organized clouds), ``fields`` (every other field by name, in header
        order, dtype as stored in native byte order, shape (N,) when its COUNT
        is 1, else (N, count); padding fields named ``_`` dropped), ``format``
        ``"pcd"`` and ``header``, a :class:`PcdLayout` with the ``encoding``,
        ``xyz_dtype``, ``width``, ``height`` and the 7 ``viewpoint`` numbers.

    Raises
    ------
    FileNotFoundError
        If `path` does not exist.
    TypeError
        If `path` is not a str or path-like object.
    ValueError
        If the file is not a valid PCD file: not PCD at all, truncated header or
        data, unknown TYPE/SIZE, no x/y/z field, WIDTH x HEIGHT != POINTS, data
        shorter than the header says (or longer, unless the excess is zero
        padding), corrupt LZF payload, non-numeric or out-of-range ascii tokens,
        or ascii rows with the wrong number of columns. The message names the
        file and the problem.

    Notes
    -----
    Follows PCL's ``pcl::PCDReader``: header lines ``VERSION``, ``FIELDS`` (or
    the v0.5 ``COLUMNS``), ``SIZE``, ``TYPE``, ``COUNT``, ``WIDTH``, ``HEIGHT``,
    ``VIEWPOINT``, ``POINTS``, ``DATA``, with ``#`` comments. Older headers may
    omit SIZE/TYPE/COUNT (then float32, count 1), HEIGHT (1), WIDTH (POINTS),
    POINTS (WIDTH x HEIGHT) and VIEWPOINT (identity). Unlike PCL, an unknown
    keyword, a mismatch, or extra ascii rows are errors rather than warnings.

    ``binary`` data is an array of packed little-endian records; padding fields
    named ``_`` are skipped. ``binary_compressed`` data is two little-endian
    uint32 (compressed size, uncompressed size) followed by an LZF block whose
    content is column-major: all values of the first field, then the next, in
    header order, padding fields omitted. Zero bytes after the data are accepted:
    files written by PCL carry them.

    PCL's ``rgb`` (float32) and ``rgba`` (uint32) fields hold a packed colour
    ``0xAARRGGBB``; they are returned as stored. Unpack with, e.g.,
    ``c = fields["rgb"].view(np.uint32); r = (c >> 16) & 0xFF``.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from pcl_rg.io import read_pcd, write_pcd
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = os.path.join(folder, "cloud.pcd")
    ...     write_pcd(path, [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]],
    ...               {"intensity": np.array([7, 9], dtype=np.uint16)}, encoding="ascii")
    ...     cloud = read_pcd(path)
    >>> cloud.points.tolist()
    [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]]
    >>> cloud.fields["intensity"].tolist(), cloud.header.width, cloud.header.height
    ([7, 9], 2, 1)
    """
    return _read(check_path(path), "pcd")


def write_points(
    path: str | os.PathLike[str],
    points: ArrayLike,
    fields: Mapping[str, ArrayLike] | None = None,
    *,
    classification: ArrayLike | None = None,
    template: PointFile | None = None,
    format: str | None = None,
) -> None:
    """Write points and per-point fields to a LAS/LAZ, PLY, PCD or XYZ text file.

    Parameters
    ----------
    path : str or os.PathLike
        File to write, format from its extension (as :func:`read_points`);
        replaced atomically if it exists.
    points : array_like, shape (N, 3)
        x, y, z in the caller's (file) coordinates. NaN rows only for PCD,
        PLY and XYZ; LAS cannot store them.
    fields : mapping of str to array_like, optional
        Per-point attributes, shape (N,) or (N, count), e.g. the ``fields`` of
        a :class:`PointFile` (possibly subset with ``take``).
    classification : array_like of int, shape (N,), optional
        Class codes (ASPRS: 1 unclassified, 2 ground, 7 noise); replaces
        ``fields["classification"]``.
    template : PointFile, optional
        A file read before, whose layout is kept when the output has the same
        format family (LAS/LAZ, PCD or PLY): for LAS the version (1.0 as 1.2,
        which holds its point formats and fields; laspy writes no 1.0), point format,
        scale, offset, VLRs (CRS included), extra-bytes definitions and
        header fields (but the generating software and creation date, which
        name pcl_rg and the day of writing); for PCD the encoding, x/y/z type,
        viewpoint and, when N is unchanged, width and height; for PLY the
        encoding, x/y/z type and comments.
    format : {"las", "laz", "ply", "pcd", "xyz"}, optional
        Write as this format whatever the extension.

    Raises
    ------
    TypeError
        Wrong argument types.
    ValueError
        Unknown extension; `points` not (N, 3); a field of the wrong length; a
        value out of range of its LAS dimension (e.g. classification > 31 in
        point formats 0-5); NaN points or coordinates that do not fit the
        template's scale and offset in LAS, or whose extent no LAS scale and
        offset hold (beyond about +-1e307); coordinates beyond float32 with a
        PLY or PCD template of float32 x, y, z; two fields that a text header
        would give one name (``"a b"`` and ``"a_b"``); a field name that a PLY
        or XYZ header cannot hold (not printable ASCII; ``,`` or ``;`` in
        XYZ); LAZ in point format 9 or 10 with more than one scanner channel,
        whose wave packet fields the LAZ compressor (lazrs) corrupts (write
        LAS instead).
    OSError
        If the file cannot be written (e.g. the disk is full), or `path` is a
        FIFO, device or socket (FileExistsError); the target is then left
        untouched and no temporary file remains.

    Notes
    -----
    Every format is written to a temporary file in the destination folder
    and renamed over `path` when complete (also on ``KeyboardInterrupt`` no
    partial file remains). A `path` that links to an existing file is
    written through (the link stays), and a file replaced keeps its
    permission bits.

    LAS/LAZ without a LAS template: version 1.4, point format 6 (7 with
    ``red``/``green``/``blue``, 8 with ``nir`` too), scale 1 mm (coarser only
    if the extent needs it), offset the minimum corner rounded down to a
    metre. Fields named like a dimension of the point format fill it (values
    are range-checked, never wrapped); any other field is added as an
    extra-bytes dimension of its dtype (e.g. ``segment_id`` int32). With a
    template, coordinates are stored as ``round((x - offset) / scale)``, so
    points read from that file are written back bit for bit; its waveform
    packets are kept when in a LAS 1.4 EVLR, else dropped with a warning.

    PCD, PLY without a template: x, y, z as float32 when that is exact, else
    float64. Both store fields with their dtype (PLY has no 64-bit integers:
    int64 becomes int32 or uint32 when the values fit, else float64 up to
    2**53, beyond which the write is refused rather than rounded; bool becomes
    uint8); (N, count) fields become ``name_0``, ``name_1``, ... in PLY and
    XYZ, and in the text formats (PCD, PLY, XYZ) white space in a field name
    becomes ``_``. XYZ text writes a ``# x y z ...`` header comment and every number as
    the shortest text that reads back to the same value; ``.pts`` whose fields
    are Leica's (none, ``intensity``, ``red green blue`` or all four) gets the
    point count as its first line instead, as Leica's readers expect.

    Examples
    --------
    A LAZ file with a field and classes, then its first point written again
    with the first file's header as template:

    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> import pcl_rg.io
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     laz, first = pathlib.Path(folder, "two.laz"), pathlib.Path(folder, "ground.laz")
    ...     pcl_rg.io.write_points(
    ...         laz,
    ...         [[500000.125, 5400000.5, 12.25], [500001.0, 5400001.0, 13.0]],
    ...         {"intensity": np.array([10, 20], np.uint16)},
    ...         classification=[2, 6],
    ...     )
    ...     cloud = pcl_rg.io.read_points(laz)
    ...     kept = {name: values[:1] for name, values in cloud.fields.items()}
    ...     pcl_rg.io.write_points(first, cloud.points[:1], kept, template=cloud)
    ...     ground = pcl_rg.io.read_points(first)
    >>> cloud.points.tolist(), cloud.classification.tolist(), cloud.fields["intensity"].tolist()
    ([[500000.125, 5400000.5, 12.25], [500001.0, 5400001.0, 13.0]], [2, 6], [10, 20])
    >>> len(ground), ground.header.point_format.id, ground.classification.tolist()
    (1, 6, [2])
    """
    name = check_path(path)
    fmt = format_of(name, format)
    xyz = check_xyz(points)
    columns = check_columns(fields, classification, len(xyz))
    if template is not None and not isinstance(template, PointFile):
        raise TypeError(f"template must be a PointFile, got {type(template).__name__}")

    if fmt in ("las", "laz"):
        header = None
        if template is not None and template.format in ("las", "laz"):
            header = template.header
        source = f" in the layout of {template.path!r}" if template is not None else ""
        _las.write(name, xyz, columns, header, compress=fmt == "laz", source=source)
    else:
        layout = template.header if template is not None and template.format == fmt else None
        _WRITERS[fmt](name, xyz, columns, layout)


_WRITERS = {"ply": _ply.write, "pcd": _pcd.write, "xyz": _xyz.write}
