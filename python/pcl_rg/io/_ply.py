"""PLY files: the ``vertex`` element's scalar properties, in ascii and both binary encodings."""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, BinaryIO, NamedTuple

import numpy as np

from ._atomic import atomic_write, write_ascii, write_chunked
from ._columns import (
    DECIMAL_INTEGER,
    PRINTABLE_TOKEN,
    exact_float32,
    load_ascii_table,
    split_columns,
)

if TYPE_CHECKING:
    from . import PlyLayout

__all__ = ["read", "write"]

# The header ends with the end_header line; real headers are a few hundred bytes.
_MAX_HEADER_BYTES = 1 << 20

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
_END_HEADER = re.compile(rb"^end_header\r?\n", re.MULTILINE)
# Bytes that no ascii PLY row holds: control characters other than tab, CR and LF
# (str.splitlines would also break rows at some of them).
_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")


class _PlyElement(NamedTuple):
    name: str
    count: int
    properties: list[tuple[str, str]]  # (name, dtype code) for scalars
    has_list: bool
    list_types: list[tuple[str, str, str]]  # (name, count type, item type)


def _bad_ply(path: str, problem: str) -> ValueError:
    return ValueError(f"invalid PLY file {path!r}: {problem}")


def _parse_ply_header(path: str, raw: bytes) -> tuple[str, list[_PlyElement], tuple[str, ...], int]:
    # The first line that is end_header and nothing else: a comment or a property name
    # may hold the word too.
    found = _END_HEADER.search(raw)
    if found is None:
        raise _bad_ply(path, "no 'end_header' line (header truncated or not a PLY file)")
    end, end_len = found.start(), len(found.group())
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
            if not DECIMAL_INTEGER.fullmatch(tokens[2]):  # int() would also take "1_0"
                raise _bad_ply(
                    path, f"line {number}: element count {tokens[2]!r} is not an integer"
                )
            count = int(tokens[2])
            if count < 0:
                raise _bad_ply(path, f"line {number}: element count {count} is negative")
            if any(element.name == tokens[1] for element in elements):
                raise _bad_ply(path, f"line {number}: a second element {tokens[1]!r}")
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


def read(path: str) -> tuple[np.ndarray, dict[str, np.ndarray], tuple]:
    """Points, fields and the layout (encoding, x/y/z dtype, comments) of a PLY file."""
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
        control = _CONTROL.search(text)
        if control:
            raise _bad_ply(
                path,
                f"ascii data has the control character {control.group()!r} at offset "
                f"{offset + control.start()}",
            )
        lines = text.splitlines()
        skip = sum(e.count for e in elements[:vertex_at])
        # numpy skips blank lines that the header's counts do count: one would shift
        # every row after it (a short file read as a made-up point).
        blank = next((k for k, line in enumerate(lines[: skip + n]) if not line.strip()), None)
        if blank is not None:
            raise _bad_ply(path, f"blank line {blank + 1} of the data, within the counted rows")
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
                table = load_ascii_table(rows, record)
            except ValueError as exc:
                raise _bad_ply(path, f"ascii vertex data, {exc}") from None
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
    return points, fields, (encoding, xyz_dtype, comments)


def _ply_column(name: str, array: np.ndarray) -> np.ndarray:
    if array.dtype == np.bool_:
        return array.astype(np.uint8)
    if array.dtype.kind in "iu" and array.dtype.itemsize == 8:
        # PLY has no 64-bit integers: the narrowest of int, uint and double that holds
        # every value exactly.
        low, high = (int(array.min()), int(array.max())) if len(array) else (0, 0)
        for kind in (np.int32, np.uint32):
            if np.iinfo(kind).min <= low and high <= np.iinfo(kind).max:
                return array.astype(kind)
        if -(2**53) <= low and high <= 2**53:
            return array.astype(np.float64)
        raise ValueError(
            f"field {name!r}: PLY has no 64-bit integers, and values beyond 2**53 (here "
            f"{low} to {high}) would be rounded as double; write LAS/LAZ (its extra bytes "
            "hold int64) instead"
        )
    if array.dtype.kind == "f" and array.dtype.itemsize < 4:
        return array.astype(np.float32)
    return array


def write(
    path: str, xyz: np.ndarray, columns: dict[str, np.ndarray], layout: PlyLayout | None
) -> None:
    """write_points for PLY: the `layout` of a template, if any."""
    n = len(xyz)
    if layout is not None:
        encoding, xyz_dtype, comments = layout.encoding, layout.xyz_dtype, layout.comments
    else:
        encoding = "binary_little_endian"
        xyz_dtype = np.dtype("f4") if exact_float32(xyz) else np.dtype("f8")
        comments = ("written by pcl_rg",)
    with np.errstate(invalid="ignore", over="ignore"):
        data = [
            ("x", xyz[:, 0].astype(xyz_dtype)),
            ("y", xyz[:, 1].astype(xyz_dtype)),
            ("z", xyz[:, 2].astype(xyz_dtype)),
        ]
    data += [(key, _ply_column(key, array)) for key, array in split_columns(columns)]
    names = [key for key, _ in data]
    for key in names[3:]:
        if not PRINTABLE_TOKEN.fullmatch(key):
            raise ValueError(
                f"field {key!r}: a PLY property name must be printable ASCII without spaces"
            )
    lines = ["ply", f"format {encoding} 1.0"]
    lines += [f"comment {c}" for c in comments]
    lines.append(f"element vertex {n}")
    for key, array in data:
        lines.append(f"property {_PLY_NAMES[array.dtype.str[1:]]} {key}")
    lines.append("end_header")
    head = ("\n".join(lines) + "\n").encode("ascii")
    if encoding == "ascii":

        def write_data(stream: BinaryIO) -> None:
            stream.write(head)
            write_ascii(stream, [array for _, array in data], n)
    else:
        order = _PLY_ENCODINGS[encoding]
        record = np.dtype([(key, order + array.dtype.str[1:]) for key, array in data])
        table = np.empty(n, dtype=record)
        for key, array in data:
            table[key] = array

        def write_data(stream: BinaryIO) -> None:
            stream.write(head)
            write_chunked(stream, memoryview(table.view(np.uint8)))

    atomic_write(path, write_data)
