"""The timing comparison (printed in the run's summary, not asserted):
the package, the `cdpr solve` CLI and the numpy reference, per pose."""

from __future__ import annotations

from conftest import TIMINGS
from timing import compare


def test_timing_is_printed(cli):
    TIMINGS.extend(compare(k=10_000, numpy_k=500, cli=cli))
