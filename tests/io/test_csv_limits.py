"""Bounded reading of text tables, and refusals of impossible values (issue 25, items 2-3).

The CSV and trace readers refuse a file above ``MAX_CSV_BYTES`` before reading it, a table with
more rows than their limit before parsing (an estimate from the size) or while parsing (a count),
parse numeric columns straight to float64 (memory a small multiple of the data returned), and
refuse values beyond the physical range of their quantity naming column, row and range. Big files
are sparse or the limits are made small, so that every test is fast.
"""

from __future__ import annotations

import re
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from viscoforce import _limits
from viscoforce.cli import main
from viscoforce.exceptions import EffortError, ParameterError, UnitError
from viscoforce.io import _csv_table, csv_small_tables
from viscoforce.io.csv_formats import (
    read_curves_csv,
    read_prony_moduli,
    read_spectrum_csv,
    read_trace,
)
from viscoforce.io.instruments import load_instrument

SPECTRUM = "frequency (Hz),stiffness (N/m),phase (deg)\n"
CURVES = "time (s),force (nN),height (nm)\n"


def write(path: Path, text: str | bytes) -> Path:
    if isinstance(text, str):
        text = text.encode()
    path.write_bytes(text)
    return path


def rows(n: int, columns: int = 3) -> str:
    t = np.arange(n) * 1e-3
    data = np.column_stack([t] + [np.sin(t + k) + 2 for k in range(columns - 1)])
    return "\n".join(",".join(f"{v:.6g}" for v in row) for row in data) + "\n"


def one_error_line(capsys, argv: list[str]) -> str:
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


# ── size and row limits ─────────────────────────────────────────────────────────────────────────


def _sparse_csv(path: Path, size: int) -> Path:
    """A valid CSV head (more than the 64 KiB sniffed) followed by a hole up to ``size`` bytes."""
    with path.open("wb") as fh:
        fh.write((CURVES + rows(4000)).encode())
        fh.truncate(size)
    return path


def test_the_limits_are_stated_and_fit_a_long_measurement():
    assert _limits.MAX_CSV_BYTES == 1_000_000_000
    assert _limits.MAX_CSV_ROWS == _limits.MAX_SAMPLES == 10_000_000
    assert _limits.MAX_TRACE_ROWS == _limits.MAX_STEPS
    # a 1e6-row time series of 9-digit numbers is ~30 MB: far inside both limits
    assert 1_000_000 * 3 * 10 < _limits.MAX_CSV_BYTES


@pytest.mark.parametrize("reader", [read_curves_csv, read_trace, load_instrument])
def test_a_file_above_the_byte_limit_is_refused_before_reading(tmp_path, reader):
    path = _sparse_csv(tmp_path / "huge.csv", 2 * 1024**3 + 5)
    tracemalloc.start()
    with pytest.raises(EffortError) as info:
        reader(path)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    message = str(info.value)
    assert f"{path}: the file is 2.1 GB; the CSV reader reads at most 1.0 GB (MAX_CSV_BYTES)" \
        in message
    assert len(message) - len(str(path)) < 200
    assert info.value.limit == _limits.MAX_CSV_BYTES and info.value.estimate == 2 * 1024**3 + 5
    assert peak < 2_000_000, f"{peak} bytes traced for a refusal"  # refused before reading


def test_the_cli_refuses_a_huge_csv_with_one_line(tmp_path, capsys):
    path = _sparse_csv(tmp_path / "huge.csv", 2 * 1024**3 + 5)
    line = one_error_line(capsys, ["load", str(path), "--out", str(tmp_path / "x.nc")])
    assert "the file is 2.1 GB" in line and "MAX_CSV_BYTES" in line
    assert not (tmp_path / "x.nc").exists()
    line = one_error_line(capsys, ["simulate", "--drive", "trace", "--trace", str(path),
                                   "--out", str(tmp_path / "t.nc")])
    assert "MAX_CSV_BYTES" in line


def test_too_many_rows_are_refused_up_front_from_the_size(tmp_path, monkeypatch):
    monkeypatch.setattr(_csv_table, "MAX_CSV_ROWS", 1000)
    path = write(tmp_path / "long.csv", CURVES + rows(5000))
    with pytest.raises(EffortError, match=r"about 5e\+03 data rows \(from the file size, "
                                          r".*reads at most 1e\+03 rows \(MAX_CSV_ROWS\), "
                                          r"refused before reading"):
        read_curves_csv(path)


