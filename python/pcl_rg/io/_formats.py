"""Which format a point-cloud file is: by its extension, checked against its first
bytes."""

from __future__ import annotations

import codecs
import os

from ._pcd_header import KEYWORDS as _PCD_KEYWORDS

__all__ = ["EXTENSIONS", "FORMAT_NAMES", "check_magic", "format_of", "sniff"]

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
FORMAT_NAMES = {"las": "LAS", "laz": "LAZ", "ply": "PLY", "pcd": "PCD", "xyz": "XYZ text"}


def format_of(path: str, format: str | None) -> str:
    """The format of `path`: `format` when given (checked), else from its extension."""
    if format is not None:
        if format not in FORMAT_NAMES:
            raise ValueError(f"format must be one of {', '.join(FORMAT_NAMES)}, got {format!r}")
        return format
    ext = os.path.splitext(path)[1].lower()
    if ext not in EXTENSIONS:
        raise ValueError(
            f"{path!r}: unknown file extension {ext or '(none)'!r}; supported: "
            f"{', '.join(EXTENSIONS)}"
        )
    return EXTENSIONS[ext]


def sniff(head: bytes) -> str:
    """What the first bytes of a file look like: las, ply, pcd, text, comments (nothing
    but comment lines: PCD or text), empty or binary."""
    if not head:
        return "empty"
    if head.startswith(b"LASF"):
        return "las"
    if head.startswith((b"ply\n", b"ply\r")):  # LF, CR LF, or CR alone (the reader refuses)
        return "ply"
    try:
        # UTF-8, which ASCII is, with a byte order mark or not (text editors on Windows
        # write one); the head may end inside a character.
        text = codecs.getincrementaldecoder("utf-8")().decode(head).removeprefix("\ufeff")
    except UnicodeDecodeError:
        # PCD headers are ASCII, binary data follows them; a head cut mid-way can
        # hold binary bytes after the DATA line.
        before = head.split(b"\nDATA", 1)[0]
        text = codecs.getincrementaldecoder("utf-8")(errors="replace").decode(before)
        if "\ufffd" in text:
            # A PCD header whose DATA line is missing runs into its binary data: the
            # PCD reader names what is missing, better than "binary data" would.
            return "pcd" if _starts_as_pcd(text.split("\ufffd", 1)[0]) else "binary"
    lines = text.splitlines()
    if len(lines) > 1 and not text.endswith(("\n", "\r")):
        lines.pop()  # cut by the head's end: its first word may be a keyword's half
    only_comments = True
    for line in lines:
        line = line.strip()
        if not line:
            continue
        if line.startswith("# .PCD"):
            return "pcd"
        if line.startswith("#"):  # a comment of PCD or XYZ text: look further
            continue
        only_comments = False
        if line.split()[0] in _PCD_KEYWORDS:
            return "pcd"
        break
    # U+0085, U+2028 and U+2029 are text that str.isprintable calls line breaks.
    printable = all(c.isprintable() or c in "\r\n\t\f\v\x85\u2028\u2029" for c in text)
    if not printable:
        return "binary"
    # Comment lines to the end of the head: the header of a PCD file or XYZ text.
    return "comments" if only_comments and text.strip() else "text"


def _starts_as_pcd(text: str) -> bool:
    """Whether the first line of `text` that is neither blank nor a comment is a PCD
    header's (or a comment is its "# .PCD" line), as sniff judges whole text."""
    for line in text.splitlines():
        line = line.strip()
        if line.startswith("# .PCD"):
            return True
        if line and not line.startswith("#"):
            return line.split()[0] in _PCD_KEYWORDS
    return False


_KIND_NAMES = {
    "las": "a LAS/LAZ file",
    "ply": "a PLY file",
    "pcd": "a PCD file",
    "text": "a text file",
    "comments": "comment lines of a text file",
    "binary": "binary data of an unknown format",
}
_EXPECTED_KIND = {"las": "las", "laz": "las", "ply": "ply", "pcd": "pcd", "xyz": "text"}


def check_magic(path: str, format: str) -> None:
    """Raise ValueError when the first bytes of `path` are not those of `format`."""
    with open(path, "rb") as stream:
        head = stream.read(4096)
    kind = sniff(head)
    if kind == "comments" and format in ("pcd", "xyz"):
        return  # their readers tell which the lines after the comments are
    if kind == "empty":
        raise ValueError(f"{path!r}: file is empty (0 bytes), not a {FORMAT_NAMES[format]} file")
    if kind != _EXPECTED_KIND[format]:
        raise ValueError(
            f"{path!r}: not a {FORMAT_NAMES[format]} file: its first bytes "
            f"({head[:8]!r}) look like {_KIND_NAMES[kind]}; check the file extension"
        )
