"""Nothing lost, nothing forged: outputs are renamed into place only when complete."""

from __future__ import annotations

import errno
import os
import resource
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import xarray as xr

import viscoforce._files as files
from viscoforce._files import atomic_output, refuse_overwriting_inputs, write_netcdf
from viscoforce.cli import main
from viscoforce.exceptions import ParameterError


def _dataset(n=1000):
    return xr.Dataset({"a": ("x", np.arange(float(n)))}, attrs={"tag": "new"})


def test_a_failing_writer_leaves_the_previous_file_and_no_debris(tmp_path):
    target = tmp_path / "out.nc"
    write_netcdf(_dataset(), target)
    before = target.read_bytes()
    with pytest.raises(RuntimeError, match="boom"), atomic_output(target) as tmp:
        tmp.write_bytes(b"half a file")
        raise RuntimeError("boom")
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.nc"]


def test_written_file_gets_the_umask_permissions(tmp_path):
    target = tmp_path / "out.nc"
    write_netcdf(_dataset(), target)
    umask = os.umask(0)
    os.umask(umask)
    assert (target.stat().st_mode & 0o777) == (0o666 & ~umask)
    with xr.open_dataset(target) as ds:
        assert ds.attrs["tag"] == "new"


def test_file_size_limit_is_a_clean_error_and_keeps_the_old_file(tmp_path):
    """RLIMIT_FSIZE in a child: exit 2 with the reason, the earlier output intact, no debris."""
    target = tmp_path / "out.nc"
    write_netcdf(_dataset(10), target)
    before = target.read_bytes()
    script = textwrap.dedent(f"""
        import resource, sys
        import numpy as np, xarray as xr
        from viscoforce._files import write_netcdf
        resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))
        try:
            write_netcdf(xr.Dataset({{"a": ("x", np.arange(1e6))}}), {str(target)!r})
        except OSError as exc:
            print("OSError", exc.errno)
            sys.exit(2)
        sys.exit(0)
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         check=False)
    assert run.returncode == 2, (run.stdout, run.stderr)
    assert run.stdout.startswith("OSError")
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.nc"]
    assert resource.getrlimit(resource.RLIMIT_FSIZE)  # the parent's limit is untouched


def test_a_dataset_over_the_memory_bound_is_written_by_hdf5_and_a_full_disk_is_an_oserror(
        tmp_path, monkeypatch):
    """Over NETCDF_IN_MEMORY HDF5 writes the temporary file itself: the same dataset as the
    in-memory route gives; ENOSPC there is an OSError naming the target, nothing left (HDF5
    never sees it: pytest would fail the test on an error HDF5's objects printed and ignored)."""
    ds = _dataset(200_000)
    write_netcdf(ds, tmp_path / "in_memory.nc")
    monkeypatch.setattr(files, "NETCDF_IN_MEMORY", 0)
    target = tmp_path / "big.nc"
    write_netcdf(ds, target)
    with xr.open_dataset(target) as big, xr.open_dataset(tmp_path / "in_memory.nc") as small:
        xr.testing.assert_identical(big.load(), small.load())
    before = target.read_bytes()
    pwrite = os.pwrite

    def full_disk(fd, data, offset):
        if offset + len(data) > 100_000:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return pwrite(fd, data, offset)

    monkeypatch.setattr(os, "pwrite", full_disk)
    with pytest.raises(OSError, match="No space left on device") as caught:
        write_netcdf(ds, target)
    assert caught.value.filename == str(target)
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.nc", "in_memory.nc"]


def test_concurrent_writers_leave_one_whole_file(tmp_path):
    target = tmp_path / "out.nc"
    script = textwrap.dedent(f"""
        import sys
        import numpy as np, xarray as xr
        from viscoforce._files import write_netcdf
        tag = sys.argv[1]
        for _ in range(20):
            write_netcdf(xr.Dataset({{"a": ("x", np.full(200_000, float(tag)))}},
                                    attrs={{"tag": tag}}), {str(target)!r})
    """)
    procs = [subprocess.Popen([sys.executable, "-c", script, tag]) for tag in ("1", "2")]
    assert [p.wait() for p in procs] == [0, 0]
    with xr.open_dataset(target) as ds:
        values = np.unique(ds["a"].values)
        assert values.size == 1 and str(int(values[0])) == ds.attrs["tag"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.nc"]


def test_refuse_overwriting_inputs(tmp_path):
    data = tmp_path / "data.nc"
    write_netcdf(_dataset(), data)
    link = tmp_path / "link.nc"
    os.link(data, link)
    with pytest.raises(ParameterError, match="is an input"):
        refuse_overwriting_inputs(link, [data], name="--out")
    refuse_overwriting_inputs(tmp_path / "new.nc", [data])


def test_cli_refuses_an_output_that_is_its_input(tmp_path, capsys):
    t = np.linspace(0, 1, 200)
    ds = xr.Dataset({"stiffness": ("omega", np.full(5, 0.1))})
    del ds, t
    spectrum = tmp_path / "spectrum.csv"
    spectrum.write_text("frequency (Hz),stiffness (N/m),phase (deg)\n1,0.1,10\n10,0.12,20\n"
                        "100,0.15,30\n")
    before = spectrum.read_bytes()
    code = main(["load", str(spectrum), "--out", str(spectrum)])
    _, err = capsys.readouterr()
    assert code == 2  # the suffix check (.nc) or the input check refuses it
    assert spectrum.read_bytes() == before
    out = tmp_path / "s.nc"
    assert main(["load", str(spectrum), "--out", str(out)]) == 0
    capsys.readouterr()
    before = out.read_bytes()
    code = main(["fit", str(out), "--model", "prony", "--out", str(out)])
    _, err = capsys.readouterr()
    assert code == 2 and "is an input of this command" in err
    assert out.read_bytes() == before
