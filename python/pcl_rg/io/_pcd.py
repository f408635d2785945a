"""PCD files: the data in PCL's three encodings, read and written in plain NumPy.

``ascii``, ``binary`` and ``binary_compressed``; the header is
:mod:`pcl_rg.io._pcd_header`'s. The LZF codec of ``binary_compressed`` comes from
the compiled extension (``pcl_rg._core``), imported only when such a file is read
or written. :func:`read` and :func:`write` serve :func:`pcl_rg.io.read_points`,
:func:`pcl_rg.io.write_points` and :func:`pcl_rg.io.read_pcd`; :func:`write_pcd`
is public.
"""

from __future__ import annotations

import os
import struct
from collections.abc import Mapping, Sequence
from io import StringIO
from typing import TYPE_CHECKING, BinaryIO

import numpy as np
from numpy.typing import ArrayLike, DTypeLike

from .._params import check_number
from ._atomic import atomic_write, write_ascii, write_chunked
from ._columns import (
    PRINTABLE_TOKEN,
    check_path,
    check_xyz,
    column_array,
    exact_float32,
    load_ascii_table,
    named_columns,
)
from ._pcd_header import (
    DEFAULT_VIEWPOINT,
    ENCODINGS,
    MAX_HEADER_BYTES,
    PAD,
    PcdHeader,
    bad_pcd,
    format_header,
    parse_header,
)

if TYPE_CHECKING:
    from . import PcdLayout

__all__ = ["read", "unorganized", "write", "write_pcd"]

_LZF_MAX_EXPANSION = 88


def _check_padding(path: str, trailing: memoryview) -> None:
    # PCL's own writers leave zero bytes after the data (the tutorial files carry
    # 4096 - header-length of them), so zeros are accepted; anything else means the
    # header promised fewer points than the file holds.
    if len(trailing) and np.frombuffer(trailing, dtype=np.uint8).any():
        raise bad_pcd(
            path,
            f"{len(trailing)} bytes after the point data are not zero padding "
            "(header POINTS smaller than the data?)",
        )


def _decode_binary(path: str, header: PcdHeader, data: memoryview) -> dict[str, np.ndarray]:
    n = header.points
    names, formats, offsets = [], [], []
    offset = 0
    for f in header.fields:
        if f.name != PAD:
            names.append(f.name)
            formats.append(f.dtype if f.count == 1 else (f.dtype, (f.count,)))
            offsets.append(offset)
        offset += f.dtype.itemsize * f.count
    record = np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": offset})
    need = n * record.itemsize
    if len(data) < need:
        raise bad_pcd(
            path,
            f"binary data is {len(data)} bytes but POINTS {n} x {record.itemsize} bytes per "
            f"point needs {need} (file truncated?)",
        )
    _check_padding(path, data[need:])
    table = np.frombuffer(data, dtype=record, count=n)
    return {name: table[name] for name in names}


