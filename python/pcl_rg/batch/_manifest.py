"""The record in the output folder that lets a rerun skip the tiles already done.

A tile is done when its output exists as it was written and everything it was
computed from is unchanged: the operation, method, parameters, buffer, pcl_rg
version and build (the digest of the installed package's code), the input file and the
files that gave it a buffer (size and modification time of each). Anything else, and the
tile is redone.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
from typing import Any

from ..io._atomic import atomic_write

__all__ = ["MANIFEST", "Manifest", "code_digest", "file_signature"]

MANIFEST = ".pcl_rg-batch.json"

#: The installed package: the folder whose code computes the outputs.
PACKAGE_FOLDER = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: What counts as code: Python modules and compiled extensions.
CODE_SUFFIXES = (".py", ".so", ".pyd")


@functools.cache
def code_digest(folder: str = PACKAGE_FOLDER) -> str:
    """SHA-256 of the code files below `folder` (relative paths and contents).

    ``__version__`` stays the same between development builds (every commit of a
    release's cycle, a rebuilt extension), so a resumed run would keep tiles that a
    changed algorithm would compute differently. This digest changes with any byte of
    the code; about 4 MB are read once per process. ``__pycache__`` is left out: it
    follows the sources.
    """
    digest = hashlib.sha256()
    for root, folders, files in os.walk(folder):
        folders[:] = sorted(name for name in folders if name != "__pycache__")
        for name in sorted(files):
            if not name.endswith(CODE_SUFFIXES):
                continue
            path = os.path.join(root, name)
            with open(path, "rb") as stream:
                content = hashlib.sha256(stream.read()).digest()
            digest.update(os.path.relpath(path, folder).encode() + b"\0" + content)
    return digest.hexdigest()


def file_signature(path: str) -> list[Any]:
    """[path, size, mtime in ns]: what says a file has not changed."""
    stat = os.stat(path)
    return [os.path.abspath(path), stat.st_size, stat.st_mtime_ns]


class Manifest:
    """Entries by output file name; saved atomically after every finished tile."""

    def __init__(self, folder: str) -> None:
        self.path = os.path.join(folder, MANIFEST)
        if os.path.islink(self.path) or (
            os.path.lexists(self.path) and not os.path.isfile(self.path)
        ):  # a link's target would be replaced by the record: an input, say
            raise ValueError(
                f"{self.path!r} is not a file: the batch keeps its record of finished tiles "
                "there; remove or rename what is in its place"
            )
        try:
            with open(self.path, encoding="utf-8") as stream:
                entries = json.load(stream)
            self.entries: dict[str, Any] = entries if isinstance(entries, dict) else {}
        except (OSError, ValueError, RecursionError):  # RecursionError: nested too deep
            self.entries = {}  # none yet, or damaged: every tile is redone

    def done(self, output: str, inputs: dict[str, Any]) -> bool:
        """Whether `output` exists as recorded, computed from exactly `inputs`."""
        entry = self.entries.get(os.path.basename(output))
        if not isinstance(entry, dict) or entry.get("inputs") != inputs:
            return False  # none, another computation, or a damaged entry
        if not os.path.exists(output):
            return False
        return entry.get("output") == file_signature(output)

    def record(self, output: str, inputs: dict[str, Any]) -> None:
        entry = {"inputs": inputs, "output": file_signature(output)}
        self.entries[os.path.basename(output)] = entry
        self._save()

    def forget(self, output: str) -> None:
        """Drop `output`'s entry, on disk too (a stale entry must not outlive the run)."""
        if self.entries.pop(os.path.basename(output), None) is not None:
            self._save()

    def clear(self) -> None:
        """Forget every entry, on disk too (a run without resuming)."""
        self.entries.clear()
        if os.path.exists(self.path):
            self._save()

    def _save(self) -> None:
        text = json.dumps(self.entries, indent=1, sort_keys=True).encode()
        atomic_write(self.path, lambda stream: stream.write(text))
