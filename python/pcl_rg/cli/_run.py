"""A command's run: progress on stderr, timings, and the result (text lines or JSON)."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from ._flags import print_out

__all__ = ["PROGRESS_DELAY", "Run", "jsonable"]

#: A stage shows progress on stderr once it has run this many seconds.
PROGRESS_DELAY = 1.0


class Run:
    """Progress on stderr, timings, and the result printed at the end."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.quiet = bool(getattr(args, "quiet", False))
        self.json = bool(getattr(args, "json", False))
        self.timings: dict[str, float] = {}
        self.result: dict[str, Any] = {"command": args.command}
        self.lines: list[str] = []
        self.start = time.perf_counter()
        # A command that finished but must report a failure (batch: some tiles failed)
        # sets this; its result is still printed.
        self.exit_status = 0

    @contextmanager
    def stage(self, key: str, description: str, source: str | None = None) -> Iterator[None]:
        """Time a stage; show a spinner on stderr if it runs past PROGRESS_DELAY.

        `source`: the file the stage works on. A ValueError the stage raises then
        names it: the message is about that file's points (their extent, say) or
        about what an earlier step made of them (the points a pipeline kept), and
        either way the user learns which input it came from.
        """
        start = time.perf_counter()
        done = threading.Event()
        outcome = ["done in"]  # how the spinner's last line reports the end of the stage
        thread = None
        if not self.quiet:
            thread = threading.Thread(
                target=_spin, args=(description, done, time.time(), outcome), daemon=True
            )
            thread.start()
        try:
            yield
        except BaseException as error:
            interrupted = isinstance(error, KeyboardInterrupt)
            outcome[0] = "interrupted after" if interrupted else "failed after"
            if isinstance(error, ValueError) and source is not None:
                raise ValueError(f"{error} (input {source!r})") from error
            raise
        finally:
            # The spinner wakes within 0.25 s and ends: nothing outlives the stage, also
            # on Ctrl-C.
            done.set()
            if thread is not None:
                thread.join()
            self.timings[key] = self.timings.get(key, 0.0) + time.perf_counter() - start

    def say(self, line: str) -> None:
        self.lines.append(line)

    def finish(self) -> None:
        self.timings["total"] = time.perf_counter() - self.start
        if self.json:
            self.result["timings_s"] = {k: round(v, 6) for k, v in self.timings.items()}
            print_out(json.dumps(jsonable(self.result), indent=2, allow_nan=False))
        else:
            for line in self.lines:
                print_out(line)


def _spin(description: str, done: threading.Event, started: float, outcome: list[str]) -> None:
    """Show the stage once it has run PROGRESS_DELAY seconds, until it ends.

    On a terminal with tqdm installed (the ``progress`` extra), a live timer;
    otherwise (a log, or no tqdm) one line when the stage is seen, one when it ends.
    """
    if done.wait(PROGRESS_DELAY):
        return
    stream = sys.stderr
    tqdm = None
    if stream.isatty():
        try:
            from tqdm import tqdm
        except ImportError:
            pass
    if tqdm is None:
        stream.write(f"pcl-rg: {description} ...\n")
        stream.flush()
        done.wait()
        seconds = time.time() - started
        stream.write(f"pcl-rg: {description}: {outcome[0]} {seconds:.1f} s\n")
        stream.flush()
        return
    bar = tqdm(
        total=None,
        desc=f"pcl-rg: {description}",
        file=stream,
        bar_format="{desc}: {elapsed}",
        leave=True,
        dynamic_ncols=True,
    )
    bar.start_t = started
    try:
        while not done.wait(0.25):
            bar.refresh()
    finally:
        bar.close()


def jsonable(value: Any) -> Any:
    """`value` with NumPy arrays and scalars, paths and non-finite floats made JSON."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value
