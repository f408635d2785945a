"""How every writer of :mod:`pcl_rg.io` puts bytes on disk.

:func:`atomic_write` writes through a temporary file in the destination folder,
renamed over the target only when complete; :func:`write_chunked` and
:func:`write_ascii` stream a binary payload or columns of numbers as text rows
into that temporary file in bounded pieces.
"""

from __future__ import annotations

import contextlib
import errno
import glob
import os
import re
import secrets
import stat
from collections.abc import Callable
from typing import BinaryIO

import numpy as np

__all__ = [
    "ASCII_CHUNK_ROWS",
    "BINARY_CHUNK_BYTES",
    "ascii_strings",
    "atomic_write",
    "partial_files",
    "special_file",
    "write_ascii",
    "write_chunked",
]

#: Rows formatted at a time by :func:`write_ascii`.
ASCII_CHUNK_ROWS = 65536
#: Bytes handed to one ``write`` call by :func:`write_chunked`.
BINARY_CHUNK_BYTES = 1 << 24


def ascii_strings(column: np.ndarray) -> list[str]:
    """The values of a 1-D column as text, each the shortest that reads back exactly."""
    # NumPy's text for a float32/float64 is the shortest that reads back to the
    # same value at that precision (Dragon4), so ascii round-trips exactly and
    # float32 0.1 is written "0.1", not "0.100000001"; NaN is "nan".
    if column.dtype.kind == "f":
        return column.astype(str).tolist()
    return list(map(str, column.tolist()))


def write_ascii(stream: BinaryIO, columns: list[np.ndarray], n: int) -> None:
    """Write `n` rows of space-separated values; (N, count) columns give count values."""
    for start in range(0, n, ASCII_CHUNK_ROWS):
        stop = min(start + ASCII_CHUNK_ROWS, n)
        texts = []
        for array in columns:
            block = array[start:stop]
            if block.ndim == 1:
                texts.append(ascii_strings(block))
            else:
                texts.extend(ascii_strings(block[:, c]) for c in range(block.shape[1]))
        rows = [" ".join(row) for row in zip(*texts)]
        stream.write(("\n".join(rows) + "\n").encode("ascii"))


def write_chunked(stream: BinaryIO, payload: bytes | memoryview) -> None:
    """Write `payload` in pieces of at most BINARY_CHUNK_BYTES."""
    view = memoryview(payload)
    for start in range(0, len(view), BINARY_CHUNK_BYTES):
        stream.write(view[start : start + BINARY_CHUNK_BYTES])


def _temporary_stem(base: str) -> str:
    """The part of file name `base` that its temporary files' names begin with."""
    # The temporary name adds about 22 bytes to the target's: of a long name (file
    # systems allow 255 bytes) only the characters in its first 64 bytes are kept (never
    # half a character), so that any name the file system takes can be written.
    stem = base
    while len(os.fsencode(stem)) > 64:
        stem = stem[:-1]
    return stem


#: What atomic_write appends to the stem: ``.{process id}.{8 hex digits}.tmp``.
_TEMPORARY_SUFFIX = re.compile(r"\.[0-9]+\.[0-9a-f]{8}\.tmp")


def partial_files(path: str) -> list[str]:
    """The temporary files that :func:`atomic_write` calls for `path` left behind (a
    process killed while writing): names of its pattern in the same folder. Of a
    target whose name is longer than 64 bytes, also those of targets that share its
    first 64 bytes."""
    folder, base = os.path.split(os.path.abspath(path))
    stem = _temporary_stem(base)
    pattern = os.path.join(glob.escape(folder), f".{glob.escape(stem)}.*.tmp")
    return [
        name
        for name in glob.glob(pattern)
        if _TEMPORARY_SUFFIX.fullmatch(os.path.basename(name)[len(stem) + 1 :])
    ]


def special_file(path: str | os.PathLike[str]) -> bool:
    """Whether `path` is (or links to) a FIFO, a device or a socket: a write's rename
    would replace it by a file, for /dev/null, run as root, the system's. Callers that
    can refuse before their work ask this first; atomic_write refuses it in any case.
    (A folder is no special file: the rename fails on it.)"""
    return os.path.exists(path) and not os.path.isfile(path) and not os.path.isdir(path)


def _naming(error: OSError, path: str) -> OSError:
    """`error` (same type and errno) naming `path`, not the hidden temporary file."""
    return type(error)(error.errno, error.strerror, path)


def atomic_write(path: str, write: Callable[[BinaryIO], None]) -> None:
    """Write through a temporary file in the same folder, renamed into place.

    A `path` that is a link to an existing file is written through, as ``cp`` does:
    its target is replaced and the link kept. A file replaced keeps its permission
    bits (the umask's are for new files: a private 0600 output stays private).
    """
    if os.path.islink(path) and os.path.exists(path):
        path = os.path.realpath(path)
    try:
        status = os.stat(path)
    except OSError:
        mode: int | None = None  # a new file
    else:
        if special_file(path):
            raise FileExistsError(
                errno.EEXIST, "exists and is not a regular file (a FIFO, device or socket)", path
            )
        mode = stat.S_IMODE(status.st_mode)
    folder, base = os.path.split(os.path.abspath(path))
    stem = _temporary_stem(base)
    temp = ""  # set once the file is ours and its stream is stored
    # The name being created, set before the call: a KeyboardInterrupt raised as the call
    # returns, before its result is stored, must still remove the file the call made.
    # Python's "x" mode creates with O_EXCL, so an existing file is never opened (an
    # interrupt right after a FileExistsError, before `creating` is cleared, would remove
    # that file: one of this process id and the same 32 random bits).
    creating = ""
    try:
        while not temp:
            creating = os.path.join(folder, f".{stem}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
            try:
                # open applies the umask, unlike tempfile's private 0600 files. One object
                # owns the descriptor from its creation: an interrupted open's stream is
                # closed when it is dropped, and nothing else ever closes its number.
                stream = open(creating, "xb")
            except FileExistsError:
                creating = ""  # not ours: draw another name
                continue
            except OSError as error:  # no such folder, no permission: the caller's path
                creating = ""
                raise _naming(error, path) from None
            temp = creating
        with stream:
            write(stream)
            stream.flush()
            if mode is not None:
                os.fchmod(stream.fileno(), mode)
            os.fsync(stream.fileno())
        try:
            os.replace(temp, path)
        except OSError as error:  # e.g. `path` is a folder
            raise _naming(error, path) from None
    except BaseException:
        if temp or creating:
            with contextlib.suppress(OSError):  # an open interrupted before it created
                os.unlink(temp or creating)
        raise
