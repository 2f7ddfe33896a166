"""The stability cases of the report, each on its own: the run ends as expected and its oracle holds.

The cases and their oracles live in :mod:`castrajectory.cli.stability` (one list for the report and
for these tests); here each is run and asserted, so a case that the report would show as failed
fails a test, and the table's rendering of a failure is checked on a case made to fail."""
import dataclasses
import math

import pytest

from castrajectory.cli import stability


@pytest.mark.parametrize("case", [pytest.param(c, marks=pytest.mark.slow) if c.slow else c for c in stability.CASES],
                         ids=[f"{c.family}: {c.title}" for c in stability.CASES])
def test_stability_case(case):
    row = stability.run_case(case)
    assert row.passed, (row.status, row.error, row.tolerance, row.what)
    if case.expect == "no_stable_drop":  # the verdict, not a failure: shown as such in the table
        assert row.status == "No_Stable_Drop" and "no stable drop" in stability.table([row])[-1]
    if case.expect == "solve":
        assert row.success and row.error <= row.tolerance


def test_every_family_has_cases():
    families = {c.family for c in stability.CASES}
    assert {"droplet", "stiff spring", "pendulum", "contact", "rigid body"} <= families


def test_a_failed_oracle_is_shown_as_failed():
    """A converged run whose oracle misses is a failed row (the tolerance made impossible here)."""
    case = next(c for c in stability.CASES if c.family == "droplet")
    strict = dataclasses.replace(case, check=lambda d: (float(d["errors"]["contact_angle"]), 0.0, "impossible"))
    row = stability.run_case(strict)
    assert row.success and not row.passed
    line = stability.table([row])[-1]
    assert "FAILED: oracle missed" in line
    assert math.isfinite(row.error)
