"""Ctrl-C stops long core calls: KeyboardInterrupt within about a second, no leftovers.

The core polls for signals at safe points on the calling thread (interrupt.hpp); the
bindings run Python's signal handlers there. SIGINT is sent from outside to a child
process (tests/interrupt_probe.py, and the command line), never to the pytest process
itself, whose own KeyboardInterrupt would end the session. In this process only
handlers that raise their own exception are installed, and always restored.

Latencies are generous for a shared 2-core CI machine: the polls come every few
milliseconds of work, the longest unpolled stretches (allocations, serial sweeps)
take a few hundred milliseconds on 10 M points.
"""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import CLI_WITH_SIGINT

import pcl_rg
from pcl_rg.io import write_points

PROBE = Path(__file__).with_name("interrupt_probe.py")
CLI = CLI_WITH_SIGINT
MAX_LATENCY = 2.0  # seconds from SIGINT to KeyboardInterrupt
SIGNAL_AFTER = 1.0  # seconds after the call started


class _Lines:
    """Lines of a child's stream with the monotonic time each arrived, read by a thread
    so that a hung child fails the test instead of hanging it."""

    def __init__(self, stream) -> None:
        self._queue: queue.Queue[tuple[float, str | None]] = queue.Queue()
        self._thread = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self._thread.start()

    def _read(self, stream) -> None:
        for line in stream:
            self._queue.put((time.monotonic(), line.rstrip("\n")))
        self._queue.put((time.monotonic(), None))

    def next(self, timeout: float) -> tuple[float, str | None]:
        try:
            return self._queue.get(timeout=timeout)
        except queue.Empty:
            pytest.fail(f"no output from the child for {timeout} s")

    def rest(self, timeout: float) -> list[str]:
        lines = []
        while (line := self.next(timeout)[1]) is not None:
            lines.append(line)
        return lines

    def join(self) -> None:
        self._thread.join(timeout=10)  # the child is gone: its end of the pipe is closed


def _spawn(argv: list[str], cwd: Path | None = None) -> subprocess.Popen:
    """`argv` in a child process with text pipes, without PCL_RG_TRACEBACK (it would
    let KeyboardInterrupt through)."""
    env = dict(os.environ)
    env.pop("PCL_RG_TRACEBACK", None)
    return subprocess.Popen(
        argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=cwd
    )


def test_sigint_stops_each_algorithm_with_keyboard_interrupt() -> None:
    jobs = ["tin_ground", "grid_ground", "normals", "region_growing"]
    latency: dict[str, float] = {}
    with _spawn([sys.executable, str(PROBE), *jobs], cwd=PROBE.parent) as child:
        lines = _Lines(child.stdout)
        try:
            for job in jobs:
                _, line = lines.next(timeout=120)
                assert line is not None, child.stderr.read()
                assert json.loads(line) == {"job": job, "event": "calling"}
                time.sleep(SIGNAL_AFTER)
                sent = time.monotonic()
                child.send_signal(signal.SIGINT)
                arrived, line = lines.next(timeout=30)
                assert line is not None, child.stderr.read()
                record = json.loads(line)
                assert record["event"] == "interrupted", f"{job} was not interrupted: {record}"
                latency[job] = arrived - sent
                _, line = lines.next(timeout=60)
                assert line is not None, child.stderr.read()
                after = json.loads(line)
                assert after["job"] == job
                before, now = after["python_threads"]
                assert now == before, f"{job}: Python threads {before} -> {now}"
                before, now = after["os_threads"]
                assert now == before, f"{job}: OS threads {before} -> {now}"
                assert after["second_call_same"], f"{job}: a call after the interrupt differs"
            assert child.wait(timeout=60) == 0, child.stderr.read()
        finally:
            child.kill()
            child.wait()
            lines.join()
    print("SIGINT -> KeyboardInterrupt (s):", {job: round(t, 3) for job, t in latency.items()})
    slow = {job: round(t, 3) for job, t in latency.items() if t > MAX_LATENCY}
    assert not slow, f"KeyboardInterrupt later than {MAX_LATENCY} s after SIGINT: {slow}"


