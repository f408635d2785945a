"""The core keeps its large freed arrays for the next call (block_cache.cpp), within a
limit and within a quarter above the most its arrays asked for at once (the peak), and
gives them back when asked.

The counters are the process's, so each scenario runs in a fresh interpreter. That
results never depend on the kept memory is tests/test_thread_independence.py's
("no blocks kept between calls" and PCL_RG_BLOCK_CACHE_CHECK=1 against the plain run).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

import pcl_rg

# A cloud whose per-point arrays pass the cache's 4 MiB (about 250 k points: 24-byte
# local coordinates, 4-byte indices from 1.05 M points up).
SCENARIO_HEAD = """
import json, numpy as np, pcl_rg
from pcl_rg import _core
points = pcl_rg.datasets.synthetic_scene(seed=1, size=520.0, density=4.0).points
stats = _core.block_cache_stats
# A limit of its own: the default is 0 in an AddressSanitizer build (make sanitize).
pcl_rg.set_memory_cache_limit(4 << 30)
"""


def room(peak: int) -> int:
    """The most live + kept bytes for a peak (block_cache.cpp's with_room): a quarter
    more, so that larger blocks lent to smaller requests can be kept."""
    return peak + peak // 4


def run_scenario(body: str, env: dict[str, str] | None = None) -> dict:
    code = SCENARIO_HEAD + textwrap.dedent(body)
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        env={**os.environ, **(env or {})},
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def test_a_repeated_call_reuses_every_block_and_the_peak_bounds_what_is_kept() -> None:
    out = run_scenario(
        """
        first_mask = pcl_rg.tin_ground(points)
        first = stats()
        second_mask = pcl_rg.tin_ground(points)
        second = stats()
        grid = pcl_rg.grid_ground(points)
        third = stats()
        print(json.dumps({"first": first, "second": second, "third": third,
                          "same": bool((first_mask == second_mask).all())}))
        """
    )
    first, second, third = out["first"], out["second"], out["third"]
    assert out["same"]
    assert first["allocated"] > 0 and first["live_bytes"] == 0
    assert first["kept_bytes"] > 0
    # The same call again: every block from the first call's.
    assert second["allocated"] == first["allocated"]
    assert second["reused"] > first["reused"]
    assert second["peak_bytes"] == first["peak_bytes"]
    # Another filter: whatever it maps anew, kept stays within the room above the peak.
    for s in (first, second, third):
        assert s["kept_bytes"] <= min(room(s["peak_bytes"]), s["limit"])


@pytest.mark.parametrize("function", ["grid_ground", "tin_ground"])
def test_a_call_repeated_maps_no_new_memory(function) -> None:
    # PCL_RG_BLOCK_CACHE_CHECK makes the cache serve blocks from 64 KiB, so that this
    # cloud's arrays meet it as 10M points' meet it by default. A small array asked for
    # while the block of its size was still live used to drop the oldest kept block and
    # map new memory, every call (grid_ground: 10 blocks per call here, 3 on 10M points).
    # One thread: with more, the threads' own rasters are taken and given in an order that
    # varies between calls, and a call may then map a block while within the peak.
    out = run_scenario(
        f"""
        run = pcl_rg.{function}
        counts = []
        for _ in range(3):
            run(points)
            counts.append(stats())
        print(json.dumps(counts))
        """,
        env={"PCL_RG_BLOCK_CACHE_CHECK": "1", "OMP_NUM_THREADS": "1"},
    )
    first, second, third = out
    assert first["allocated"] > 0
    assert third["allocated"] == second["allocated"] == first["allocated"]
    assert third["peak_bytes"] == first["peak_bytes"]
    assert all(s["kept_bytes"] <= room(s["peak_bytes"]) for s in out)


@pytest.mark.parametrize("function", ["grid_ground", "tin_ground"])
def test_the_peak_is_what_was_asked_for_not_what_was_lent(function) -> None:
    # Crops of the cloud, of varying sizes, in one process: the peak is the whole cloud's
    # alone (its calls ask for the most), and what is kept stays within the room above
    # it. When the peak counted the whole of a larger block lent to a smaller request,
    # the unused tails raised it (and with it what could be kept) from call to call.
    # Check mode and one thread, as above: every array goes through the cache, in one
    # order.
    def crops(shares: list[float]) -> list[dict]:
        return run_scenario(
            f"""
            x = points[:, 0]
            out = []
            for share in {shares}:
                pcl_rg.{function}(points[x <= np.quantile(x, share)] if share < 1 else points)
                out.append(stats())
            print(json.dumps(out))
            """,
            env={"PCL_RG_BLOCK_CACHE_CHECK": "1", "OMP_NUM_THREADS": "1"},
        )

    alone = crops([1.0])
    mixed = crops([0.3, 1.0, 0.5, 0.8, 0.2, 1.0, 0.6, 0.9, 0.4, 1.0])
    assert alone[0]["allocated"] > 0
    assert mixed[-1]["peak_bytes"] == alone[0]["peak_bytes"]
    assert all(s["kept_bytes"] <= room(s["peak_bytes"]) for s in alone + mixed)


def test_release_and_a_zero_limit_keep_nothing() -> None:
    out = run_scenario(
        """
        pcl_rg.grid_ground(points)
        kept = stats()["kept_bytes"]
        released = pcl_rg.release_memory()
        after_release = stats()
        previous = pcl_rg.set_memory_cache_limit(0)
        pcl_rg.grid_ground(points)
        off = stats()
        pcl_rg.grid_ground(points)
        off_again = stats()
        restored = pcl_rg.set_memory_cache_limit(previous)
        print(json.dumps({"kept": kept, "released": released, "after": after_release,
                          "previous": previous, "off": off, "off_again": off_again,
                          "restored": restored}))
        """
    )
    assert out["kept"] > 0 and out["released"] == out["kept"]
    assert out["after"]["kept_bytes"] == 0
    assert out["previous"] > 0 and out["restored"] == 0
    # Limit 0: the calls map all their blocks, and nothing stays.
    assert out["off"]["kept_bytes"] == 0 and out["off_again"]["kept_bytes"] == 0
    assert out["off_again"]["reused"] == out["off"]["reused"]
    assert out["off_again"]["allocated"] > out["off"]["allocated"]


def test_a_lower_limit_frees_what_lies_above_it() -> None:
    out = run_scenario(
        """
        pcl_rg.tin_ground(points)
        kept = stats()["kept_bytes"]
        pcl_rg.set_memory_cache_limit(kept // 2)
        print(json.dumps({"kept": kept, "after": stats()}))
        """
    )
    assert out["kept"] > 0 and out["after"]["kept_bytes"] <= out["kept"] // 2


def test_threads_at_once_keep_within_the_room_above_the_peak() -> None:
    # Three threads taking and giving blocks of different sizes at once: what is kept
    # stays within the room above the peak, and the masks are each cloud's own.
    out = run_scenario(
        """
        from concurrent.futures import ThreadPoolExecutor
        clouds = [points, points[::2].copy(), points[::3].copy()]
        alone = [pcl_rg.tin_ground(c).tobytes() for c in clouds]
        def job(k):
            got = []
            for r in range(4):
                c = (k + r) % 3
                f = pcl_rg.tin_ground if r % 2 == 0 else pcl_rg.grid_ground
                mask = f(clouds[c])
                got.append(f is pcl_rg.grid_ground or mask.tobytes() == alone[c])
            return all(got)
        with ThreadPoolExecutor(3) as pool:
            same = all(pool.map(job, range(3)))
        print(json.dumps({"same": same, "end": stats()}))
        """
    )
    end = out["end"]
    assert out["same"]
    assert end["live_bytes"] == 0
    assert end["kept_bytes"] <= room(end["peak_bytes"])


@pytest.mark.parametrize(
    ("value", "error"),
    [(-1, ValueError), (2**64, ValueError), (1.5, TypeError), (True, TypeError), ("1", TypeError)],
)
def test_the_limit_must_be_a_byte_count(value, error) -> None:
    before = pcl_rg.set_memory_cache_limit(0)
    pcl_rg.set_memory_cache_limit(before)
    with pytest.raises(error, match="nbytes"):
        pcl_rg.set_memory_cache_limit(value)
    assert pcl_rg.set_memory_cache_limit(before) == before  # unchanged by the refusal
