"""Point-cloud file input and output.

:func:`read_points` and :func:`write_points` handle LAS/LAZ (through laspy and
lazrs), PLY, PCD and XYZ text, chosen by the file extension and checked against
the file's first bytes; they keep every per-point attribute and, given the file
read as a template, its layout (LAS scale, offset, point format, VLRs).

PCD (PCL's Point Cloud Data format, v0.7, also reading v0.5/v0.6 headers) in its
three encodings ``ascii``, ``binary`` and ``binary_compressed``, in plain NumPy.
The LZF codec of ``binary_compressed`` comes from the compiled extension
(``pcl_rg._core``), imported only when such a file is read or written.
"""

from __future__ import annotations

import contextlib
import io as _stdio
import os
import re
import secrets
import struct
from collections.abc import Callable, Mapping, Sequence
from typing import BinaryIO, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, DTypeLike

from ._las_header import check_las_header
from ._validation import check_int

__all__ = [
    "EXTENSIONS",
    "PcdLayout",
    "PlyLayout",
    "PointCloudData",
    "PointFile",
    "read_pcd",
    "read_points",
    "write_pcd",
    "write_points",
]


class PointCloudData(NamedTuple):
    """A point cloud read from a file.

    Attributes
    ----------
    points : numpy.ndarray
        float64 array of shape (N, 3): x, y, z of every point, in file order.
        Invalid points of organized clouds stay NaN.
    fields : dict of str to numpy.ndarray
        Every other field, by name, in header order, with the dtype stored in the
        file (native byte order); shape (N,) when its COUNT is 1, else (N, count).
        Padding fields named ``_`` are dropped.
    width : int
        WIDTH of the header: points per row.
    height : int
        HEIGHT of the header: rows; > 1 for organized clouds, whose points are
        row-major (``points.reshape(height, width, 3)``).
    viewpoint : tuple of float
        The 7 VIEWPOINT numbers: translation tx ty tz, then quaternion qw qx qy qz.
    """

    points: np.ndarray
    fields: dict[str, np.ndarray]
    width: int
    height: int
    viewpoint: tuple[float, ...]


# --------------------------------------------------------------------------- PCD

_ENCODINGS = ("ascii", "binary", "binary_compressed")
_VERSIONS = ("0.7", ".7", "0.6", ".6", "0.5", ".5")
_KEYWORDS = (
    "VERSION",
    "FIELDS",
    "COLUMNS",
    "SIZE",
    "TYPE",
    "COUNT",
    "WIDTH",
    "HEIGHT",
    "VIEWPOINT",
    "POINTS",
    "DATA",
)
_DEFAULT_VIEWPOINT = (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
# (TYPE, SIZE) -> little-endian NumPy dtype; PCL has no 1- or 2-byte floats.
_PCD_DTYPES = {
    ("I", 1): np.dtype("i1"),
    ("I", 2): np.dtype("<i2"),
    ("I", 4): np.dtype("<i4"),
    ("I", 8): np.dtype("<i8"),
    ("U", 1): np.dtype("u1"),
    ("U", 2): np.dtype("<u2"),
    ("U", 4): np.dtype("<u4"),
    ("U", 8): np.dtype("<u8"),
    ("F", 4): np.dtype("<f4"),
    ("F", 8): np.dtype("<f8"),
}
_PAD = "_"
# The header ends with the DATA line; real headers are a few hundred bytes.
_MAX_HEADER_BYTES = 1 << 20
_ASCII_CHUNK_ROWS = 65536
_BINARY_CHUNK_BYTES = 1 << 24
_LZF_MAX_EXPANSION = 88
_MAX_PCD_COUNT = 1 << 16
_FIELD_NAME = re.compile(r"[!-~]+")


class _Field(NamedTuple):
    name: str
    dtype: np.dtype  # little-endian scalar dtype
    count: int


class _Header(NamedTuple):
    fields: list[_Field]
    width: int
    height: int
    points: int
    viewpoint: tuple[float, ...]
    data: str
    data_offset: int


def _bad(path: str, problem: str) -> ValueError:
    return ValueError(f"invalid PCD file {path!r}: {problem}")


def _fspath(path: object, argname: str = "path") -> str:
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"{argname} must be a str or os.PathLike, got {type(path).__name__}")
    result = os.fspath(path)
    if not isinstance(result, str):
        raise TypeError(f"{argname} must be a text path, got {type(result).__name__}")
    return result


def _parse_ints(path: str, key: str, tokens: list[str], minimum: int) -> list[int]:
    values = []
    for tok in tokens:
        try:
            value = int(tok)
        except ValueError:
            raise _bad(path, f"{key} value {tok!r} is not an integer") from None
        if value < minimum:
            raise _bad(path, f"{key} value {value} must be >= {minimum}")
        values.append(value)
    return values


