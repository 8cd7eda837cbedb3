"""Issue 22: schema._core.assemble builds what ``xr.Dataset(...)`` builds, without the merge.

The oracle is xarray's public constructor on the same inputs: identical variables, coordinates,
attributes and indexes (``xr.testing.assert_identical`` plus the index types), and the same
refusal of a dimension with two sizes.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from viscoforce.exceptions import SchemaError
from viscoforce.schema import make_spectrum
from viscoforce.schema._core import assemble


def _inputs():
    omega = np.geomspace(1.0, 1e3, 5)
    names = ["E0", "E_inf", "tau"]
    data = {
        "E0": xr.Variable((), 1e9, {"units": "Pa"}),
        "correlation": xr.Variable(("param_i", "param_j"), np.eye(3), {"units": "1"}),
        "fit_stiffness": xr.Variable(("omega",), omega * 2, {"units": "N/m"}),
        "success": xr.DataArray(np.int8(1), attrs={"flag_values": np.array([0, 1], np.int8)}),
        "identifiability": xr.Variable(("param_i",), np.zeros(3, np.int8)),
    }
    coords = {"param_i": ("param_i", names), "param_j": ("param_j", names),
              "omega": xr.Variable(("omega",), omega, {"units": "rad/s"}),
              "x": xr.Variable(("omega",), np.arange(5.0), {"units": "m"})}
    return data, coords, {"model": "svda", "nfev": 12}


def _fresh(inputs):
    data, coords, attrs = inputs
    copy = {k: (v.copy(deep=True) if hasattr(v, "copy") else v) for k, v in data.items()}
    return copy, dict(coords), dict(attrs)


def test_assemble_is_identical_to_the_public_constructor():
    data, coords, attrs = _fresh(_inputs())
    expected = xr.Dataset(data, coords=coords, attrs=attrs)
    got = assemble(*_fresh(_inputs()))
    xr.testing.assert_identical(got, expected)
    assert set(got.xindexes) == set(expected.xindexes) == {"param_i", "param_j", "omega"}
    for name in got.xindexes:
        assert type(got.xindexes[name]) is type(expected.xindexes[name])
        assert got.xindexes[name].equals(expected.xindexes[name])
    assert list(got.variables) == list(expected.variables)  # the order too (reprs, files)
    assert list(got.coords) == list(expected.coords)
    assert list(got.sizes.items()) == list(expected.sizes.items())
    # the result behaves as a dataset: selection by label, arithmetic, a round trip through dict
    assert float(got.sel(omega=got.omega[2])["fit_stiffness"]) == pytest.approx(
        float(expected["fit_stiffness"][2]))
    xr.testing.assert_identical(xr.Dataset.from_dict(got.to_dict()),
                                xr.Dataset.from_dict(expected.to_dict()))


def test_assemble_refuses_a_dimension_with_two_sizes_naming_it():
    data = {"a": xr.Variable(("omega",), np.ones(3)), "b": xr.Variable(("omega",), np.ones(4))}
    with pytest.raises(SchemaError, match="'omega' has size 3 in 'a' but 4 in 'b'"):
        assemble(data)
    with pytest.raises(ValueError):
        xr.Dataset(data)  # the public constructor refuses it too


def test_a_coordinate_named_after_one_of_its_dims_takes_the_public_path():
    """A 2-D coordinate named after one of its dims: whatever xarray makes of it."""
    data = {"a": xr.Variable(("x", "y"), np.ones((2, 2)))}
    coords = {"x": (("x", "y"), np.arange(4.0).reshape(2, 2))}
    try:
        expected = xr.Dataset(data, coords=coords)
    except ValueError:
        with pytest.raises(SchemaError):
            assemble(data, coords)
    else:
        xr.testing.assert_identical(assemble(data, coords), expected)


def test_assemble_falls_back_for_inputs_that_need_alignment():
    """A DataArray with its own coordinates goes through the public constructor (aligned)."""
    da = xr.DataArray([1.0, 2.0], dims="t", coords={"t": [0.0, 1.0]})
    got = assemble({"f": da, "g": xr.Variable(("t",), [3.0, 4.0])})
    xr.testing.assert_identical(got, xr.Dataset({"f": da, "g": ("t", [3.0, 4.0])}))


def test_spectrum_built_by_assemble_is_the_public_constructors():
    omega = np.geomspace(1.0, 1e3, 4)
    k = (1 + 0.3j) * np.arange(1.0, 9.0).reshape(2, 4)
    ds = make_spectrum(omega, k, 1e-9, 1e-9, dims=("curve", "omega"),
                       coords={"x": ("curve", [0.0, 1e-6])}, stderr={"stiffness": 0.01},
                       quality=np.zeros((2, 4), dtype=int))
    rebuilt = xr.Dataset({n: ds[n].variable for n in ds.data_vars},
                         coords={n: ds[n].variable for n in ds.coords}, attrs=ds.attrs)
    xr.testing.assert_identical(ds, rebuilt)
    assert list(ds.variables) == list(rebuilt.variables)
    assert list(ds.sizes) == list(rebuilt.sizes) == ["curve", "omega"]
    assert set(ds.xindexes) == {"omega"}


FIT_CASES = [
    ("svda", 1, {"position": 2e-9, "radius": 10e-6, "P": 1e6, "debye_length": 1e-9}),
    ("contact", 1, {"radius": 5e-6, "indentation": 5e-7}),
    ("contact", 1, {"radius": 5e-6, "indentation": 5e-7, "material": "power-law"}),
    ("prony", 2, {}),
    ("prony", "auto", {}),
]


@pytest.mark.parametrize("name, modes, fixed", FIT_CASES,
                         ids=["svda", "contact", "contact-power-law", "prony-2", "prony-auto"])
def test_every_fit_result_validates(name, modes, fixed):
    """The fitting code assembles its results unchecked (make_fit_result(check=False))."""
    import warnings

    from viscoforce.fitting.data import spectrum_data
    from viscoforce.fitting.fit import fit_data
    from viscoforce.fitting.models import make_model
    from viscoforce.schema.fit import validate_fit_result

    omega = np.geomspace(10.0, 1e5, 16)
    truth = {"svda": {"E0": 1e9, "E_inf": 2e8, "tau": 1e-3},
             "contact": {"E0": 1e4, "E_inf": 2e3, "tau": 1e-3},
             "prony": {"k_inf": 1.0, "dk_1": 2.0, "dk_2": 1.0, "tau_1": 1e-4, "tau_2": 1e-2}}[name]
    if fixed.get("material") == "power-law":
        truth = {"E0": 1e4, "E_inf": 2e3, "tau": 1e-3}
        k = make_model("contact", 1, radius=5e-6, indentation=5e-7).raw(omega, truth)
    else:
        k = make_model(name, 2 if modes == "auto" else modes, **fixed).raw(omega, truth)
    rng = np.random.default_rng(3)
    noisy = k * (1 + 0.01 * rng.standard_normal(k.shape))
    ds_in = make_spectrum(omega, noisy, 1e-7, 1e-10, stderr={"stiffness": 0.01 * np.abs(k),
                                                              "phase": 0.5})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = fit_data(spectrum_data(ds_in), name, modes=modes, **fixed)
    assert validate_fit_result(ds) is ds


def test_linear_response_spectrum_validates():
    """linear_response builds its spectrum unchecked (make_spectrum(check=False))."""
    import viscoforce as vf
    from viscoforce.schema import validate_spectrum

    problem = vf.ContactProblem.create(sphere=vf.PAPER.sphere(),
                                       surface_force=vf.paper_pressure_law(),
                                       material=vf.PAPER.material(), deepest_position=-5e-9)
    ds = vf.linear_response(problem, -5e-9, 1e-11, np.geomspace(1.0, 1e5, 8))
    assert validate_spectrum(ds) is ds


def test_the_callers_objects_are_left_alone():
    """Coordinates and extra variables given by the caller are copied, as xr.Dataset does."""
    from viscoforce.schema import make_fit_result

    x = xr.DataArray([0.0, 1e-6], dims="curve")
    omega = np.geomspace(1.0, 1e3, 4)
    ds = make_spectrum(omega, np.ones((2, 4)) * (1 + 0.3j), 1e-9, 1e-9, dims=("curve", "omega"),
                       coords={"x": x})
    assert ds["x"].attrs["units"] == "m" and x.attrs == {}
    extra = xr.Variable((), 1.0, {"units": "1"})
    fit = make_fit_result({"E0": (1e9, 1e7)}, success=True, redchi=1.0, aic=0.0, bic=0.0,
                          modes=1, model="svda", extra={"extra_value": extra})
    fit["extra_value"].attrs["long_name"] = "changed in the result"
    assert extra.attrs == {"units": "1"}


def test_two_datasets_sharing_a_parameter_index_are_independent():
    from viscoforce.schema import make_fit_result

    one, two = (make_fit_result({"E0": (v, 1.0), "tau": (1e-3, 1e-5)}, success=True, redchi=1.0,
                                aic=0.0, bic=0.0, modes=1, model="svda") for v in (1e9, 2e9))
    assert one.xindexes["param_i"] is two.xindexes["param_i"]  # shared, immutable
    one["E0"].attrs["units"] = "GPa"
    assert two["E0"].attrs["units"] == "Pa"
    assert float(two.sel(param_i="tau")["E0"]) == 2e9


@pytest.mark.parametrize("data, coords", [
    ({"a": xr.Variable(("x",), [1.0])}, {"a": ("x", [2.0])}),            # a name twice
])
def test_what_xarray_refuses_is_a_schema_error(data, coords):
    with pytest.raises(ValueError):
        xr.Dataset(data, coords=coords)
    with pytest.raises(SchemaError, match="dataset variables disagree"):
        assemble(data, coords)


def test_results_equal_the_public_constructors_on_the_same_inputs(monkeypatch):
    """make_spectrum and make_fit_result with xarray's constructor in place of assemble."""
    import viscoforce.schema.fit as fit_schema
    import viscoforce.schema.spectrum as spectrum_schema
    from viscoforce.schema import make_fit_result

    def build():
        omega = np.geomspace(1.0, 1e3, 4)
        spectrum = make_spectrum(omega, (1 + 0.3j) * np.arange(1.0, 9.0).reshape(2, 4), 1e-9,
                                 1e-9, dims=("curve", "omega"),
                                 coords={"x": ("curve", [0.0, 1e-6])},
                                 stderr={"stiffness": 0.01}, quality=np.zeros((2, 4), int))
        fit = make_fit_result({"E0": (1e9, 1e7), "tau": (1e-3, None)}, success=True,
                              redchi=1.2, aic=3.0, bic=4.0, modes=1, model="svda", omega=omega,
                              fit_stiffness=np.ones(4), fit_phase=np.full(4, 10.0),
                              extra={"chi2_pvalue": xr.Variable((), 0.5, {"units": "1"})})
        return spectrum, fit

    fast = build()

    def public(data, coords=None, attrs=None, *, fresh=()):
        return xr.Dataset(dict(data), coords=coords, attrs=attrs)

    monkeypatch.setattr(spectrum_schema, "assemble", public)
    monkeypatch.setattr(fit_schema, "assemble", public)
    for got, expected in zip(fast, build(), strict=True):
        xr.testing.assert_identical(got, expected)
        assert list(got.variables) == list(expected.variables)
        assert list(got.sizes.items()) == list(expected.sizes.items())