def _decode_compressed(path: str, header: PcdHeader, data: memoryview) -> dict[str, np.ndarray]:
    from pcl_rg._core import lzf_decompress

    n = header.points
    if len(data) < 8:
        raise bad_pcd(path, "binary_compressed data is truncated (no size words after DATA)")
    compressed_size, uncompressed_size = struct.unpack_from("<II", data)
    # Padding fields are not stored in the compressed layout (as in PCL).
    columns = [f for f in header.fields if f.name != PAD]
    step = sum(f.dtype.itemsize * f.count for f in columns)
    if uncompressed_size != n * step:
        raise bad_pcd(
            path,
            f"binary_compressed uncompressed size is {uncompressed_size} bytes but POINTS {n} x "
            f"{step} bytes per point is {n * step}",
        )
    # An LZF back-reference of 3 bytes expands to at most 264 bytes, so no payload
    # decompresses to more than 88 times its size: a larger claim is damage, caught
    # here; a smaller false one, by the codec's scan of the payload's control bytes
    # before it allocates the output (lzf_codec.cpp).
    if uncompressed_size > _LZF_MAX_EXPANSION * compressed_size:
        raise bad_pcd(
            path,
            f"binary_compressed sizes are inconsistent: {compressed_size} compressed bytes "
            f"cannot hold {uncompressed_size} bytes (LZF expands at most "
            f"{_LZF_MAX_EXPANSION}-fold)",
        )
    if len(data) - 8 < compressed_size:
        raise bad_pcd(
            path,
            f"binary_compressed data is truncated: {len(data) - 8} bytes present, "
            f"{compressed_size} announced",
        )
    _check_padding(path, data[8 + compressed_size :])
    try:
        raw = lzf_decompress(bytes(data[8 : 8 + compressed_size]), uncompressed_size)
    except ValueError as exc:
        raise bad_pcd(path, f"binary_compressed payload does not decompress: {exc}") from None
    if len(raw) != uncompressed_size:  # the codec promises this; keep the error readable
        raise bad_pcd(path, f"LZF payload gave {len(raw)} bytes, expected {uncompressed_size}")
    result = {}
    offset = 0
    for f in columns:
        values = np.frombuffer(raw, dtype=f.dtype, count=n * f.count, offset=offset)
        offset += n * f.count * f.dtype.itemsize
        result[f.name] = values if f.count == 1 else values.reshape(n, f.count)
    return result


def _decode_ascii(path: str, header: PcdHeader, data: memoryview) -> dict[str, np.ndarray]:
    n = header.points
    try:
        text = bytes(data).decode("ascii")
    except UnicodeDecodeError as exc:
        raise bad_pcd(path, f"ascii data has a non-ASCII byte at offset {exc.start}") from None
    if not text.strip():  # np.loadtxt warns on empty input
        if n:
            raise bad_pcd(path, f"ascii data has no rows but POINTS is {n}")
        return {
            f.name: np.empty((0,) if f.count == 1 else (0, f.count), f.dtype)
            for f in header.fields
            if f.name != PAD
        }
    # Every value takes at least one character: a cheap bound before any parsing.
    n_values = sum(f.count for f in header.fields)
    if n * n_values > len(data):
        raise bad_pcd(
            path,
            f"POINTS {n} with {n_values} values per row needs at least {n * n_values} bytes "
            f"of ascii data, the file holds {len(data)} (truncated?)",
        )
    names, formats = [], []
    for i, f in enumerate(header.fields):
        # PCL's ascii reader skips COUNT tokens for a padding field; any number goes.
        # (A name with a space cannot clash with a PCD field name.)
        names.append(f.name if f.name != PAD else f"padding {i}")
        dtype = f.dtype if f.name != PAD else np.dtype("<f8")
        formats.append(dtype if f.count == 1 else (dtype, (f.count,)))
    record = np.dtype({"names": names, "formats": formats})
    try:
        table = load_ascii_table(StringIO(text, newline=None), record)
    except ValueError as exc:
        raise bad_pcd(path, f"ascii data, {exc}") from None
    if len(table) != n:
        raise bad_pcd(path, f"ascii data has {len(table)} rows but POINTS is {n}")
    return {f.name: table[f.name] for f in header.fields if f.name != PAD}