def test_too_many_rows_are_refused_after_reading_the_limit(tmp_path, monkeypatch):
    monkeypatch.setattr(_csv_table, "MAX_CSV_ROWS", 1000)
    path = write(tmp_path / "long.csv", SPECTRUM + "".join(
        f"{i + 1},1,10\n" for i in range(1500)))  # the estimate (1.5e3) stays below 2x
    with pytest.raises(EffortError, match=r"more than 1e\+03 data rows; .*MAX_CSV_ROWS"):
        read_spectrum_csv(path)
    ok = write(tmp_path / "ok.csv", SPECTRUM + "".join(f"{i + 1},1,10\n" for i in range(1000)))
    assert read_spectrum_csv(ok).sizes["omega"] == 1000


def test_a_trace_has_its_own_row_limit(tmp_path, monkeypatch):
    monkeypatch.setattr(csv_small_tables, "MAX_TRACE_ROWS", 100)
    path = write(tmp_path / "trace.csv", "time (ms),position (nm)\n" + rows(150, 2))
    with pytest.raises(EffortError, match=r"reads at most 100 rows \(MAX_TRACE_ROWS\)"):
        read_trace(path)
    read_curves_csv(write(tmp_path / "c.csv", CURVES + rows(150)))  # other tables: their limit


def test_a_million_row_trace_loads_in_seconds_with_bounded_memory(tmp_path):
    n = 1_000_000
    t = np.arange(n) * 1e-5
    path = tmp_path / "trace.csv"
    with path.open("w") as fh:
        fh.write("time (s),position (nm)\n")
        np.savetxt(fh, np.column_stack([t, 5 - t]), delimiter=",", fmt="%.9g")
    tracemalloc.start()
    time_s, position = read_trace(path)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert time_s.size == position.size == n
    np.testing.assert_allclose(position[-1], (5 - t[-1]) * 1e-9)
    assert peak < 4 * (time_s.nbytes + position.nbytes)


@pytest.mark.parametrize(("header", "columns", "reader", "factor"), [
    (CURVES, 3, read_curves_csv, 4.0),
    ("time (s),position (nm)\n", 2, read_trace, 4.0),
    (SPECTRUM, 3, read_spectrum_csv, 6.0),
], ids=["curves", "trace", "spectrum"])
def test_reading_memory_is_a_small_multiple_of_the_data(tmp_path, header, columns, reader,
                                                          factor):
    n = 100_000
    data = rows(n, columns)
    if reader is read_spectrum_csv:  # strictly increasing frequencies, positive stiffness
        data = "".join(f"{i + 1},{1 + (i % 7) / 10},{10 + i % 50}\n" for i in range(n))
    path = write(tmp_path / "t.csv", header + data)
    reader(path)  # imports and caches outside the measurement
    tracemalloc.start()
    out = reader(path)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    returned = out.nbytes if hasattr(out, "nbytes") else sum(a.nbytes for a in out)
    assert peak < factor * returned, f"peak {peak / 1e6:.1f} MB for {returned / 1e6:.1f} MB"


def _peak(reader, path: Path):
    reader(path)  # imports and caches outside the measurement
    tracemalloc.start()
    out = reader(path)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return out, peak


def test_ignored_text_columns_are_not_held_in_memory(tmp_path):
    n = 200_000  # the notes as Python strings would take ~20 MB
    plain = write(tmp_path / "plain.csv", CURVES + "".join(
        f"{i * 1e-3:.6g},{i % 5},{i % 3}\n" for i in range(n)))
    notes = write(tmp_path / "notes.csv", "time (s),note (1),force (nN),height (nm)\n" + "".join(
        f"{i * 1e-3:.6g},free text number {i} of a long comment column,{i % 5},{i % 3}\n"
        for i in range(n)))
    ds, peak = _peak(read_curves_csv, notes)
    _, plain_peak = _peak(read_curves_csv, plain)
    assert ds.attrs["ignored_columns"] == "note (1)"
    assert peak < plain_peak + 4_000_000, (peak, plain_peak)


# ── impossible values: column, row, value and the allowed range ─────────────────────────────────

