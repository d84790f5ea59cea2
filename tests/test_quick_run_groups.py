"""The quick runs of the shipped scenarios are split into two pytest-xdist groups (tests/quick_runs.py GROUP,
tests/conftest.py): every test that reads quick runs is in the group of the scenarios it reads, so that each
scenario is run once per session whichever worker runs its group."""

from conftest import _scenarios_used

from quick_runs import GROUP, quick_run_group, scenario_names


def test_group_names_are_shipped_scenarios():
    assert set(GROUP) <= set(scenario_names()), set(GROUP) - set(scenario_names())
    assert set(GROUP.values()) == {"b"}


def test_a_test_reading_several_quick_runs_reads_them_from_one_group(request):
    items = [item for item in request.session.items if "quick_run" in getattr(item, "fixturenames", ())]
    for item in items:
        used = _scenarios_used(item)
        assert len({quick_run_group([name]) for name in used}) <= 1, (item.nodeid, used)


def test_the_groups_of_the_tests_that_read_named_quick_runs():
    assert quick_run_group(["biomass_default"]) == "quick_runs_a"
    assert quick_run_group(["nisar_lband", "biomass_default"]) == "quick_runs_b"
    assert quick_run_group([]) == "quick_runs_a"