def read(name: str) -> tuple[np.ndarray, dict[str, np.ndarray], tuple]:
    """Points, fields and the layout (encoding, x/y/z dtype, width, height, viewpoint).

    The header is parsed once; the rules and errors are those of
    :func:`pcl_rg.io.read_pcd`, the layout's order that of
    :class:`pcl_rg.io.PcdLayout`.
    """
    with open(name, "rb") as stream:
        head = stream.read(MAX_HEADER_BYTES)
        header = parse_header(name, head)
        data = memoryview(head[header.data_offset :] + stream.read())

    decode = {
        "ascii": _decode_ascii,
        "binary": _decode_binary,
        "binary_compressed": _decode_compressed,
    }[header.data]
    columns = decode(name, header, data)

    n = header.points
    points = np.empty((n, 3), dtype=np.float64)
    # A signalling NaN (e.g. 0x7f800001) sets the "invalid" flag when widened; it
    # is still NaN, so no warning.
    with np.errstate(invalid="ignore"):
        for i, axis in enumerate(("x", "y", "z")):
            points[:, i] = columns[axis]
    # Copies in native byte order that own their memory (the sources are read-only
    # views of the file buffer or strided columns of a record array).
    fields = {
        key: np.array(values, dtype=values.dtype.newbyteorder("="), order="C")
        for key, values in columns.items()
        if key not in ("x", "y", "z")
    }
    # float32 only when all three axes are: a float64 or integer axis written back as
    # float32 (a template round trip) would lose digits without a word.
    axes = {f.dtype.newbyteorder("=") for f in header.fields if f.name in ("x", "y", "z")}
    xyz_dtype = np.dtype("f4") if axes == {np.dtype("f4")} else np.dtype("f8")
    layout = (
        header.data,
        xyz_dtype,
        header.width,
        header.height,
        header.viewpoint,
    )
    return points, fields, layout


def _check_points(points: ArrayLike, xyz_dtype: np.dtype) -> np.ndarray:
    array = check_xyz(points)
    if xyz_dtype == np.float32:
        limit = float(np.finfo(np.float32).max)
        too_big = np.isfinite(array) & (np.abs(array) > limit)
        if too_big.any():
            first = np.argwhere(too_big)[0]
            raise ValueError(
                f"points[{first[0]}, {first[1]}] = {float(array[tuple(first)])!r} is beyond the "
                "float32 range; pass xyz_dtype=np.float64"
            )
    with np.errstate(invalid="ignore"):
        return array.astype(xyz_dtype.newbyteorder("<"))


def _check_fields(fields: Mapping[str, ArrayLike] | None, n: int) -> list[tuple[str, np.ndarray]]:
    if fields is None:
        return []
    if not isinstance(fields, Mapping):
        raise TypeError(f"fields must be a mapping of name to array, got {type(fields).__name__}")
    checked = []
    for name, values in fields.items():
        if not isinstance(name, str):
            raise TypeError(f"fields keys must be str, got {name!r}")
        if name in ("x", "y", "z"):
            raise ValueError(f"fields[{name!r}]: x, y and z are given in points, not fields")
        # A name may start with '#': only a line that starts with it is a comment, and
        # FIELDS starts the line (the reader, and PCL's, read such a name back).
        if name == PAD or not PRINTABLE_TOKEN.fullmatch(name):
            raise ValueError(
                f"fields[{name!r}]: a field name must be printable ASCII without spaces, "
                "and not '_'"
            )
        array = column_array(f"fields[{name!r}]", values, f"({n},) or ({n}, count)")
        kind, size = array.dtype.kind, array.dtype.itemsize
        if kind not in "fiu" or (kind == "f" and size not in (4, 8)) or size not in (1, 2, 4, 8):
            raise TypeError(
                f"fields[{name!r}] has dtype {array.dtype}; PCD stores (u)int8/16/32/64, "
                "float32 and float64 (convert bool with .astype(np.uint8))"
            )
        bad_count = array.ndim == 2 and array.shape[1] < 1
        if array.ndim not in (1, 2) or array.shape[0] != n or bad_count:
            raise ValueError(
                f"fields[{name!r}] must have shape ({n},) or ({n}, count), got {array.shape}"
            )
        checked.append((name, array.astype(array.dtype.newbyteorder("<"), copy=False)))
    return checked


def _check_shape(n: int, width: int | None, height: int | None) -> tuple[int, int]:
    if width is not None:
        width = check_number("width", width, int, minimum=0)
    if height is not None:
        height = check_number("height", height, int, minimum=0)
    if width is None and height is None:
        width, height = n, 1
    elif width is None:
        width = n // height if height else 0
    elif height is None:
        height = n // width if width else 1
    width, height = int(width), int(height)
    if width * height != n:
        raise ValueError(
            f"width * height must equal the number of points {n}, got {width} * {height}"
        )
    return width, height


