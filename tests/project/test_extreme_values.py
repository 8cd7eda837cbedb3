"""Extreme but parseable values are computed or refused with the parameter and its range (issue 40).

Items 6 and 7 of the hostile-input test of the command line: a force column scaled by 1e-300, a
UFF spring constant of 1e-308, ``--tip sphere:1e300m`` and their kin ended in tracebacks; a tip
that did not parse said only "invalid _tip_type value"; ``curves=[0, 0]`` and an unknown
``height_channel`` were accepted (or refused only after every curve was decoded); a JPK archive
in a zip of archives took three times its size in memory; a UFF file with more rows than it
declares, and a CSV of text, were parsed whole before the first bad line was refused. Every test
here failed before the fix. No test measures time: early refusals are shown by what the message
names (the first line too many) and by the memory the work took (tracemalloc).
"""

from __future__ import annotations

import io
import re
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest

from viscoforce import _limits
from viscoforce.cli import main
from viscoforce.exceptions import EffortError, InstrumentFormatError, ParameterError
from viscoforce.io import _csv_table
from viscoforce.io.bruker import read_uff
from viscoforce.io.curves import jpk_to_curves
from viscoforce.io.instruments import load_instrument
from viscoforce.io.jpk import read_jpk
from viscoforce.physics.tips import Cone, Flat, Paraboloid, Pyramid, Sphere, parse_tip

REPO = Path(__file__).resolve().parents[2]
JPK = REPO / "tests" / "data" / "jpk" / "synthetic.jpk-force"
MAP = REPO / "tests" / "data" / "jpk" / "synthetic-2x2.jpk-force-map"
MODULATION = REPO / "data_examples" / "sls_modulation.jpk-force"
SPECTRUM = REPO / "data_examples" / "sls_spectrum.csv"
MiB = 1024**2


def _cli(capsys, *argv) -> tuple[int, str]:
    code = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert "Traceback" not in err and "internal error" not in err, err
    return code, err


def _curve_csv(path: Path, *, force=1.0, height=1.0, time=1.0, times=None) -> Path:
    """A Hertz-like approach, pause and retract (force [N], height [m]) with scaled columns."""
    n = 60
    h = np.linspace(3e-6, 1e-6, n)
    f = 1.3e4 * np.sqrt(5e-6) * np.clip(2e-6 - h, 0, None) ** 1.5 + 1e-11 * np.cos(np.arange(n))
    heights = np.concatenate([h, np.full(20, h[-1]), h[::-1]])
    forces = np.concatenate([f, np.full(20, f[-1]) * 0.9, f[::-1] * 0.8])
    labels = ["approach"] * n + ["pause"] * 20 + ["retract"] * n
    t = np.arange(heights.size) * 1e-3 if times is None else np.asarray(times)
    lines = ["time (s),force (N),deflection (m),height (m),segment"]
    lines += [",".join(repr(float(v)) for v in (ti * time, fi * force, fi / 0.1 * force,
                                                  hi * height)) + f",{s}"
              for ti, fi, hi, s in zip(t, forces, heights, labels, strict=True)]
    path.write_text("\n".join(lines) + "\n")
    return path


_UFF_HEADER = {
    "UFF_code": "_1_2_3_4_5", "Entry_UFF_version": "0", "Entry_tot_nb_curve": "1",
    "Cantilever_springK_used(N/m)": "1.0E-01", "Tip_geometry": "pyramidal",
    "Tip_half_angle(deg)": "1.75E+01", "Tip_radius(m)": "-1",
    "Recording_xposition(m)": "1.0E-06", "Recording_yposition(m)": "2.0E-06",
    "Recording_inv_optical_lever_sens_used(m/V)": "5.0E-08", "Recording_number_segment": "2",
}


def _uff(path: Path, header=None, *, approach=None, scale=1.0, extra_rows=0,
         velocity="1.0E-06", tail=()) -> Path:
    """A two-segment UFF text curve (Displacement [m], Deflection [V]), as Nanoscope writes it."""
    fields = dict(_UFF_HEADER, **(header or {}))
    rows = {"AP": [(0.0, 1.0), (1e-8, 0.6), (2e-8, 0.2)] if approach is None else approach,
            "RE": [(0.0, 0.9), (1e-8, 0.1), (2e-8, 0.0)]}
    lines = [f"HE {k}: {v}" for k, v in fields.items()]
    for i, (code, kind) in enumerate((("AP", "Approach"), ("RE", "Retract"))):
        pre = f"HE Recording_segment_{i}_"
        lines += [f"{pre}type: {kind}", f"{pre}code: {code}", f"{pre}nb: {i}",
                  f"{pre}nb_point: {len(rows[code])}", f"{pre}nb_col: 2",
                  f"{pre}col_0_title: Displacement", f"{pre}col_0_unit: m",
                  f"{pre}col_1_title: Deflection", f"{pre}col_1_unit: volt",
                  f"{pre}velocity(m/s): {velocity if code == 'AP' else '1.0E-06'}"]
        lines += [f"{code} {i} {z:E} {d * scale:E}" for z, d in rows[code]]
        if code == "AP":
            lines += [f"AP 0 {3e-8 + 1e-9 * k:E} 0.1" for k in range(extra_rows)]
    path.write_text("\n".join([*lines, *tail]) + "\n****\n")
    return path


