"""Issue 21 item 3: E′, E″, G′, G″ per frequency of a measured spectrum, with stderr."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from viscoforce.cli import main
from viscoforce.exceptions import ModelValidityError, ParameterError
from viscoforce.experiments.moduli import add_complex_modulus
from viscoforce.physics.materials import StandardLinearSolid
from viscoforce.physics.tips import Cone, Paraboloid
from viscoforce.schema import make_spectrum

OMEGA = 2 * np.pi * np.geomspace(1.0, 300.0, 6)
MAP = Path(__file__).resolve().parents[2] / "data_examples" / "real" / "modulation-map.jpk-force-map"


def _spectrum(tip, depth=400e-9, drag=0.0):
    modulus = 1.0 / StandardLinearSolid(5e3, 1e3, 0.01).complex_compliance(OMEGA)
    k = modulus * float(tip.contact_stiffness_factor(depth)) + 1j * OMEGA * drag
    spec = make_spectrum(OMEGA, k, np.full(OMEGA.size, 1e-9), 1e-8,
                         stderr={"stiffness": 0.01 * np.abs(k),
                                 "phase": np.full(OMEGA.size, np.degrees(0.01))},
                         mean_indentation=np.full(OMEGA.size, depth))
    return spec, modulus


@pytest.mark.parametrize("tip", [Paraboloid(5e-6), Cone.from_degrees(35)], ids=["hertz", "cone"])
@pytest.mark.parametrize("nu", [0.5, 0.3])
def test_storage_and_loss_moduli_equal_the_material_law(tip, nu):
    spec, modulus = _spectrum(tip)
    ds = add_complex_modulus(spec, tip, poisson=nu)
    young = modulus * (1 - nu**2) / 2
    np.testing.assert_allclose(ds["E_storage"].values, young.real, rtol=1e-12)
    np.testing.assert_allclose(ds["E_loss"].values, young.imag, rtol=1e-12)
    np.testing.assert_allclose(ds["G_storage"].values, young.real / (2 * (1 + nu)), rtol=1e-12)
    # 1 % radial and 1 % tangential error: each part's stderr is 1 % of |Y*|
    np.testing.assert_allclose(ds["E_storage_stderr"].values, 0.01 * np.abs(young), rtol=1e-12)
    assert ds.attrs["tip_shape"] == tip.shape and ds.attrs["poisson"] == nu


def test_drag_is_subtracted_once():
    tip = Paraboloid(5e-6)
    spec, modulus = _spectrum(tip, drag=1e-6)
    ds = add_complex_modulus(spec, tip, drag=1e-6)
    np.testing.assert_allclose(ds["E_loss"].values, (modulus * 3 / 8).imag, rtol=1e-10)
    with pytest.raises(ParameterError, match="already had a drag"):
        add_complex_modulus(spec.assign_attrs(drag=1e-6), tip, drag=1e-6)


def test_refusals():
    spec, _ = _spectrum(Paraboloid(5e-6))
    with pytest.raises(ModelValidityError, match="needs the operating indentation"):
        add_complex_modulus(spec.drop_vars("mean_indentation"), "sphere:5um")
    with pytest.raises(ParameterError, match=r"poisson must be in \[0, 0.5\]"):
        add_complex_modulus(spec, "sphere:5um", poisson=0.6)


@pytest.mark.skipif(not MAP.is_file(), reason="bundled real map missing")
def test_load_adds_the_moduli_of_the_real_map(tmp_path, capsys):
    out = tmp_path / "map.nc"
    assert main(["load", str(MAP), "--tip", "sphere:10um", "--out", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert {"E_storage", "E_loss", "G_storage", "G_loss", "E_loss_stderr"} <= set(
        info["variables"])
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        good = ds["quality"].values == 0
        assert np.all(np.isfinite(ds["E_storage"].values[good]))
        assert np.all(ds["E_loss"].values[good] > 0)  # passive: phase in (0, 90°)
        assert ds["E_storage"].attrs["units"] == "Pa"
    assert main(["load", str(MAP), "--poisson", "0.4"]) == 2


@pytest.mark.skipif(not MAP.is_file(), reason="bundled real map missing")
def test_bode_modulus_panel(tmp_path, capsys):
    out = tmp_path / "bode.png"
    assert main(["bode", str(MAP), "--curve", "0", "--tip", "cone:35", "--modulus",
                 "--out", str(out)]) == 0
    assert out.stat().st_size > 10_000
    assert main(["bode", str(MAP), "--curve", "0", "--modulus", "--out", str(out)]) == 2
    assert "--modulus needs --tip" in capsys.readouterr().err


def test_bode_plot_modulus_needs_the_moduli():
    from viscoforce.plotting import bode_plot

    spec, _ = _spectrum(Paraboloid(5e-6))
    with pytest.raises(ParameterError, match="modulus=True needs exactly one spectrum with"):
        bode_plot(spec, modulus=True)
    handle = bode_plot(add_complex_modulus(spec, Paraboloid(5e-6)), modulus=True)
    assert len(handle.axes) == 3 and "Young's modulus" in handle.axes[2].get_ylabel()
