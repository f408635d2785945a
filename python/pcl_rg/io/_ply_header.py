"""PLY headers: the element and property declarations, parsed once, and the element
counts checked against the data's size before any of it is parsed."""

from __future__ import annotations

import re
from typing import NamedTuple

import numpy as np

from ._columns import DECIMAL_INTEGER

__all__ = [
    "ENCODINGS",
    "MAX_HEADER_BYTES",
    "PLY_NAMES",
    "PLY_TYPES",
    "PlyElement",
    "bad_ply",
    "check_counts",
    "parse_header",
]

# The header ends with the end_header line; real headers are a few hundred bytes.
MAX_HEADER_BYTES = 1 << 20

PLY_TYPES = {
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
PLY_NAMES = {
    "i1": "char",
    "u1": "uchar",
    "i2": "short",
    "u2": "ushort",
    "i4": "int",
    "u4": "uint",
    "f4": "float",
    "f8": "double",
}
ENCODINGS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}
END_HEADER = re.compile(rb"^end_header\r?\n", re.MULTILINE)


class PlyElement(NamedTuple):
    name: str
    count: int
    properties: list[tuple[str, str]]  # (name, dtype code) for scalars
    has_list: bool
    list_types: list[tuple[str, str, str]]  # (name, count type, item type)
    # Every property in header order as (name, count type or "" for a scalar, type).
    layout: list[tuple[str, str, str]]


def bad_ply(path: str, problem: str) -> ValueError:
    return ValueError(f"invalid PLY file {path!r}: {problem}")


def parse_header(path: str, raw: bytes) -> tuple[str, list[PlyElement], tuple[str, ...], int]:
    # The first line that is end_header and nothing else: a comment or a property name
    # may hold the word too.
    found = END_HEADER.search(raw)
    if found is None:
        if raw.startswith(b"ply\r") and b"\n" not in raw.split(b"end_header", 1)[0]:
            raise bad_ply(path, "its header's lines end in CR alone; PLY's end in LF (or CR LF)")
        raise bad_ply(path, "no 'end_header' line (header truncated or not a PLY file)")
    end, end_len = found.start(), len(found.group())
    try:
        lines = raw[:end].decode("ascii").splitlines()
    except UnicodeDecodeError:
        raise bad_ply(path, "header is not ASCII text") from None
    if not lines or lines[0].strip() != "ply":
        raise bad_ply(path, "first line is not 'ply'")
    encoding = None
    elements: list[PlyElement] = []
    element_names: set[str] = set()  # a set: a 1 MiB header holds some 75,000 elements
    comments = []
    for number, line in enumerate(lines[1:], start=2):
        tokens = line.split()
        if not tokens:
            continue
        key = tokens[0]
        if key == "format":
            if len(tokens) != 3 or tokens[1] not in ENCODINGS or tokens[2] != "1.0":
                raise bad_ply(path, f"line {number}: unsupported format line {line.strip()!r}")
            encoding = tokens[1]
        elif key == "comment":
            comments.append(line.strip()[len("comment") :].strip())
        elif key == "obj_info":
            continue
        elif key == "element":
            if len(tokens) != 3:
                raise bad_ply(path, f"line {number}: 'element' needs a name and a count")
            if not DECIMAL_INTEGER.fullmatch(tokens[2]):  # int() would also take "1_0"
                raise bad_ply(path, f"line {number}: element count {tokens[2]!r} is not an integer")
            count = int(tokens[2])
            if count < 0:
                raise bad_ply(path, f"line {number}: element count {count} is negative")
            if tokens[1] in element_names:
                raise bad_ply(path, f"line {number}: a second element {tokens[1]!r}")
            element_names.add(tokens[1])
            elements.append(PlyElement(tokens[1], count, [], False, [], []))
        elif key == "property":
            if not elements:
                raise bad_ply(path, f"line {number}: property before any element")
            element = elements[-1]
            if len(tokens) == 5 and tokens[1] == "list":
                if tokens[2] not in PLY_TYPES or tokens[3] not in PLY_TYPES:
                    raise bad_ply(path, f"line {number}: unknown list types in {line.strip()!r}")
                element.list_types.append((tokens[4], PLY_TYPES[tokens[2]], PLY_TYPES[tokens[3]]))
                element.layout.append(element.list_types[-1])
                elements[-1] = element._replace(has_list=True)
            elif len(tokens) == 3:
                if tokens[1] not in PLY_TYPES:
                    raise bad_ply(path, f"line {number}: unknown property type {tokens[1]!r}")
                element.properties.append((tokens[2], PLY_TYPES[tokens[1]]))
                element.layout.append((tokens[2], "", PLY_TYPES[tokens[1]]))
            else:
                raise bad_ply(path, f"line {number}: malformed property line {line.strip()!r}")
        else:
            raise bad_ply(path, f"line {number}: unknown header keyword {key!r}")
    if encoding is None:
        raise bad_ply(path, "header has no 'format' line")
    return encoding, elements, tuple(comments), end + end_len


def check_counts(path: str, encoding: str, elements: list[PlyElement], size: int) -> None:
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
            raise bad_ply(
                path,
                f"element {element.name!r} count {element.count} needs at least {need} bytes "
                f"of {encoding} data with the elements before it, the file holds {size} "
                "(truncated?)",
            )