def _check_viewpoint(viewpoint: Sequence[float] | None) -> tuple[float, ...]:
    if viewpoint is None:
        return DEFAULT_VIEWPOINT
    try:
        values = np.asarray(viewpoint, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"viewpoint must be 7 numbers, got {viewpoint!r}") from None
    if values.shape != (7,) or not np.isfinite(values).all():
        raise ValueError(
            f"viewpoint must be 7 finite numbers (tx ty tz qw qx qy qz), got {viewpoint!r}"
        )
    return tuple(float(v) for v in values)


def write_pcd(
    path: str | os.PathLike[str],
    points: ArrayLike,
    fields: Mapping[str, ArrayLike] | None = None,
    *,
    encoding: str = "binary_compressed",
    width: int | None = None,
    height: int | None = None,
    viewpoint: Sequence[float] | None = None,
    xyz_dtype: DTypeLike = np.float32,
) -> None:
    """Write a PCD v0.7 file.

    Parameters
    ----------
    path : str or os.PathLike
        File to write; replaced atomically if it exists.
    points : array_like, shape (N, 3)
        x, y, z of every point (float or integer; NaN allowed, e.g. for the
        invalid points of organized clouds).
    fields : mapping of str to array_like, optional
        Extra fields, written after x y z in mapping order: arrays of shape (N,)
        (COUNT 1) or (N, count). dtypes (u)int8/16/32/64, float32, float64 are
        stored as they are, so PCL's packed colours go in unchanged: ``rgb`` as
        float32, ``rgba`` as uint32. A (N, 1) array reads back as (N,).
    encoding : {"binary_compressed", "binary", "ascii"}, default "binary_compressed"
        DATA encoding. ``binary_compressed`` is LZF over the column-major data,
        as PCL writes it.
    width, height : int, optional
        Organized layout (row-major, ``width * height == N``). Default: N x 1;
        when only one is given, the other is N divided by it.
    viewpoint : sequence of 7 float, optional
        Sensor pose tx ty tz qw qx qy qz; default 0 0 0 1 0 0 0.
    xyz_dtype : {numpy.float32, numpy.float64}, default numpy.float32
        Storage type of x, y, z. float32 is PCL's convention and what PCL's
        ``PointXYZ`` types read, but it has only 24 bits of mantissa: UTM
        northings (~5e6 m) are rounded to 0.5 m. Subtract a local origin first
        (and keep it, e.g. in the VIEWPOINT translation or beside the file), or
        pass ``np.float64`` for lossless storage.

    Raises
    ------
    TypeError
        If `path`, `points`, `fields`, `width`, `height`, `viewpoint` or
        `xyz_dtype` has the wrong type (e.g. complex, bool or object arrays).
    ValueError
        If `points` is not (N, 3), a field has the wrong length or shape or a bad
        name, ``width * height != N``, `encoding` is unknown, `viewpoint` is not 7
        finite numbers, or a coordinate overflows float32.
    OSError
        If the file cannot be written; the target is then left untouched.

    Notes
    -----
    The header is PCL's (``pcl::PCDWriter``), so PCL and this module read each
    other's files in all three encodings. The data go to a temporary file in the
    destination folder that is renamed over `path` only when complete; on any
    error, including ``KeyboardInterrupt``, the temporary file is removed and an
    existing `path` is left as it was.

    ``ascii`` writes each float as the shortest text that reads back to the same
    float32/float64 value (``nan`` for NaN), so all three encodings round-trip
    exactly, except that the sign and payload bits of NaN (e.g. a float ``rgba``
    with alpha 255) survive only the binary encodings. ascii is slow (about a
    second per million values each way); prefer the binary encodings for big
    clouds.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from pcl_rg.io import read_pcd, write_pcd
    >>> xyz = np.array([[5e5 + 0.25, 5e6 + 0.5, 10.0], [np.nan, np.nan, np.nan]])
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = os.path.join(folder, "utm.pcd")
    ...     write_pcd(path, xyz, encoding="binary", xyz_dtype=np.float64)
    ...     cloud = read_pcd(path)
    >>> cloud.points.tolist()
    [[500000.25, 5000000.5, 10.0], [nan, nan, nan]]
    """
    name = check_path(path)
    if not isinstance(encoding, str) or encoding not in ENCODINGS:
        raise ValueError(f"encoding must be one of {', '.join(ENCODINGS)}, got {encoding!r}")
    try:
        xyz_type = np.dtype(xyz_dtype)
    except TypeError:
        raise TypeError(f"xyz_dtype must be np.float32 or np.float64, got {xyz_dtype!r}") from None
    if xyz_type not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise ValueError(f"xyz_dtype must be np.float32 or np.float64, got {xyz_type}")
    xyz = _check_points(points, xyz_type)
    n = xyz.shape[0]
    extra = _check_fields(fields, n)
    width, height = _check_shape(n, width, height)
    pose = _check_viewpoint(viewpoint)

    columns = [xyz[:, 0], xyz[:, 1], xyz[:, 2]] + [array for _, array in extra]
    names = ["x", "y", "z"] + [key for key, _ in extra]
    header = format_header(names, columns, width, height, pose, encoding)

    if encoding == "ascii":

        def write_data(stream: BinaryIO) -> None:
            stream.write(header)
            write_ascii(stream, columns, n)

    else:
        if encoding == "binary":
            formats = [a.dtype if a.ndim == 1 else (a.dtype, (a.shape[1],)) for a in columns]
            record = np.dtype({"names": names, "formats": formats})
            table = np.empty(n, dtype=record)
            for key, array in zip(names, columns):
                table[key] = array
            payload: bytes | memoryview = memoryview(table.view(np.uint8))
        else:
            from pcl_rg._core import lzf_compress

            raw = b"".join(np.ascontiguousarray(a).tobytes() for a in columns)
            if len(raw) > 0xFFFFFFFF:  # the sizes are uint32 in the format
                raise ValueError(
                    f"binary_compressed holds at most 4 GiB of data, these points need {len(raw)} "
                    "bytes; use encoding='binary'"
                )
            compressed = lzf_compress(raw)
            payload = struct.pack("<II", len(compressed), len(raw)) + compressed

        def write_data(stream: BinaryIO) -> None:
            stream.write(header)
            write_chunked(stream, payload)

    atomic_write(name, write_data)


