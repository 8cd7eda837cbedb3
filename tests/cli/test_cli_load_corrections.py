"""``load`` corrections on a spectrum that already exists (CSV) and drag from several heights."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr

from viscoforce.cli import main

FREQ = np.array([1.0, 3.0, 10.0, 30.0, 100.0, 300.0])
OMEGA = 2 * np.pi * FREQ
ETA, A_EFF, H_EFF = 1e-3, 12e-6, 1.5e-6  # water, effective radius and height [m]


def _drag(h):
    return 6 * np.pi * ETA * A_EFF**2 / (h + H_EFF)


def _write_spectrum(path, k, rel_err=0.01):
    stiffness, phase = np.abs(k), np.degrees(np.angle(k))
    rows = ["frequency (Hz),stiffness (N/m),phase (deg),stiffness_stderr (N/m),phase_stderr (deg)"]
    rows += [f"{float(f)!r},{float(s)!r},{float(p)!r},{float(rel_err * s)!r},{math.degrees(rel_err)!r}"
             for f, s, p in zip(FREQ, stiffness, phase, strict=True)]
    path.write_text("\n".join(rows) + "\n")


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_drag_heights_extrapolate_to_contact_and_are_subtracted(tmp_path, capsys):
    heights = np.array([1e-6, 2e-6, 4e-6, 8e-6])
    files = []
    for h in heights:  # out of contact: a small elastic part plus the viscous drag
        path = tmp_path / f"free_{h * 1e6:g}um.csv"
        _write_spectrum(path, 1e-4 + 1j * OMEGA * _drag(h), rel_err=1e-4)
        files.append(f"{h}m={path}")
    contact = 0.02 * (1 + 0.1j) + 1j * OMEGA * _drag(0.0)
    data = tmp_path / "contact.csv"
    _write_spectrum(data, contact)
    out_nc = tmp_path / "corrected.nc"
    code, out, err = _run(capsys, "load", data, "--drag-heights", *files, "--out", out_nc,
                          "--json")
    assert code == 0, err
    info = json.loads(out)
    assert info["drag_at_contact"] == pytest.approx(_drag(0.0), rel=1e-3)
    assert info["drag_at_contact"] > 3 * info["drag_at_contact_stderr"]
    with xr.open_dataset(out_nc) as ds:
        k = ds["stiffness"].values * np.exp(1j * np.radians(ds["phase"].values))
        assert ds.attrs["drag"] == pytest.approx(_drag(0.0), rel=1e-3)
        assert "Alcaraz" in ds.attrs["drag_model"]
    # the drag left: what is not extrapolated exactly, far below the sample's own loss
    np.testing.assert_allclose(k, 0.02 * (1 + 0.1j), rtol=2e-3)


def test_drag_heights_refusals(tmp_path, capsys):
    data = tmp_path / "contact.csv"
    _write_spectrum(data, 0.02 * (1 + 0.1j) * np.ones(FREQ.size))
    code, _, err = _run(capsys, "load", data, "--drag", "1e-6", "--drag-heights",
                        f"1um={data}", f"2um={data}", f"3um={data}")
    assert code == 2 and "not both" in err
    code, _, err = _run(capsys, "load", data, "--drag-heights", "nonsense")
    assert code == 2 and "HEIGHT=FILE" in err
    code, _, err = _run(capsys, "load", data, "--drag-heights", f"1um={data}", f"2um={data}")
    assert code == 2 and "heights" in err  # at least 3


def test_phase_lag_pairs_on_a_csv_spectrum_use_its_frequencies(tmp_path, capsys):
    data = tmp_path / "spectrum.csv"
    k = 0.02 * np.exp(1j * np.radians(np.array([10, 15, 20, 40, 60, 100.0])))
    _write_spectrum(data, k)
    out_nc = tmp_path / "out.nc"
    code, _, err = _run(capsys, "load", data, "--phase-lag", "300Hz=14", "--out", out_nc)
    assert code == 0, err
    with xr.open_dataset(out_nc) as ds:
        np.testing.assert_allclose(ds["phase"].values, [10, 15, 20, 40, 60, 86.0], atol=1e-9)
        assert int(ds["quality"].values[-1]) == 0  # 86 deg: now a passive phase
    code, _, err = _run(capsys, "load", data, "--phase-lag", "200Hz=14")
    assert code == 2 and "no modulation at that frequency" in err