RANGE_CASES = [
    (SPECTRUM + "1,1,10\n2,1e308,20\n", r"column 'stiffness \(N/m\)' data row 2 \(line 3\) holds "
     r"'1e308' = 1e\+308 N/m, beyond the physical range 0 < stiffness <= 1e\+10 N/m"),
    ("frequency (MHz),stiffness (N/m),phase (deg)\n1,1,10\n1e305,1,20\n",
     r"column 'frequency \(MHz\)' data row 2 \(line 3\) holds '1e305' = inf Hz \(the conversion "
     r"to SI overflows\), beyond the physical range 0 < frequency <= 1e\+09 Hz"),
    (SPECTRUM + "1,1,10\n2,1,400\n", r"column 'phase \(deg\)' data row 2 \(line 3\) holds '400' "
     r"= 400 deg, beyond the physical range -360 <= phase <= 360 deg"),
    (SPECTRUM + "1,1,10\n2e10,1,20\n", r"-?column 'frequency \(Hz\)' data row 2 .*0 < frequency "
     r"<= 1e\+09 Hz"),
    (SPECTRUM + "0,1,10\n", r"frequency at data row 1 \(line 2\) must be > 0 \(0 < frequency "
     r"<= 1e\+09 Hz\), got 0"),
    (SPECTRUM + "1,0,10\n", r"the magnitude at data row 1 \(line 2\) is 0 \(allowed: 0 < "
     r"stiffness <= 1e\+10 N/m\)"),
    ("frequency (Hz),force_amplitude (N),drive_amplitude (m),phase (deg)\n1,100,1e-12,10\n",
     r"the stiffness at data row 1 \(line 2\) \(force_amplitude / drive_amplitude\) is 1e\+14 "
     r"N/m, beyond the physical range 0 < stiffness <= 1e\+10 N/m"),
    ("frequency (Hz),stiffness (N/m),stiffness_stderr (N/m),phase (deg)\n1,1,1e300,10\n",
     r"column 'stiffness_stderr \(N/m\)' data row 1 .* 0 <= stiffness_stderr <= 1e\+10 N/m"),
    (SPECTRUM + "1,1,10\n2,1,nan\n", r"column 'phase \(deg\)' data row 2 \(line 3\) is not a "
     r"finite number \('nan'\)"),
]


@pytest.mark.parametrize(("text", "match"), RANGE_CASES)
def test_spectrum_values_beyond_physics_are_refused(tmp_path, text, match):
    path = write(tmp_path / "s.csv", text)
    with pytest.raises(ParameterError, match=match) as info:
        load_instrument(path)
    assert str(path) in str(info.value)
    assert len(str(info.value)) - len(str(path)) < 300


CURVE_RANGE_CASES = [
    (CURVES + "0,1,2\n1,1,2e12\n", r"column 'height \(nm\)' data row 2 \(line 3\) holds '2e12' "
     r"= 2000 m, beyond the physical range -1 <= height <= 1 m"),
    (CURVES + "1e11,1,2\n", r"column 'time \(s\)' data row 1 .* -1e\+10 <= time <= 1e\+10 s"),
    (CURVES + "0,1e308,2\n", r"column 'force \(nN\)' .* -1000 <= force <= 1000 N"),
    ("curve,time (s),force (nN),height (nm)\na,0,1,2\nb,0,inf,2\n",
     r"column 'force \(nN\)' data row 2 \(line 3\) is not a finite number \('inf'\) in curve 'b'"),
]


@pytest.mark.parametrize(("text", "match"), CURVE_RANGE_CASES)
def test_curve_values_beyond_physics_are_refused(tmp_path, text, match):
    with pytest.raises(ParameterError, match=match):
        read_curves_csv(write(tmp_path / "c.csv", text))


def test_a_number_error_comes_before_a_range_error(tmp_path):
    path = write(tmp_path / "c.csv", CURVES + "0,1,2e12\n1,x,2\n")  # height is read first
    with pytest.raises(ParameterError, match=r"column 'force \(nN\)' data row 2 .*\('x'\)"):
        read_curves_csv(path)


