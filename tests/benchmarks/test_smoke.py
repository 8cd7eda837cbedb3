"""The one smoke test of every timing suite and study (benchmarks/run.py's SUITES).

Each suite's smoke run (``Suite.quick``) runs once per session (the ``quick_run`` fixture,
shared with the per-suite checks in test_solvers.py, test_fits_and_io.py and test_studies.py);
here: it exits 0 and writes its JSON with the documented top-level keys and every documented
file. No wall time is asserted or compared (timings depend on the machine and its load). Also:
the command-line errors the scripts refuse with, and that SUITES is the whole list.
"""

from __future__ import annotations

import re

import pytest

from tests._bench import REPO, run_main
from tests.benchmarks._smoke import RUNNER, SUITES, passed

#: The documented top-level keys of each suite's JSON (benchmarks/README.md, section of the
#: script; studies/<name>/README.md).
TOP_KEYS = {
    "bench_static": {"schema", "created", "quick", "machine", "target", "settings", "build",
                     "default_grid", "sweep", "summary", "files"},
    "bench_dynamics": {"schema", "created", "quick", "machine", "target", "settings",
                       "reference", "sweep", "equal_accuracy", "outputs_effect", "profile",
                       "summary", "files"},
    "bench_spectrum": {"schema", "created", "quick", "machine", "target", "settings", "linear",
                       "time_domain", "paper_eta", "fig4_peak", "summary", "files"},
    "bench_linear": {"schema", "created", "quick", "machine", "target", "settings", "rows",
                     "summary", "files"},
    "bench_regression": {"schema", "created", "quick", "machine", "target", "settings",
                         "workers", "accuracy", "rows", "checks", "summary", "files"},
    "bench_step": {"schema", "created", "quick", "machine", "target", "settings", "results",
                   "summary", "files", "wall_time_s", "loadavg_end"},
    "bench_fit": {"schema", "created", "quick", "machine", "target", "settings", "single",
                  "profiles", "maps", "summary", "files"},
    "bench_overhead": {"schema", "created", "quick", "machine", "target", "settings", "cases",
                       "summary", "files"},
    "bench_chooser": {"real", "synthetic", "replicas", "blas_threads"},
    "bench_maps": {"schema", "created", "quick", "machine", "target", "settings", "startup",
                   "capacity", "results", "checks", "summary", "files", "wall_time_s",
                   "loadavg_end"},
    "bench_load": {"schema", "created", "quick", "machine", "target", "settings", "real",
                   "synthetic", "summary", "files"},
    "bench_stream": {"schema", "created", "quick", "machine", "target", "settings", "maps",
                     "runs", "summary", "files"},
    "bench_startup": {"schema", "created", "quick", "machine", "target", "settings", "results",
                      "ratio", "extra_imports", "summary", "files"},
    "bench_budget": {"schema", "created", "quick", "machine", "target", "settings", "results",
                     "skipped", "summary", "files"},
    "bench_modes_auto": {"schema", "created", "quick", "machine", "target", "settings",
                         "results", "skipped", "summary", "files"},
    "bench_hertz_speed": {"schema", "created", "quick", "machine", "target", "settings",
                          "nanite_source", "results", "skipped", "summary", "files"},
    "bench_ting_nonuniform": {"schema", "created", "quick", "machine", "target", "settings",
                              "results", "ratio", "summary", "files"},
    "speed_accuracy": {"schema", "created", "quick", "machine", "settings", "rows", "summary",
                       "files"},
    "validity_maps": {"schema", "created", "quick", "machine", "settings", "rows", "boundaries",
                      "summary", "files"},
    "real_data": {"schema", "created", "quick", "machine", "data_dir", "radius_m", "datasets",
                  "coverage", "markdown", "wall_time_s"},
    "split_half": {"schema", "created", "machine", "file", "frequencies_hz", "periods_per_half",
                   "rms_z", "mean_z", "n_values", "cost_us_per_segment"},
    "phase_lag_real": {"schema", "created", "viscoforce", "file", "frequencies_hz",
                       "sensor_vs_piezo_lag_deg", "runs", "conclusion"},
    "ting_real": {"schema", "created", "viscoforce", "file", "settings", "pyfmrheo", "curve0",
                  "curves", "speed", "differences"},
    "adhesion_loops": {"schema", "created", "quick", "settings", "loops", "limits",
                       "speed_series"},
    "adhesion_pulloff": {"schema", "created", "quick", "machine", "settings", "rows",
                         "maugis_dugdale", "fold_onset", "path", "summary", "files"},
}
#: The real JPK modulation map real_data.py needs (the bundled copy, else the shared one).
REAL_MAPS = (REPO / "data_examples" / "real" / "modulation-map.jpk-force-map",
             REPO.parent / "shared" / "data" / "real" / "PyFMReader"
             / "map-data-2021.11.05-17.37.44.432.jpk-force-map")
