"""The published-value checks can fail (issue 15, defect 9): a known discrepancy pins the value e2esim
computes, the pooled Table II records catch a 4 % error in the analytic variance, and the Table 1 records
say which assumptions were fitted to Table 1 itself and how far plausible alternatives move each edge."""

import dataclasses
import math

import pytest

from e2esim.verification import men2021
from e2esim.verification.published import all_published
from e2esim.verification.reproduce import check

PUBLISHED = {p.id: p for p in all_published()}


def test_every_discrepancy_pins_its_computed_value():
    for p in PUBLISHED.values():
        if p.known_discrepancy:
            assert p.expected_computed is not None, p.id
            assert 0 < p.computed_tolerance <= 1.01e-6 * abs(p.expected_computed), p.id


@pytest.mark.parametrize("id_", ["men2021.fig5.channel_imbalance_limit_db", "ahmed2014.table3.broadening_factor"])
def test_a_discrepancy_turns_failed_when_the_computed_value_moves(monkeypatch, id_):
    entry = PUBLISHED[id_]
    record = check(entry)
    assert record.status == "discrepancy" and record.expected_computed == entry.expected_computed
    assert "Pinned: e2esim computes" in record.note
    module_name, _, func = entry.compute.partition(":")
    module = __import__(module_name, fromlist=[func])
    original = getattr(module, func)
    for shift in (1e-3, math.nan):  # a regression of 0.1 %, or NaN
        def broken(rec, shift=shift):
            value, tol, note = original(rec)
            return value * (1 + shift), tol, note

        monkeypatch.setattr(module, func, broken)
        moved = check(entry)
        assert moved.status == "failed", (shift, moved)
        assert "REGRESSION" in moved.note


def test_a_discrepancy_without_a_pin_is_failed():
    entry = dataclasses.replace(PUBLISHED["men2021.fig1.system_bias_lower"], expected_computed=None)
    record = check(entry)
    assert record.status == "failed" and "No computed value is pinned" in record.note


def _pooled_and_rows(monkeypatch, variance_factor: float) -> tuple:
    original = men2021.hv_error_moments

    def perturbed(*args, **kwargs):
        m = original(*args, **kwargs)
        return dataclasses.replace(m, variance=m.variance * variance_factor)

    monkeypatch.setattr(men2021, "hv_error_moments", perturbed)
    men2021.table2_case.cache_clear()
    try:
        pooled = check(PUBLISHED["men2021.table2.pooled.var_rel_diff"])
        rows = [check(PUBLISHED[f"men2021.table2.row{i:02d}.var_rel_diff"]) for i in range(1, 11)]
    finally:
        men2021.table2_case.cache_clear()
    return pooled, rows


def test_pooled_table2_record_catches_a_4_percent_error_in_the_analytic_variance(monkeypatch):
    pooled, rows = _pooled_and_rows(monkeypatch, 1.0)
    assert pooled.status == "reproduced" and pooled.tolerance < 1.6  # 3 SE of the pooled mean, in percent
    assert all(r.status == "reproduced" for r in rows)

    pooled, rows = _pooled_and_rows(monkeypatch, 1.04)
    assert pooled.status == "failed"
    assert pooled.computed == pytest.approx(-100 * 0.04 / 1.04, abs=1.0)  # every row shifts by about -3.8 %
    assert sum(r.status == "failed" for r in rows) < 10  # one row at a time cannot see it reliably


def test_table1_notes_name_the_fitted_assumptions_and_the_spread():
    record = check(PUBLISHED["quegan2018.table1.snr10_L100.south"])
    assert record.status == "reproduced"
    assert "FITTED TO TABLE 1 ITSELF" in record.note and "partly by construction" in record.note
    assert "between -1.93 and 1.07 deg N (spread 3.00 deg)" in record.note