def _parse_header(path: str, head: bytes) -> _Header:
    """Parse the header at the start of `head`; see read_pcd for the rules."""
    entries: dict[str, list[str]] = {}
    pos = 0
    data_offset = -1
    while pos < len(head):
        end = head.find(b"\n", pos)
        if end < 0:
            break
        raw = head[pos:end].strip()
        line_no = head.count(b"\n", 0, pos) + 1
        pos = end + 1
        if not raw or raw.startswith(b"#"):
            continue
        try:
            line = raw.decode("ascii")
        except UnicodeDecodeError:
            what = "not a PCD file" if not entries else "header is not ASCII text"
            raise _bad(path, f"{what} (line {line_no}: {raw[:40]!r})") from None
        tokens = line.split()
        key = tokens[0]
        if key not in _KEYWORDS:
            if not entries:
                raise _bad(path, f"not a PCD file (line {line_no}: {line[:40]!r})")
            raise _bad(path, f"unknown header keyword {key!r} on line {line_no}")
        if key == "COLUMNS":  # the v0.5 spelling of FIELDS
            key = "FIELDS"
        if key in entries:
            raise _bad(path, f"header has {key} twice (line {line_no})")
        entries[key] = tokens[1:]
        if key == "DATA":
            data_offset = pos
            break
    if data_offset < 0:
        if not head:
            raise _bad(path, "file is empty")
        if not entries:
            raise _bad(path, "not a PCD file (no header keywords found)")
        if len(head) >= _MAX_HEADER_BYTES:
            raise _bad(path, f"no DATA line within the first {_MAX_HEADER_BYTES} bytes")
        raise _bad(path, "header is truncated (file ends before the DATA line)")

    version = entries.get("VERSION")
    if version is not None and (len(version) != 1 or version[0] not in _VERSIONS):
        raise _bad(path, f"unsupported VERSION {' '.join(version)!r} (expected 0.7, 0.6 or 0.5)")

    data = entries["DATA"]
    if len(data) != 1 or data[0] not in _ENCODINGS:
        raise _bad(path, f"DATA must be one of {', '.join(_ENCODINGS)}, got {' '.join(data)!r}")

    names = entries.get("FIELDS")
    if not names:
        raise _bad(path, "header has no FIELDS")
    n_fields = len(names)
    # v0.5/v0.6 headers may omit SIZE, TYPE and COUNT; PCL then assumes float32, count 1.
    for key in ("SIZE", "TYPE", "COUNT"):
        if key in entries and len(entries[key]) != n_fields:
            raise _bad(
                path, f"{key} has {len(entries[key])} values but FIELDS has {n_fields} names"
            )
    sizes = _parse_ints(path, "SIZE", entries.get("SIZE", ["4"] * n_fields), 1)
    types = entries.get("TYPE", ["F"] * n_fields)
    counts = _parse_ints(path, "COUNT", entries.get("COUNT", ["1"] * n_fields), 1)
    if max(counts) > _MAX_PCD_COUNT:  # PCL's widest descriptors hold a few hundred values
        raise _bad(path, f"COUNT value {max(counts)} is above the supported {_MAX_PCD_COUNT}")

    fields = []
    seen = set()
    for name, size, typ, count in zip(names, sizes, types, counts):
        dtype = _PCD_DTYPES.get((typ, size))
        if dtype is None:
            raise _bad(
                path,
                f"field {name!r} has unsupported TYPE {typ!r} with SIZE {size} "
                "(TYPE I or U with SIZE 1, 2, 4, 8; TYPE F with SIZE 4, 8)",
            )
        if name != _PAD:
            if name in seen:
                raise _bad(path, f"field {name!r} appears twice in FIELDS")
            seen.add(name)
        fields.append(_Field(name, dtype, count))
    for axis in ("x", "y", "z"):
        if axis not in seen:
            raise _bad(path, f"FIELDS has no {axis!r} (got {' '.join(names)})")
        count = next(f.count for f in fields if f.name == axis)
        if count != 1:
            raise _bad(path, f"field {axis!r} must have COUNT 1, got {count}")

    def one_int(key: str) -> int | None:
        if key not in entries:
            return None
        if len(entries[key]) != 1:
            raise _bad(path, f"{key} must be one integer, got {' '.join(entries[key])!r}")
        return _parse_ints(path, key, entries[key], 0)[0]

    width, height, n_points = one_int("WIDTH"), one_int("HEIGHT"), one_int("POINTS")
    if width is None and n_points is None:
        raise _bad(path, "header has neither WIDTH nor POINTS")
    if width is None:
        if height is not None and height != 1:
            raise _bad(path, f"HEIGHT {height} given without WIDTH")
        width, height = n_points, 1
    if height is None:
        height = 1
    if n_points is None:
        n_points = width * height
    if width * height != n_points:
        raise _bad(
            path,
            f"WIDTH {width} x HEIGHT {height} = {width * height} does not equal POINTS {n_points}",
        )

    viewpoint = _DEFAULT_VIEWPOINT
    if "VIEWPOINT" in entries:
        tokens = entries["VIEWPOINT"]
        if len(tokens) != 7:
            raise _bad(path, f"VIEWPOINT needs 7 numbers (tx ty tz qw qx qy qz), got {len(tokens)}")
        try:
            viewpoint = tuple(float(t) for t in tokens)
        except ValueError:
            raise _bad(path, f"VIEWPOINT has a non-numeric value: {' '.join(tokens)!r}") from None

    return _Header(fields, width, height, n_points, viewpoint, data[0], data_offset)


def _check_padding(path: str, trailing: memoryview) -> None:
    # PCL's own writers leave zero bytes after the data (the tutorial files carry
    # 4096 - header-length of them), so zeros are accepted; anything else means the
    # header promised fewer points than the file holds.
    if len(trailing) and np.frombuffer(trailing, dtype=np.uint8).any():
        raise _bad(
            path,
            f"{len(trailing)} bytes after the point data are not zero padding "
            "(header POINTS smaller than the data?)",
        )


def _decode_binary(path: str, header: _Header, data: memoryview) -> dict[str, np.ndarray]:
    n = header.points
    names, formats, offsets = [], [], []
    offset = 0
    for f in header.fields:
        if f.name != _PAD:
            names.append(f.name)
            formats.append(f.dtype if f.count == 1 else (f.dtype, (f.count,)))
            offsets.append(offset)
        offset += f.dtype.itemsize * f.count
    record = np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": offset})
    need = n * record.itemsize
    if len(data) < need:
        raise _bad(
            path,
            f"binary data is {len(data)} bytes but POINTS {n} x {record.itemsize} bytes per "
            f"point needs {need} (file truncated?)",
        )
    _check_padding(path, data[need:])
    table = np.frombuffer(data, dtype=record, count=n)
    return {name: table[name] for name in names}


def _decode_compressed(path: str, header: _Header, data: memoryview) -> dict[str, np.ndarray]:
    from pcl_rg._core import lzf_decompress

    n = header.points
    if len(data) < 8:
        raise _bad(path, "binary_compressed data is truncated (no size words after DATA)")
    compressed_size, uncompressed_size = struct.unpack_from("<II", data)
    # Padding fields are not stored in the compressed layout (as in PCL).
    columns = [f for f in header.fields if f.name != _PAD]
    step = sum(f.dtype.itemsize * f.count for f in columns)
    if uncompressed_size != n * step:
        raise _bad(
            path,
            f"binary_compressed uncompressed size is {uncompressed_size} bytes but POINTS {n} x "
            f"{step} bytes per point is {n * step}",
        )
    # An LZF back-reference of 3 bytes expands to at most 264 bytes, so no payload
    # decompresses to more than 88 times its size: a larger claim is damage, caught
    # before the output buffer is allocated.
    if uncompressed_size > _LZF_MAX_EXPANSION * compressed_size:
        raise _bad(
            path,
            f"binary_compressed sizes are inconsistent: {compressed_size} compressed bytes "
            f"cannot hold {uncompressed_size} bytes (LZF expands at most "
            f"{_LZF_MAX_EXPANSION}-fold)",
        )
    if len(data) - 8 < compressed_size:
        raise _bad(
            path,
            f"binary_compressed data is truncated: {len(data) - 8} bytes present, "
            f"{compressed_size} announced",
        )
    _check_padding(path, data[8 + compressed_size :])
    try:
        raw = lzf_decompress(bytes(data[8 : 8 + compressed_size]), uncompressed_size)
    except ValueError as exc:
        raise _bad(path, f"binary_compressed payload does not decompress: {exc}") from None
    if len(raw) != uncompressed_size:  # the codec promises this; keep the error readable
        raise _bad(path, f"LZF payload gave {len(raw)} bytes, expected {uncompressed_size}")
    result = {}
    offset = 0
    for f in columns:
        values = np.frombuffer(raw, dtype=f.dtype, count=n * f.count, offset=offset)
        offset += n * f.count * f.dtype.itemsize
        result[f.name] = values if f.count == 1 else values.reshape(n, f.count)
    return result


