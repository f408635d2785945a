"""Point-cloud file input and output.

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

from ._validation import check_int

__all__ = ["PointCloudData", "read_pcd", "write_pcd"]


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
        raise _bad(
            path, f"ascii data, {n_columns} columns per row expected: {message}"
        ) from None
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