# ── 6. tips: every part named, the ranges stated, the argparse message kept ─────────────────


@pytest.mark.parametrize(("tip", "match"), [
    ("sphere:1e300m", r"argument --tip: tip 'sphere:1e300m': the radius after ':' is wrong: "
                      r"radius must be within the plausible range \[1e-09, 1\] m"),
    ("pyramid:1e300", r"argument --tip: tip 'pyramid:1e300': the half-angle after ':' is wrong: "
                      r"half_angle \(degree\) must be in \[0.1, 89.9\], got 1e\+300"),
    ("sphere:5", r"tip 'sphere:5': the radius after ':' is wrong: '5' has no unit: a length "
                 r"needs one"),
    ("cone:1e-300", r"half_angle \(degree\) must be in \[0.1, 89.9\], got 1e-300"),
    ("flat:5e-320m", r"radius must be within the plausible range \[1e-09, 1\] m"),
    ("ball:5um", r"unknown shape 'ball' before ':' \(the shapes are sphere, paraboloid, cone, "
                 r"pyramid, flat\)"),
])
def test_cli_tip_names_the_wrong_part_and_the_forms(capsys, tmp_path, tip, match):
    code, err = _cli(capsys, "fit", _curve_csv(tmp_path / "c.csv"), "--model", "hertz",
                     "--tip", tip)
    assert code == 2
    assert "invalid _tip_type value" not in err
    assert re.search(match, err), err
    assert ("accepted: sphere:R | paraboloid:R | cone:ANGLE | pyramid:ANGLE | flat:RADIUS" in err
            or "one of sphere:R" in err)
    assert "1 nm to 1 m" in err and "[0.1, 89.9]" in err


@pytest.mark.parametrize(("make", "match"), [
    (lambda: Sphere(1e300), r"radius must be within the plausible range \[1e-09, 1\] m"),
    (lambda: Paraboloid(5e-320), r"radius must be within the plausible range"),
    (lambda: Flat(2.0), r"radius must be within the plausible range .*got 2\.0 m"),
    (lambda: Cone.from_degrees(1e-300), r"half_angle \(degree\) must be in \[0.1, 89.9\]"),
    (lambda: Pyramid(1e-300), r"half_angle must be within the plausible range .* rad = "
                              r"\[0.1°, 89.9°\]"),
    (lambda: parse_tip("sphere:1e-5"), r"'1e-5' has no unit"),
])
def test_tips_refuse_values_outside_their_ranges(make, match):
    with pytest.raises(ParameterError, match=match):
        make()


def test_tips_at_the_ends_of_their_ranges_are_made_and_beyond_refused():
    assert parse_tip("sphere:1nm").radius == 1e-9 and parse_tip("flat:1m").radius == 1.0
    for text in ("cone:0.1", "pyramid:89.9deg"):
        tip = parse_tip(text)
        assert type(tip).from_attrs(tip.as_attrs()) == tip  # the degree round trip stays in
    for text in ("sphere:0.999nm", "flat:1.001m", "cone:0.099", "pyramid:89.91deg"):
        with pytest.raises(ParameterError, match=r"plausible range|must be in \[0.1, 89.9\]"):
            parse_tip(text)


def test_contact_fit_with_a_subnormal_radius_is_refused(capsys):
    code, err = _cli(capsys, "fit", SPECTRUM, "--model", "contact", "--R", "5e-320m",
                     "--indentation", "5nm")
    assert code == 2 and "radius must be within the plausible range [1e-09, 1] m" in err


# ── 6. data files scaled by 1e±300, subnormal values, absurd time steps ─────────────────────


def test_force_column_times_1e_300_is_refused_not_a_traceback(capsys, tmp_path):
    path = _curve_csv(tmp_path / "tiny.csv", force=1e-300)
    code, err = _cli(capsys, "fit", path, "--model", "hertz", "--tip", "sphere:5um")
    assert code == 2
    assert "column 'force (N)' is at most" in err
    assert "below the smallest scale of a measured force, 1e-15 N" in err


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"force": 1e-310}, r"column 'force \(N\)' is at most \d\.\d+e-3\d\d N in magnitude "),
    ({"height": 1e-12}, r"column 'height \(m\)' .* below the smallest scale of a measured height, "
                        r"1e-12 m"),
    ({"time": 1e-15}, r"column 'time \(s\)' .* below the smallest scale of a measured time, "
                      r"1e-09 s"),
    ({"force": 1e-300, "height": 1e-300}, r"column 'height \(m\)'"),
])
def test_curve_columns_below_any_measurement_are_refused(tmp_path, kwargs, match):
    with pytest.raises(ParameterError, match=match):
        load_instrument(_curve_csv(tmp_path / "c.csv", **kwargs))


def test_subnormal_time_steps_are_refused(tmp_path):
    t = np.arange(140) * 1e-3
    t[1:4] = [1e-300, 2e-300, 3e-300]
    with pytest.raises(ParameterError, match=r"time steps by 1e-300 s at data row 2 \(line 3\) "
                                             r"\(1e-300 s after 0\.0 s\): a sample interval must "
                                             r"be at least 1e-12 s"):
        load_instrument(_curve_csv(tmp_path / "c.csv", times=t))