def _decode_ascii(path: str, header: _Header, data: memoryview) -> dict[str, np.ndarray]:
    n = header.points
    try:
        text = bytes(data).decode("ascii")
    except UnicodeDecodeError as exc:
        raise _bad(path, f"ascii data has a non-ASCII byte at offset {exc.start}") from None
    if not text.strip():  # np.loadtxt warns on empty input
        if n:
            raise _bad(path, f"ascii data has no rows but POINTS is {n}")
        return {
            f.name: np.empty((0,) if f.count == 1 else (0, f.count), f.dtype)
            for f in header.fields
            if f.name != _PAD
        }
    # Every value takes at least one character: a cheap bound before any parsing.
    n_values = sum(f.count for f in header.fields)
    if n * n_values > len(data):
        raise _bad(
            path,
            f"POINTS {n} with {n_values} values per row needs at least {n * n_values} bytes "
            f"of ascii data, the file holds {len(data)} (truncated?)",
        )
    names, formats = [], []
    for i, f in enumerate(header.fields):
        # PCL's ascii reader skips COUNT tokens for a padding field; any number goes.
        # (A name with a space cannot clash with a PCD field name.)
        names.append(f.name if f.name != _PAD else f"padding {i}")
        dtype = f.dtype if f.name != _PAD else np.dtype("<f8")
        formats.append(dtype if f.count == 1 else (dtype, (f.count,)))
    record = np.dtype({"names": names, "formats": formats})
    n_columns = sum(f.count for f in header.fields)
    try:
        table = np.loadtxt(
            _stdio.StringIO(text, newline=None), dtype=record, ndmin=1, comments=None
        )
    except ValueError as exc:
        message = str(exc).split("; use `usecols`")[0]
        raise _bad(path, f"ascii data, {n_columns} columns per row expected: {message}") from None
    if len(table) != n:
        raise _bad(path, f"ascii data has {len(table)} rows but POINTS is {n}")
    return {f.name: table[f.name] for f in header.fields if f.name != _PAD}


def read_pcd(path: str | os.PathLike[str]) -> PointCloudData:
    """Read a PCD file (any of PCL's three encodings).

    Parameters
    ----------
    path : str or os.PathLike
        File to read.

    Returns
    -------
    PointCloudData
        ``points`` (float64, shape (N, 3), NaN kept), ``fields`` (every other
        field by name, dtype as stored, shape (N,) or (N, count)), ``width``,
        ``height`` and the 7 ``viewpoint`` numbers.

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
    >>> cloud.fields["intensity"].tolist(), cloud.width, cloud.height
    ([7, 9], 2, 1)
    """
    name = _fspath(path)
    with open(name, "rb") as stream:
        head = stream.read(_MAX_HEADER_BYTES)
        header = _parse_header(name, head)
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
    return PointCloudData(points, fields, header.width, header.height, header.viewpoint)


# ----------------------------------------------------------------------- writing


def _format_number(value: float) -> str:
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text


