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
from pathlib import Path

import pytest

PROBE = Path(__file__).with_name("thread_probe.py")
OMP_VARIABLES = ("OMP_NUM_THREADS", "OMP_THREAD_LIMIT", "OMP_DYNAMIC", "OMP_MAX_ACTIVE_LEVELS")
# Set only by the conditions that ask for them, never inherited.
CONDITION_VARIABLES = (*OMP_VARIABLES, "PCL_RG_BLOCK_CACHE_CHECK")

# The plain run has as many threads as cores (2 on CI): one thread, an odd count and
# more threads than cores are the counts that differ from it.
CONDITIONS = {
    "OMP_NUM_THREADS=1": ({"OMP_NUM_THREADS": "1"}, "plain"),
    "OMP_NUM_THREADS=3": ({"OMP_NUM_THREADS": "3"}, "plain"),
    "OMP_NUM_THREADS=8": ({"OMP_NUM_THREADS": "8"}, "plain"),
    "OMP_THREAD_LIMIT=1": ({"OMP_THREAD_LIMIT": "1"}, "plain"),
    "OMP_DYNAMIC=true": ({"OMP_DYNAMIC": "true", "OMP_NUM_THREADS": "8"}, "plain"),
    "inside an OpenMP parallel region": ({}, "parallel-region"),
    "3 Python threads at once": ({}, "python-threads"),
    # The core's kept blocks (block_cache.cpp): none kept, and every block handed out
    # filled with 0xA5 bytes from 64 KiB up, so a read of what a block held before it
    # was written would change a digest.
    "no blocks kept between calls": ({}, "no-kept-blocks"),
    "PCL_RG_BLOCK_CACHE_CHECK=1": ({"PCL_RG_BLOCK_CACHE_CHECK": "1"}, "plain"),
}


class _Probes:
    """The plain run's probe and those of the selected conditions, started at once: the
    machine's cores are then shared by up to eight interpreters (each mostly one thread
    in its set-up, or waiting on OpenMP's barriers), not left idle between them, and
    each result must still be the plain run's."""

    TIMEOUT = 600  # seconds for each probe: a bound against a hang, not a speed

    def __init__(self, names: list[str]) -> None:
        self.running: dict[str, subprocess.Popen] = {}
        self.outcome: dict[str, dict[str, str] | str] = {}  # digests, or why there are none
        for name in names:
            environment, mode = ({}, "plain") if name == "plain" else CONDITIONS[name]
            env = {k: v for k, v in os.environ.items() if k not in CONDITION_VARIABLES}
            env.update(environment)
            self.running[name] = subprocess.Popen(
                [sys.executable, str(PROBE), mode],
                env=env,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                cwd=PROBE.parent,
            )

    def digests(self, name: str) -> dict[str, str]:
        if name not in self.outcome:
            probe = self.running.pop(name)
            try:
                out, err = probe.communicate(timeout=self.TIMEOUT)
            except subprocess.TimeoutExpired:
                self.stop(f"stopped when the probe of {name!r} ran past {self.TIMEOUT} s")
                probe.kill()
                probe.communicate()
                self.outcome[name] = f"ran past {self.TIMEOUT} s"
            else:
                self.outcome[name] = json.loads(out) if probe.returncode == 0 else err
        outcome = self.outcome[name]
        assert isinstance(outcome, dict), f"probe failed ({name}):\n{outcome}"
        return outcome

    def stop(self, why: str) -> None:
        for name, probe in self.running.items():
            probe.kill()
            probe.communicate()
            self.outcome[name] = why
        self.running.clear()


def _condition(item: pytest.Item) -> str | None:
    callspec = getattr(item, "callspec", None)
    return callspec.params.get("condition") if callspec else None


@pytest.fixture(scope="module")
def probes(request):
    """The probes of the conditions this session runs (all of them but when a selection
    leaves some out), started when the module's first test asks."""
    here = request.node.path
    selected = [
        condition
        for item in request.session.items
        if item.path == here and (condition := _condition(item)) is not None
    ]
    started = _Probes(["plain", *dict.fromkeys(selected)])
    yield started
    started.stop("the module ended first")


@pytest.mark.parametrize("condition", list(CONDITIONS))
def test_same_results_as_the_plain_run(condition: str, probes: _Probes) -> None:
    plain = probes.digests("plain")
    got = probes.digests(condition)
    assert set(got) == set(plain)
    differing = sorted(name for name in plain if got[name] != plain[name])
    assert not differing, f"{condition}: results differ from the plain run for {differing}"


def test_probe_covers_every_public_algorithm(probes: _Probes) -> None:
    import pcl_rg
    import pcl_rg.pcl

    def functions(module, prefix: str) -> set[str]:
        return {
            prefix + name
            for name in module.__all__
            if callable(getattr(module, name)) and not name[0].isupper()
        }

    # collect_diagnostics and the memory settings are no algorithms; PCL's classes
    # (pcl_rg.pcl) are probed too.
    settings = {"collect_diagnostics", "release_memory", "set_memory_cache_limit"}
    algorithms = functions(pcl_rg, "") - settings | functions(pcl_rg.pcl, "pcl.")
    assert algorithms <= set(probes.digests("plain"))
