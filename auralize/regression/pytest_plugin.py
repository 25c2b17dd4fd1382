"""pytest plugin: the ``auralize_regression`` fixture (registered by the ``pytest11``
entry point ``auralize``, as pytest-pyvista registers its ``verify_image_cache``).

In a test::

    def test_my_simulation_still_sounds_the_same(auralize_regression):
        auralize_regression.check("run/output.pvd", listener=(2, 0, 0), duration=2.0)

The first run records the expectation (``auralize_regression/<test name>.json``
and ``.png`` beside the test file) and fails, asking for it to be reviewed and
committed; later runs compare with it (:func:`auralize.regression.user.check`)
and fail naming every figure that moved.  Options:

``--auralize-regression-record``
    record the expectations again (the tests pass), after a change that was meant;
``--auralize-regression-report DIR``
    write the report of each check into ``DIR/<test name>/``.

This module imports nothing of auralize until a test uses the fixture, so a
pytest session that does not is not slowed down.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

RECORD_OPTION = "--auralize-regression-record"
REPORT_OPTION = "--auralize-regression-report"
#: the folder beside a test file that holds its expectations
FOLDER = "auralize_regression"


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("auralize", "auralize: regression of a dataset's sources and sound")
    group.addoption(
        RECORD_OPTION,
        action="store_true",
        default=False,
        help="record the auralize_regression expectations again instead of "
        "checking them (the tests pass)",
    )
    group.addoption(
        REPORT_OPTION,
        metavar="DIR",
        default=None,
        help="write the report of each auralize_regression check into DIR/<test name>/",
    )


class AuralizeRegression:
    """What the ``auralize_regression`` fixture gives a test (see the module docstring).

    ``folder`` holds the expectations (``auralize_regression/`` beside the test
    file); ``record_mode`` is whether ``--auralize-regression-record`` was given.
    """

    def __init__(self, request: pytest.FixtureRequest) -> None:
        self.request = request
        self.folder = Path(str(request.node.path)).parent / FOLDER
        self.record_mode = bool(request.config.getoption(RECORD_OPTION))
        report = request.config.getoption(REPORT_OPTION)
        self.report_root = Path(report) if report else None

    def expectation(self, name: str | None = None) -> Path:
        """The expectation file of this test (``name`` for a second check in one test)."""
        base = re.sub(r"[^\w.-]+", "_", self.request.node.name).strip("_")
        return self.folder / f"{base}{'-' + name if name else ''}.json"

    def check(
        self,
        data: str | Path,
        *,
        name: str | None = None,
        tolerances: dict[str, float] | None = None,
        **settings: Any,
    ) -> Any:
        """Check ``data`` against this test's expectation (record it if there is none,
        or with ``--auralize-regression-record``).

        ``settings`` are :func:`auralize.regression.user.record`'s (``listener``,
        ``path``, ``duration``, ``layout``, ``rate``, reader and detection options
        ...); they are stored when recording, and a check uses the stored ones.
        ``tolerances`` override the stored ones when checking and are stored when
        recording.  Returns the :class:`~auralize.regression.user.CheckResult`
        (None when it recorded).
        """
        from auralize.regression.user import check, record

        expect = self.expectation(name)
        if self.record_mode or not expect.is_file():
            self.folder.mkdir(exist_ok=True)
            record(data, expect, tolerances=tolerances, **settings)
            if not self.record_mode:
                pytest.fail(
                    f"auralize_regression: no expectation yet; recorded {expect} (and "
                    f"its picture): review it, commit it and run again",
                    pytrace=False,
                )
            return None
        report = None
        if self.report_root is not None:
            self.report_root.mkdir(parents=True, exist_ok=True)
            report = self.report_root / expect.stem
        result = check(data, expect, tolerances=tolerances, report=report)
        if not result.passed:
            where = f"\nreport: {report}" if report is not None else ""
            pytest.fail(
                f"auralize_regression: {result.summary()}{where}\n(if the change was "
                f"meant, record again with {RECORD_OPTION})",
                pytrace=False,
            )
        return result


@pytest.fixture
def auralize_regression(request: pytest.FixtureRequest) -> AuralizeRegression:
    """Check a dataset's sources and sound against a recorded expectation
    (:class:`AuralizeRegression`)."""
    return AuralizeRegression(request)
