"""Shared test helpers: the real data beside the repository, fixed-seed clouds."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import laspy
import numpy as np
import pytest
from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import pcl_rg.io._atomic
from pcl_rg import datasets

# Hypothesis profiles. "ci" (the default, `make test`) derandomizes: every run draws
# the same examples, so a red CI is reproducible and a green one is not luck.
# "fuzz" (`make fuzz`) draws fresh random examples, FUZZ_FACTOR times as many.
FUZZ_FACTOR = 20
settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
settings.register_profile("fuzz", derandomize=False, print_blob=True)
HYPOTHESIS_PROFILE = os.environ.get("PCL_RG_HYPOTHESIS_PROFILE", "ci")
settings.load_profile(HYPOTHESIS_PROFILE)


def examples(count: int) -> int:
    """A test's number of hypothesis examples under the active profile."""
    return count * FUZZ_FACTOR if HYPOTHESIS_PROFILE == "fuzz" else count


# ../shared/data next to the repository (CI always provides it; see its README).
SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"

ISPRS_SAMPLES = ("samp11", "samp21", "samp31", "samp41", "samp51", "samp52", "samp61")
MOSD_SCENES = ("learn0", "learn5", "learn17", "learn20", "learn25", "learn33", "learn40")


def shared_data(*parts: str) -> Path:
    """Path of a file under ../shared/data; fails the test loudly when missing."""
    path = SHARED_DATA.joinpath(*parts)
    if not path.exists():
        pytest.fail(
            f"test data {path} is missing: these tests need ../shared/data beside the "
            "repository (see its README); they never skip",
            pytrace=False,
        )
    return path


def uniform_cloud(n: int, seed: int, extent: float = 10.0) -> np.ndarray:
    """n points uniform in a cube of the given extent (float64)."""
    return np.random.default_rng(seed).uniform(0.0, extent, (n, 3))


def clustered_cloud(n: int, seed: int) -> np.ndarray:
    """Gaussian blobs plus sparse far outliers: a cloud where SOR has work to do."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(0, 20, (8, 3))
    blob = centres[rng.integers(0, 8, n)] + rng.normal(0, 0.5, (n, 3))
    outliers = rng.uniform(-20, 40, (max(n // 50, 1), 3))
    return np.vstack([blob, outliers])


def point_arrays(
    points: tuple[int, int], ties: list[float], span: float
) -> st.SearchStrategy[np.ndarray]:
    """Float64 (N, 3) arrays, N in `points`, of values in [-span, span] or from `ties`.

    The values of `ties` recur, so that draws hold duplicates, shared coordinates and
    exact ties, which random floats almost never give.
    """
    return hnp.arrays(
        np.float64,
        st.tuples(st.integers(*points), st.just(3)),
        elements=st.one_of(st.sampled_from(ties), st.floats(-span, span, allow_nan=False)),
    )


def run_command(*argv: object, timeout: float = 120, **options) -> subprocess.CompletedProcess:
    """Run `argv` (paths allowed) to the end; its exit status, stdout and stderr as text.

    `timeout` catches a hang; `options` go to :func:`subprocess.run` (cwd, env).
    """
    command = [os.fspath(a) if isinstance(a, os.PathLike) else str(a) for a in argv]
    return subprocess.run(
        command, capture_output=True, text=True, timeout=timeout, check=False, **options
    )


def run_pcl_rg(*argv: object, timeout: float = 120, **options) -> subprocess.CompletedProcess:
    """``python -m pcl_rg *argv`` in a fresh interpreter (see :func:`run_command`)."""
    return run_command(sys.executable, "-m", "pcl_rg", *argv, timeout=timeout, **options)


class FailingStream:
    """A file object that accepts `budget` bytes, then fails like a full disk."""

    def __init__(self, real, budget: int, error: BaseException) -> None:
        self.real, self.budget, self.error = real, budget, error

    def write(self, data) -> int:
        size = memoryview(data).nbytes
        if size > self.budget:
            self.real.write(memoryview(data).tobytes()[: self.budget])
            self.real.flush()
            raise self.error
        self.budget -= size
        return self.real.write(data)

    def __getattr__(self, name):
        return getattr(self.real, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.real.close()
        return False


def fail_writes(monkeypatch, budget: int, error: BaseException) -> list[str]:
    """Make pcl_rg.io's temporary-file writes fail; return the temp names seen."""
    seen = []
    real_open = open

    def fake_open(file, mode="r", *args, **kwargs):
        stream = real_open(file, mode, *args, **kwargs)
        if "x" in mode:  # the temporary file: created, never opened over an existing one
            seen.append(os.fspath(file))
            return FailingStream(stream, budget, error)
        return stream

    monkeypatch.setattr(pcl_rg.io._atomic, "open", fake_open, raising=False)
    return seen