def _check_points(points: ArrayLike, xyz_dtype: np.dtype) -> np.ndarray:
    array = np.asarray(points)
    if array.dtype.kind not in "fiu":
        raise TypeError(f"points must be a real float or integer array, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {array.shape}")
    with np.errstate(invalid="ignore"):  # signalling NaNs stay NaN without a warning
        array = array.astype(np.float64, copy=False)
    if xyz_dtype == np.float32:
        limit = float(np.finfo(np.float32).max)
        too_big = np.isfinite(array) & (np.abs(array) > limit)
        if too_big.any():
            first = np.argwhere(too_big)[0]
            raise ValueError(
                f"points[{first[0]}, {first[1]}] = {array[tuple(first)]!r} is beyond the "
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
        if name == _PAD or not _FIELD_NAME.fullmatch(name) or name.startswith("#"):
            raise ValueError(
                f"fields[{name!r}]: a field name must be printable ASCII without spaces, "
                "not '_' and not starting with '#'"
            )
        array = np.asarray(values)
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
        width = check_int("width", width, minimum=0)
    if height is not None:
        height = check_int("height", height, minimum=0)
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
        return _DEFAULT_VIEWPOINT
    try:
        values = np.asarray(viewpoint, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"viewpoint must be 7 numbers, got {viewpoint!r}") from None
    if values.shape != (7,) or not np.isfinite(values).all():
        raise ValueError(
            f"viewpoint must be 7 finite numbers (tx ty tz qw qx qy qz), got {viewpoint!r}"
        )
    return tuple(float(v) for v in values)


def _ascii_strings(column: np.ndarray) -> list[str]:
    # NumPy's text for a float32/float64 is the shortest that reads back to the
    # same value at that precision (Dragon4), so ascii round-trips exactly and
    # float32 0.1 is written "0.1", not "0.100000001"; NaN is "nan".
    if column.dtype.kind == "f":
        return column.astype(str).tolist()
    return list(map(str, column.tolist()))


def _write_ascii(stream: BinaryIO, columns: list[np.ndarray], n: int) -> None:
    for start in range(0, n, _ASCII_CHUNK_ROWS):
        stop = min(start + _ASCII_CHUNK_ROWS, n)
        texts = []
        for array in columns:
            block = array[start:stop]
            if block.ndim == 1:
                texts.append(_ascii_strings(block))
            else:
                texts.extend(_ascii_strings(block[:, c]) for c in range(block.shape[1]))
        rows = [" ".join(row) for row in zip(*texts)]
        stream.write(("\n".join(rows) + "\n").encode("ascii"))


def _write_chunked(stream: BinaryIO, payload: bytes | memoryview) -> None:
    view = memoryview(payload)
    for start in range(0, len(view), _BINARY_CHUNK_BYTES):
        stream.write(view[start : start + _BINARY_CHUNK_BYTES])


def _atomic_write(path: str, write: Callable[[BinaryIO], None]) -> None:
    """Write through a temporary file in the same folder, renamed into place."""
    folder, base = os.path.split(os.path.abspath(path))
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    while True:
        temp = os.path.join(folder, f".{base}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
        try:
            # os.open applies the umask, unlike tempfile's private 0600 files.
            fd = os.open(temp, flags, 0o666)
            break
        except FileExistsError:
            continue
    try:
        with open(fd, "wb") as stream:
            write(stream)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temp)
        raise


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
    name = _fspath(path)
    if not isinstance(encoding, str) or encoding not in _ENCODINGS:
        raise ValueError(f"encoding must be one of {', '.join(_ENCODINGS)}, got {encoding!r}")
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
    counts = [1 if a.ndim == 1 else a.shape[1] for a in columns]
    types = ["F" if a.dtype.kind == "f" else a.dtype.kind.upper() for a in columns]
    header = "".join(
        [
            "# .PCD v0.7 - Point Cloud Data file format\n",
            "VERSION 0.7\n",
            f"FIELDS {' '.join(names)}\n",
            f"SIZE {' '.join(str(a.dtype.itemsize) for a in columns)}\n",
            f"TYPE {' '.join(types)}\n",
            f"COUNT {' '.join(str(c) for c in counts)}\n",
            f"WIDTH {width}\n",
            f"HEIGHT {height}\n",
            f"VIEWPOINT {' '.join(_format_number(v) for v in pose)}\n",
            f"POINTS {n}\n",
            f"DATA {encoding}\n",
        ]
    ).encode("ascii")

    if encoding == "ascii":

        def write(stream: BinaryIO) -> None:
            stream.write(header)
            _write_ascii(stream, columns, n)

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

        def write(stream: BinaryIO) -> None:
            stream.write(header)
            _write_chunked(stream, payload)

    _atomic_write(name, write)


# ================================================================== any format
#
# read_points / write_points: one entry point for LAS/LAZ (laspy), PLY, PCD and
# XYZ text, dispatched by extension and checked against the file's first bytes.

#: File extension -> format name understood by :func:`read_points`/:func:`write_points`.
EXTENSIONS: dict[str, str] = {
    ".las": "las",
    ".laz": "laz",
    ".ply": "ply",
    ".pcd": "pcd",
    ".xyz": "xyz",
    ".txt": "xyz",
    ".pts": "xyz",
}
_FORMAT_NAMES = {"las": "LAS", "laz": "LAZ", "ply": "PLY", "pcd": "PCD", "xyz": "XYZ text"}


class PcdLayout(NamedTuple):
    """What a PCD file stores besides its values (``PointFile.header`` of a PCD)."""

    encoding: str
    """``ascii``, ``binary`` or ``binary_compressed``."""
    xyz_dtype: np.dtype
    """Storage type of x, y, z (float32 or float64)."""
    width: int
    height: int
    viewpoint: tuple[float, ...]


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
    """

    __slots__ = ("points", "fields", "format", "header", "path")

    def __init__(
        self,
        points: np.ndarray,
        fields: dict[str, np.ndarray],
        format: str,
        header: object | None = None,
        path: str | None = None,
    ) -> None:
        self.points = points
        self.fields = fields
        self.format = format
        self.header = header
        self.path = path

    def __len__(self) -> int:
        return len(self.points)

    def __repr__(self) -> str:
        where = f" from {self.path!r}" if self.path else ""
        return (
            f"<PointFile {self.format}{where}: {len(self.points)} points, "
            f"fields {list(self.fields)}>"
        )

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
        )


def _format_of(path: str, format: str | None) -> str:
    if format is not None:
        if format not in _FORMAT_NAMES:
            raise ValueError(f"format must be one of {', '.join(_FORMAT_NAMES)}, got {format!r}")
        return format
    ext = os.path.splitext(path)[1].lower()
    if ext not in EXTENSIONS:
        raise ValueError(
            f"{path!r}: unknown file extension {ext or '(none)'!r}; supported: "
            f"{', '.join(EXTENSIONS)}"
        )
    return EXTENSIONS[ext]


def _sniff(head: bytes) -> str:
    """What the first bytes of a file look like: las, ply, pcd, text, empty or binary."""
    if not head:
        return "empty"
    if head.startswith(b"LASF"):
        return "las"
    if head.startswith((b"ply\n", b"ply\r\n")):
        return "ply"
    try:
        text = head.decode("ascii")
    except UnicodeDecodeError:
        # PCD headers are ASCII, binary data follows them; a head cut mid-way can
        # hold binary bytes after the DATA line.
        text = head.split(b"\nDATA", 1)[0].decode("ascii", errors="replace")
        if "\ufffd" in text:
            return "binary"
    for line in text.splitlines():
        line = line.strip()
        if not line:
            continue
        if line.startswith("# .PCD"):
            return "pcd"
        if line.startswith("#"):  # a comment of PCD or XYZ text: look further
            continue
        if line.split()[0] in _KEYWORDS:
            return "pcd"
        break
    printable = all(c.isprintable() or c in "\r\n\t\f\v" for c in text)
    return "text" if printable else "binary"


_KIND_NAMES = {
    "las": "a LAS/LAZ file",
    "ply": "a PLY file",
    "pcd": "a PCD file",
    "text": "a text file",
    "binary": "binary data of an unknown format",
}
_EXPECTED_KIND = {"las": "las", "laz": "las", "ply": "ply", "pcd": "pcd", "xyz": "text"}


def _check_magic(path: str, format: str) -> None:
    with open(path, "rb") as stream:
        head = stream.read(4096)
    kind = _sniff(head)
    if kind == "empty":
        raise ValueError(f"{path!r}: file is empty (0 bytes), not a {_FORMAT_NAMES[format]} file")
    if kind != _EXPECTED_KIND[format]:
        raise ValueError(
            f"{path!r}: not a {_FORMAT_NAMES[format]} file: its first bytes "
            f"({head[:8]!r}) look like {_KIND_NAMES[kind]}; check the file extension"
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

    Notes
    -----
    LAS 1.0-1.4 and LAZ come through laspy (with the lazrs backend for LAZ);
    coordinates are the stored integers times the header's scale plus its
    offset, in float64, so nothing is lost. Scaled extra-bytes dimensions come
    back scaled (float64).

    PLY: ``ascii``, ``binary_little_endian`` and ``binary_big_endian``; the
    ``vertex`` element's scalar properties are read (x, y, z must be among
    them); other elements such as faces are skipped (elements with list
    properties only after ``vertex``).

    XYZ text: one point per line, ``x y z`` and optional further columns, split
    on whitespace; blank lines and lines starting with ``#`` or ``//`` are
    skipped. A comment line right before the data that names every column
    (``# x y z intensity``) names the fields; otherwise they are ``column_4``,
    ``column_5``, ... (``.pts``: ``intensity``, then ``red green blue``, Leica's
    layout, whose optional first line holding the point count is checked).
    Columns of whole numbers come back as int64, others as float64.

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
    name = _fspath(path)
    fmt = _format_of(name, format)
    _check_magic(name, fmt)
    if fmt in ("las", "laz"):
        return _read_las(name, fmt)
    if fmt == "ply":
        return _read_ply(name)
    if fmt == "pcd":
        with open(name, "rb") as stream:
            header = _parse_header(name, stream.read(_MAX_HEADER_BYTES))
        cloud = read_pcd(name)
        x_dtype = next(f.dtype for f in header.fields if f.name == "x")
        layout = PcdLayout(
            header.data,
            np.dtype(x_dtype.newbyteorder("=")),
            cloud.width,
            cloud.height,
            cloud.viewpoint,
        )
        return PointFile(cloud.points, cloud.fields, "pcd", layout, name)
    return _read_xyz(name)


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
        format family (LAS/LAZ, PCD or PLY): for LAS the version, point format,
        scale, offset, VLRs (CRS included), extra-bytes definitions and
        header fields; for PCD the encoding, x/y/z type, viewpoint and, when N
        is unchanged, width and height; for PLY the encoding, x/y/z type and
        comments.
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
        template's scale and offset in LAS.
    OSError
        If the file cannot be written (e.g. the disk is full); the target is
        then left untouched and no temporary file remains.

    Notes
    -----
    Every format is written to a temporary file in the destination folder
    and renamed over `path` when complete (also on ``KeyboardInterrupt`` no
    partial file remains).

    LAS/LAZ without a LAS template: version 1.4, point format 6 (7 with
    ``red``/``green``/``blue``, 8 with ``nir`` too), scale 1 mm (coarser only
    if the extent needs it), offset the minimum corner rounded down to a
    metre. Fields named like a dimension of the point format fill it (values
    are range-checked, never wrapped); any other field is added as an
    extra-bytes dimension of its dtype (e.g. ``segment_id`` int32). With a
    template, coordinates are stored as ``round((x - offset) / scale)``, so
    points read from that file are written back bit for bit.

    PCD, PLY without a template: x, y, z as float32 when that is exact, else
    float64. Both store fields with their dtype (PLY has no 64-bit integers:
    int64 becomes int32 when the values fit, else float64; bool becomes
    uint8); (N, count) fields become ``name_0``, ``name_1``, ... in PLY and
    XYZ. XYZ text writes a ``# x y z ...`` header comment and every number as
    the shortest text that reads back to the same value.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from pcl_rg.io import read_points, write_points
    >>> xyz = np.array([[500000.125, 5400000.5, 12.25], [500001.0, 5400001.0, 13.0]])
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = os.path.join(folder, "two.laz")
    ...     write_points(path, xyz, {"intensity": np.array([10, 20], np.uint16)},
    ...                  classification=[2, 6])
    ...     cloud = read_points(path)
    ...     write_points(os.path.join(folder, "ground.laz"), cloud.points[:1],
    ...                  {k: v[:1] for k, v in cloud.fields.items()}, template=cloud)
    ...     ground = read_points(os.path.join(folder, "ground.laz"))
    >>> cloud.points.tolist(), cloud.classification.tolist(), cloud.fields["intensity"].tolist()
    ([[500000.125, 5400000.5, 12.25], [500001.0, 5400001.0, 13.0]], [2, 6], [10, 20])
    >>> len(ground), ground.header.point_format.id, ground.classification.tolist()
    (1, 6, [2])
    """
    name = _fspath(path)
    fmt = _format_of(name, format)
    xyz = np.asarray(points)
    if xyz.dtype.kind not in "fiu":
        raise TypeError(f"points must be a real float or integer array, got dtype {xyz.dtype}")
    if xyz.ndim != 2 or xyz.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {xyz.shape}")
    with np.errstate(invalid="ignore"):
        xyz = np.ascontiguousarray(xyz, dtype=np.float64)
    n = len(xyz)
    if fields is not None and not isinstance(fields, Mapping):
        raise TypeError(f"fields must be a mapping of name to array, got {type(fields).__name__}")
    columns: dict[str, np.ndarray] = {}
    for key, values in (fields or {}).items():
        if not isinstance(key, str) or not key:
            raise TypeError(f"fields keys must be non-empty str, got {key!r}")
        if key.lower() in ("x", "y", "z"):
            raise ValueError(f"fields[{key!r}]: x, y and z are given in points, not fields")
        array = np.asarray(values)
        if array.dtype.kind not in "biuf":
            raise TypeError(
                f"fields[{key!r}] must be a bool, integer or float array, got dtype {array.dtype}"
            )
        if array.ndim not in (1, 2) or array.shape[0] != n:
            raise ValueError(
                f"fields[{key!r}] must have shape ({n},) or ({n}, count), got {array.shape}"
            )
        columns[key] = array
    if classification is not None:
        codes = np.asarray(classification)
        if codes.dtype.kind not in "iu":
            raise TypeError(f"classification must be an integer array, got dtype {codes.dtype}")
        if codes.shape != (n,):
            raise ValueError(f"classification must have shape ({n},), got {codes.shape}")
        if n and (codes.min() < 0 or codes.max() > 255):
            raise ValueError(
                f"classification must be in [0, 255], got values from {codes.min()} to "
                f"{codes.max()}"
            )
        existing = columns.get("classification")
        dtype = existing.dtype if existing is not None else np.dtype(np.uint8)
        columns["classification"] = codes.astype(dtype)
    if template is not None and not isinstance(template, PointFile):
        raise TypeError(f"template must be a PointFile, got {type(template).__name__}")

    if fmt in ("las", "laz"):
        header = None
        if template is not None and template.format in ("las", "laz"):
            header = template.header
        source = f" in the layout of {template.path!r}" if template is not None else ""
        try:
            _write_las(name, xyz, columns, header, compress=fmt == "laz")
        except UnicodeError as error:  # laspy encodes the header's text fields as ASCII
            raise ValueError(f"cannot write {name!r}{source}: a header text is not ASCII "
                             f"({error})") from None
        except (OSError, ValueError, TypeError):
            raise
        except Exception as error:  # laspy or lazrs refusing the template's header
            raise ValueError(f"cannot write {name!r}{source}: {error}") from None
    elif fmt == "ply":
        layout = template.header if template is not None and template.format == "ply" else None
        _write_ply(name, xyz, columns, layout)
    elif fmt == "pcd":
        layout = template.header if template is not None and template.format == "pcd" else None
        _write_pcd_points(name, xyz, columns, layout)
    else:
        _write_xyz(name, xyz, columns)


def _exact_float32(xyz: np.ndarray) -> bool:
    with np.errstate(invalid="ignore", over="ignore"):
        back = xyz.astype(np.float32).astype(np.float64)
    return bool(np.array_equal(back, xyz, equal_nan=True))


def _split_columns(columns: Mapping[str, np.ndarray]) -> list[tuple[str, np.ndarray]]:
    """(name, 1-D array) pairs, (N, count) fields split into name_0, name_1, ..."""
    out = []
    for key, array in columns.items():
        key = re.sub(r"\s+", "_", key.strip())
        if array.ndim == 1:
            out.append((key, array))
        else:
            out.extend((f"{key}_{i}", array[:, i]) for i in range(array.shape[1]))
    return out


# ----------------------------------------------------------------------- PCD


def _write_pcd_points(
    path: str, xyz: np.ndarray, columns: dict[str, np.ndarray], layout: PcdLayout | None
) -> None:
    fields = {}
    for key, array in columns.items():
        key = re.sub(r"\s+", "_", key.strip())
        if array.dtype == np.bool_:
            array = array.astype(np.uint8)
        elif array.dtype.kind == "f" and array.dtype.itemsize < 4:
            array = array.astype(np.float32)
        fields[key] = array
    n = len(xyz)
    if layout is not None:
        organized = layout.width * layout.height == n
        write_pcd(
            path,
            xyz,
            fields,
            encoding=layout.encoding,
            width=layout.width if organized else n,
            height=layout.height if organized else 1,
            viewpoint=layout.viewpoint,
            xyz_dtype=layout.xyz_dtype,
        )
    else:
        write_pcd(
            path,
            xyz,
            fields,
            xyz_dtype=np.float32 if _exact_float32(xyz) else np.float64,
        )


# ----------------------------------------------------------------------- LAS


def _laspy():
    try:
        import laspy
    except ImportError as error:  # pragma: no cover - depends on the environment
        raise ImportError(
            "reading and writing LAS/LAZ needs laspy with lazrs: pip install 'pcl_rg[las]'"
        ) from error
    return laspy


# Points decoded in the first step of a LAZ read; each later step doubles, up to the
# last. A header's point count is so trusted only as far as the data bear it out
# (LAZ sizes bound it only loosely), while large files still go in few big steps.
_LAZ_FIRST_STEP = 1 << 16
_LAZ_LARGEST_STEP = 1 << 22


def _read_las(path: str, fmt: str) -> PointFile:
    try:
        return _decode_las(path, fmt)
    except OSError as error:
        if error.errno is not None:  # a real I/O error, not a decoder's complaint
            raise
        raise _bad_las(path, error) from None
    except ValueError as error:
        if str(error).startswith(("invalid LAS/LAZ file", "invalid LAS file")):
            raise
        raise _bad_las(path, error) from None
    except Exception as error:  # laspy, lazrs and NumPy raise many kinds on corrupt data
        raise _bad_las(path, error) from None


def _decode_las(path: str, fmt: str) -> PointFile:
    laspy = _laspy()
    with open(path, "rb") as stream:
        facts = check_las_header(path, stream)
        stream.seek(0)
        backend = (
            laspy.LazBackend.LazrsParallel if facts.parallel_decompression else laspy.LazBackend.Lazrs
        )
        with laspy.open(stream, closefd=False, laz_backend=backend) as reader:
            header = reader.header
            chunks = []
            # Uncompressed: the size check made the count trustworthy, one step.
            step = _LAZ_FIRST_STEP if facts.compressed else max(facts.point_count, 1)
            while reader.points_read < facts.point_count:
                chunk = reader.read_points(min(step, facts.point_count - reader.points_read))
                if len(chunk) == 0:
                    break
                chunks.append(chunk.array)
                step = min(2 * step, _LAZ_LARGEST_STEP)
    read = sum(len(c) for c in chunks)
    if read != facts.point_count:
        raise ValueError(
            f"invalid LAS file {path!r}: header says {facts.point_count} points, "
            f"the file holds {read} (truncated?)"
        )
    dtype = header.point_format.dtype()
    array = np.concatenate(chunks) if chunks else np.zeros(0, dtype=dtype)
    record = laspy.ScaleAwarePointRecord(
        array, header.point_format, scales=header.scales, offsets=header.offsets
    )
    points = np.column_stack([np.asarray(record.x), np.asarray(record.y), np.asarray(record.z)])
    fields = {}
    for dim in header.point_format.dimensions:
        if dim.name in ("X", "Y", "Z"):
            continue
        fields[dim.name] = np.array(record[dim.name])
    return PointFile(points.astype(np.float64), fields, fmt, header, path)


def _bad_las(path: str, error: BaseException) -> ValueError:
    detail = str(error) or type(error).__name__
    return ValueError(f"invalid LAS/LAZ file {path!r}: {detail}")


def _new_las_header(laspy, xyz: np.ndarray, names: set[str]):
    point_format = 6
    if {"red", "green", "blue"} <= names:
        point_format = 8 if "nir" in names else 7
    header = laspy.LasHeader(version="1.4", point_format=point_format)
    if len(xyz):
        lower = np.floor(xyz.min(axis=0))
        extent = xyz.max(axis=0) - lower
    else:
        lower = np.zeros(3)
        extent = np.zeros(3)
    scale = np.full(3, 0.001)
    # Stored integers are int32: coarsen the scale by 10 until the extent fits.
    while np.any(extent / scale > 2**31 - 2):
        scale = np.where(extent / scale > 2**31 - 2, scale * 10, scale)
    header.offsets = lower
    header.scales = scale
    return header


def _write_las(
    path: str, xyz: np.ndarray, columns: dict[str, np.ndarray], template, compress: bool
) -> None:
    import copy

    laspy = _laspy()
    finite = np.isfinite(xyz).all(axis=1)
    if not finite.all():
        raise ValueError(
            f"points has {int((~finite).sum())} row(s) with NaN or Inf coordinates, which "
            "LAS cannot store; drop them or write PCD, PLY or XYZ"
        )
    if template is not None:
        header = copy.deepcopy(template)
    else:
        header = _new_las_header(laspy, xyz, set(columns))
    standard = {d.name: d for d in header.point_format.dimensions}
    new_dims = []
    for key, array in columns.items():
        if key in standard:
            continue
        array = np.asarray(array)
        base = np.dtype(np.uint8) if array.dtype == np.bool_ else array.dtype
        if base.kind == "f" and base.itemsize < 4:
            base = np.dtype(np.float32)
        if array.ndim == 2 and array.shape[1] not in (1, 2, 3):
            raise ValueError(
                f"fields[{key!r}] has {array.shape[1]} values per point; LAS extra bytes "
                "hold 1, 2 or 3"
            )
        kind = base.newbyteorder("<").str.lstrip("<|=")
        type_str = kind if array.ndim == 1 or array.shape[1] == 1 else f"{array.shape[1]}{kind}"
        new_dims.append(laspy.ExtraBytesParams(name=key, type=type_str))
    if new_dims:
        try:
            header.add_extra_dims(new_dims)
        except Exception as error:
            raise ValueError(
                f"cannot add extra-bytes dimensions to the LAS header: {error}"
            ) from None
        standard = {d.name: d for d in header.point_format.dimensions}

    n = len(xyz)
    record = laspy.ScaleAwarePointRecord.zeros(n, header=header)
    scales = np.asarray(header.scales, dtype=np.float64)
    offsets = np.asarray(header.offsets, dtype=np.float64)
    for i, axis in enumerate("XYZ"):
        stored = np.round((xyz[:, i] - offsets[i]) / scales[i])
        if n and (stored.min() < -(2**31) or stored.max() > 2**31 - 1):
            raise ValueError(
                f"{'xyz'[i]} coordinates from {xyz[:, i].min()} to {xyz[:, i].max()} do not fit "
                f"LAS int32 storage with scale {scales[i]} and offset {offsets[i]}"
            )
        record[axis] = stored.astype(np.int32)
    for key, array in columns.items():
        dim = standard[key]
        values = np.asarray(array)
        if values.dtype == np.bool_:
            values = values.astype(np.uint8)
        if values.ndim == 2 and values.shape[1] == 1:
            values = values[:, 0]
        if n and dim.kind != laspy.DimensionKind.FloatingPoint and not dim.is_scaled:
            if values.dtype.kind == "f":
                if not np.array_equal(values, np.round(values)):
                    raise ValueError(
                        f"fields[{key!r}] holds fractional values but LAS stores {key} as integers"
                    )
            low, high = values.min(), values.max()
            if low < dim.min or high > dim.max:
                raise ValueError(
                    f"fields[{key!r}] has values from {low} to {high}, outside the range "
                    f"[{dim.min}, {dim.max}] of LAS point format {header.point_format.id}"
                )
            values = values.astype(np.int64)
        try:
            record[key] = values
        except (OverflowError, ValueError) as error:
            raise ValueError(f"fields[{key!r}] cannot be stored in LAS: {error}") from None
    las = laspy.LasData(header=header, points=record)

    def write(stream: BinaryIO) -> None:
        recorder = _RecordingStream(stream)
        try:
            las.write(recorder, do_compress=compress)
        except Exception as error:
            # lazrs turns an exception of the stream (e.g. ENOSPC) into its own
            # LazrsError; surface the original.
            if recorder.error is not None:
                raise recorder.error from None
            raise
        if recorder.error is not None:
            raise recorder.error

    _atomic_write(path, write)


class _RecordingStream:
    """A binary stream that remembers the first exception its write() raised."""

    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream
        self.error: BaseException | None = None

    def write(self, data) -> int:
        try:
            return self._stream.write(data)
        except BaseException as error:
            if self.error is None:
                self.error = error
            raise

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


# ----------------------------------------------------------------------- PLY

_PLY_TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}
_PLY_NAMES = {
    "i1": "char",
    "u1": "uchar",
    "i2": "short",
    "u2": "ushort",
    "i4": "int",
    "u4": "uint",
    "f4": "float",
    "f8": "double",
}
_PLY_ENCODINGS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}


