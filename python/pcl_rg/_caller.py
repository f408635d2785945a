"""Where a warning should point: the caller's line, outside this package."""

from __future__ import annotations

import os
import sys

__all__ = ["outside_stacklevel"]

_PACKAGE = os.path.dirname(os.path.abspath(__file__)) + os.sep


def outside_stacklevel() -> int:
    """warnings.warn's stacklevel, from the caller of this, of the first frame outside
    pcl_rg: a warning then names the user's line, however deep the call (a reader under
    the batch engine, a step under a pipeline)."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_code.co_filename.startswith(_PACKAGE):
        frame, level = frame.f_back, level + 1
    return level
