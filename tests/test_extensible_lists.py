"""Kinds, composites, plot types and units are registered, not listed in e2esim (issue 27, Build 6): a plug-in
defined here adds a stage kind with its section order, a composite list section, a plot type and the units of its
output scalars, through the entry-point groups e2esim.kinds, e2esim.modules and e2esim.plots. Bad declarations are
left out with a message that names the plug-in and says what is wrong. The plug-ins are fake distributions (a
package and its .dist-info folder) on PYTHONPATH, as in tests/test_hostile_plugins.py."""

import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from e2esim import registry
from e2esim.kinds import Kind
from e2esim.products import Product
from e2esim.settings import SIMULATION_PARAMS, SimulationSettings

GOOD = '''
from dataclasses import dataclass

from e2esim.kinds import Kind
from e2esim.module import Module, Stage
from e2esim.params import Param
from e2esim.products import Product


@dataclass(frozen=True)
class Echo:
    strength: float

    def scalars(self):
        return {"strength": self.strength, "gain_db": 3.0}


@dataclass(frozen=True)
class Checks:
    passed: int

    def scalars(self):
        return {"passed": float(self.passed)}


ECHO = Product("regplug.echo", Echo, "an echo of the case", scalars="echo", units=(("strength", "W"),))
CHECKS = Product("regplug.checks", Checks, "how many thresholds the echo exceeds", scalars="checks",
                 units=(("passed", "count"),))


class ConstantEcho(Stage):
    kind = "echo"
    type_name = "constant"
    summary = "an echo of fixed strength"
    params = (Param("strength", "float", "echo strength", unit="W", default=1.0, minimum=0.0),)
    provides = (ECHO,)

    def forward(self, case):
        return {"regplug.echo": Echo(self.si["strength"])}


class Threshold(Module):
    kind = "check"
    type_name = "threshold"
    summary = "a threshold on the echo"
    params = (Param("limit", "float", "threshold", unit="W", default=1.0),)


class CheckSet:
    """The checks list as one stage: counts the thresholds the echo exceeds."""

    kind = "check"
    provides = (CHECKS,)
    needs = ("regplug.echo",)
    uses = ()

    def __init__(self, modules, location):
        self.modules, self.location = tuple(modules), location

    @property
    def identity(self):
        return "the checks"

    def forward(self, case):
        strength = case["regplug.echo"].strength
        return {"regplug.checks": Checks(sum(strength > m.si["limit"] for m in self.modules))}


class Scale(Module):
    kind = "tweak"
    type_name = "scale"
    summary = "scales the echo"
    params = (Param("factor", "float", "factor", default=1.0),)


class Tweaks:
    """The echo stage with the tweaks list: they change the echo before any other stage sees it."""

    kind = "tweak"

    def __init__(self, modules, location):
        self.echo, self.tweaks = modules[0], tuple(modules[1:])
        self.modules, self.location = tuple(modules), location
        self.provides, self.needs, self.uses = self.echo.provides, self.echo.needs, self.echo.uses

    @property
    def identity(self):
        return "the tweaked echo"

    def forward(self, case):
        strength = self.echo.forward(case)["regplug.echo"].strength
        for tweak in self.tweaks:
            strength *= tweak.si["factor"]
        return {"regplug.echo": Echo(strength)}


TWEAK_KIND = Kind("tweak", "changes to the echo", 47, "tweaks", composite=Tweaks, absorbs="regplug.echo")
ECHO_KIND = Kind("echo", "an echo between the ionosphere and the calibration", 45, "echo", many=False)
CHECK_KIND = Kind("check", "thresholds on the echo, one stage", 85, "checks", composite=CheckSet)


def plot_echo(result, folder, options):
    (folder / "echo.txt").write_text("echo")
    return [("echo.txt", "The echo of every case.")]
'''

BAD = '''
from e2esim.kinds import Kind
from e2esim.products import Product

LATE = Kind("late", "a kind whose order is no number", "soon", "late")
TAKEN = Kind("taken", "a kind that wants the output section", 1, "output")
LONELY = Kind("lonely", "a composite that is no stage", 1, "lonely", composite="CheckSet")
'''

