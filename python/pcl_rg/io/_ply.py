"""PLY files: the ``vertex`` element's scalar properties, in ascii and both binary encodings."""

from __future__ import annotations

import itertools
import math
import re
from typing import TYPE_CHECKING, BinaryIO

import numpy as np

from ._atomic import atomic_write, write_ascii, write_chunked
from ._columns import (
    DECIMAL_INTEGER,
    PRINTABLE_TOKEN,
    exact_float32,
    load_ascii_table,
    split_columns,
)
from ._ply_header import (
    ENCODINGS,
    MAX_HEADER_BYTES,
    PLY_NAMES,
    PlyElement,
    bad_ply,
    check_counts,
    parse_header,
)

if TYPE_CHECKING:
    from . import PlyLayout

__all__ = ["read", "write"]

# Bytes that no ascii PLY row holds: control characters other than tab, CR and LF
# (str.splitlines would also break rows at some of them).
_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")
# A number as np.loadtxt reads a float (and float() without its "1_0").
_FLOAT = re.compile(r"[+-]?((\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|inf|infinity|nan)", re.IGNORECASE)


def read(path: str) -> tuple[np.ndarray, dict[str, np.ndarray], tuple]:
    """Points, fields and the layout (encoding, x/y/z dtype, comments) of a PLY file."""
    with open(path, "rb") as stream:
        raw = stream.read()
    encoding, elements, comments, offset = parse_header(path, raw[:MAX_HEADER_BYTES])
    vertex_at = next((i for i, e in enumerate(elements) if e.name == "vertex"), None)
    if vertex_at is None:
        raise bad_ply(path, "no 'vertex' element")
    vertex = elements[vertex_at]
    if vertex.has_list:
        raise bad_ply(path, "the vertex element has list properties, which are not supported")
    names = [name for name, _ in vertex.properties]
    if len(set(names)) != len(names):
        raise bad_ply(path, f"the vertex element repeats a property name ({' '.join(names)})")
    # x, y, z, else X, Y, Z (some scanners' software): the one name of any case.
    coordinates = []
    for axis in "xyz":
        spelled = [name for name in names if name.lower() == axis]
        if axis not in names and len(spelled) != 1:
            raise bad_ply(
                path, f"the vertex element has no {axis!r} property (got {' '.join(names)})"
            )
        coordinates.append(axis if axis in names else spelled[0])
    data = memoryview(raw)[offset:]
    check_counts(path, encoding, elements, len(data))
    if encoding == "ascii":
        table = _read_ascii(path, offset, data, elements, vertex_at)
    else:
        table = _read_binary(path, encoding, data, elements, vertex_at)
    points = np.empty((vertex.count, 3), dtype=np.float64)
    for i, name in enumerate(coordinates):
        points[:, i] = table[name]
    fields = {
        name: np.array(table[name], dtype=np.dtype(code))
        for name, code in vertex.properties
        if name not in coordinates
    }
    xyz_codes = {code for name, code in vertex.properties if name in coordinates}
    xyz_dtype = np.dtype("f8") if xyz_codes - {"f4"} else np.dtype("f4")
    return points, fields, (encoding, xyz_dtype, comments)


def _element_counts(elements: list[PlyElement]) -> str:
    return ", ".join(f"{e.count} {e.name}" for e in elements)