def test_spectrum_column_times_1e_300_is_refused(tmp_path):
    text = SPECTRUM.read_text().splitlines()
    header, rows = text[1], [r.split(",") for r in text[2:]]
    lines = [header] + [",".join([r[0], repr(float(r[1]) * 1e-300), *r[2:]]) for r in rows]
    path = tmp_path / "s.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ParameterError, match=r"column 'stiffness \(N/m\)' is at most .* below "
                                             r"the smallest scale of a measured stiffness"):
        load_instrument(path)


@pytest.mark.parametrize(("option", "value", "match"), [
    ("spring_constant", 1e-300, r"spring_constant must be within the plausible range "
                                r"\[1e-05, 1000\] N/m, got 1e-300 N/m"),
    ("sensitivity", "5e-320m/V", r"sensitivity must be within the plausible range \[1e-12, "
                                 r"0.001\] m/V \(given as '5e-320m/V'\)"),
])
def test_csv_calibrations_have_a_lower_bound(tmp_path, option, value, match):
    with pytest.raises(ParameterError, match=match):
        load_instrument(_curve_csv(tmp_path / "c.csv"), **{option: value})


# ── 6. UFF: the calibration ranges of the JPK reader, checked channels and times ───────────


def test_uff_spring_constant_1e_308_is_refused_with_its_range(capsys, tmp_path):
    path = _uff(tmp_path / "k.uff", {"Cantilever_springK_used(N/m)": "1.0E-308"})
    code, err = _cli(capsys, "fit", path, "--model", "hertz")
    assert code == 2
    assert ("the header's spring constant Cantilever_springK_used(N/m) = 1.0E-308 is outside "
            "the plausible range [1e-05, 1000] N/m (spring_constant): a corrupt header") in err
    assert "--spring-constant" in err


@pytest.mark.parametrize(("header", "velocity", "match"), [
    ({"Cantilever_springK_used(N/m)": "1E308"}, "1E-06",
     r"spring constant .* = 1E308 is outside the plausible range \[1e-05, 1000\] N/m"),
    ({"Recording_inv_optical_lever_sens_used(m/V)": "4.9E-324"}, "1E-06",
     r"inverse optical lever sensitivity .* is outside the plausible range \[1e-12, 0.001\] m/V"),
    ({}, "1E308", r"Recording_segment_0_velocity\(m/s\) = 1E308 gives a sample interval of .* s "
                  r".*outside \[1e-12 s,"),
    ({"Recording_xposition(m)": "1E308"}, "1E-06",
     r"Recording_xposition\(m\) = 1e\+308 m is beyond the physical range -1 <= x <= 1 m"),
])
def test_uff_header_values_outside_their_ranges_are_refused(tmp_path, header, velocity, match):
    with pytest.raises(InstrumentFormatError, match=match):
        read_uff(_uff(tmp_path / "h.uff", header, velocity=velocity))


@pytest.mark.parametrize(("options", "match"), [
    ({"spring_constant": 1e300}, r"spring_constant must be within the plausible range "
                                 r"\[1e-05, 1000\] N/m, got 1e\+300 N/m"),
    ({"sensitivity": "1e-300m/V"}, r"sensitivity must be within the plausible range"),
])
def test_uff_options_outside_their_ranges_are_refused(tmp_path, options, match):
    with pytest.raises(ParameterError, match=match):
        read_uff(_uff(tmp_path / "o.uff"), **options)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"scale": 1e-300}, r"the deflection: it is at most .* below the smallest scale of a measured "
                        r"deflection, 1e-13 m"),
    ({"scale": 1e300}, r"the deflection: sample \d is .* beyond the physical range"),
    ({"approach": [(0.0, 1.0), (1e-308, 0.6), (2e-308, 0.2)]},
     r"column 'Displacement' is at most 2e-308 m in magnitude"),
])
def test_uff_channels_outside_physics_are_refused(tmp_path, kwargs, match):
    with pytest.raises(InstrumentFormatError, match=match):
        read_uff(_uff(tmp_path / "c.uff", **kwargs))


def test_uff_tip_outside_the_tip_ranges_is_not_recorded(tmp_path):
    ds = read_uff(_uff(tmp_path / "t.uff", {"Tip_half_angle(deg)": "1E-300"}))
    assert "tip_shape" not in ds.attrs
    assert "without a half angle in [0.1, 89.9] degrees" in ds.attrs["tip_note"]


def test_a_dataset_from_elsewhere_is_checked_against_the_same_ranges():
    """The check every reader's dataset passes, ready for a netCDF file before it is fitted."""
    from viscoforce.io import quality

    spectrum = load_instrument(SPECTRUM)
    quality.check_measured(spectrum, "s.nc")
    with pytest.raises(ParameterError, match=r"s\.nc: stiffness holds 2\.\d+e\+302 N/m \(entry "
                                             r"0\), beyond the physical range 0 < stiffness <= "
                                             r"1e\+10 N/m"):
        quality.check_measured(spectrum.assign(stiffness=spectrum["stiffness"] * 1e300), "s.nc")
    with pytest.raises(ParameterError, match=r"omega is at most .* rad/s in magnitude .* below the "
                                             r"smallest scale of a measured omega"):
        quality.check_measured(spectrum.assign_coords(omega=spectrum["omega"] * 1e-300), "s.nc")


