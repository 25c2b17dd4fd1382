"""``auralize bench --only``: the groups run are those named, in the bench's order, and
the JSON holds their rows; an unknown name is a usage error listing the groups."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from auralize.bench import runner
from auralize.cli import build_parser, main
from auralize.plugins import BenchRow


def test_only_runs_the_named_groups_in_order(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    ran: list[str] = []

    def group(name: str):  # type: ignore[no-untyped-def]
        def rows(args):  # type: ignore[no-untyped-def]
            ran.append(name)
            return [BenchRow(name, f"{name} row", 1.0, "s", note=f"quick={args.quick}")]

        return rows

    monkeypatch.setattr(runner, "GROUPS", {n: group(n) for n in runner.GROUPS})
    out = tmp_path / "bench.json"
    assert main(["bench", "--quick", "--only", "scaling,timbre", "--json", str(out)]) == 0
    assert ran == ["timbre", "scaling"]  # the bench's order, not the option's
    rows = json.loads(out.read_text())
    assert [r["group"] for r in rows] == ["timbre", "scaling"]
    assert all(r["note"] == "quick=True" for r in rows)


def test_every_group_is_named_in_the_help() -> None:
    sub = build_parser()._subparsers._group_actions[0].choices["bench"]  # type: ignore[union-attr]
    text = " ".join(sub.format_help().split())
    for name in runner.GROUPS:
        assert name in text


def test_an_unknown_group_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        build_parser().parse_args(["bench", "--only", "timbre,nope"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "unknown bench group 'nope'" in err and "efficiency" in err
