"""The red-team table (tests/redteam.py): no hostile input is a raw exception, and the table in
docs/reliability.md is the one the code gives now."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("torch")

from tests import redteam

PAGE = Path(__file__).resolve().parents[1] / "docs" / "reliability.md"


def test_every_attack_is_refused_with_our_error_or_handled_and_the_table_is_current():
    table = redteam.table()
    rows = table.splitlines()[2:]
    raw = [row for row in rows if "| RAW:" in row]
    assert not raw, raw
    assert len(rows) == len(redteam.ATTACKS) >= 25
    page = PAGE.read_text()
    committed = page.split(redteam.START, 1)[1].split(redteam.END, 1)[0].strip()
    assert committed == table, \
        "docs/reliability.md's red-team table is stale: python -m tests.redteam --write docs/reliability.md"