@pytest.mark.parametrize("dims, values", [
    ((), 1.5), ((), 3), ((), True), ((), "text"), ((), np.int8(2)), ((), np.float64(2.5)),
    ((), float("nan")), (("d",), [1, 2]), (("d",), np.arange(3.0)), ("d", ["a", "bb"]),
    ((), None), (("d",), [1, "a"]), (("d",), np.ma.masked_array([1.0, 2.0], [False, True])),
])
def test_plain_variables_equal_xarrays(dims, values):
    """plain_variable (xarray's fastpath for plain numbers and text) builds xr.Variable's
    object: same dims, dtype, values and attrs; other inputs (a masked array: its mask) take
    the public constructor."""
    from viscoforce.schema import plain_variable

    ours = plain_variable(dims, values, {"units": "Pa"})
    theirs = xr.Variable(dims, values, {"units": "Pa"})
    xr.testing.assert_identical(ours, theirs)
    assert ours.dtype == theirs.dtype


def test_fresh_extra_variables_are_taken_over_and_others_copied():
    from viscoforce.schema import make_fit_result

    def build(fresh_extra):
        extra = {"chi2_pvalue": xr.Variable((), 0.5, {"units": "1"})}
        ds = make_fit_result({"E0": (1e9, 1e7)}, success=True, redchi=1.0, aic=1.0, bic=1.0,
                             modes=1, model="svda", extra=extra, fresh_extra=fresh_extra)
        ds["chi2_pvalue"].attrs["note"] = "changed"
        return "note" in extra["chi2_pvalue"].attrs

    assert build(True) and not build(False)