def unorganized(cloud):
    """`cloud` (a PointFile) as the template of points that are not its rows in order,
    such as voxel centroids: :func:`write` keeps an organized PCD's WIDTH x HEIGHT
    whenever the number of points is the same, which would then scramble the image."""
    if cloud.format != "pcd" or cloud.header is None:
        return cloud
    header = cloud.header._replace(width=len(cloud), height=1)
    return type(cloud)(cloud.points, cloud.fields, cloud.format, header, cloud.path)


def write(
    path: str, xyz: np.ndarray, columns: dict[str, np.ndarray], layout: PcdLayout | None
) -> None:
    """write_points for PCD: the `layout` of a template, if any; shape kept when N is."""
    fields = {}
    for key, array in named_columns(columns):
        if array.dtype == np.bool_:
            array = array.astype(np.uint8)
        elif array.dtype.kind == "f" and array.dtype.itemsize < 4:
            array = array.astype(np.float32)
        fields[key] = array
    n = len(xyz)
    if layout is None:
        options = {"xyz_dtype": np.float32 if exact_float32(xyz) else np.float64}
    else:
        organized = layout.width * layout.height == n
        options = {
            "encoding": layout.encoding,
            "width": layout.width if organized else n,
            "height": layout.height if organized else 1,
            "viewpoint": layout.viewpoint,
            "xyz_dtype": layout.xyz_dtype,
        }
    write_pcd(path, xyz, fields, **options)