class _PlyElement(NamedTuple):
    name: str
    count: int
    properties: list[tuple[str, str]]  # (name, dtype code) for scalars
    has_list: bool
    list_types: list[tuple[str, str, str]]  # (name, count type, item type)


def _bad_ply(path: str, problem: str) -> ValueError:
    return ValueError(f"invalid PLY file {path!r}: {problem}")


def _parse_ply_header(path: str, raw: bytes) -> tuple[str, list[_PlyElement], tuple[str, ...], int]:
    end = -1
    for marker in (b"end_header\r\n", b"end_header\n"):
        found = raw.find(marker)
        if found >= 0 and (end < 0 or found < end):
            end = found
            end_len = len(marker)
    if end < 0:
        raise _bad_ply(path, "no 'end_header' line (header truncated or not a PLY file)")
    try:
        lines = raw[:end].decode("ascii").splitlines()
    except UnicodeDecodeError:
        raise _bad_ply(path, "header is not ASCII text") from None
    if not lines or lines[0].strip() != "ply":
        raise _bad_ply(path, "first line is not 'ply'")
    encoding = None
    elements: list[_PlyElement] = []
    comments = []
    for number, line in enumerate(lines[1:], start=2):
        tokens = line.split()
        if not tokens:
            continue
        key = tokens[0]
        if key == "format":
            if len(tokens) != 3 or tokens[1] not in _PLY_ENCODINGS or tokens[2] != "1.0":
                raise _bad_ply(path, f"line {number}: unsupported format line {line.strip()!r}")
            encoding = tokens[1]
        elif key == "comment":
            comments.append(line.strip()[len("comment") :].strip())
        elif key == "obj_info":
            continue
        elif key == "element":
            if len(tokens) != 3:
                raise _bad_ply(path, f"line {number}: 'element' needs a name and a count")
            try:
                count = int(tokens[2])
            except ValueError:
                raise _bad_ply(
                    path, f"line {number}: element count {tokens[2]!r} is not an integer"
                ) from None
            if count < 0:
                raise _bad_ply(path, f"line {number}: element count {count} is negative")
            elements.append(_PlyElement(tokens[1], count, [], False, []))
        elif key == "property":
            if not elements:
                raise _bad_ply(path, f"line {number}: property before any element")
            element = elements[-1]
            if len(tokens) == 5 and tokens[1] == "list":
                if tokens[2] not in _PLY_TYPES or tokens[3] not in _PLY_TYPES:
                    raise _bad_ply(path, f"line {number}: unknown list types in {line.strip()!r}")
                element.list_types.append((tokens[4], _PLY_TYPES[tokens[2]], _PLY_TYPES[tokens[3]]))
                elements[-1] = element._replace(has_list=True)
            elif len(tokens) == 3:
                if tokens[1] not in _PLY_TYPES:
                    raise _bad_ply(path, f"line {number}: unknown property type {tokens[1]!r}")
                element.properties.append((tokens[2], _PLY_TYPES[tokens[1]]))
            else:
                raise _bad_ply(path, f"line {number}: malformed property line {line.strip()!r}")
        else:
            raise _bad_ply(path, f"line {number}: unknown header keyword {key!r}")
    if encoding is None:
        raise _bad_ply(path, "header has no 'format' line")
    return encoding, elements, tuple(comments), end + end_len


