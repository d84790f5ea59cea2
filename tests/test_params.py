"""Parameter declarations validate YAML and Python calls alike, with messages that say what is allowed."""

import pytest

from e2esim.errors import ConfigError, Location
from e2esim.instrument.modules import BiomassInstrument, GaussianErrorsInstrument
from e2esim.params import Param, ParamGroup, validate_section, with_defaults
from e2esim.scene.modules import CovarianceScene, ForestAGBScene

WHERE = Location("test.yaml", ("section",))


def test_python_call_is_validated_like_yaml():
    with pytest.raises(ConfigError, match=r"BiomassInstrument\(\.\.\.\): nesz_db: 'low' has the wrong type"):
        BiomassInstrument(nesz_db="low")
    with pytest.raises(ConfigError, match=r"crosstalk.level_db: 3 is out of range; expected a number with "
                                          r"-200 <= value <= 0 dB \(or null\)"):
        BiomassInstrument(crosstalk={"level_db": 3})
    with pytest.raises(ConfigError, match=r"agb_t_ha: 0 is out of range; expected a number with 0 < value <= 1000"):
        ForestAGBScene(agb_t_ha=0)


def test_missing_required_parameter_is_named():
    with pytest.raises(ConfigError, match=r"crosstalk.level_db: is required but missing"):
        GaussianErrorsInstrument(nesz_db=-27, centre_frequency_mhz=435, bandwidth_mhz=6)


def test_physics_errors_become_config_errors_at_the_module():
    with pytest.raises(ConfigError, match=r"CovarianceScene\(\.\.\.\): scattering covariance is not positive"):
        CovarianceScene(hhvv_magnitude=1.0)


def test_defaults_and_normalisation():
    p = (Param("n", "int", "count", default=3, minimum=1), Param("x", "float", "value", default=1.0),
         Param("pair", "float", "two values", default=(0.0, 1.0), length=2),
         ParamGroup("g", "group", (Param("flag", "bool", "a flag", default=False),)))
    out = validate_section(p, {"n": 1e5, "x": 2, "pair": [1, 2]}, WHERE)
    assert out == {"n": 100000, "x": 2.0, "pair": (1.0, 2.0), "g": {"flag": False}}
    assert isinstance(out["n"], int) and isinstance(out["x"], float)
    with pytest.raises(ConfigError, match=r"2.5 is not an integer"):
        validate_section(p, {"n": 2.5}, WHERE)
    with pytest.raises(ConfigError, match=r"section.pair: \[1\] has 1 items; expected a list of 2 items"):
        validate_section(p, {"pair": [1]}, WHERE)
    with pytest.raises(ConfigError, match=r"section.g.flag: 'yes' has the wrong type; expected true or false"):
        validate_section(p, {"g": {"flag": "yes"}}, WHERE)
    with pytest.raises(ConfigError, match="nan is not a finite number"):
        validate_section(p, {"x": float("nan")}, WHERE)
    with pytest.raises(ConfigError, match="true has the wrong type"):
        validate_section(p, {"x": True}, WHERE)


def test_with_defaults_changes_only_named_defaults():
    p = (Param("a", "float", "a"), ParamGroup("g", "g", (Param("b", "float", "b", default=1.0),)))
    q = with_defaults(p, {"a": 2.0, "g.b": 3.0})
    assert q[0].default == 2.0 and q[1].params[0].default == 3.0 and p[0].required
    with pytest.raises(KeyError, match="no parameters named"):
        with_defaults(p, {"c": 1})


def test_biomass_preset_defaults_come_from_the_declaration():
    m = BiomassInstrument()
    assert m.config["crosstalk"]["level_db"] == -30.0
    assert m.config["channel_imbalance"]["level_db"] == -34.0
    assert m.config["nesz_db"] == -27.0 and m.config["centre_frequency_mhz"] == 435.0
    assert m.model.crosstalk_rho13 == 0.9 and m.description.name == "BIOMASS"


def test_a_module_parameter_brings_its_lookup():
    """A parameter naming a module type looks it up through the lookup its declaring module hands in (the
    registry's), so that parameters never import the registry (no import cycle: tests/test_architecture.py)."""
    from e2esim import registry

    with pytest.raises(TypeError, match="'module' parameter needs a kind"):
        Param("estimator", "module", "d", lookup=registry.lookup)
    with pytest.raises(TypeError, match=r"'module' parameter needs a lookup \(e2esim.registry.lookup\)"):
        Param("estimator", "module", "d", kind="faraday_estimator")
    with pytest.raises(TypeError, match="needs a lookup"):
        Param("looks", "int", "d", lookup=registry.lookup)
    asked = []
    param = Param("estimator", "module", "d", kind="faraday_estimator",
                  lookup=lambda kind, name: asked.append((kind, name)) or registry.lookup(kind, name))
    assert param.validate("freeman", Location("x"))["type"] == "freeman" and asked == [("faraday_estimator", "freeman")]


def test_a_list_that_declares_it_may_be_empty_takes_the_empty_list_and_others_refuse_it():
    may = Param("names", "str", "names ([]: none)", default=None, variable_length=True, may_be_empty=True,
                nullable=True)
    assert may.validate([], WHERE) == ()
    assert may.validate(["a"], WHERE) == ("a",)
    assert may.describe_allowed() == "expected a list, each item a string (or null)"
    must = Param("names", "str", "names", default=None, variable_length=True, nullable=True)
    with pytest.raises(ConfigError, match=r"\[\] has 0 items; expected a non-empty list, each item a string"):
        must.validate([], WHERE)