ENTRY_POINTS = {
    "regplug": ("[e2esim.modules]\necho.constant = regplug:ConstantEcho\ncheck.threshold = regplug:Threshold\n"
                "tweak.scale = regplug:Scale\n"
                "[e2esim.kinds]\necho = regplug:ECHO_KIND\ncheck = regplug:CHECK_KIND\ntweak = regplug:TWEAK_KIND\n"
                "[e2esim.plots]\necho_strength = regplug:plot_echo\n"),
    "regbad": ("[e2esim.kinds]\nlate = regbad:LATE\ntaken = regbad:TAKEN\nlonely = regbad:LONELY\n"
               "orbit = regbad:LATE\n[e2esim.plots]\necho_broken = regbad:nothing_here\n"),
}

SCENARIO = """
scene: {type: table1_forest, forest: boreal_200}
instrument: {type: biomass}
echo: {type: constant, strength: 2.5}
checks:
  - {type: threshold, limit: 1}
  - {type: threshold, limit: 5}
tweaks: [{type: scale, factor: 1.5}, {type: scale, factor: 0.8}]
simulation: {mode: analytic}
output: {plots: [echo_strength, echo_broken]}
"""


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    site = tmp_path_factory.mktemp("site")
    for name, body in (("regplug", GOOD), ("regbad", BAD)):
        (site / name).mkdir()
        (site / name / "__init__.py").write_text(body)
        info = site / f"{name}-0.1.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
        (info / "entry_points.txt").write_text(ENTRY_POINTS[name])
    return site


def _e2esim(site: Path, *args, cwd=None):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-m", "e2esim", *args], capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=300)