# ── 6. hunted: positions, loads and drags beyond what the solvers can compute ──────────────


def test_exact_fit_where_the_surfaces_do_not_interact_is_refused(capsys):
    code, err = _cli(capsys, "fit", SPECTRUM, "--model", "exact", "--h0=1e30m")
    assert code == 2
    assert "--h0 1e30m: the position must be where the surfaces interact" in err
    assert "p'(h) is 0 at every node of the grid" in err


def test_a_subnormal_mean_force_is_refused_with_its_range(capsys):
    code, err = _cli(capsys, "fit", SPECTRUM, "--model", "exact", "--mean-force=5e-320N")
    assert code == 2
    assert ("--mean-force 5e-320N: mean_force must be within the plausible range "
            "[1e-18, 1000] N, got 5e-320 N") in err


def test_a_drag_beyond_physics_is_refused_by_load(capsys, tmp_path):
    code, err = _cli(capsys, "load", MODULATION, "--out", tmp_path / "o.nc",
                     "--drag=1e300N*s/m")
    assert code == 2
    assert "drag must be within the plausible range [0, 1e+06] N·s/m" in err
    assert not (tmp_path / "o.nc").exists()


def test_a_tip_beyond_its_range_is_refused_by_load(capsys, tmp_path):
    code, err = _cli(capsys, "load", MODULATION, "--out", tmp_path / "o.nc", "--tip",
                     "sphere:1e300m")
    assert code == 2 and "radius must be within the plausible range [1e-09, 1] m" in err


# ── 7. curves=[0, 0] and an unknown height_channel, refused before any decoding ────────────


@pytest.mark.parametrize(("curves", "match"), [
    ([0, 0], r"curves selects curve 0 twice, at positions 0 and 1 of \[0, 0\]; give each curve "
             r"once"),
    ([1, -3], r"curves selects curve 1 twice \(as 1 and -3\)"),
    (np.array([2, 3, 2]), r"curves selects curve 2 twice, at positions 0 and 2"),
])
def test_a_curve_selected_twice_is_refused(curves, match):
    with read_jpk(MAP) as archive, pytest.raises(ParameterError, match=match):
        jpk_to_curves(archive, curves=curves)
    with pytest.raises(ParameterError, match=match):
        load_instrument(MAP, curves=curves)


def _no_decoding(monkeypatch):
    from viscoforce.io.jpk import JPKArchive

    def refuse(*args, **kwargs):
        raise AssertionError("a curve was decoded before the options were checked")

    monkeypatch.setattr(JPKArchive, "_decode", refuse)
    monkeypatch.setattr(JPKArchive, "_units", refuse)


@pytest.mark.parametrize("height_channel", ["bogus", "HEIGHT", 5, ["height"]])
def test_an_unknown_height_channel_is_refused_before_decoding(monkeypatch, height_channel):
    _no_decoding(monkeypatch)
    match = (r"height_channel must be None \(the first of strainGaugeHeight, measuredHeight, "
             r"capacitiveSensorHeight, height present in every segment\) or one of them, got ")
    with pytest.raises(ParameterError, match=match):
        load_instrument(MAP, height_channel=height_channel)
    from viscoforce.experiments.modulation import modulation_spectrum
    from viscoforce.experiments.stream import stream_spectrum

    with pytest.raises(ParameterError, match=match):
        modulation_spectrum(MODULATION, height_channel=height_channel)
    with pytest.raises(ParameterError, match=match):
        stream_spectrum(MODULATION, height_channel=height_channel, chunk=1)


def test_a_height_channel_missing_from_the_file_is_refused_from_the_headers(monkeypatch):
    from viscoforce.io.jpk import JPKArchive

    monkeypatch.setattr(JPKArchive, "_decode", lambda *a, **k: pytest.fail("decoded"))
    with pytest.raises(ParameterError, match=r"height_channel 'strainGaugeHeight' is missing in "
                                             r"curve 0 segment 0"):
        load_instrument(MAP, height_channel="strainGaugeHeight")


def test_modulation_of_a_dataset_refuses_repeats_and_another_height():
    from viscoforce.experiments.modulation import modulation_spectrum

    ds = load_instrument(MODULATION, height_channel="measuredHeight")
    with pytest.raises(ParameterError, match=r"curves selects curve 0 twice"):
        modulation_spectrum(ds, curves=[0, -1])
    with pytest.raises(ParameterError, match=r"height_channel 'height' chooses the height of a "
                                             r"JPK archive; this curves dataset was made with "
                                             r"'measuredHeight'"):
        modulation_spectrum(ds, height_channel="height")


# ── 7. a JPK archive inside a zip of archives: held once, refused with the estimate ────────