def test_a_shared_parameter_coordinate_keeps_its_attributes_apart():
    """The cached param_i variable is copied per dataset: attributes set on one stay there."""
    from viscoforce.schema import make_fit_result

    one, two = (make_fit_result({"E0": (1e9, 1.0), "tau": (1e-3, 1e-5)}, success=True,
                                redchi=1.0, aic=0.0, bic=0.0, modes=1, model="svda")
                for _ in range(2))
    one["param_i"].attrs["long_name"] = "changed in one"
    assert "long_name" not in two["param_i"].attrs
    # a text coordinate with attributes keeps them (no cached variable for it)
    ds = assemble({"a": xr.Variable(("param_i",), [1.0, 2.0])},
                  {"param_i": xr.Variable(("param_i",), ["E0", "tau"], {"long_name": "p"})})
    expected = xr.Dataset({"a": ("param_i", [1.0, 2.0])},
                          coords={"param_i": ("param_i", ["E0", "tau"], {"long_name": "p"})})
    xr.testing.assert_identical(ds, expected)
    # and one with an encoding keeps it
    labels = xr.Variable(("param_i",), ["E0", "tau"], encoding={"dtype": "S1"})
    ds = assemble({"a": xr.Variable(("param_i",), [1.0, 2.0])}, {"param_i": labels})
    assert ds["param_i"].encoding == {"dtype": "S1"}
    assert "dtype" not in make_fit_result(
        {"E0": (1e9, 1.0), "tau": (1e-3, 1e-5)}, success=True, redchi=1.0, aic=0.0, bic=0.0,
        modes=1, model="svda")["param_i"].encoding