def test_cli_sigint_exits_130_and_leaves_no_file(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    n = 300_000
    points = np.column_stack([rng.uniform(0.0, 300.0, (n, 2)), rng.normal(0.0, 0.05, n)])
    write_points(tmp_path / "big.laz", points)
    # 600 neighbours per point keep the outlier stage busy for many seconds.
    with _spawn([*CLI, "denoise", "big.laz", "out.laz", "--mean-k", "600"], tmp_path) as child:
        errors = _Lines(child.stderr)
        seen: list[str] = []
        try:
            # The progress line appears once the stage has run pcl_rg.cli._run.PROGRESS_DELAY (1 s).
            while not seen or not seen[-1].startswith("pcl-rg: statistical outlier removal"):
                _, line = errors.next(timeout=60)
                assert line is not None, f"the command ended early: {seen}"
                seen.append(line)
            time.sleep(0.5)
            sent = time.monotonic()
            child.send_signal(signal.SIGINT)
            status = child.wait(timeout=30)
            latency = time.monotonic() - sent
            seen += errors.rest(timeout=10)
            output = child.stdout.read()
        finally:
            child.kill()
            child.wait()
            errors.join()
    assert status == 130, seen
    assert [line for line in seen if line.startswith("pcl-rg: error:")] == [
        "pcl-rg: error: interrupted"
    ], seen
    assert output == ""
    assert sorted(os.listdir(tmp_path)) == ["big.laz"]  # no out.laz, no temporary file
    print(f"SIGINT -> exit 130: {latency:.3f} s")
    assert latency < MAX_LATENCY, f"exit {latency:.2f} s after SIGINT"


class _HandlerError(Exception):
    pass


@pytest.fixture
def sigusr1_raises():
    """A SIGUSR1 handler that raises _HandlerError; the previous one restored after."""

    def handler(signum, frame):
        raise _HandlerError("raised by the signal handler")

    previous = signal.signal(signal.SIGUSR1, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGUSR1, previous)


def _signal_later(signum: int, delay: float) -> threading.Thread:
    thread = threading.Thread(
        target=lambda: (time.sleep(delay), os.kill(os.getpid(), signum)), daemon=True
    )
    thread.start()
    return thread


def test_signal_handler_exception_propagates_from_the_core(sigusr1_raises) -> None:
    rng = np.random.default_rng(8)
    n = 6_000_000
    terrain = np.column_stack([rng.uniform(0.0, 1000.0, (n, 2)), rng.normal(0.0, 0.05, n)])
    expected = pcl_rg.grid_ground(terrain[:20_000])
    # Cells of 0.21 m (22.7 M of them): about 4 s, far more than the 0.3 s before the
    # signal, on any machine.
    sender = _signal_later(signal.SIGUSR1, 0.3)
    start = time.monotonic()
    with pytest.raises(_HandlerError, match="raised by the signal handler"):
        pcl_rg.grid_ground(terrain, cell_size=0.21)
    elapsed = time.monotonic() - start
    sender.join()
    assert elapsed < 0.3 + MAX_LATENCY
    np.testing.assert_array_equal(pcl_rg.grid_ground(terrain[:20_000]), expected)


def test_calls_from_other_threads_run_to_the_end(sigusr1_raises) -> None:
    # Only the main thread runs signal handlers: a call on another thread is neither
    # stopped nor disturbed while the main thread takes the signal.
    rng = np.random.default_rng(9)
    n = 4_000_000
    terrain = np.column_stack([rng.uniform(0.0, 1000.0, (n, 2)), rng.normal(0.0, 0.05, n)])
    expected = pcl_rg.grid_ground(terrain)  # 1 s or so
    result: list[np.ndarray] = []
    worker = threading.Thread(target=lambda: result.append(pcl_rg.grid_ground(terrain)))
    worker.start()
    time.sleep(0.1)  # the worker is inside the core now
    with pytest.raises(_HandlerError):
        os.kill(os.getpid(), signal.SIGUSR1)
        time.sleep(5)  # interrupted by the handler as soon as the signal arrives
    assert worker.is_alive()  # else the test proves nothing: make the call longer
    worker.join()
    np.testing.assert_array_equal(result[0], expected)


def _wait_for(condition, timeout: float, child: subprocess.Popen) -> None:
    """Poll `condition` until it holds; fail if the child ends or time runs out first."""
    deadline = time.monotonic() + timeout
    while not condition():
        assert child.poll() is None, f"the command ended first: {child.communicate()}"
        assert time.monotonic() < deadline, f"not seen within {timeout} s"
        time.sleep(0.01)


def _terminate_when(condition, timeout: float, child: subprocess.Popen) -> tuple[str, str]:
    """SIGTERM to `child` once `condition` holds (see _wait_for); its (stdout, stderr)."""
    try:
        _wait_for(condition, timeout, child)
        child.send_signal(signal.SIGTERM)
        return child.communicate(timeout=120)
    finally:
        child.kill()
        child.wait()


def test_cli_sigterm_exits_143_and_leaves_no_partial_file(tmp_path: Path) -> None:
    # SIGTERM (kill, a batch system's time limit) ended the process at once and left
    # the temporary file of OUTPUT; now it unwinds like Ctrl-C. 1 M points written as
    # text take seconds: the signal lands while the temporary file is being written.
    rng = np.random.default_rng(10)
    write_points(tmp_path / "big.pcd", rng.uniform(0.0, 100.0, (1_000_000, 3)))
    argv = [sys.executable, "-m", "pcl_rg", "downsample", "big.pcd", "out.xyz", "--leaf-size"]
    with _spawn([*argv, "1e-4"], tmp_path) as child:
        output, errors = _terminate_when(
            lambda: any(n.endswith(".tmp") for n in os.listdir(tmp_path)), 120, child
        )
    assert child.returncode == 143, errors
    assert "pcl-rg: error: terminated (SIGTERM)" in errors.splitlines(), errors
    assert "Traceback" not in errors
    assert output == ""
    assert sorted(os.listdir(tmp_path)) == ["big.pcd"]  # no out.xyz, no temporary file


def test_cli_sigterm_stops_a_batch_and_removes_its_scratch_folder(tmp_path: Path) -> None:
    from pcl_rg.datasets import synthetic_survey

    # As in test_batch_interrupts: the TIN filter on about 4 M points keeps both workers
    # busy for seconds after the first tile is written.
    source = synthetic_survey(tmp_path / "in", tiles=(4, 4), tile_size=250.0, seed=9)
    out = tmp_path / "out"
    argv = ["batch", "ground", *source.paths, "--out", str(out), "--workers", "2"]
    with _spawn([sys.executable, "-m", "pcl_rg", *argv, "--method", "tin", "--quiet"]) as child:

        def busy() -> bool:
            names = os.listdir(out) if out.exists() else []
            return any(n.startswith(".pcl_rg-scratch") for n in names) and any(
                n.endswith(".laz") for n in names
            )

        _, errors = _terminate_when(busy, 180, child)
    assert child.returncode == 143, errors
    assert "pcl-rg: error: terminated (SIGTERM)" in errors.splitlines(), errors
    left = os.listdir(out)
    assert len([n for n in left if n.endswith(".laz")]) < len(source.paths)
    assert not [n for n in left if n.endswith(".tmp") or n.startswith(".pcl_rg-scratch")]


def test_sigterm_while_lazrs_writes_ends_the_cli_with_143(tmp_path, capsys, monkeypatch) -> None:
    # Raised inside a call from lazrs, the handler's exception became lazrs's own
    # "failed to call write" (exit 1); it is held back to the stream's next write, as
    # Ctrl-C is. The signal is sent to this process only while pcl-rg's handler is in
    # place (the default would end the test session).
    from cli_helpers import run

    from pcl_rg.io import _las

    sent = []
    original = _las._RecordingStream.write

    def write(self, data):
        # The first block of compressed points (the header's writes are small): lazrs
        # calls this write.
        if len(data) > 10_000 and not sent:
            assert callable(signal.getsignal(signal.SIGTERM)), "no SIGTERM handler"
            sent.append(len(data))
            os.kill(os.getpid(), signal.SIGTERM)
        return original(self, data)

    monkeypatch.setattr(_las._RecordingStream, "write", write)
    write_points(tmp_path / "in.pcd", np.random.default_rng(11).uniform(0, 100, (200_000, 3)))
    before = signal.getsignal(signal.SIGTERM)
    code, out, err = run(
        capsys, "downsample", tmp_path / "in.pcd", tmp_path / "o.laz", "--leaf-size", "1e-4", "-q"
    )
    assert sent
    assert (code, err) == (143, "pcl-rg: error: terminated (SIGTERM)\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.pcd"]
    assert signal.getsignal(signal.SIGTERM) == before  # restored when main returns