def test_options_beyond_physics_are_refused(tmp_path):
    path = write(tmp_path / "d.csv", "time (s),deflection (nm),height (nm)\n0,1,2\n1,2,3\n")
    with pytest.raises(ParameterError, match=r"spring_constant must be within the plausible "
                                             r"range \[1e-05, 1000\] N/m, got 1e\+308 N/m"):
        read_curves_csv(path, spring_constant=1e308)
    with pytest.raises(ParameterError, match=r"sensitivity must be within the plausible range "
                                             r"\[1e-12, 0.001\] m/V \(given as '2m/V'\), got 2.0"):
        read_curves_csv(path, sensitivity="2m/V")
    spectrum = write(tmp_path / "s.csv", "frequency (Hz),amplitude (1),phase (deg),"
                                         "mean_force (N)\n1,0.1,10,1e-9\n")
    with pytest.raises(ParameterError, match=r"drive_amplitude = 10.0 is beyond .* <= 1 m"):
        read_spectrum_csv(spectrum, drive_amplitude=10.0)


def test_prony_and_trace_values_beyond_physics(tmp_path):
    with pytest.raises(ParameterError, match=r"column 'modulus \(GPa\)' data row 1 .* \(the "
                                             r"conversion to SI overflows\).* <= 1e\+13 Pa"):
        read_prony_moduli(write(tmp_path / "p.csv", "modulus (GPa),tau (ms)\n1e300,1\n1,\n"))
    with pytest.raises(ParameterError, match=r"column 'position \(nm\)' data row 2 .* -1 <= "
                                             r"position <= 1 m"):
        read_trace(write(tmp_path / "t.csv", "time (s),position (nm)\n0,1\n1,1e15\n"))


@pytest.mark.parametrize("command", ["fit", "bode"])
def test_fit_and_bode_refuse_a_1e308_stiffness_in_one_line(tmp_path, capsys, command):
    path = write(tmp_path / "s.csv", SPECTRUM + "1,1,10\n10,1e308,20\n100,2,30\n")
    argv = ([command, str(path), "--model", "prony"] if command == "fit"
            else [command, str(path), "--out", str(tmp_path / "b.png")])
    line = one_error_line(capsys, argv)
    assert re.search(r"column 'stiffness \(N/m\)' data row 2 \(line 3\) holds '1e308'", line)
    assert not (tmp_path / "b.png").exists()


# ── duplicates, non-monotonic time ──────────────────────────────────────────────────────────────


def test_a_repeated_frequency_names_both_rows(tmp_path):
    path = write(tmp_path / "s.csv", SPECTRUM + "1,1,10\n2,1,20\n1,2,10\n")
    with pytest.raises(ParameterError, match=r"a frequency appears twice: 1 Hz at data row 1 "
                                             r"\(line 2\) and data row 3 \(line 4\)"):
        read_spectrum_csv(path)


def test_a_repeated_frequency_in_a_later_curve(tmp_path):
    path = write(tmp_path / "s.csv", "curve," + SPECTRUM + "a,1,1,10\na,2,1,10\nb,1,1,10\n"
                                                            "b,1,1,10\n")
    with pytest.raises(ParameterError, match=r"a frequency appears twice in curve 'b': 1 Hz at "
                                             r"data row 3 \(line 4\) and data row 4 \(line 5\)"):
        read_spectrum_csv(path)


def test_a_duplicated_curve_is_refused(tmp_path):
    path = write(tmp_path / "c.csv", "curve," + CURVES + "a,0,1,2\na,1,2,3\nb,0,1,2\nb,1,2,3\n")
    with pytest.raises(ParameterError, match=r"curve 'b' repeats curve 'a' sample for sample "
                                             r"\(2 rows from data row 3 \(line 4\)\): a "
                                             r"duplicated curve"):
        read_curves_csv(path)


def test_a_duplicated_row_and_a_restarted_curve(tmp_path):
    with pytest.raises(ParameterError, match=r"time is not strictly increasing at data row 3 "
                                             r"\(line 4\) \(1.0 s after 1.0 s\); the same time "
                                             r"as data row 2 \(line 3\): a duplicated row\?"):
        read_curves_csv(write(tmp_path / "c.csv", CURVES + "0,1,2\n1,2,3\n1,2,3\n"))
    with pytest.raises(ParameterError, match=r"time of curve 'a' .* curve 'a' starts again "
                                             r"after other curves' rows"):
        read_curves_csv(write(tmp_path / "r.csv", "curve," + CURVES + "a,0,1,2\na,1,2,3\n"
                                                                      "b,0,1,2\na,0,1,2\n"))