@pytest.mark.parametrize("coords", [
    {"omega": np.geomspace(1.0, 1e3, 5)},                                  # float index
    {"omega": np.geomspace(1.0, 1e3, 5).astype(np.float32)},               # float32 index
    {"omega": np.arange(5)},                                               # integer index
    {"omega": ["a", "b", "c", "d", "e"]},                                  # text index
    {"omega": np.geomspace(1.0, 1e3, 5), "x": ("omega", np.arange(5.0))},  # not an index
])
def test_index_values_equal_the_variables_values(coords):
    from viscoforce.schema import index_values

    ds = xr.Dataset({"k": ("omega", np.ones(5))}, coords=coords)
    for name in ds.coords:
        got, expected = index_values(ds, str(name)), ds.variables[name].values
        assert got.dtype == expected.dtype
        np.testing.assert_array_equal(got, expected)
        assert not got.flags.writeable  # a view of the dataset's memory
    if "x" in ds.coords:  # the dataset's own array stays writable, and the view follows it
        view = index_values(ds, "x")
        ds.variables["x"].values[0] = 7.0
        assert view[0] == 7.0


def test_parameter_names_read_from_the_index_from_a_file_and_without_one(tmp_path):
    from viscoforce.schema import make_fit_result, parameter_names

    fit = make_fit_result({"E0": (1e9, 1.0), "E_inf": (1e8, 1.0), "tau": (1e-3, 1e-5)},
                          success=True, redchi=1.0, aic=0.0, bic=0.0, modes=1, model="svda")
    expected = ["E0", "E_inf", "tau"]
    assert parameter_names(fit) == expected
    fit.to_netcdf(tmp_path / "fit.nc", engine="scipy")
    with xr.open_dataset(tmp_path / "fit.nc", engine="scipy") as read:
        assert parameter_names(read) == expected
    assert parameter_names(fit.drop_indexes("param_i")) == expected