#: Marks of a suite's tests, as its own test file had them (dask: skipped by quick_run).
MARKS = {
    # the paper's Fig. 3 scene (2 nm) is deliberately evaluated with the SVDA, which warns there
    # (estimated error > 1 %, issue 15); the warning itself is tested in
    # tests/theory/test_failure_regions.py
    "bench_fit": pytest.mark.filterwarnings(
        "ignore:the SVDA is about:viscoforce.exceptions.ModelValidityWarning"),
    "real_data": pytest.mark.skipif(not any(p.is_file() for p in REAL_MAPS),
                                    reason="the real JPK modulation map is absent"),
}


def suites():
    # from the last suite to the first: the runs are shared with the per-suite files (a lock per
    # suite), which go from first to last, so two xdist workers meet in the middle instead of one
    # waiting for the suite the other is running
    # the studies' smoke runs are slow studies (`-m slow`; CI skips them, they stay runnable)
    return [pytest.param(name, marks=(*_as_tuple(MARKS.get(name, ())),
                                      *((pytest.mark.slow,) if SUITES[name].kind == "study"
                                        else ())), id=name)
            for name in reversed(SUITES)]


def _as_tuple(marks):
    return marks if isinstance(marks, tuple) else (marks,)


@pytest.mark.parametrize("name", suites())
def test_smoke_run_writes_the_documented_keys_and_files(name, quick_run):
    run = passed(quick_run(name))
    report = run.report
    assert set(report) == TOP_KEYS[name]
    if "schema" in report:
        assert report["schema"].startswith(f"viscoforce.{name}/"), report["schema"]
    if "quick" in report:
        assert report["quick"] is True
    for file in (SUITES[name].output, *SUITES[name].files):
        assert (run.out / file).stat().st_size > 0, file


#: Command lines each script refuses before any work: exit status 2 and the message.
REFUSED = [
    ("bench_static", ("--quick", "--repeats", "0"), "--repeats must be >= 1"),
    ("bench_dynamics", ("--quick", "--repeats", "0"), "--repeats must be >= 1"),
    ("bench_linear", ("--quick", "--repeats", "0"), "--repeats must be >= 1"),
    ("bench_regression", ("--quick", "--repeats", "0"), "--repeats must be >= 1"),
    ("bench_spectrum", ("--quick", "--repeats", "5"), "--repeats must be >= 10"),
    pytest.param("bench_stream", ("--sizes", "16", "20"),
                 "--sizes must be at least two square numbers",
                 marks=pytest.mark.skipif(RUNNER.missing(SUITES["bench_stream"]) is not None,
                                          reason="needs dask.distributed")),
]


@pytest.mark.parametrize(("name", "args", "message"), REFUSED)
def test_refuses_bad_arguments(name, args, message, tmp_path):
    out = () if name == "bench_stream" else ("--out", str(tmp_path))
    code, _, stderr = run_main(SUITES[name].path.name, *args, *out)
    assert code == 2
    assert message in stderr


def test_suites_is_the_whole_list():
    # every bench_*.py in benchmarks/ and every study script is in SUITES, and nothing else
    scripts = {p.relative_to(REPO).as_posix() for p in (REPO / "benchmarks").glob("bench_*.py")}
    scripts |= {p.relative_to(REPO).as_posix() for p in (REPO / "studies").glob("*/*.py")
                if p.stem == p.parent.name}
    assert {s.script for s in SUITES.values()} == scripts
    for s in SUITES.values():
        assert s.path.is_file() and s.kind == ("timing" if s.name.startswith("bench_") else "study")
        assert s.kind == "timing" or (REPO / "studies" / s.name / "README.md").is_file()


def test_every_timing_suite_has_one_case_table():
    for s in SUITES.values():
        if s.kind == "timing":
            source = s.path.read_text()
            assert len(re.findall(r"^CASES = ", source, flags=re.M)) == 1, s.script
            assert len(re.findall(r"^QUICK_CASES = ", source, flags=re.M)) <= 1, s.script


def test_runner_lists_every_suite_and_refuses_unknown_names(capsys):
    assert RUNNER.main(["--list"]) == 0
    listed = capsys.readouterr().out
    assert all(f"{s.name} " in listed and s.script in listed for s in SUITES.values())
    with pytest.raises(SystemExit) as exc:
        RUNNER.main(["no_such_suite"])
    assert exc.value.code == 2
    assert "unknown suite(s) no_such_suite" in capsys.readouterr().err