def test_a_trace_with_time_going_back_names_the_row(tmp_path):
    path = write(tmp_path / "t.csv", "time (ms),position (nm)\n0,5\n2,-3\n2,5\n")
    with pytest.raises(ParameterError, match=r"time must be strictly increasing; entry 2, data "
                                             r"row 3 \(line 4\), is 0.002 s, after 0.002 s "
                                             r"\(the same time twice: a duplicated row\?\)"):
        read_trace(path)


# ── field counts, trailing delimiters, comments ─────────────────────────────────────────────────


@pytest.mark.parametrize("text", [
    SPECTRUM.replace("\n", ",\n") + "1,1,10,\n2,1,20,\n",
    SPECTRUM + "1,1,10,\n2,1,20,\n",
    SPECTRUM.replace("\n", ",\n") + "1,1,10\n2,1,20\n",
], ids=["both", "data", "header"])
def test_a_trailing_delimiter_is_an_empty_column(tmp_path, text):
    ds = read_spectrum_csv(write(tmp_path / "s.csv", text))
    np.testing.assert_allclose(ds["phase"].values, [10, 20])


def test_a_value_in_the_unnamed_trailing_column_is_refused(tmp_path):
    path = write(tmp_path / "s.csv", SPECTRUM.replace("\n", ",\n") + "1,1,10,\n2,1,20,7\n")
    with pytest.raises(ParameterError, match=r"data row 2 \(line 3\) holds '7' in field 4, "
                                             r"which the header .* does not name"):
        read_spectrum_csv(path)


def test_field_counts_name_the_line(tmp_path):
    header = "frequency (Hz),stiffness (N/m),phase (deg),mean_force (N),drive_amplitude (m)\n"
    good = "".join(f"{i},1,10,1e-9,1e-9\n" for i in range(1, 6))
    with pytest.raises(ParameterError, match=r"line 7 has 6 fields, expected 5 \(header "
                                             r"'frequency \(Hz\),stiffness"):
        read_spectrum_csv(write(tmp_path / "long.csv", header + good + "6,1,10,1e-9,1e-9,3\n"))
    with pytest.raises(ParameterError, match=r"column 'drive_amplitude \(m\)' data row 6 \(line "
                                             r"7\) is missing: the line has 4 fields, expected 5"):
        read_spectrum_csv(write(tmp_path / "short.csv", header + good + "6,1,10,1e-9\n"))
    ignored = "frequency (Hz),note (1),stiffness (N/m),phase (deg)\n"
    with pytest.raises(ParameterError, match=r"line 3 has 5 fields, expected 4: a trailing "
                                             r"delimiter\? remove it|line 3 has 5 fields, "
                                             r"expected 4 \(header .*\): a trailing"):
        read_spectrum_csv(write(tmp_path / "ign.csv", ignored + "1,a,1,10\n2,b,1,20,\n"))


def test_comments_blank_lines_crlf_and_encodings_keep_line_numbers(tmp_path):
    text = SPECTRUM + "1,1,10\n\n# a note\n   \n2,1,20\n  # indented\n3,x,30\n"
    with pytest.raises(ParameterError, match=r"data row 3 \(line 8\) is not a finite number"):
        read_spectrum_csv(write(tmp_path / "c.csv", text))
    with pytest.raises(ParameterError, match=r"data row 3 \(line 8\) is not a finite number"):
        read_spectrum_csv(write(tmp_path / "crlf.csv", text.replace("\n", "\r\n")))
    latin = write(tmp_path / "l.csv", "frequency (Hz),stiffness (N/m),phase (°)\n1,1,10\n"
                                      "2,1,20\n".encode("latin-1"))
    np.testing.assert_allclose(read_spectrum_csv(latin)["phase"].values, [10, 20])
    bom = write(tmp_path / "b.csv", "\ufeff" + SPECTRUM + "1,1,10\n2,1,20\n")
    assert read_spectrum_csv(bom).sizes["omega"] == 2
    comma = write(tmp_path / "d.csv", SPECTRUM.replace(",", ";") + "1;1,5;10\n2;1.5;20\n")
    np.testing.assert_allclose(read_spectrum_csv(comma)["stiffness"].values, [1.5, 1.5])


def test_units_errors_are_unchanged(tmp_path):
    with pytest.raises(UnitError, match=r"column 'force' has no unit"):
        read_curves_csv(write(tmp_path / "u.csv", "time (s),force,height (m)\n0,1,1\n"))
