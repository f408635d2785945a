"""Every algorithm gives bit-identical results whatever threads OpenMP grants.

Each run condition is a fresh interpreter (OpenMP reads its environment once, at
start-up) running tests/thread_probe.py, which prints one digest per algorithm. Every
condition must print exactly the plain run's digests. The conditions that grant a
region fewer threads than ``omp_get_max_threads()`` reports (a thread limit, dynamic
adjustment, a call from inside a parallel region) are the ones that once made the
shared radix sort skip chunks.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from functools import cache
from pathlib import Path

import pytest

PROBE = Path(__file__).with_name("thread_probe.py")
OMP_VARIABLES = ("OMP_NUM_THREADS", "OMP_THREAD_LIMIT", "OMP_DYNAMIC", "OMP_MAX_ACTIVE_LEVELS")

CONDITIONS = {
    "OMP_NUM_THREADS=1": ({"OMP_NUM_THREADS": "1"}, "plain"),
    "OMP_NUM_THREADS=2": ({"OMP_NUM_THREADS": "2"}, "plain"),
    "OMP_NUM_THREADS=3": ({"OMP_NUM_THREADS": "3"}, "plain"),
    "OMP_NUM_THREADS=8": ({"OMP_NUM_THREADS": "8"}, "plain"),
    "OMP_THREAD_LIMIT=1": ({"OMP_THREAD_LIMIT": "1"}, "plain"),
    "OMP_DYNAMIC=true": ({"OMP_DYNAMIC": "true", "OMP_NUM_THREADS": "8"}, "plain"),
    "inside an OpenMP parallel region": ({}, "parallel-region"),
    "4 Python threads at once": ({}, "python-threads"),
}


@cache
def _started() -> dict[str, subprocess.Popen]:
    """Every condition's probe, and the plain run's, started at once on first use: the
    machine's cores are then shared by nine interpreters (each mostly one thread in its
    set-up, or waiting on OpenMP's barriers), not left idle between them, and each
    result must still be the plain run's."""
    started = {}
    for name, (environment, mode) in {"plain": ({}, "plain"), **CONDITIONS}.items():
        env = {k: v for k, v in os.environ.items() if k not in OMP_VARIABLES}
        env.update(environment)
        started[name] = subprocess.Popen(
            [sys.executable, str(PROBE), mode],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=PROBE.parent,
        )
    return started


@cache
def _digests(name: str) -> dict[str, str]:
    probe = _started()[name]
    try:
        out, err = probe.communicate(timeout=600)
    except subprocess.TimeoutExpired:
        for other in _started().values():
            other.kill()
        raise
    assert probe.returncode == 0, f"probe failed ({name}):\n{err}"
    return json.loads(out)


def _plain() -> dict[str, str]:
    return _digests("plain")


@pytest.fixture(scope="module", autouse=True)
def _no_probe_outlives_the_module():
    yield
    if _started.cache_info().currsize:
        for probe in _started().values():
            if probe.poll() is None:
                probe.kill()
                probe.communicate()


@pytest.mark.parametrize("condition", list(CONDITIONS))
def test_same_results_as_the_plain_run(condition: str) -> None:
    plain = _plain()
    got = _digests(condition)
    assert set(got) == set(plain)
    differing = sorted(name for name in plain if got[name] != plain[name])
    assert not differing, f"{condition}: results differ from the plain run for {differing}"


def test_probe_covers_every_public_algorithm() -> None:
    import pcl_rg
    import pcl_rg.pcl

    def functions(module, prefix: str) -> set[str]:
        return {
            prefix + name
            for name in module.__all__
            if callable(getattr(module, name)) and not name[0].isupper()
        }

    # collect_diagnostics is no algorithm; PCL's classes (pcl_rg.pcl) are probed too.
    algorithms = functions(pcl_rg, "") - {"collect_diagnostics"} | functions(pcl_rg.pcl, "pcl.")
    assert algorithms <= set(_plain())