def _check_ply_counts(path: str, encoding: str, elements: list[_PlyElement], size: int) -> None:
    """Every element count against the bytes after the header, before any parsing.

    A binary entry takes at least its scalar properties plus one count per list;
    an ascii entry at least one character per property (a loose bound, so that rows
    of the wrong width still get the more precise message of the parser).
    """
    need = 0
    for element in elements:
        if encoding == "ascii":
            per_entry = len(element.properties) + len(element.list_types)
        else:
            per_entry = sum(np.dtype(code).itemsize for _, code in element.properties) + sum(
                np.dtype(count_type).itemsize for _, count_type, _ in element.list_types
            )
        need += element.count * per_entry
        if need > size + 1:
            raise _bad_ply(
                path,
                f"element {element.name!r} count {element.count} needs at least {need} bytes "
                f"of {encoding} data with the elements before it, the file holds {size} "
                "(truncated?)",
            )


def _read_ply(path: str) -> PointFile:
    with open(path, "rb") as stream:
        raw = stream.read()
    encoding, elements, comments, offset = _parse_ply_header(path, raw[:_MAX_HEADER_BYTES])
    vertex_at = next((i for i, e in enumerate(elements) if e.name == "vertex"), None)
    if vertex_at is None:
        raise _bad_ply(path, "no 'vertex' element")
    vertex = elements[vertex_at]
    if vertex.has_list:
        raise _bad_ply(path, "the vertex element has list properties, which are not supported")
    names = [name for name, _ in vertex.properties]
    for axis in "xyz":
        if axis not in names:
            raise _bad_ply(
                path, f"the vertex element has no {axis!r} property (got {' '.join(names)})"
            )
    if len(set(names)) != len(names):
        raise _bad_ply(path, f"the vertex element repeats a property name ({' '.join(names)})")
    n = vertex.count
    last = vertex_at == len(elements) - 1
    data = memoryview(raw)[offset:]
    _check_ply_counts(path, encoding, elements, len(data))
    if encoding == "ascii":
        try:
            text = bytes(data).decode("ascii")
        except UnicodeDecodeError as exc:
            raise _bad_ply(
                path, f"ascii data has a non-ASCII byte at offset {offset + exc.start}"
            ) from None
        lines = text.splitlines()
        skip = sum(e.count for e in elements[:vertex_at])
        rows = lines[skip : skip + n]
        if len(rows) < n:
            raise _bad_ply(
                path, f"header says {n} vertices but the data hold {max(len(rows), 0)} (truncated?)"
            )
        if last and any(line.strip() for line in lines[skip + n :]):
            raise _bad_ply(path, f"more data rows than the {n} vertices the header says")
        record = np.dtype([(name, code) for name, code in vertex.properties])
        if n == 0:
            table = np.zeros(0, dtype=record)
        else:
            try:
                table = np.loadtxt(rows, dtype=record, ndmin=1, comments=None)
            except ValueError as exc:
                message = str(exc).split("; use `usecols`")[0]
                raise _bad_ply(
                    path, f"ascii vertex data, {len(names)} values per row expected: {message}"
                ) from None
    else:
        order = _PLY_ENCODINGS[encoding]
        skip = 0
        for element in elements[:vertex_at]:
            if element.has_list:
                raise _bad_ply(
                    path,
                    f"element {element.name!r} with list properties comes before 'vertex' "
                    "in a binary file, which is not supported",
                )
            skip += element.count * sum(np.dtype(c).itemsize for _, c in element.properties)
        record = np.dtype([(name, order + code) for name, code in vertex.properties])
        need = skip + n * record.itemsize
        if len(data) < need:
            raise _bad_ply(
                path,
                f"binary data is {len(data)} bytes but {n} vertices x {record.itemsize} "
                f"bytes need {need} (truncated?)",
            )
        if last and len(data) > need and bytes(data[need:]).strip(b"\r\n\x00 "):
            raise _bad_ply(path, f"{len(data) - need} bytes after the {n} vertices the header says")
        table = np.frombuffer(data, dtype=record, count=n, offset=skip)
    points = np.empty((n, 3), dtype=np.float64)
    for i, axis in enumerate("xyz"):
        points[:, i] = table[axis]
    fields = {
        name: np.array(table[name], dtype=np.dtype(code))
        for name, code in vertex.properties
        if name not in ("x", "y", "z")
    }
    xyz_codes = {code for name, code in vertex.properties if name in ("x", "y", "z")}
    xyz_dtype = np.dtype("f8") if xyz_codes - {"f4"} else np.dtype("f4")
    return PointFile(points, fields, "ply", PlyLayout(encoding, xyz_dtype, comments), path)


