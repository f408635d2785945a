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


def _probe(environment: dict[str, str], mode: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in OMP_VARIABLES}
    env.update(environment)
    done = subprocess.run(
        [sys.executable, str(PROBE), mode],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        cwd=PROBE.parent,
    )
    assert done.returncode == 0, f"probe failed ({mode}, {environment}):\n{done.stderr}"
    return json.loads(done.stdout)


@cache
def _plain() -> dict[str, str]:
    return _probe({}, "plain")


@pytest.mark.parametrize("condition", list(CONDITIONS))
def test_same_results_as_the_plain_run(condition: str) -> None:
    environment, mode = CONDITIONS[condition]
    plain = _plain()
    got = _probe(environment, mode)
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
