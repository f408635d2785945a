"""The output folder's housekeeping around a batch run: the scratch folder for the
stage-1 arrays, locked while its run lives, and the removal of what runs that were
cut short left behind (scratch folders, temporary files of unfinished writes)."""

from __future__ import annotations

import contextlib
import fcntl
import glob
import os
import secrets
import shutil
import time
from collections.abc import Iterator, Sequence

from ..io._atomic import partial_files

#: The scratch folders' names begin with this; each holds its run's lock file.
SCRATCH_PREFIX = ".pcl_rg-scratch-"
SCRATCH_LOCK = "owner.lock"
#: A scratch folder younger than this is never taken for a killed run's: its run may be
#: between making it and locking it.
STALE_AFTER_SECONDS = 60.0


def remove_stale_scratch(folder: str) -> None:
    """Remove the scratch folders that runs killed outright (SIGKILL, the OOM killer, a
    power cut) left in `folder`: those whose lock nobody holds, or without a lock file.

    A live run holds an exclusive ``flock`` on its folder's lock file until its end, and
    the kernel drops it when the process dies however it dies. Where the file system
    cannot tell (no lock support), the folder is left alone.
    """
    for path in glob.glob(os.path.join(glob.escape(folder), SCRATCH_PREFIX + "*")):
        lock = os.path.join(path, SCRATCH_LOCK)
        try:
            if time.time() - os.stat(path).st_mtime < STALE_AFTER_SECONDS:
                continue
            descriptor = os.open(lock, os.O_RDWR)
        except FileNotFoundError:
            if os.path.isdir(path):  # no lock file: an older run's, or cut off at its end
                shutil.rmtree(path, ignore_errors=True)
            continue
        except OSError:
            continue
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            continue  # held (a live run), or the file system cannot say
        else:
            shutil.rmtree(path, ignore_errors=True)
        finally:
            os.close(descriptor)


def remove_scratch(path: str) -> None:
    """Remove scratch folder `path`, its lock file last, so that what a task still
    running on another machine writes meanwhile is removed too or, failing that, left
    in a folder without a lock, which the next run removes."""
    for _ in range(10):
        try:
            entries = os.listdir(path)
        except OSError:
            return  # gone
        for entry in entries:
            inside = os.path.join(path, entry)
            if entry == SCRATCH_LOCK:
                continue
            if os.path.isdir(inside) and not os.path.islink(inside):
                shutil.rmtree(inside, ignore_errors=True)
            else:
                with contextlib.suppress(OSError):
                    os.unlink(inside)
        with contextlib.suppress(OSError):
            os.unlink(os.path.join(path, SCRATCH_LOCK))
        with contextlib.suppress(OSError):
            os.rmdir(path)
        if not os.path.exists(path):
            return
        time.sleep(0.2)


@contextlib.contextmanager
def scratch_folder(folder: str) -> Iterator[str]:
    """A new folder in `folder` for the stage-1 arrays, locked by this run while it runs
    and removed with its contents after; killed runs' folders are removed first."""
    remove_stale_scratch(folder)
    # Named before it is made: a KeyboardInterrupt raised as mkdir returns, before
    # anything stores its result, must still find the folder to remove.
    creating = ""
    descriptor = -1
    try:
        while not creating:
            creating = os.path.join(folder, SCRATCH_PREFIX + secrets.token_hex(8))
            try:
                os.mkdir(creating, 0o700)
            except FileExistsError:
                creating = ""  # not ours: draw another name
        descriptor = os.open(os.path.join(creating, SCRATCH_LOCK), os.O_RDWR | os.O_CREAT, 0o600)
        with contextlib.suppress(OSError):  # no lock support: the folder is then never stale
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        yield creating
    finally:
        if creating:
            remove_scratch(creating)
        if descriptor >= 0:
            os.close(descriptor)


def remove_partial_outputs(outputs: Sequence[str]) -> None:
    """Temporary files of writes cut short (a killed worker, Ctrl-C, a run killed
    before): never left behind."""
    for output in outputs:
        for stray in partial_files(output):
            with contextlib.suppress(OSError):
                os.unlink(stray)