def _zip_of_archives(path: Path, padding: int) -> int:
    """A deflated zip holding one JPK archive that carries ``padding`` incompressible bytes."""
    inner = io.BytesIO()
    with zipfile.ZipFile(JPK) as src, zipfile.ZipFile(inner, "w", zipfile.ZIP_STORED) as dst:
        for info in src.infolist():
            dst.writestr(info, src.read(info))
        dst.writestr("padding.bin", np.random.default_rng(40).bytes(padding))
    data = inner.getvalue()
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as outer:
        outer.writestr("a.jpk-force", data)
    return len(data)


def _peak(work) -> int:
    tracemalloc.start()
    try:
        work()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_a_member_archive_is_held_once_not_three_times(tmp_path):
    path = tmp_path / "archives.zip"
    size = _zip_of_archives(path, 24 * MiB)

    def read():
        with read_jpk(path) as archive:
            archive.curve(0)

    peak = _peak(read)
    assert peak < 1.3 * size, f"peak {peak / MiB:.0f} MiB for a {size / MiB:.0f} MiB member"


def test_a_member_archive_beyond_the_memory_budget_is_refused_before_decompressing(
        tmp_path, monkeypatch):
    path = tmp_path / "archives.zip"
    size = _zip_of_archives(path, 8 * MiB)
    monkeypatch.setattr(_limits, "MAX_MEMORY_BYTES", 4 * MiB)
    error = []

    def read():
        with pytest.raises(EffortError) as info:
            read_jpk(path)
        error.append(info.value)

    peak = _peak(read)
    assert str(error[0]).startswith(
        f"{path}: a.jpk-force: holding this JPK archive in memory (a member of a zip of archives "
        f"is read whole): about {size + 2 * MiB:.3g} bytes needed, beyond the limit of "
        f"{4 * MiB:.3g} bytes")
    assert peak < MiB  # nothing was decompressed


# ── 7. slow refusals: the first bad line, before the rest of the file is parsed ────────────


def test_a_uff_segment_with_more_rows_than_it_declares_is_refused_at_the_first_extra(tmp_path):
    # damage far below the first row too many: it used to be reported, after every line of the
    # file had been split into tokens
    path = _uff(tmp_path / "long.uff", extra_rows=20_000, tail=("AP 0 x y",))
    peak = []

    def read():
        with pytest.raises(InstrumentFormatError, match=r"segment 0 \(AP\) declares 3 points "
                                                         r"\(Recording_segment_0_nb_point\), the "
                                                         r"file has more: line \d+ is its data "
                                                         r"line 4; refused there"):
            read_uff(path)

    peak.append(_peak(read))
    assert peak[0] < 4 * path.stat().st_size  # the text, not a list of every line's tokens


def test_a_csv_of_text_is_refused_from_its_first_rows(tmp_path):
    path = tmp_path / "text.csv"
    path.write_text("time (s),force (N),height (m)\n" + "abc,def,ghi\n" * 400_000)
    peak = []

    def read():
        with pytest.raises(ParameterError, match=r"column 'time \(s\)' data row 1 \(line 2\) is "
                                                 r"not a finite number \('abc'\)"):
            load_instrument(path)

    peak.append(_peak(read))
    assert peak[0] < 5 * MiB  # 1000 rows parsed, not 400 000 rows of strings (25 MiB)


def test_text_at_the_end_of_a_csv_is_found_chunk_by_chunk(tmp_path, monkeypatch):
    monkeypatch.setattr(_csv_table, "_CHUNK_ROWS", 5_000)
    path = tmp_path / "late.csv"
    rows = "".join(f"{k * 1e-3!r},1e-9,{1e-6 + k * 1e-12!r}\n" for k in range(300_000))
    path.write_text("time (s),force (N),height (m)\n" + rows + "x,1e-9,1e-6\n")
    peak = []

    def read():
        with pytest.raises(ParameterError, match=r"column 'time \(s\)' data row 300001 "
                                                 r"\(line 300002\) is not a finite number"):
            load_instrument(path)

    peak.append(_peak(read))
    assert peak[0] < 12 * MiB  # not a column of 300 000 Python objects (37 MiB)


@pytest.mark.parametrize(("header", "row", "match"), [
    ("time (s),force (N),height (m),junk (1)", "0,1e-9,1e-6,0", r"line 200002 has 5 fields, "
                                                                r"expected 4"),
    ("time (s),force (N),height (m)", "0,1e-9,1e-6", r"line 200002 has 4 fields, expected 3"),
])
def test_a_line_with_an_extra_field_is_found_without_parsing_every_line(tmp_path, monkeypatch,
                                                                        header, row, match):
    """NumPy counts the delimiters; Python parses only the lines whose count differs."""
    calls = []
    split = _csv_table._split
    monkeypatch.setattr(_csv_table, "_split", lambda *a: calls.append(1) or split(*a))
    path = tmp_path / "extra.csv"
    rows = [row.replace("0,", f"{k * 1e-3!r},", 1) for k in range(200_000)]
    path.write_text("\n".join([header, *rows, rows[-1] + ",5"]) + "\n")
    with pytest.raises(ParameterError, match=match):
        load_instrument(path)
    assert len(calls) < 100  # was one csv split per line: 200 000


