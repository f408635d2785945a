"""XYZ text: one point per line, ``x y z`` and optional further columns."""

from __future__ import annotations

import decimal
import os
import re
from typing import BinaryIO

import numpy as np

from ._atomic import atomic_write, write_ascii
from ._columns import DECIMAL_INTEGER, loadtxt_reason, split_columns

__all__ = ["read", "write"]

_PTS_NAMES = {
    4: ["intensity"],
    6: ["red", "green", "blue"],
    7: ["intensity", "red", "green", "blue"],
}


# Longest accepted line: far above any real row, low enough that one line cannot
# turn into a parser's long loop over a single record.
_MAX_XYZ_LINE = 1 << 16
_LINE_BREAK = re.compile(r"\r\n|\r|\n")
# A column name the "# x y z ..." header line can hold and the reader splits back out.
_COLUMN_NAME = re.compile(r"[!-+\--:<-~]+")  # printable ASCII but , (0x2c) and ; (0x3b)


def _bad_xyz(path: str, problem: str) -> ValueError:
    return ValueError(f"invalid XYZ text file {path!r}: {problem}")


def read(path: str) -> tuple[np.ndarray, dict[str, np.ndarray], None]:
    """Points and fields of an XYZ text file (the rules of :func:`pcl_rg.io.read_points`)."""
    with open(path, "rb") as stream:
        raw = stream.read()
    try:
        # UTF-8 (ASCII among it), with a byte order mark or not: comments may name
        # places or columns in any language.
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise _bad_xyz(path, f"not UTF-8 text at byte {exc.start} (binary data?)") from None
    # Not str.splitlines, which also breaks at U+0085, U+2028 and U+2029: a comment
    # holding one would end there and the rest of it be read as a row.
    lines = _LINE_BREAK.split(text)
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
            if not all(_COLUMN_NAME.fullmatch(name) for name in header_names):
                header_names = None  # prose, or names no writer could write back
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
    # Each row's line in the file (from 1), for messages.
    numbered = [
        (number, line)
        for number, line in enumerate(lines, start=1)
        if number > len(lines) - len(body)
        and line.strip()
        and not line.lstrip().startswith(("#", "//"))
    ]
    rows = [line for _, line in numbered]
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
        return np.zeros((0, 3)), empty, None
    try:
        table = np.loadtxt(rows, dtype=np.float64, ndmin=2, comments=None)
    except ValueError as exc:
        raise _bad_xyz(
            path,
            f"cannot read the rows as numbers (x y z [more] per line, whitespace-separated, "
            f"the same count on every line): "
            f"{loadtxt_reason(exc, lambda row: f'line {numbered[row - 1][0]}')}",
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
    # Integers are what the text says: a column of whole numbers with at least one
    # written as one (7, not 7.0 or 7e0). write_points writes every float with a point
    # or an exponent, so its float64 columns come back float64, large whole values
    # (1.2345678901234568e+17) as the double they were, not as the integer their
    # shortest text spells.
    whole = [
        i
        for i in range(3, width)
        if np.isfinite(table[:, i]).all() and np.array_equal(table[:, i], np.round(table[:, i]))
    ]
    integer = _written_as_integers(rows, whole)
    # float64 rounds integers from 2^53: those columns are read from the text.
    exact = [i for i in integer if np.abs(table[:, i]).max() >= 2.0**53]
    texts = _column_texts(rows, exact)
    fields = {}
    for i, key in enumerate(names, start=3):
        column = table[:, i]
        if i not in integer:
            fields[key] = column.copy()
        elif i in texts:
            integers = _exact_integers(texts[i])
            fields[key] = column.copy() if integers is None else integers
        else:
            fields[key] = column.astype(np.int64)
    return np.ascontiguousarray(table[:, :3]), fields, None


def _written_as_integers(rows: list[str], columns: list[int]) -> set[int]:
    """The `columns` in which some row writes a decimal integer. Each row is split
    once, and the scan stops when every column has one (mostly at the first row):
    a scan a column, each splitting every row again, took minutes on rows of
    thousands of whole numbers written as floats."""
    left, found = set(columns), set()
    for row in rows:
        if not left:
            break
        tokens = row.split()
        hits = {i for i in left if DECIMAL_INTEGER.fullmatch(tokens[i])}
        found |= hits
        left -= hits
    return found


def _column_texts(rows: list[str], columns: list[int]) -> dict[int, list[str]]:
    """The text of each of `columns` in every row, each row split once."""
    texts: dict[int, list[str]] = {i: [] for i in columns}
    if columns:
        for row in rows:
            tokens = row.split()
            for i in columns:
                texts[i].append(tokens[i])
    return texts


def _exact_integers(tokens: list[str]) -> np.ndarray | None:
    """`tokens`, the text of whole numbers (``7``, ``7.0``, ``7e0``), as int64, or
    uint64 when beyond int64 and none negative, or None beyond both (or when a token
    is not whole in decimal, only in float64)."""
    values = []
    for token in tokens:
        try:
            values.append(int(token))
        except ValueError:  # 1e3, 5., 1.0e16: whole when their decimal value is
            exact = decimal.Decimal(token)
            if exact != exact.to_integral_value():
                return None
            values.append(int(exact))
    low, high = min(values), max(values)
    for kind in (np.int64, np.uint64):
        if np.iinfo(kind).min <= low and high <= np.iinfo(kind).max:
            return np.array(values, dtype=kind)
    return None  # beyond int64 and uint64: the float64 values, rounded


def write(path: str, xyz: np.ndarray, columns: dict[str, np.ndarray], layout: None = None) -> None:
    """write_points for XYZ text: a ``# x y z ...`` comment, then one row per point
    (``.pts`` in Leica's layout: the point count instead, see below)."""
    data = [("x", xyz[:, 0]), ("y", xyz[:, 1]), ("z", xyz[:, 2])]
    for key, array in split_columns(columns):
        if not _COLUMN_NAME.fullmatch(key):
            raise ValueError(
                f"field {key!r}: an XYZ column name must be printable ASCII without spaces, "
                "',' or ';' (the header line is split at them)"
            )
        data.append((key, array.astype(np.uint8) if array.dtype == np.bool_ else array))
    head = ("# " + " ".join(key for key, _ in data) + "\n").encode("ascii")
    extra = [key for key, _ in data[3:]]
    if (
        os.path.splitext(path)[1].lower() == ".pts"
        and len(xyz) > 0
        and (not extra or extra == _PTS_NAMES.get(len(data)))
    ):
        # Leica's .pts: the point count on the first line and no names (strict readers
        # take a comment for a bad count); the columns are named by their number on
        # reading. Other fields, or no rows, keep the "# x y z ..." line.
        head = f"{len(xyz)}\n".encode("ascii")

    def write_data(stream: BinaryIO) -> None:
        stream.write(head)
        write_ascii(stream, [array for _, array in data], len(xyz))

    atomic_write(path, write_data)
