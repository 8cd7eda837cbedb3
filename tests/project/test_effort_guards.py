"""Effort guards and refusals: workers bounded by the machine, cluster failures named, options."""

from __future__ import annotations

import numpy as np
import pytest

from viscoforce.exceptions import ClusterError, ParameterError
from viscoforce.fitting import maps
from viscoforce.fitting.maps import check_workers, fit_map, max_workers
from viscoforce.schema import make_spectrum


def _spectra(n=4):
    omega = np.geomspace(1.0, 1e3, 8)
    k = 0.02 * (1 + 1j * omega * 1e-2 / (1 + 1j * omega * 1e-2))
    k = np.broadcast_to(k, (n, omega.size))
    spectrum = make_spectrum(omega, k[0], np.full(omega.size, 1e-9), 1e-8)
    import xarray as xr

    return xr.concat([spectrum] * n, dim="curve")


def test_workers_are_bounded_by_the_machine():
    check_workers(None)
    check_workers(max_workers())
    for bad in (0, -1, max_workers() + 1, 10_000, 2.0, True):
        with pytest.raises(ParameterError, match=r"workers must be an integer in \[1, "):
            check_workers(bad)
    with pytest.raises(ParameterError, match="workers must be"):
        fit_map(_spectra(), "prony", workers=10_000)


def test_a_failing_cluster_is_a_clean_error_naming_the_lost_pixels(monkeypatch):
    from distributed import LocalCluster

    def died(*args, **kwargs):
        raise RuntimeError("worker tcp://127.0.0.1:1 died (simulated)")

    monkeypatch.setattr(maps, "_fit_block_shared", died)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=":0") as local:
        with pytest.raises(ClusterError, match=r"lost pixels 0 to .* of 4: the scheduler failed "
                                               r"\(RuntimeError: worker .* died"):
            fit_map(_spectra(), "prony", scheduler=local.scheduler_address, progress=False)


@pytest.mark.parametrize(("options", "match"), [
    ({"drag": -1e-6}, r"drag must be a finite number >= 0"),
    ({"phase_lag": 1e6}, r"phase_lag must be within ±180 degrees"),
    ({"phase_lag": {300.0: -400.0}}, r"phase_lag must be within ±180 degrees"),
    ({"subtract_baseline": "yes"}, r"subtract_baseline must be True or False"),
])
def test_impossible_correction_options_are_refused(options, match):
    from viscoforce.experiments.modulation import modulation_spectrum
    from viscoforce.schema import make_curves

    curves = make_curves(np.linspace(0, 1, 10), np.zeros(10), np.zeros(10), np.zeros(10),
                         segment=0, segment_names=("modulation",), source="synthetic")
    with pytest.raises(ParameterError, match=match):
        modulation_spectrum(curves, **options)


def test_a_single_curve_jpk_file_is_one_spectrum_not_a_map(capsys, tmp_path):
    from pathlib import Path

    from viscoforce.cli import main

    example = Path(__file__).resolve().parents[2] / "data_examples" / "sls_modulation.jpk-force"
    code = main(["bode", str(example), "--out", str(tmp_path / "b.png")])
    _, err = capsys.readouterr()
    assert code == 0, err
    code = main(["fit", str(example), "--model", "prony", "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    import json

    info = json.loads(out)
    assert "value" in info["params"]["k_inf"]  # a single fit, not a map summary


def test_calibration_flags_on_a_self_calibrated_file_are_a_usage_error(capsys):
    from tests.conftest import REAL_DATA_DIR
    from viscoforce.cli import main

    path = REAL_DATA_DIR / "afmformats" / "fmt-jpk-cc_pr14-brain-2021.06.30.jpk-force"
    if not path.is_file():
        pytest.skip("shared real data absent")
    code = main(["load", str(path), "--spring-constant", "0.1N/m"])
    _, err = capsys.readouterr()
    assert code == 2 and "--spring-constant" in err and "own calibration" in err
    assert "Traceback" not in err


def test_a_huge_uff_file_is_refused_before_reading(tmp_path, monkeypatch):
    from viscoforce.exceptions import EffortError
    from viscoforce.io import bruker

    path = tmp_path / "big.uff"
    path.write_bytes(b"x" * 2048)
    monkeypatch.setattr(bruker, "MAX_UFF_BYTES", 1024)
    with pytest.raises(EffortError, match="UFF text file .*2048.* beyond the limit"):
        bruker._read_text(path)


@pytest.mark.parametrize("method", ["time-domain", "contact", "auto"])
def test_a_huge_frequency_list_is_refused_before_any_route(method):
    """Every route refuses more than MAX_SAMPLES frequencies up front (the time domain ran into a
    23.9 GiB allocation in its lock-in bound, the contact route computed them); the time-domain
    sweep also refuses up front when one period of samples per frequency is beyond the limit."""
    import viscoforce as vf
    from viscoforce._limits import MAX_SAMPLES
    from viscoforce.exceptions import EffortError

    problem = vf.ContactProblem.create(sphere=vf.Sphere(10e-6), surface_force=vf.paper_pressure_law(),
                                       material=vf.StandardLinearSolid(1e10, 1e9, 1e-3),
                                       deepest_position=-6e-9)
    omega = np.broadcast_to(100.0, (MAX_SAMPLES + 1,))
    with pytest.raises(EffortError, match="frequencies of spectrum"):
        vf.spectrum(problem, -5e-9, 1e-11, omega, method=method)
    if method == "time-domain":
        few = np.geomspace(10.0, 1e5, MAX_SAMPLES // 64 + 1)
        with pytest.raises(EffortError, match="output samples of the time-domain sweep"):
            vf.spectrum(problem, -5e-9, 1e-11, few, method=method)