def run_in_threads(call, threads: int = 4) -> list:
    """`call()` from `threads` Python threads started together; their results in order.

    The core releases the GIL, so the calls overlap: a result that differs from a
    serial one means shared state in the core.
    """
    barrier = threading.Barrier(threads)
    results: list = [None] * threads

    def work(i: int) -> None:
        barrier.wait()
        results[i] = call()

    workers = [threading.Thread(target=work, args=(i,)) for i in range(threads)]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    return results


# `python -m pcl_rg`, with SIGINT handled as in a terminal also when the tests run in
# the background of a shell, which starts its children with SIGINT ignored.
CLI_WITH_SIGINT = [
    sys.executable,
    "-c",
    "import runpy, signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
    "runpy.run_module('pcl_rg', run_name='__main__', alter_sys=True)",
]


@pytest.fixture
def python_sigint_handler():
    """Python's own SIGINT handler, as in a terminal: a shell that runs the tests in the
    background starts them with SIGINT ignored, and then nothing is recorded."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.fixture(scope="session")
def scene_las(tmp_path_factory) -> Path:
    """The synthetic scene as LAS 1.2 point format 3 with every dimension filled."""
    scene = datasets.synthetic_scene(seed=5, size=80.0, offset=(500_000.0, 5_000_000.0, 0.0))
    n = len(scene.points)
    rng = np.random.default_rng(8)
    header = laspy.LasHeader(version="1.2", point_format=3)
    header.scales = [0.01, 0.01, 0.01]
    header.offsets = [500_000.0, 5_000_000.0, 0.0]
    las = laspy.LasData(header)
    las.x, las.y, las.z = scene.points.T
    las.classification = scene.labels
    las.intensity = rng.integers(0, 65536, n)
    las.return_number = rng.integers(1, 4, n)
    las.number_of_returns = np.full(n, 3)
    las.gps_time = np.sort(rng.uniform(0, 1000, n))
    las.red, las.green, las.blue = rng.integers(0, 65536, (3, n))
    las.point_source_id = rng.integers(0, 10, n)
    las.user_data = rng.integers(0, 256, n)
    las.scan_angle_rank = rng.integers(-90, 91, n)
    path = tmp_path_factory.mktemp("scene") / "scene.las"
    las.write(path)
    return path


# The batch tests' (test_batch.py, test_batch_faults.py): one local Dask cluster per
# module, and a survey of tiles.
@pytest.fixture(scope="module")
def scheduler():
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as cluster:
        yield cluster.scheduler_address


@pytest.fixture(scope="module")
def survey(tmp_path_factory):
    """A 5 x 5 synthetic survey (about 380k points) with objects across tile borders."""
    folder = tmp_path_factory.mktemp("survey")
    return datasets.synthetic_survey(folder, tiles=(5, 5), tile_size=60.0, seed=7)


@pytest.fixture(scope="module")
def small_survey(tmp_path_factory):
    """A 3 x 3 survey like `survey` (about 140k points), for the tests whose work grows
    with the tiles times the points each one reads (a denoise buffer beyond the survey)
    or that run a survey twice: a middle tile with eight neighbours is what they need."""
    folder = tmp_path_factory.mktemp("small_survey")
    return datasets.synthetic_survey(folder, tiles=(3, 3), tile_size=60.0, seed=7)
