"""Shared fixtures: the repository's robot files, the `cdpr` CLI built in the
same run, and the timing lines printed at the end of the run."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import pytest

import cdpr

ROOT = Path(__file__).resolve().parents[2]
ROBOTS = ROOT / "robots"
sys.path.insert(0, str(Path(__file__).resolve().parent))

#: Every shipped robot file, by stem.
ROBOT_FILES = {p.stem: p for p in sorted(ROBOTS.glob("*.toml"))}

#: Lines the timing test prints in the summary (pytest captures stdout).
TIMINGS: list[str] = []


@pytest.fixture(scope="session")
def robots() -> dict[str, cdpr.Robot]:
    return {name: cdpr.Robot.from_toml(path) for name, path in ROBOT_FILES.items()}


@pytest.fixture(scope="session")
def cli() -> str:
    """The `cdpr` binary: `CDPR_CLI` (the test command builds it in the same
    run and sets it), else one found under target/ or on PATH."""
    path = os.environ.get("CDPR_CLI")
    if path:
        if not Path(path).is_file():
            pytest.fail(f"CDPR_CLI={path} does not exist")
        return path
    for profile in ("wheel", "release", "debug"):
        candidate = ROOT / "target" / profile / "cdpr"
        if candidate.is_file():
            return str(candidate)
    found = shutil.which("cdpr")
    if found:
        return found
    pytest.skip("no cdpr binary: build it (cargo build -p cdpr --profile wheel) or set CDPR_CLI")


def pytest_terminal_summary(terminalreporter):
    if TIMINGS:
        terminalreporter.section("timing (printed, not asserted)")
        for line in TIMINGS:
            terminalreporter.write_line(line)
