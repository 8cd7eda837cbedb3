"""The model registry (issue 36 item 1): one entry per model, checked when registered.

Every SPEC model is registered with its kind of data, inputs (check, unit, flag), parameters and
their units; an entry that lacks any of these is refused; a model registered from a test (a
straight line F = F_0 + slope·t, fitted to an exact line) is built and fitted by the library's
own front doors with no other change.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pytest

from viscoforce.exceptions import ParameterError, SchemaError
from viscoforce.fitting import MODEL_NAMES, MODELS, fit_data, make_model
from viscoforce.fitting import _params as P
from viscoforce.fitting.base import FitModel, ModelSpec
from viscoforce.fitting.data import FitData
from viscoforce.fitting.registry import Input, ModelEntry, entries, register, unregister
from viscoforce.schema.fit import parameter_units

#: The SPEC's Models table, in its order.
SPEC_MODELS = ("svda", "exact", "contact", "prony", "relaxation", "step", "hertz", "creep",
               "ting")


def test_every_spec_model_is_registered_in_the_spec_order():
    assert tuple(MODELS) == SPEC_MODELS == MODEL_NAMES
    assert entries(data="spectrum") == ("svda", "exact", "contact", "prony")
    assert entries(data="curve") == ("relaxation", "hertz", "creep", "ting")
    assert entries(data="trajectory") == ("step",)
    assert entries(modal=True) == ("exact", "contact", "prony", "relaxation", "creep", "ting")
    assert entries(autocorrelated=True) == ("relaxation", "hertz", "creep", "ting")


@pytest.mark.parametrize("name", SPEC_MODELS)
def test_each_entry_is_complete(name):
    e = MODELS[name]
    assert e.summary and e.validity
    for i in e.inputs:
        assert callable(i.check) and i.help
    assert len(set(e.flags)) == len(e.flags)
    for modes in (1, 2) if e.modal else (1,):
        for material in e.materials or (None,):
            for p in e.parameters(modes, material):
                assert e.parameter_unit(p)


#: (model, modes, fixed inputs) that build without a problem or a trace.
BUILDABLE = [("prony", 1, {}), ("prony", 3, {}), ("relaxation", 2, {}), ("creep", 2, {}),
             ("hertz", 1, {"tip": "sphere:5um"}),
             ("contact", 1, {"radius": 1e-5, "indentation": 1e-7}),
             ("contact", 2, {"radius": 1e-5, "indentation": 1e-7, "material": "prony"}),
             ("contact", 1, {"radius": 1e-5, "indentation": 1e-7, "material": "structural"}),
             ("svda", 1, {"position": 2e-9, "radius": 1e-5, "P": 1e7, "debye_length": 1e-9})]


@pytest.mark.parametrize(("name", "modes", "fixed"), BUILDABLE)
def test_the_built_model_reports_the_entrys_parameters(name, modes, fixed):
    model = make_model(name, modes, **fixed)
    declared = set(MODELS[name].parameters(modes, fixed.get("material", "sls")
                                           if MODELS[name].materials else None))
    assert set(model.names) <= declared  # power-law's mu only with newtonian
    assert declared - set(model.names) <= {"mu"}
    assert model.autocorrelated == MODELS[name].autocorrelated


def test_a_model_takes_only_its_own_inputs():
    with pytest.raises(TypeError, match="takes no input tip"):
        make_model("prony", 1, tip="sphere:5um")
    with pytest.raises(ParameterError, match="material must be one of sls, prony, structural"):
        MODELS["ting"].check_fixed({"material": "power-law"})


# ── a model registered from a test ──────────────────────────────────────────────────────────────

def _line_model(spec: ModelSpec) -> FitModel:
    def function(t: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        return v["F_inf"] + v["baseline_slope"] * np.asarray(t, dtype=float)

    def guesser(f: np.ndarray, t: np.ndarray) -> dict[str, float]:
        slope, offset = np.polyfit(t, f, 1)
        return {"F_inf": float(offset), "baseline_slope": float(slope)}

    return FitModel(spec, function, [P.Signed("F_inf"), P.Signed("baseline_slope")], "t",
                    guesser)


@pytest.fixture
def line_model():
    e = register(ModelEntry(
        name="line", data="trajectory", summary="a straight line (a test's model)",
        build=_line_model, parameters=lambda modes, material: ["F_inf", "baseline_slope"]))
    yield e
    unregister("line")


def test_a_registered_model_is_built_and_fitted_with_no_other_change(line_model):
    t = np.linspace(0.0, 1.0, 50)
    truth = {"F_inf": 2e-9, "baseline_slope": -3e-9}
    f = truth["F_inf"] + truth["baseline_slope"] * t
    result = fit_data(FitData(t, f, None, {}), "line")
    for name, value in truth.items():
        assert float(result[name]) == pytest.approx(value, rel=1e-9, abs=1e-18)
    assert result.attrs["model"] == "line"
    assert "line" in MODELS


@pytest.mark.parametrize(("change", "match"), [
    ({"name": "prony"}, "the name is taken"),
    ({"name": "auto"}, "the name is taken"),
    ({"name": "two words"}, "must be an identifier"),
    ({"data": "image"}, "data must be one of"),
    ({"inputs": (Input("k", None, "m", "no check"),)}, "has no check"),
    ({"inputs": (Input("a", float, "", "a", "--a"), Input("b", float, "", "b", "--a"))},
     "set one input only"),
    ({"inputs": (Input("a", float, "", "a"), Input("a", float, "", "a"))}, "declared twice"),
    ({"parameters": lambda modes, material: ["F_inf", "whatsit"]}, "'whatsit' has no unit"),
    ({"cut": lambda curves, **kw: None}, "a curve model has a cut"),
])
def test_an_incomplete_entry_is_refused(change, match):
    base = {"name": "bad", "data": "trajectory", "summary": "bad", "build": _line_model,
            "parameters": lambda modes, material: ["F_inf"]}
    with pytest.raises(SchemaError, match=match):
        register(ModelEntry(**{**base, **change}))
    assert "bad" not in MODELS


def test_the_cli_offers_exactly_the_registered_models():
    from viscoforce.cli import fitting as cli

    assert cli._MODELS == (*MODELS, "auto")
    assert cli._CURVE_MODELS == entries(data="curve")


def test_parameter_units_come_from_the_schema_or_the_entry():
    assert MODELS["ting"].parameter_unit("drag") == parameter_units("drag") == "N s/m"
