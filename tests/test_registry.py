"""The module registry: entry points, direct class paths, errors that list the valid names."""

import pytest

from e2esim import registry
from e2esim.errors import ModuleLookupError


def test_builtins_register_through_the_entry_point_group():
    regs = registry.available()
    assert {r.kind for r in regs} >= {"scene", "instrument", "ionosphere", "propagation", "retrieval", "requirement"}
    assert all(r.distribution.lower() == "e2esim" for r in regs if r.cls.__module__.startswith("e2esim."))
    assert registry.lookup("instrument", "biomass").__name__ == "BiomassInstrument"
    ranks = [registry.kind(r.kind).order for r in regs]
    assert ranks == sorted(ranks)  # e2esim's own kinds in section order, then the others
    assert registry.kinds()[-1] == "faraday_estimator"
    assert registry.lookup("faraday_estimator", "chirp_slope").ambiguous is False


def test_unknown_type_lists_the_valid_names():
    with pytest.raises(ModuleLookupError,
                       match="unknown scene type 'forest'; registered scene types: agb_map, covariance"):
        registry.lookup("scene", "forest")


def test_package_module_class_syntax():
    cls = registry.lookup("scene", "e2esim.scene.modules:Table1ForestScene")
    assert cls.type_name == "table1_forest"
    with pytest.raises(ModuleLookupError, match="is a scene module, not a instrument module"):
        registry.lookup("instrument", "e2esim.scene.modules:Table1ForestScene")
    with pytest.raises(ModuleLookupError, match="cannot import"):
        registry.lookup("scene", "e2esim.nowhere:Thing")
    with pytest.raises(ModuleLookupError, match="not an e2esim Module subclass"):
        registry.lookup("scene", "e2esim.scene.covariance:ScatteringCovariance")


def test_a_run_imports_the_modules_its_chain_names_only():
    """e2esim's own module classes are imported when a scenario names them (issue 28: the fixed cost of a run):
    resolving a one-stage chain leaves the campaign, the product readers and the scintillation screens unimported."""
    import subprocess
    import sys

    code = ("import sys\nfrom e2esim.runner.scenario import Scenario\n"
            "Scenario({'name': 't', 'scene': {'type': 'table1_forest'}, 'instrument': {'type': 'biomass'}, "
            "'ionosphere': {'type': 'gaussian_faraday', 'sd_deg': 5.0}, "
            "'propagation': {'type': 'hv_backscatter_error'}}, 'test').resolve()\n"
            "print(sorted(m for m in sys.modules if m.startswith(('e2esim.campaign', 'e2esim.products_io.biomass', "
            "'e2esim.scintillation'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out
    assert registry.lookup("propagation", "hv_backscatter_error").type_name == "hv_backscatter_error"


def test_e2esim_run_reaches_its_first_stage_without_matplotlib_or_asyncio(tmp_path):
    """What ``e2esim run`` imports before the run (the command, the scenario, the report's text for the verdict
    lines) leaves matplotlib to the thread that imports it while the run computes, and asyncio (tqdm.auto's) out
    (issue 28: the start-up every command pays)."""
    import subprocess
    import sys
    from pathlib import Path

    scenario = Path(__file__).resolve().parents[1] / "scenarios" / "biomass_default.yaml"
    code = ("import sys\nimport e2esim.runner.folder_run as folder_run\n"
            "def first_stage(*args, **kwargs):\n"
            "    print(sorted(m for m in ('asyncio', 'dask', 'matplotlib', 'pandas', 'xarray') if m in sys.modules))\n"
            "    raise SystemExit(0)\n"
            "folder_run.run_into_folder = first_stage\n"
            f"from e2esim.cli import main\nmain(['run', {str(scenario)!r}, '-o', {str(tmp_path / 'run')!r}])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out