def _ply_column(array: np.ndarray) -> np.ndarray:
    if array.dtype == np.bool_:
        return array.astype(np.uint8)
    if array.dtype.kind in "iu" and array.dtype.itemsize == 8:
        info = np.iinfo(np.int32)
        if len(array) == 0 or (array.min() >= info.min and array.max() <= info.max):
            return array.astype(np.int32)
        return array.astype(np.float64)
    if array.dtype.kind == "f" and array.dtype.itemsize < 4:
        return array.astype(np.float32)
    return array


def _write_ply(
    path: str, xyz: np.ndarray, columns: dict[str, np.ndarray], layout: PlyLayout | None
) -> None:
    n = len(xyz)
    if layout is not None:
        encoding, xyz_dtype, comments = layout.encoding, layout.xyz_dtype, layout.comments
    else:
        encoding = "binary_little_endian"
        xyz_dtype = np.dtype("f4") if _exact_float32(xyz) else np.dtype("f8")
        comments = ("written by pcl_rg",)
    with np.errstate(invalid="ignore", over="ignore"):
        data = [
            ("x", xyz[:, 0].astype(xyz_dtype)),
            ("y", xyz[:, 1].astype(xyz_dtype)),
            ("z", xyz[:, 2].astype(xyz_dtype)),
        ]
    data += [(key, _ply_column(array)) for key, array in _split_columns(columns)]
    names = [key for key, _ in data]
    if len(set(names)) != len(names):
        raise ValueError(f"PLY property names must be unique, got {names}")
    lines = ["ply", f"format {encoding} 1.0"]
    lines += [f"comment {c}" for c in comments]
    lines.append(f"element vertex {n}")
    for key, array in data:
        lines.append(f"property {_PLY_NAMES[array.dtype.str[1:]]} {key}")
    lines.append("end_header")
    head = ("\n".join(lines) + "\n").encode("ascii")
    if encoding == "ascii":

        def write(stream: BinaryIO) -> None:
            stream.write(head)
            _write_ascii(stream, [array for _, array in data], n)
    else:
        order = _PLY_ENCODINGS[encoding]
        record = np.dtype([(key, order + array.dtype.str[1:]) for key, array in data])
        table = np.empty(n, dtype=record)
        for key, array in data:
            table[key] = array

        def write(stream: BinaryIO) -> None:
            stream.write(head)
            _write_chunked(stream, memoryview(table.view(np.uint8)))

    _atomic_write(path, write)