def test_a_refusal_reaches_the_command_line_as_one_message(capsys, tmp_path):
    path = _curve_csv(tmp_path / "tiny.csv", force=1e-300)
    code = main(["load", str(path), "--out", str(tmp_path / "o.nc"), "--json"])
    out, err = capsys.readouterr()
    assert code == 2 and not out and err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "o.nc").exists()


# ── fitting and theory inputs: fixed inputs, netCDF data, spans, surface-force laws ────────


CONTACT = ("fit", SPECTRUM, "--model", "contact", "--tip", "sphere:5um")


@pytest.mark.parametrize(("argv", "message"), [
    ((*CONTACT, "--indentation", "5nm", "--drag=1e300N*s/m"),
     "--drag 1e300N*s/m: drag must be within the plausible range [0, 1e+06] N*s/m"),
    ((*CONTACT, "--indentation", "5nm", "--material", "structural", "--reference-frequency",
      "5e-320Hz"),
     "--reference-frequency 5e-320Hz: the reference frequency must be within the plausible "
     "range [1e-06, 1e+09] Hz"),
    ((*CONTACT, "--indentation", "5e-320m"),
     "--indentation 5e-320m: indentation must be within the plausible range [1e-12, 1] m"),
    ((*CONTACT, "--indentation=1e300m"),
     "--indentation 1e300m: indentation must be within the plausible range [-1, 1] m"),
    (("fit", SPECTRUM, "--model", "svda", "--mean-force=5e-320N"),
     "--mean-force 5e-320N: mean_force must be within the plausible range [1e-18, 1000] N"),
])
def test_fixed_inputs_of_spectrum_models_have_ranges(capsys, argv, message):
    code, err = _cli(capsys, *argv)
    assert code == 2 and message in err, err


@pytest.mark.parametrize(("extra", "message"), [
    (("--contact-point=1e300m",),
     "--contact-point 1e300m: contact_point must be within the plausible range [-1, 1] m"),
    (("--drag=1e300N*s/m",), "drag must be within the plausible range [0, 1e+06] N*s/m"),
    (("--material", "structural", "--reference-frequency", "5e-320Hz"),
     "--reference-frequency 5e-320Hz: the reference frequency must be within the plausible "
     "range [1e-06, 1e+09] Hz"),
])
def test_fixed_inputs_of_the_ting_model_have_ranges(capsys, tmp_path, extra, message):
    code, err = _cli(capsys, "fit", _curve_csv(tmp_path / "c.csv"), "--model", "ting", "--tip",
                     "sphere:5um", *extra)
    assert code == 2 and message in err, err


@pytest.mark.parametrize(("name", "fixed", "match"), [
    ("contact", {"radius": 1e-5, "indentation": 5e-9, "drag": 1e300},
     r"drag must be within the plausible range \[0, 1e\+06\] N\*s/m, got 1e\+300"),
    ("contact", {"radius": 1e-5, "indentation": 5e-320},
     r"indentation must be within the plausible range \[1e-12, 1\] m"),
    ("contact", {"radius": 1e-5, "indentation": 5e-9, "material": "structural",
                 "reference_frequency": 5e-320},
     r"reference_frequency must be within the plausible range \[1e-06, 1e\+09\] Hz"),
    ("svda", {"radius": 1e-5, "P": 1e7, "debye_length": 1e-9, "mean_force": 5e-320},
     r"mean_force must be within the plausible range \[1e-18, 1000\] N"),
    ("svda", {"radius": 1e300, "P": 1e7, "debye_length": 1e-9, "position": 2e-9},
     r"radius must be within the plausible range \[1e-09, 1\] m"),
    ("svda", {"radius": 1e-5, "P": 1e300, "debye_length": 1e-9, "position": 2e-9},
     r"P must be within the plausible range \[0.001, 1e\+12\] Pa"),
    ("svda", {"radius": 1e-5, "P": 1e7, "debye_length": 5e-320, "position": 2e-9},
     r"debye_length must be within the plausible range \[1e-12, 1\] m"),
])
def test_make_model_refuses_fixed_inputs_beyond_their_ranges(name, fixed, match):
    from viscoforce.fitting.models import make_model

    with pytest.raises(ParameterError, match=match):
        make_model(name, **fixed)


def test_ting_solve_refuses_a_drag_a_contact_point_and_a_reference_frequency_beyond_physics():
    from viscoforce.physics.ting import PowerLawRelaxation, PronyRelaxation, ting_solve

    t = np.linspace(0.0, 1.0, 50)
    z = 1e-6 * np.sin(np.pi * t)
    kernel = PronyRelaxation(1e3, (1e3,), (0.1,))
    with pytest.raises(ParameterError, match=r"drag must be within the plausible range "
                                             r"\[0, 1e\+06\] N\*s/m"):
        ting_solve(t, z, 0.0, Sphere(5e-6), kernel, drag=1e300)
    with pytest.raises(ParameterError, match=r"contact_point must be within the plausible range "
                                             r"\[-1, 1\] m, got 1e\+300 m"):
        ting_solve(t, z, 1e300, Sphere(5e-6), kernel)
    with pytest.raises(ParameterError, match=r"reference_frequency must be within the plausible "
                                             r"range \[1e-06, 1e\+09\] Hz, got 5e-320 Hz"):
        PowerLawRelaxation.from_structural(1e3, 0.2, reference_frequency=5e-320)


