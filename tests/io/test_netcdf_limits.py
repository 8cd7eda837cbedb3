"""netCDF inputs are read with a bound: declared sizes are checked before loading (issue 40 item 3).

A small HDF5 file can declare gigabytes (unwritten chunks take no space): ``fit``, ``bode``,
``view`` and ``view --data`` refuse it before reading, with the estimate in the message.
"""

from __future__ import annotations

import h5netcdf
import numpy as np
import pytest
import xarray as xr

from viscoforce._limits import MAX_MEMORY_BYTES
from viscoforce.cli import main
from viscoforce.data import example_path
from viscoforce.exceptions import EffortError, ParameterError
from viscoforce.io.netcdf import declared_bytes, open_netcdf

#: Elements of the crafted file's variable: 8 GB of float64.
_DECLARED = 10**9


@pytest.fixture
def lying_file(tmp_path):
    """A spectrum-shaped netCDF4 file of a few kB that declares 8 GB of stiffness."""
    path = tmp_path / "lying.nc"
    with h5netcdf.File(path, "w") as handle:
        handle.dimensions = {"omega": _DECLARED}
        var = handle.create_variable("stiffness", ("omega",), dtype="f8", chunks=(1024,))
        var.attrs["units"] = "N/m"
    assert path.stat().st_size < 100_000
    return path


def test_declared_bytes_counts_the_header_not_the_file(lying_file):
    assert declared_bytes(lying_file) >= 8 * _DECLARED > MAX_MEMORY_BYTES


@pytest.mark.parametrize("engine", ["h5netcdf", "scipy"])
def test_declared_bytes_of_an_ordinary_file(tmp_path, engine):
    path = tmp_path / "small.nc"
    ds = xr.Dataset({"a": (("y", "x"), np.zeros((3, 5))), "b": ("x", np.arange(5, dtype="i4"))})
    ds.to_netcdf(path, engine=engine)
    assert declared_bytes(path) >= 3 * 5 * 8 + 5 * 4
    assert declared_bytes(path) < 1000
    xr.testing.assert_identical(open_netcdf(path), xr.open_dataset(path).load())


def test_open_netcdf_refuses_before_loading(lying_file):
    with pytest.raises(EffortError, match=r"about \d\.\d+e\+(09|10) bytes needed, beyond the limit"):
        open_netcdf(lying_file)


def test_a_file_that_is_not_netcdf(tmp_path):
    path = tmp_path / "text.nc"
    path.write_text("not a netCDF file")
    with pytest.raises(ParameterError, match="is not a netCDF file"):
        declared_bytes(path)


@pytest.mark.parametrize("argv", [
    ["fit", "{f}", "--model", "prony"],
    ["bode", "{f}", "--plot", "{tmp}/b.png"],
    ["view", "{f}", "--out", "{tmp}/r.html"],
    ["view", "{map}", "--data", "{f}", "--out", "{tmp}/r.html"],
])
def test_the_cli_refuses_a_file_declaring_gigabytes(capsys, tmp_path, lying_file, argv):
    fits = tmp_path / "fits.nc"
    if "{map}" in argv:
        assert main(["fit", str(example_path("sls_spectrum_map.nc")), "--model", "prony",
                     "--out", str(fits)]) == 0
        capsys.readouterr()
    args = [a.format(f=lying_file, tmp=tmp_path, map=fits) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "bytes needed, beyond the limit" in err and "Traceback" not in err