def test_a_plugin_adds_a_kind_a_composite_a_plot_and_its_units(site, tmp_path):
    """The echo section sits by its order between the ionosphere and the calibration; the checks list is one
    stage; the tweaks list takes in the echo stage and changes its product before the checks see it; the plot type
    is drawn; the echo's scalars carry the units its product declares. The broken
    declarations of regbad are named, and everything else works."""
    (tmp_path / "s.yaml").write_text(SCENARIO)
    run = _e2esim(site, "run", "s.yaml", "-o", "out", "--no-progress", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    results = summary["cases"][0]["results"]
    assert results["echo.strength"] == 2.5 * 1.5 * 0.8  # tweaked, in order
    assert results["checks.passed"] == 1.0  # 3 W exceeds 1 W, not 5 W
    with h5py.File(tmp_path / "out" / "results.h5") as f:
        units = {name: f["cases/results"][name].attrs["units"] for name in ("echo.strength", "echo.gain_db",
                                                                               "checks.passed", "scene.sigma_hv")}
    units = {k: v.decode() if isinstance(v, bytes) else v for k, v in units.items()}
    assert units == {"echo.strength": "W", "echo.gain_db": "dB", "checks.passed": "count", "scene.sigma_hv": "m^2/m^2"}
    assert (tmp_path / "out" / "echo.txt").read_text() == "echo"
    problems = {
        "late": "kind 'late': order 'soon' is not a number",
        "taken": "kind 'taken': section 'output' is reserved (name, description, plugins, simulation, sweep, output)",
        "lonely": "kind 'lonely': composite 'CheckSet' is not callable (members, where) -> Stage",
        "orbit": "the entry point is named 'orbit' but declares the kind 'late'",
    }
    for name, problem in problems.items():
        value = {"orbit": "LATE"}.get(name, name.upper())
        assert (f"plug-in regbad, entry point {name} of e2esim.kinds = regbad:{value}, is not available: {problem}; "
                "e2esim goes on without it") in run.stderr
    assert ("plot echo_broken: not drawn: plot type 'echo_broken' of the plug-in regbad (regbad:nothing_here) could "
            "not be loaded") in run.stderr

    validate = _e2esim(site, "validate", "s.yaml", cwd=tmp_path)
    assert validate.returncode == 0, validate.stderr
    assert ("modules: scene=table1_forest, instrument=biomass, ionosphere=constant_faraday, echo=constant, "
            "tweak=scale, tweak=scale, propagation=hv_backscatter_error, retrieval=power_law, check=threshold, "
            "check=threshold") in validate.stdout


@pytest.mark.parametrize("change, message", [
    (("checks:\n  - {type: threshold, limit: 1}\n  - {type: threshold, limit: 5}\n", "checks: {type: threshold}\n"),
     "s.yaml:5: checks: is not a list; expected a list of check sections, each with a type"),
    (("echo: {type: constant, strength: 2.5}\n", ""),
     "s.yaml:7: tweaks: the tweaks list refines 'regplug.echo', which no stage of this chain provides; add a section "
     "with one of echo.constant"),
    (("echo_broken", "echo_missing"),
     "s.yaml:10: output.plots[1]: 'echo_missing' is not allowed (did you mean 'echo_strength'?); expected a "
     "non-empty list, each item one of 'auto', 'agb_error_vs_faraday_difference', "),
    (("echo: {type: constant, strength: 2.5}", "echo: {type: threshold}"),
     "s.yaml:4: echo.type: unknown echo type 'threshold'; registered echo types: constant"),
])
def test_bad_input_to_a_plugins_sections_is_a_clear_error(site, tmp_path, change, message):
    (tmp_path / "s.yaml").write_text(SCENARIO.replace(*change))
    proc = _e2esim(site, "validate", "s.yaml", cwd=tmp_path)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert message in proc.stderr, proc.stderr


def test_a_products_units_must_be_pairs_of_pattern_and_unit():
    with pytest.raises(ValueError, match=r"product 'x\.y': units must be a tuple of \(pattern, unit\) text pairs"):
        Product("x.y", object, "d", scalars="y", units={"a": "W"})
    with pytest.raises(ValueError, match=r"product 'x\.y': units pattern '\(a' is not a regular expression"):
        Product("x.y", object, "d", scalars="y", units=(("(a", "W"),))


def test_a_product_gives_the_units_of_its_own_scalars_only():
    product = Product("x.y", object, "d", scalars="y", units=(("power", "W"), (r"band\.\w+", "Hz")))
    assert product.unit_of("y.power") == "W" and product.unit_of("y.band.low") == "Hz"
    assert product.unit_of("z.power") is None and product.unit_of("y.other") is None


def test_kind_declarations_say_what_is_wrong():
    assert Kind("echo", "d", 45, "echo").problem("echo") is None
    assert Kind("echo", "d", 45, "echo").problem("ech") == ("the entry point is named 'ech' but declares the kind "
                                                            "'echo'")
    assert Kind("echo", "d", 45, "echo", default={"kind": "x"}).problem() == (
        "kind 'echo': default {'kind': 'x'} is not a section with a type")
    assert Kind("echo", "d", 45, "echo", many=False, composite=list).problem() == (
        "kind 'echo': a composite section holds a list (many=True)")
    assert Kind("2echo", "d", 45).problem() == "kind name '2echo' is not a name (e.g. 'interferometry')"
    assert Kind("echo", "d", 45, "echo", absorbs="x").problem() == (
        "kind 'echo': absorbs 'x' needs a composite and a product name")


def test_e2esims_own_lists_are_registered():
    """Kinds, their section order, defaults and composites, and the plot types come from the entry points."""
    kinds = {k.name: k for k in registry.section_kinds("e2esim")}
    assert [k.section for k in kinds.values()] == ["orbit", "scene", "instrument", "ionosphere", "calibration",
                                                   "propagation", "error_terms", "retrieval", "requirements"]
    assert [k.name for k in kinds.values() if k.required] == ["scene", "instrument"]
    assert {k.name: k.default["type"] for k in kinds.values() if k.default} == {
        "ionosphere": "constant_faraday", "propagation": "hv_backscatter_error", "retrieval": "power_law"}
    assert kinds["calibration"].composite.__name__ == "CalibrationStrategy" and kinds["calibration"].always
    assert kinds["requirement"].composite.__name__ == "RequirementSet" and not kinds["requirement"].always
    assert kinds["error_terms"].absorbs == "backscatter.error" and not kinds["error_terms"].always
    assert {"verdicts", "error_budget", "global_maps", "tradeoff"} <= set(registry.plot_types("e2esim"))
    assert all(callable(registry.plot(name)) for name in registry.plot_types("e2esim"))


def test_each_simulation_setting_is_declared_once():
    """The parameters of the simulation section are the fields of SimulationSettings, with their defaults."""
    assert [p.name for p in SIMULATION_PARAMS] == list(SimulationSettings.__dataclass_fields__)
    assert {p.name: p.default for p in SIMULATION_PARAMS} == vars(SimulationSettings())