def _spectrum_nc(path: Path, scale: float, *, source: str | None = "csv-spectrum",
                 omega_scale: float = 1.0) -> Path:
    ds = load_instrument(SPECTRUM)
    ds = ds.assign(stiffness=ds["stiffness"] * scale,
                   stiffness_stderr=ds["stiffness_stderr"] * scale)
    ds = ds.assign_coords(omega=ds["omega"] * omega_scale)
    if source is None:
        del ds.attrs["source"]
    else:
        ds.attrs["source"] = source
    ds.to_netcdf(path)
    return path


@pytest.mark.parametrize("model", [("contact", "--tip", "sphere:5um", "--indentation", "5nm"),
                                   ("exact", "--h0=-5nm"), ("svda", "--h0=5nm")])
@pytest.mark.parametrize(("scale", "message"), [
    (1e300, r"x\.nc: stiffness holds 2\.\d+e\+302 N/m \(entry 0\), beyond the physical range "
            r"0 < stiffness <= 1e\+10 N/m"),
    (1e-300, r"x\.nc: stiffness is at most \S+ N/m in magnitude .* below the smallest scale of a "
             r"measured stiffness"),
])
def test_a_measured_netcdf_spectrum_is_checked_before_it_is_fitted(capsys, tmp_path, model,
                                                                    scale, message):
    path = _spectrum_nc(tmp_path / "x.nc", scale)
    code, err = _cli(capsys, "fit", path, "--model", *model)
    assert code == 2 and re.search(message, err), err


def test_a_simulated_netcdf_spectrum_is_fitted_as_before(capsys, tmp_path):
    """Beyond a measured range (ω up to 1.9e10 rad/s) but simulated: fitted, not refused."""
    measured = _spectrum_nc(tmp_path / "m.nc", 1.0, omega_scale=1e6)
    code, err = _cli(capsys, "fit", measured, "--model", "prony")
    assert code == 2 and "omega holds" in err and "beyond the physical range" in err
    for source in ("simulation", None):
        path = _spectrum_nc(tmp_path / f"{source}.nc", 1.0, source=source, omega_scale=1e6)
        code, err = _cli(capsys, "fit", path, "--model", "prony")
        assert code == 0, err


def test_the_bundled_netcdf_example_is_still_fitted(capsys):
    import viscoforce as vf

    code, err = _cli(capsys, "fit", vf.example_path("sls_spectrum_map.nc"), "--model", "prony",
                     "--curve", "0")
    assert code == 0, err


def test_equilibrium_at_a_subnormal_load_is_refused_with_its_range(make_problem):
    from viscoforce.physics.materials import Elastic
    from viscoforce.solvers.static import equilibrium_at_load, position_at_load

    problem = make_problem(Elastic(1e9), -5e-9)
    for solve in (equilibrium_at_load, position_at_load):
        with pytest.raises(ParameterError, match=r"load must be within the plausible range "
                                                 r"\[1e-18, 1000\] N, got 5e-320 N"):
            solve(problem, 5e-320, 1e9)


def _approach_curves(*, z_scale=1.0, f_scale=1.0):
    from viscoforce.schema import make_curves

    z = np.linspace(0.0, 2e-6, 80) * z_scale
    f = 1e-9 * np.clip(z / z_scale - 1e-6, 0, None) ** 1.5 / 1e-9 * f_scale + 1e-9 * f_scale
    return make_curves(np.linspace(0, 1, z.size), f, -z, np.zeros_like(z), tip_position=z,
                       segment=0, segment_names=("approach",), source="synthetic")


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"z_scale": 5e-9}, r"the approach spans 1e-14 m of tip position \(from 0 m to 1e-14 m\), "
                        r"below the smallest span a fit can bound, 1e-12 m"),
    ({"f_scale": 1e-8}, r"the approach spans \S+ N of force .*, below the smallest span a fit "
                        r"can bound, 1e-13 N"),
])
def test_a_curve_with_a_tiny_span_is_refused_naming_the_span(kwargs, match):
    from viscoforce.fitting.curves import fit_curve

    with pytest.raises(ParameterError, match=match):
        fit_curve(_approach_curves(**kwargs), "hertz", tip="sphere:5um")


@pytest.mark.parametrize("window", [(0.0, 1e-14), (0.0, 1e300)])
def test_a_contact_window_beyond_its_range_or_too_narrow_is_refused(window):
    from viscoforce.fitting.models import make_model

    with pytest.raises(ParameterError, match=r"contact_window must lie within the plausible "
                                             r"range \[-1, 1\] m and be at least 1e-12 m wide"):
        make_model("hertz", tip="sphere:5um", contact_window=window)


def test_a_parameter_window_narrower_than_lmfits_resolution_is_a_parameter_error():
    from viscoforce.fitting._params import Internal

    with pytest.raises(ParameterError, match=r"parameter 'contact_point' needs min < max by more "
                                             r"than 1e-13 \(lmfit's resolution of bounds\), got "
                                             r"\[0.0, 1e-14\]"):
        Internal("contact_point", 0.0, 0.0, 1e-14)