def _read_ascii(
    path: str, offset: int, data: memoryview, elements: list[PlyElement], vertex_at: int
) -> np.ndarray:
    """The vertex table of ascii data: a row per entry of every element, in header order.

    A vertex count short of the vertex rows shows only against all the counts when
    another element follows: the data must hold their sum of rows (blank lines at the
    end aside), and the first and last row of every other element must read as its
    entry (a surplus vertex row in place of a missing row of the next keeps the sum).
    """
    try:
        text = bytes(data).decode("ascii")
    except UnicodeDecodeError as exc:
        raise bad_ply(
            path, f"ascii data has a non-ASCII byte at offset {offset + exc.start}"
        ) from None
    control = _CONTROL.search(text)
    if control:
        raise bad_ply(
            path,
            f"ascii data has the control character {control.group()!r} at offset "
            f"{offset + control.start()}",
        )
    lines = text.splitlines()
    vertex = elements[vertex_at]
    n = vertex.count
    skip = sum(e.count for e in elements[:vertex_at])
    total = sum(e.count for e in elements)
    starts = [0, *itertools.accumulate(e.count for e in elements)]
    # numpy skips blank lines that the header's counts do count: one would shift
    # every row after it (a short file read as a made-up point). An entry of an
    # element without properties is an empty line.
    for element, start in zip(elements, starts):
        stop = min(start + element.count, len(lines))
        blank = next((k for k in range(start, stop) if not lines[k].strip()), None)
        if element.layout and blank is not None:
            raise bad_ply(path, f"blank line {blank + 1} of the data, within the counted rows")
    if len(lines) < skip + n:
        raise bad_ply(
            path,
            f"header says {n} vertices but the data hold {max(len(lines) - skip, 0)} (truncated?)",
        )
    if len(lines) < total:
        raise bad_ply(
            path,
            f"the header's elements ({_element_counts(elements)}) count {total} data rows, "
            f"the data hold {len(lines)} (truncated?)",
        )
    surplus = sum(1 for line in lines[total:] if line.strip())
    if surplus:
        raise bad_ply(
            path,
            f"more data rows than the {total} the header's elements count "
            f"({_element_counts(elements)}): {surplus} more (an element count too small?)",
        )
    for index, (element, start) in enumerate(zip(elements, starts)):
        if index == vertex_at or not element.count:
            continue
        for k in sorted({start, start + element.count - 1}):
            if not _ascii_entry_fits(lines[k], element):
                raise bad_ply(
                    path,
                    f"data row {k + 1} is not one {element.name!r} entry as the header "
                    f"declares it ({len(element.layout)} properties): the element counts "
                    f"({_element_counts(elements)}) do not match the rows",
                )
    record = np.dtype([(name, code) for name, code in vertex.properties])
    if n == 0:
        return np.zeros(0, dtype=record)
    try:
        return load_ascii_table(lines[skip : skip + n], record)
    except ValueError as exc:
        raise bad_ply(path, f"ascii vertex data, {exc}") from None


def _ascii_entry_fits(line: str, element: PlyElement) -> bool:
    """Whether `line` reads as one entry of `element`: a number per scalar property, a
    count and that many numbers per list property, integers where the type is one."""
    tokens = line.split()
    at = 0
    for _, count_type, code in element.layout:
        items = 1
        if count_type:
            if at >= len(tokens) or not _ascii_number(tokens[at], count_type):
                return False
            count = float(tokens[at])  # a float count type is legal: "3.0" is 3
            if not (math.isfinite(count) and count == math.floor(count)):
                return False
            items = int(count)
            at += 1
        if items < 0 or at + items > len(tokens):
            return False
        if not all(_ascii_number(token, code) for token in tokens[at : at + items]):
            return False
        at += items
    return at == len(tokens)


def _ascii_number(token: str, code: str) -> bool:
    if code[0] in "iu":
        return DECIMAL_INTEGER.fullmatch(token) is not None
    return _FLOAT.fullmatch(token) is not None


def _read_binary(
    path: str, encoding: str, data: memoryview, elements: list[PlyElement], vertex_at: int
) -> np.ndarray:
    """The vertex table of binary data: the entries of every element, in header order.

    The elements after the vertices must end the data (NUL or white space padding
    aside), or a vertex count short of the vertex data goes unseen; that end is known
    where each of them has entries of one size (see _binary_element_size).
    """
    order = ENCODINGS[encoding]
    vertex = elements[vertex_at]
    n = vertex.count
    skip = 0
    for element in elements[:vertex_at]:
        if element.has_list:
            raise bad_ply(
                path,
                f"element {element.name!r} with list properties comes before 'vertex' "
                "in a binary file, which is not supported",
            )
        skip += element.count * sum(np.dtype(c).itemsize for _, c in element.properties)
    record = np.dtype([(name, order + code) for name, code in vertex.properties])
    need = skip + n * record.itemsize
    if len(data) < need:
        raise bad_ply(
            path,
            f"binary data is {len(data)} bytes but {n} vertices x {record.itemsize} "
            f"bytes need {need} (truncated?)",
        )
    end: int | None = need
    for element in elements[vertex_at + 1 :]:
        size = _binary_element_size(path, order, data, end, element)
        if size is None:
            # List lengths that vary between entries: where this element ends shows
            # only by walking every entry, which a reader of the vertices does not do;
            # the data after the vertices are then checked only against the lower
            # bound of check_counts.
            end = None
            break
        end += size
        if len(data) < end:
            raise bad_ply(
                path,
                f"binary data is {len(data)} bytes but the header's elements "
                f"({_element_counts(elements)}) need {end} (truncated?)",
            )
    if end is not None and len(data) > end and bytes(data[end:]).strip(b"\r\n\x00 "):
        raise bad_ply(
            path,
            f"{len(data) - end} bytes after the data of the header's elements "
            f"({_element_counts(elements)}): an element count too small?",
        )
    return np.frombuffer(data, dtype=record, count=n, offset=skip)