# ----------------------------------------------------------------------- XYZ

_PTS_NAMES = {
    4: ["intensity"],
    6: ["red", "green", "blue"],
    7: ["intensity", "red", "green", "blue"],
}


# Longest accepted line: far above any real row, low enough that one line cannot
# turn into a parser's long loop over a single record.
_MAX_XYZ_LINE = 1 << 16


def _bad_xyz(path: str, problem: str) -> ValueError:
    return ValueError(f"invalid XYZ text file {path!r}: {problem}")


def _read_xyz(path: str) -> PointFile:
    with open(path, "rb") as stream:
        raw = stream.read()
    try:
        text = raw.decode("ascii")
    except UnicodeDecodeError as exc:
        raise _bad_xyz(path, f"non-ASCII byte at offset {exc.start} (binary data?)") from None
    lines = text.splitlines()
    if max(map(len, lines), default=0) > _MAX_XYZ_LINE:
        number = next(i for i, line in enumerate(lines, start=1) if len(line) > _MAX_XYZ_LINE)
        raise _bad_xyz(
            path,
            f"line {number} is longer than {_MAX_XYZ_LINE} characters (not point rows; a "
            "row of x y z and a few attributes is well under 1000)",
        )
    # The last comment line before the first data line may name the columns.
    header_names = None
    first = len(lines)
    for number, line in enumerate(lines):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith(("#", "//")):
            header_names = re.split(r"[\s,;]+", stripped.lstrip("#/").strip())
            continue
        first = number
        break
    body = lines[first:]
    count_line = None
    if body:
        tokens = body[0].split()
        if len(tokens) == 1 and re.fullmatch(r"\d+", tokens[0]):
            count_line = int(tokens[0])
            body = body[1:]
    rows = [line for line in body if line.strip() and not line.lstrip().startswith(("#", "//"))]
    if not rows:
        if count_line:
            raise _bad_xyz(path, f"first line announces {count_line} points but none follow")
        named = header_names is not None and [h.lower() for h in header_names[:3]] == [
            "x",
            "y",
            "z",
        ]
        if not named:
            raise _bad_xyz(path, "no data rows (need x y z per line)")
        # No rows under a "# x y z ..." header: an empty cloud, as write_points writes it.
        empty = {key: np.zeros(0) for key in header_names[3:]}
        return PointFile(np.zeros((0, 3)), empty, "xyz", None, path)
    try:
        table = np.loadtxt(rows, dtype=np.float64, ndmin=2, comments=None)
    except ValueError as exc:
        message = str(exc).split("; use `usecols`")[0]
        raise _bad_xyz(
            path,
            f"cannot read the rows as numbers (x y z [more] per line, whitespace-separated, "
            f"the same count on every line): {message}",
        ) from None
    if table.shape[1] < 3:
        raise _bad_xyz(path, f"rows hold {table.shape[1]} numbers, x y z need 3")
    if count_line is not None and count_line != len(table):
        raise _bad_xyz(path, f"first line announces {count_line} points but {len(table)} follow")
    width = table.shape[1]
    ext = os.path.splitext(path)[1].lower()
    if (
        header_names is not None
        and len(header_names) == width
        and [h.lower() for h in header_names[:3]] == ["x", "y", "z"]
        and len(set(header_names)) == width
    ):
        names = header_names[3:]
    elif ext == ".pts" and width in _PTS_NAMES:
        names = _PTS_NAMES[width]
    else:
        names = [f"column_{i + 1}" for i in range(3, width)]
    fields = {}
    for i, key in enumerate(names, start=3):
        column = table[:, i]
        whole = np.isfinite(column).all() and np.array_equal(column, np.round(column))
        if whole and np.abs(column).max() <= 2.0**53:
            fields[key] = column.astype(np.int64)
        else:
            fields[key] = column.copy()
    return PointFile(np.ascontiguousarray(table[:, :3]), fields, "xyz", None, path)


def _write_xyz(path: str, xyz: np.ndarray, columns: dict[str, np.ndarray]) -> None:
    data = [("x", xyz[:, 0]), ("y", xyz[:, 1]), ("z", xyz[:, 2])]
    for key, array in _split_columns(columns):
        data.append((key, array.astype(np.uint8) if array.dtype == np.bool_ else array))
    head = ("# " + " ".join(key for key, _ in data) + "\n").encode("ascii", errors="replace")

    def write(stream: BinaryIO) -> None:
        stream.write(head)
        _write_ascii(stream, [array for _, array in data], len(xyz))

    _atomic_write(path, write)
