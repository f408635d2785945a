"""The ``pcl-rg`` command line (also ``python -m pcl_rg``).

One subcommand per job; the algorithm flags are generated from the parameter
dataclasses (their fields, types, defaults and ``metadata["help"]``), so the
command line cannot drift from the Python API. Run ``pcl-rg --help`` or
``pcl-rg COMMAND --help``.

Commands that write a file take ``INPUT OUTPUT`` (LAS/LAZ, PLY, PCD or XYZ text,
by extension) and classify rather than delete: ``ground`` sets class 2 (ground)
or 1 (other), ``denoise`` class 7 (noise), ``segment`` and ``pipeline`` a
``segment_id`` dimension (int32, -1 for none); ``--drop`` writes only the kept
points. The output is written to a temporary file beside it and renamed into
place; an output that is the input (also through a link) is refused.

Exit status: 0 success, 1 the output could not be written (e.g. disk full),
2 bad usage, parameters or input files (one ``pcl-rg: error: ...`` line on
stderr), 130 interrupted (Ctrl-C), 143 terminated (SIGTERM).

Layout: ``_flags`` turns dataclasses into flags and back, ``_run`` shows progress
and prints the result, ``_common`` holds what the commands share, and
``commands/<name>.py`` each subcommand, imported only when it runs (``pcl-rg
--help`` and ``pcl-rg info FILE`` import no algorithm and no compiled code).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import signal
import sys
import threading
import warnings
from collections.abc import Iterable, Iterator, Sequence

from ._flags import (
    EXIT_FAILURE,
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    EXIT_USAGE,
    CliError,
    Parser,
    print_out,
)
from .commands import COMMANDS, configure

__all__ = ["build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    """The argparse parser of ``pcl-rg``, every subcommand with all its flags."""
    return _parser(COMMANDS)


def _parser(full: Iterable[str]) -> argparse.ArgumentParser:
    """The parser; only the subcommands in `full` get their arguments (and imports)."""
    from .. import __version__

    parser = Parser(
        prog="pcl-rg",
        description="LiDAR ground filtering and point-cloud segmentation (pcl_rg). "
        "Files: LAS/LAZ, PLY, PCD, XYZ text (.xyz/.txt/.pts), by extension.",
        epilog="Commands classify rather than delete (ASPRS classes 2 ground, 1 other, "
        "7 noise; segment_id -1 none); --drop writes only the kept points. "
        "Exit status: 0 ok, 1 output not written, 2 bad usage or input, 130 interrupted, "
        "143 terminated.",
    )
    parser.add_argument("--version", action="version", version=f"pcl-rg {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, text in COMMANDS.items():
        p = sub.add_parser(name, help=text, description=text)
        if name in full:
            configure(name, p)
    return parser


def _command(argv: Sequence[str]) -> str | None:
    """The subcommand named in `argv` (its first word that is not an option)."""
    for word in argv:
        if not word.startswith("-"):
            return word if word in COMMANDS else None
    return None


def _check_common(args: argparse.Namespace) -> None:
    """Checks of the shared options, before any work."""
    width = getattr(args, "profile_width", None)
    if width is not None and not width > 0:
        raise CliError(f"argument --profile-width: must be > 0, got {width:g}")
    line = getattr(args, "profile_line", None)
    if line is not None:
        x0, y0, x1, y1 = line
        if (x0, y0) == (x1, y1):
            raise CliError("argument --profile-line: its ends A and B must differ")
        # Finite ends can still be too far apart for a float (1e308,0,-1e308,0): the
        # figure, drawn after OUTPUT is written, would then fail on an infinite axis.
        if not math.isfinite(math.hypot(x1 - x0, y1 - y0)):
            raise CliError(
                f"argument --profile-line: its length overflows (ends {x0:g},{y0:g} and "
                f"{x1:g},{y1:g}); it must be finite"
            )


def _execute(argv: Sequence[str]) -> int:
    command = _command(argv)
    args = _parser([] if command is None else [command]).parse_args(argv)
    _check_common(args)
    from ._run import Run

    run = Run(args)
    args.run(args, run)
    run.finish()
    return run.exit_status


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``pcl-rg`` with `argv` (default ``sys.argv[1:]``); return the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    # Warnings (a damaged LAS point count, ...) as one line each, like the errors.
    with _sigterm_raises(), warnings.catch_warnings():
        warnings.showwarning = _warning_line
        return _main(argv)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C's KeyboardInterrupt so that the same cleanup runs."""


def _terminate(signum: int, frame: object) -> None:
    raise Terminated


@contextlib.contextmanager
def _sigterm_raises() -> Iterator[None]:
    """SIGTERM raises Terminated while pcl-rg runs; the previous handler is back after.

    Without it SIGTERM (``kill``, a batch system's time limit) ends the process at
    once and leaves the temporary output file, or batch's scratch folder: the cleanup
    that runs for Ctrl-C (``except BaseException``, ``finally``) never ran. Only the
    command line does this, never the library on import: a program using pcl_rg keeps
    its own SIGTERM. A handler runs in the main thread between bytecodes: the compiled
    core polls for signals and raises it from there, while a long call that does not
    poll (a NumPy operation, a write) is ended when it returns. A SIGTERM that was
    ignored (SIG_IGN) or handled by someone else is left as it is.
    """
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGTERM) != signal.SIG_DFL
    ):
        yield
        return
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _one_line(message: object) -> str:
    return " ".join(str(message).split())


def _warning_line(message: Warning | str, *args: object, **kwargs: object) -> None:
    print(f"pcl-rg: warning: {_one_line(message)}", file=sys.stderr)


def _main(argv: list[str]) -> int:
    json_mode = "--json" in argv
    if os.environ.get("PCL_RG_TRACEBACK"):  # developers: let exceptions through
        return _execute(argv)
    try:
        return _execute(argv)
    except SystemExit as exit_:  # --help and --version
        return exit_.code if isinstance(exit_.code, int) else EXIT_USAGE
    except CliError as error:
        return _fail(str(error), error.code, json_mode)
    except Terminated:
        return _fail("terminated (SIGTERM)", EXIT_TERMINATED, json_mode)
    except KeyboardInterrupt:
        return _fail("interrupted", EXIT_INTERRUPTED, json_mode)
    except (ValueError, TypeError) as error:
        # Bad input files and parameters; the message names the file or argument.
        return _fail(str(error), EXIT_USAGE, json_mode)
    except OSError as error:
        where = f" {error.filename!r}" if error.filename else ""
        return _fail(f"cannot access{where}: {error.strerror or error}", EXIT_USAGE, json_mode)
    except (ImportError, MemoryError, RuntimeError) as error:
        # Missing optional dependency, or a failure inside the compiled core.
        return _fail(f"{type(error).__name__}: {error}", EXIT_FAILURE, json_mode)
    except Exception as error:  # a bug: one line here, the traceback on request
        return _fail(
            f"internal error: {type(error).__name__}: {error} (run with PCL_RG_TRACEBACK=1 "
            "for the traceback, and please report it)",
            EXIT_FAILURE,
            json_mode,
        )


def _fail(message: str, code: int, json_mode: bool) -> int:
    line = _one_line(message)  # one line, whatever the message held
    print(f"pcl-rg: error: {line}", file=sys.stderr)
    if json_mode:
        print_out(json.dumps({"error": line, "exit_status": code}))
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
