"""The work arrays' rows of the synthesis kernels are declared once, as lists: each
name gets its first row, the blocks are contiguous and do not overlap."""

from __future__ import annotations

import pytest

from auralize.emitters._kernels import common
from auralize.emitters._kernels.common import (
    KNOT_ROW,
    KNOT_ROWS,
    ROW,
    RUN_ROW,
    RUN_ROWS,
    WORK_ROWS,
    row_table,
)


@pytest.mark.parametrize(
    ("rows", "table"), [(WORK_ROWS, ROW), (RUN_ROWS, RUN_ROW), (KNOT_ROWS, KNOT_ROW)]
)
def test_rows_are_unique_and_contiguous(rows, table) -> None:  # type: ignore[no-untyped-def]
    names = [n for n, _ in rows]
    assert len(set(names)) == len(names)
    start = 0
    for name, n in rows:
        assert getattr(table, name) == start, name
        start += n
    assert table.END == start == sum(n for _, n in rows)
    # every row belongs to exactly one block
    covered = [r for name, n in rows for r in range(getattr(table, name), getattr(table, name) + n)]
    assert covered == list(range(table.END))


def test_rows_the_kernels_rely_on() -> None:
    # the piece's input is its chunk of piece_data, in that order
    assert [ROW.X, ROW.Y, ROW.Z, ROW.RM, ROW.Q0, ROW.M0, ROW.Q1, ROW.M1] == list(range(8))
    assert ROW.INPUT_END == 8
    # polynomial B follows A (12 values each); pair index and its two gains are adjacent
    assert ROW.VAL_B == ROW.VAL_A + 12
    assert (ROW.G00, ROW.G01, ROW.G10, ROW.G11) == (ROW.P0 + 1, ROW.P0 + 2, ROW.P1 + 1, ROW.P1 + 2)
    # the parts' rows continue the pieces' work array
    assert ROW.PIECE_END <= ROW.J < ROW.END
    assert RUN_ROW.PLAIN_END <= RUN_ROW.GX < RUN_ROW.END
    assert RUN_ROW.PF == RUN_ROW.P + 4
    assert KNOT_ROW.KNOT == KNOT_ROW.LEN + 1


def test_piece_kinds_are_distinct() -> None:
    kinds = [common.KIND_SILENT, common.KIND_SIMPLE, common.KIND_GENERAL, common.KIND_ACROSS]
    assert len(set(kinds)) == 4 and common.KIND_SILENT == 0.0


def test_row_table_refuses_duplicates() -> None:
    with pytest.raises(ValueError, match="unique"):
        row_table("T", [("A", 1), ("A", 2)])
    with pytest.raises(ValueError, match=">= 0"):
        row_table("T", [("A", -1)])
    t = row_table("T", [("A", 2), ("MARK", 0), ("B", 3)])
    assert (t.A, t.MARK, t.B, t.END) == (0, 2, 2, 5)
