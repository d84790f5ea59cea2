"""``e2esim reproduce ahmed2014``: every published value of Ahmed, Siqueira & Hensley (2014) listed in
issue 6 is recomputed from the paper's equations and inputs; reproduced or an explained discrepancy."""

import json
import math

import pytest

import e2esim.verification.published  # noqa: F401  (first: the *_values modules import it back)
from e2esim.cli import main
from e2esim.verification.ahmed2014_values import PUBLISHED
from e2esim.verification.reproduce import check

IDS = {
    "ahmed2014.table3.range_resolution_m": ("discrepancy", 299_792_458 / 160e6),
    "ahmed2014.table3.azimuth_resolution_m": ("reproduced", 0.75),
    "ahmed2014.table3.broadening_factor": ("discrepancy", 1.6363 - 0.6363 * math.sqrt(0.7)),
    "ahmed2014.table3.slc_pixel_area_m2": ("discrepancy", 299_792_458 / 160e6 * 0.75),
    "ahmed2014.table4.looks": ("discrepancy", 10_000 * math.sin(math.radians(40))
                               / ((1.6363 - 0.6363 * math.sqrt(0.7)) ** 2 * 299_792_458 / 160e6 * 0.75)),
    "ahmed2014.table4.dem_pointing_error": ("discrepancy", 3 / 16_322 * 1e3),
    "ahmed2014.table4.slope_error": ("reproduced", 0.1 / (1 + math.tan(math.radians(3)) ** 2)),
    "ahmed2014.sec3a.looks_subplot": ("discrepancy", 625 * math.sin(math.radians(40)) / (1.45**2 * 1.6 * 0.66)),
    "ahmed2014.sec3a.looks_hectare": ("discrepancy", 10_000 * math.sin(math.radians(40)) / (1.45**2 * 1.6 * 0.66)),
}


def test_all_issue_ids_are_listed():
    assert {p.id for p in PUBLISHED} == set(IDS)
    assert all(p.known_discrepancy for p in PUBLISHED if IDS[p.id][0] == "discrepancy")


@pytest.mark.parametrize("record", PUBLISHED, ids=lambda p: p.id)
def test_computed_values_and_status(record):
    status, hand = IDS[record.id]
    result = check(record)
    assert result.computed == pytest.approx(hand, rel=1e-12)
    assert result.status == status, result.note


def test_table3_values_follow_from_c_3e8_and_linear_eta():
    """The printed Table III/IV numbers are what eqs. (22)-(25) give with c = 3e8 m/s and
    kappa = 1.6363 - 0.6363 eta: the equations are implemented right, the table used other inputs."""
    from e2esim.verification.ahmed2014 import _table3_looks

    assert 3e8 / 160e6 == pytest.approx(1.875)
    assert round(_table3_looks(1.6363 - 0.6363 * 0.7, 3e8)) == 3223


def test_reproduce_cli_json_lists_every_id(capsys):
    assert main(["reproduce", "ahmed2014", "--json"]) == 0
    out = capsys.readouterr().out
    records = json.loads(out)
    records = records if isinstance(records, list) else records["checks"]
    assert {r["id"]: r["status"] for r in records} == {k: v[0] for k, v in IDS.items()}