def _binary_element_size(
    path: str, order: str, data: memoryview, start: int, element: PlyElement
) -> int | None:
    """The bytes of `element`'s entries from byte `start` of `data`, or None when its
    list lengths vary between entries.

    With list properties the first entry's counts give its size; when every entry
    holds the same counts (triangles), which one comparison of the count bytes of all
    entries proves, all have that size.
    """
    if not element.count:
        return 0
    if not element.has_list:
        return element.count * sum(np.dtype(code).itemsize for _, code in element.properties)
    past_end = bad_ply(
        path,
        f"the first {element.name!r} entry runs past the {len(data)} bytes of data "
        "(truncated, or an element count wrong?)",
    )
    at = start
    count_bytes = []  # (offset in the entry, width) of each list count
    for _, count_type, code in element.layout:
        if not count_type:
            at += np.dtype(code).itemsize
            continue
        width = np.dtype(count_type).itemsize
        if at + width > len(data):
            raise past_end
        value = np.frombuffer(data, order + count_type, 1, at)[0]
        # A float count type is legal; its value must still be a whole number of items
        # (int() of inf raised OverflowError, of NaN a ValueError naming no file).
        if not (np.isfinite(value) and value == np.floor(value)):
            raise bad_ply(
                path,
                f"element {element.name!r}: list length {value} in its first entry is "
                "not a whole number",
            )
        items = int(value)
        if items < 0:
            raise bad_ply(
                path,
                f"element {element.name!r}: negative list length {items} in its first entry",
            )
        count_bytes.append((at - start, width))
        at += width + items * np.dtype(code).itemsize
    entry = at - start
    # The other entries take at least their scalars and list counts.
    least = entry + (element.count - 1) * sum(
        np.dtype(count_type or code).itemsize for _, count_type, code in element.layout
    )
    if start + least > len(data):
        raise bad_ply(
            path,
            f"the {element.count} {element.name!r} entries need at least {least} bytes from "
            f"byte {start} of the data, which hold {len(data)} (truncated, or an element "
            "count wrong?)",
        )
    if start + element.count * entry > len(data):
        return None  # the later entries may be shorter
    rows = np.frombuffer(data, np.uint8, element.count * entry, start).reshape(-1, entry)
    for where, width in count_bytes:
        counts = rows[:, where : where + width]
        if (counts != counts[0]).any():
            return None
    return element.count * entry


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
        stored = xyz.astype(xyz_dtype)
    # A template's float32 x, y, z: a coordinate beyond float32 would be written inf.
    beyond = np.isinf(stored) & np.isfinite(xyz)
    if beyond.any():
        row, axis = np.argwhere(beyond)[0]
        raise ValueError(
            f"points[{row}, {axis}] = {float(xyz[row, axis])!r} is beyond the float32 range "
            "of the template's PLY layout (xyz_dtype float32); use a layout with xyz_dtype "
            "float64 or no template"
        )
    data = [("x", stored[:, 0]), ("y", stored[:, 1]), ("z", stored[:, 2])]
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
        lines.append(f"property {PLY_NAMES[array.dtype.str[1:]]} {key}")
    lines.append("end_header")
    head = ("\n".join(lines) + "\n").encode("ascii")
    if encoding == "ascii":

        def write_data(stream: BinaryIO) -> None:
            stream.write(head)
            write_ascii(stream, [array for _, array in data], n)
    else:
        order = ENCODINGS[encoding]
        record = np.dtype([(key, order + array.dtype.str[1:]) for key, array in data])
        table = np.empty(n, dtype=record)
        for key, array in data:
            table[key] = array

        def write_data(stream: BinaryIO) -> None:
            stream.write(head)
            write_chunked(stream, memoryview(table.view(np.uint8)))

    atomic_write(path, write_data)