def test_load_refuses_a_bad_tip_before_reading_the_file(capsys, tmp_path):
    code, err = _cli(capsys, "load", tmp_path / "absent.jpk-force", "--tip", "sphere:1e300m")
    assert code == 2
    assert ("argument --tip: tip 'sphere:1e300m': the radius after ':' is wrong: radius must be "
            "within the plausible range [1e-09, 1] m") in err
    assert "absent" not in err


def test_streamed_curves_refuse_an_unknown_height_channel_before_decoding(monkeypatch, tmp_path):
    from viscoforce.io.stream import iter_curves, write_curves_netcdf

    _no_decoding(monkeypatch)
    match = r"height_channel must be None .* got 'bogus'"
    with read_jpk(MAP) as archive:
        with pytest.raises(ParameterError, match=match):
            list(iter_curves(archive, height_channel="bogus"))
        with pytest.raises(ParameterError, match=match):
            write_curves_netcdf(archive, tmp_path / "o.nc", height_channel="bogus")
    assert not list(tmp_path.iterdir())


SPECTRUM_RUN = ("spectrum", "--h0=5nm", "--eta", "0.1nm", "--omega", "1Hz")


@pytest.mark.parametrize(("flag", "value", "message"), [
    ("--debye-length", "5e-320m",
     "--debye-length 5e-320m: debye_length must be within the plausible range [1e-12, 1] m"),
    ("--debye-length", "1e300m", "debye_length must be within the plausible range [1e-12, 1] m"),
    ("--z0", "1e300m",
     "--z0 1e300m: z0 (soft-wall length) must be within the plausible range [1e-12, 1] m"),
    ("--z0", "5e-320m", "z0 (soft-wall length) must be within the plausible range"),
    ("--P", "1e300Pa", "--P 1e300Pa: P (double-layer pressure scale) must be within the "
                       "plausible range [0.001, 1e+12] Pa"),
    ("--P", "5e-320Pa", "P (double-layer pressure scale) must be within the plausible range"),
    ("--Pw", "1e300Pa", "--Pw 1e300Pa: Pw (soft-wall pressure) must be within the plausible "
                        "range [0.001, 1e+12] Pa"),
    ("--R", "1e300m", "--R 1e300m: the radius (R) must be within the plausible range "
                      "[1e-09, 1] m"),
    ("--R", "5e-320m", "the radius (R) must be within the plausible range [1e-09, 1] m"),
])
def test_theory_parameters_beyond_their_ranges_are_refused_naming_the_flag(capsys, flag, value,
                                                                          message):
    code, err = _cli(capsys, *SPECTRUM_RUN, flag, value)
    assert code == 2 and message in err, err


@pytest.mark.parametrize(("make", "match"), [
    (lambda vf: vf.DoubleLayer(1e7, 5e-320), r"debye_length must be within the plausible range "
                                             r"\[1e-12, 1\] m, got 5e-320 m"),
    (lambda vf: vf.DoubleLayer(1e300, 1e-9), r"P \(double-layer pressure scale\) must be within "
                                             r"the plausible range \[0.001, 1e\+12\] Pa"),
    (lambda vf: vf.SoftWall(1e7, 1e300), r"z0 \(soft-wall length\) must be within the plausible "
                                         r"range \[1e-12, 1\] m"),
    (lambda vf: vf.SoftWall(5e-320, 5e-10), r"Pw \(soft-wall pressure\) must be within the "
                                            r"plausible range"),
    (lambda vf: vf.ContactProblem.create(sphere=vf.Sphere(1e300), surface_force=vf.DoubleLayer(),
                                         material=vf.Elastic(1e9), deepest_position=0.0),
     r"radius \(R\) must be within the plausible range \[1e-09, 1\] m"),
])
def test_surface_force_laws_and_the_sphere_refuse_values_beyond_their_ranges(make, match):
    import viscoforce as vf

    with pytest.raises(ParameterError, match=match):
        make(vf)


def test_the_papers_defaults_lie_inside_the_theory_ranges():
    import viscoforce as vf

    law = vf.DoubleLayer(vf.PAPER.P, vf.PAPER.debye_length) + vf.SoftWall(vf.PAPER.Pw, vf.PAPER.z0)
    problem = vf.ContactProblem.create(sphere=vf.PAPER.sphere(), surface_force=law,
                                       material=vf.Elastic(vf.PAPER.E_inf), deepest_position=-5e-9)
    assert problem.sphere.radius == vf.PAPER.R


@pytest.mark.parametrize("h0", ["100nm", "1um", "1e300m"])
def test_svda_far_from_the_surface_is_refused_not_a_traceback(capsys, h0):
    """k* does not depend on the moduli there (its sensitivity 0 or NaN): was ZeroDivisionError."""
    from viscoforce.data import example_path

    assert main(["fit", str(example_path("sls_spectrum.csv")), "--model", "svda",
                 f"--h0={h0}"]) == 2
    err = capsys.readouterr().err
    assert "does not depend on the moduli" in err and "Traceback" not in err
