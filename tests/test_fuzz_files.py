"""Damaged files fail fast and clean: a result or our ValueError, never anything else.

Mutated and truncated copies of small valid files of every format we read
(tests/fuzz_files.py, seeded) go through `pcl_rg.io.read_points` in this process,
and a sample through `pcl-rg ground` and `pcl-rg info` in subprocesses. The files
in ../shared/data/fuzz are regression cases: each once hung the reader or ended in
an internal error.

Each in-process case runs under a watchdog that aborts the whole run with every
thread's traceback if it hangs, and under tracemalloc (NumPy and laspy report their
buffers to it), so a header that makes a reader allocate by its claims rather than
by the file's size fails the test instead of passing slowly.
`make fuzz` runs the same with PCL_RG_FUZZ_CASES=5000 and PCL_RG_FUZZ_CLI_CASES=300.
"""

from __future__ import annotations

import faulthandler
import os
import subprocess
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from conftest import run_pcl_rg, shared_data
from fuzz_files import Mutant, mutants, templates

from pcl_rg.io import PointFile, read_points, write_points

# `make fuzz FUZZ_SEED=N` draws other damaged files; make test keeps this one.
SEED = int(os.environ.get("PCL_RG_FUZZ_SEED", "20261130"))
CASES = int(os.environ.get("PCL_RG_FUZZ_CASES", "360"))
CLI_CASES = int(os.environ.get("PCL_RG_FUZZ_CLI_CASES", "12"))
CASE_SECONDS = 2.0  # a small file must be decided well within this
WATCHDOG_SECONDS = 60.0  # beyond this a case is a hang: abort with tracebacks
PEAK_BYTES = 64 << 20  # a file of a few KB never needs more
REGRESSION_FILES = ("vlr-count-hang.laz", "vlr-count-slow.las", "bad-version.las")


@pytest.fixture(scope="module")
def template_files(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    return templates(tmp_path_factory.mktemp("fuzz-templates"))


def _check_result(cloud: PointFile) -> None:
    n = len(cloud.points)
    assert cloud.points.dtype == np.float64 and cloud.points.shape == (n, 3)
    for name, values in cloud.fields.items():
        assert len(values) == n, f"field {name} has {len(values)} rows for {n} points"


def _read_in_process(path: Path) -> str:
    """Read one file; 'ok' or the error message. Anything but ValueError fails."""
    faulthandler.dump_traceback_later(WATCHDOG_SECONDS, exit=True)
    tracemalloc.start()
    start = time.perf_counter()
    try:
        cloud = read_points(path)
        _check_result(cloud)
        outcome = "ok"
    except ValueError as error:
        assert str(path) in str(error), f"error does not name the file: {error}"
        outcome = str(error)
    finally:
        seconds = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        faulthandler.cancel_dump_traceback_later()
    assert seconds < CASE_SECONDS, f"{path.name} took {seconds:.1f} s"
    assert peak < PEAK_BYTES, f"{path.name} made the reader allocate {peak / 2**20:.0f} MiB"
    return outcome


def _write_mutant(folder: Path, mutant: Mutant) -> Path:
    path = folder / f"{mutant.name}{mutant.suffix}"
    path.write_bytes(mutant.data)
    return path


def test_templates_are_valid(template_files: list[Path]) -> None:
    for path in template_files:
        assert _read_in_process(path) == "ok", path.name


def test_mutated_files_in_process(template_files: list[Path], tmp_path: Path) -> None:
    outcomes = {"ok": 0, "error": 0}
    for mutant in mutants(template_files, CASES, SEED):
        path = _write_mutant(tmp_path, mutant)
        outcomes["ok" if _read_in_process(path) == "ok" else "error"] += 1
        path.unlink()
    # A fuzzer that only ever hits one outcome is not exercising the readers.
    assert outcomes["ok"] > 0 and outcomes["error"] > CASES // 4, outcomes


def _run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    # timeout: a hang, not a slow start (each case takes about a second)
    return run_pcl_rg(*args, timeout=30, cwd=cwd, env={**os.environ, "PCL_RG_TRACEBACK": ""})


def _assert_clean_cli(done: subprocess.CompletedProcess[str], path: Path) -> None:
    assert "Traceback" not in done.stderr and "internal error" not in done.stderr, done.stderr
    assert done.returncode in (0, 2), f"exit {done.returncode}: {done.stderr}"
    if done.returncode == 2:
        errors = [line for line in done.stderr.splitlines() if line.startswith("pcl-rg: error:")]
        assert len(errors) == 1, done.stderr
        assert path.name in errors[0], errors[0]


def _cli_case(path: Path, folder: Path) -> None:
    out = folder / f"out{path.suffix}"
    done = _run_cli("ground", str(path), str(out), cwd=folder)
    _assert_clean_cli(done, path)
    left = sorted(p.name for p in folder.iterdir() if p != path)
    if done.returncode == 0:
        assert left == [out.name], left
        out.unlink()
    else:
        assert left == [], f"files left behind: {left}"
    info = _run_cli("info", str(path), cwd=folder)
    _assert_clean_cli(info, path)


def test_mutated_files_through_the_cli(template_files: list[Path], tmp_path: Path) -> None:
    # A different seed from the in-process run, so the sample adds cases.
    for mutant in mutants(template_files, CLI_CASES, SEED + 1):
        folder = tmp_path / mutant.name
        folder.mkdir()
        _cli_case(_write_mutant(folder, mutant), folder)


@pytest.mark.parametrize("name", REGRESSION_FILES)
def test_regression_files(name: str, tmp_path: Path) -> None:
    source = shared_data("fuzz", name)
    start = time.perf_counter()
    message = _read_in_process(source)
    assert message != "ok" and time.perf_counter() - start < 1.0
    copy = tmp_path / name
    copy.write_bytes(source.read_bytes())
    for command in (["info", str(copy)], ["ground", str(copy), str(tmp_path / f"out-{name}")]):
        done = _run_cli(*command, cwd=tmp_path)
        _assert_clean_cli(done, copy)
        assert done.returncode == 2, done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_a_tiny_file_claiming_a_trillion_points_fails_at_once(tmp_path: Path) -> None:
    xyz = np.random.default_rng(5).uniform(0, 10, (10, 3))
    claims = {
        "pcd": (b"POINTS 10\n", b"POINTS 1000000000000\n", b"WIDTH 10\n", b"WIDTH 1000000000000\n"),
        "ply": (b"element vertex 10\n", b"element vertex 1000000000000\n"),
        "xyz": None,
    }
    for suffix, swaps in claims.items():
        path = tmp_path / f"claim.{suffix}"
        write_points(path, xyz)
        data = path.read_bytes()
        if swaps is None:
            data = b"1000000000000\n" + data.split(b"\n", 1)[1]  # a .pts-style count line
        else:
            for i in range(0, len(swaps), 2):
                data = data.replace(swaps[i], swaps[i + 1])
        path.write_bytes(data)
        assert path.stat().st_size < 1024
        assert _read_in_process(path) != "ok"
    for suffix in ("las", "laz"):
        path = tmp_path / f"claim.{suffix}"
        write_points(path, xyz)
        data = bytearray(path.read_bytes())
        data[247:255] = (10**12).to_bytes(8, "little")  # LAS 1.4's 64-bit point count
        path.write_bytes(bytes(data))
        start = time.perf_counter()
        message = _read_in_process(path)
        assert "1000000000000 points" in message, message
        assert time.perf_counter() - start < 0.5
