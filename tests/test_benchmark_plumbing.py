"""benchmarks/_common: generated sections replaced and notes by hand kept (write_section);
interleaved methods in orders balanced for the call before (carryover_balanced_orders)."""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from _common import (  # noqa: E402
    KEPT_END,
    KEPT_START,
    carryover_balanced_orders,
    write_section,
)

KEPT = f"{KEPT_START}\nBefore the change: 4.25 %.\n\nA second paragraph.\n{KEPT_END}\n"


def results(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "RESULTS.md"
    path.write_text(text)
    return path


def test_a_rewritten_section_keeps_its_notes_by_hand(tmp_path: Path) -> None:
    path = results(
        tmp_path,
        "# Benchmark results\n\n## A\n\nold table A\n\n" + KEPT + "\n## B\n\ntable B\n",
    )
    write_section("## A\n\nnew table A\n", "## A", path)
    text = path.read_text()
    assert "old table A" not in text
    assert text == "# Benchmark results\n\n## A\n\nnew table A\n\n" + KEPT + "\n## B\n\ntable B\n"
    # Again: the notes are carried, not copied twice.
    write_section("## A\n\nnewer table A\n", "## A", path)
    assert path.read_text() == text.replace("new table A", "newer table A")


def test_notes_of_the_last_section_and_of_no_section(tmp_path: Path) -> None:
    path = results(tmp_path, "# Benchmark results\n\n## B\n\ntable B\n\n" + KEPT.rstrip("\n"))
    write_section("## B\n\nnew B\n", "## B", path)
    assert path.read_text() == "# Benchmark results\n\n## B\n\nnew B\n\n" + KEPT + "\n"
    write_section("## C\n\ntable C\n", "## C", path)  # a new section is appended
    assert path.read_text().endswith(KEPT + "\n## C\n\ntable C\n")


def test_a_section_without_notes_is_replaced_whole(tmp_path: Path) -> None:
    path = results(tmp_path, "# Benchmark results\n\n## A\n\nold\n\nold note\n\n## B\n\nb\n")
    write_section("## A\n\nnew\n", "## A", path)
    assert path.read_text() == "# Benchmark results\n\n## A\n\nnew\n\n## B\n\nb\n"


@pytest.mark.parametrize("count", range(1, 9))
def test_each_method_follows_every_other_equally_often(count: int) -> None:
    orders = carryover_balanced_orders(count)
    assert len(orders) == (count if count % 2 == 0 else 2 * count)
    assert all(sorted(order) == list(range(count)) for order in orders)
    pairs = Counter((a, b) for order in orders for a, b in zip(order, order[1:]))
    expected = {(a, b) for a in range(count) for b in range(count) if a != b}
    assert set(pairs) == expected
    assert set(pairs.values()) <= {1 if count % 2 == 0 else 2}


def test_no_orders_of_no_methods() -> None:
    with pytest.raises(ValueError, match="at least 1"):
        carryover_balanced_orders(0)
