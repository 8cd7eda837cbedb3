#!/usr/bin/env python
"""Fit benchmark: single spectrum fits (svda, exact 1 and 2 modes) and fitted maps (issue 13 item 5).

What it measures (see benchmarks/README.md, section ``bench_fit.py``), on synthetic 30-point
spectra (ω log-spaced over [1e1, 1e6] rad/s, 1 % complex noise from a fixed seed, stderr given so
the fit is weighted): the paper's 10 µm sphere and pressure law, SLS E0 = 1e10 Pa, E_inf = 1e9 Pa,
τ = 1 ms; the two-mode material E0 = 1e10, E_1 = 3e9, E_inf = 1e9 Pa, τ = 0.1 ms and 3 ms.

1. Single fits, ``fit_spectrum`` (lmfit), median wall time of ``--repeats`` runs (≥ 5; 1 with
   --quick, and no warm-up call). The exact model's ``linearized_state`` cache is cleared before
   each timed run ("cold": a new spectrum), and the warm-cache time is reported beside it. Cases:
   svda at h̄0 = 2 nm; exact one-mode and two-mode at h̄0 = 2 nm (pre-contact) and −5 nm (contact).
   Beside each, a plain ``scipy.optimize.least_squares`` on the same weighted complex residual
   (real and imaginary parts stacked, the real part of ``FitData.weights`` on the real residual,
   the imaginary part on the imaginary one), from the same start (the model's ``guess``), in the
   same log10 parameters: MINPACK ``lm`` (unbounded, lmfit's ``leastsq`` algorithm) and ``trf``
   (the guess's bounds). Reported: floor time, function evaluations, the relative difference of the
   parameters to lmfit's, and every fit's relative error against the truth.
2. Where the time goes, for one cold fit per model (svda, exact one- and two-mode at 2 nm): the
   library's steps timed by wrapping them (reading the dataset, guess, model evaluations, lmfit
   overhead, result dataset), uncertainties from cProfile, and a cProfile listing per case
   (--quick: one fit, instrumented and profiled at once, so its split is inflated by cProfile).
3. Maps, ``fit_map(..., scheduler=None)`` (a local cluster, 1 thread per worker): a 64×64 svda
   map on 1 and 2 workers (8×8 with --quick) and a 16×16 exact one-mode map on 2 workers (4×4).
   With --quick the exact model's grid has twice the default spacing (a smoke run).
   The cluster start-up and teardown (LocalCluster + Client) are timed inside each fit_map run
   (``fitting.maps.cluster`` wrapped by a timing context manager) and are part of the total;
   both are reported. Memory: peak of the summed RSS of this process and its children (the
   workers), sampled every 20 ms with psutil (resource.getrusage when psutil is missing).

BLAS is pinned to one thread (environment before NumPy loads, inherited by the workers, plus
threadpoolctl). Run ``python benchmarks/bench_fit.py [--quick] [--out DIR] [--repeats N]``.
Outputs in ``--out``: ``fit_benchmark.json`` (keys :data:`JSON_KEYS`), ``fit_single.csv``,
``fit_maps.csv``, ``fit_profile_<case>.txt`` and ``fit_timings.png``.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # this process and the LocalCluster workers, before NumPy loads

import contextlib  # noqa: E402
import cProfile  # noqa: E402
import functools  # noqa: E402
import io  # noqa: E402
import math  # noqa: E402
import pstats  # noqa: E402
import resource  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402
from threadpoolctl import threadpool_info, threadpool_limits  # noqa: E402

import viscoforce as vf  # noqa: E402
from viscoforce import PAPER  # noqa: E402
from viscoforce.experiments.linear_response import linear_stiffness, linearized_state  # noqa: E402
from viscoforce.fitting import _params, fit_spectrum, maps  # noqa: E402
from viscoforce.fitting.data import spectrum_data  # noqa: E402
from viscoforce.fitting.maps import fit_map  # noqa: E402
from viscoforce.fitting.models import make_model  # noqa: E402
from viscoforce.fitting.pixels import pixel_data  # noqa: E402
from viscoforce.physics.materials import PronySeries, StandardLinearSolid  # noqa: E402
from viscoforce.physics.paper import paper_pressure_law  # noqa: E402
from viscoforce.physics.particle import Sphere  # noqa: E402
from viscoforce.schema import make_spectrum  # noqa: E402
from viscoforce.svda import svda_complex_stiffness  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/_common.py, from any cwd
from _common import (  # noqa: E402
    gc_paused,
    load_average,
    machine_facts,
    parse_args,
    pf,
    print_machine,
    report_head,
    run_end,
    write_csv,
    write_json,
)

try:  # memory of this process plus the workers
    import psutil
except ImportError:  # pragma: no cover - psutil is a dependency of distributed
    psutil = None

# the system and the synthetic data
N_OMEGA, OMEGA_MIN, OMEGA_MAX = 30, 1e1, 1e6  # [rad/s]
NOISE = 0.01  # relative complex noise per component (σ = 1 % of |k*|)
SEED = 20261201
E0, E_INF, TAU = 1e10, 1e9, 1e-3  # one-mode truth [Pa, Pa, s]
TWO_MODE = {"E0": 1e10, "E_1": 3e9, "E_inf": 1e9, "tau_1": 1e-4, "tau_2": 3e-3}
H0_PRE, H0_CONTACT = 2e-9, -5e-9  # [m]
SVDA_FIXED = {"position": H0_PRE, "radius": PAPER.R, "P": PAPER.P,
              "debye_length": PAPER.debye_length}
# targets (issue 13 item 5)
TARGETS = {"svda_fit_s": 20e-3, "exact_1mode_fit_s": 0.3, "exact_2mode_fit_s": 1.0,
           "svda_map_s": 20.0, "svda_map_speedup": 1.6, "exact_map_s": 60.0,
           "map_memory_bytes": 2 ** 30, "svda_map_size": 64, "exact_map_size": 16,
           "map_workers": 2}
REPEATS, QUICK_REPEATS = 7, 1
#: --quick: the exact model's grid spacing × 2 (half the nodes; a smoke run, its times are not the
#: default grid's)
QUICK_GRID_FACTOR = 2.0
#: The case table. ``single`` (parts 1 and 2): one fit per row, the model with its modes at a
#: position [m], from 1 % noisy synthetic data of the one- or two-mode truth; ``profiled`` rows are
#: also profiled. ``map`` (part 3): an n × n map of the svda or the exact one-mode model fitted on
#: each number of ``workers``. Built (in this order: one seeded generator) by :func:`cases` and
#: :func:`main`.
CASES = (
    {"part": "single", "case": "svda", "model": "svda", "modes": 1, "position": H0_PRE,
     "profiled": True},
    {"part": "single", "case": "exact1_2nm", "model": "exact", "modes": 1, "position": H0_PRE,
     "profiled": True},
    {"part": "single", "case": "exact1_-5nm", "model": "exact", "modes": 1,
     "position": H0_CONTACT, "profiled": False},
    {"part": "single", "case": "exact2_2nm", "model": "exact", "modes": 2, "position": H0_PRE,
     "profiled": True},
    {"part": "single", "case": "exact2_-5nm", "model": "exact", "modes": 2,
     "position": H0_CONTACT, "profiled": False},
    {"part": "map", "map": "svda", "n": 64, "workers": (1, 2)},
    {"part": "map", "map": "exact", "n": 16, "workers": (2,)},
)
#: --quick: the same single fits (on :data:`QUICK_GRID_FACTOR` × the grid spacing), maps of 8×8
#: (svda) and 4×4 (exact).
QUICK_CASES = tuple({**c, "n": {"svda": 8, "exact": 4}[c["map"]]} if c["part"] == "map" else c
                    for c in CASES)
SAMPLE_PERIOD = 0.02  # [s] RSS sampling
PROFILE_TOP = 25
SCHEMA = "viscoforce.bench_fit/1"
#: Top-level keys of fit_benchmark.json (documented in benchmarks/README.md).
JSON_KEYS = ("schema", "created", "quick", "machine", "target", "settings", "single", "profiles",
             "maps", "summary", "files")


# ── synthetic data ───────────────────────────────────────────────────────────────────────────────

def omega_grid() -> np.ndarray:
    return np.logspace(math.log10(OMEGA_MIN), math.log10(OMEGA_MAX), N_OMEGA)


def noisy(k: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """k* with independent real and imaginary noise of σ = NOISE·|k*| each."""
    return k + NOISE * np.abs(k) * (rng.standard_normal(k.shape) + 1j * rng.standard_normal(k.shape))


def spectrum(k: np.ndarray, mean_force: float, dims: tuple[str, ...] = ("omega",)):
    """Spectrum dataset of noisy k*; stderr 1 % of the stiffness and 0.01 rad of the phase."""
    stderr = {"stiffness": NOISE * np.abs(k), "phase": np.full(k.shape, math.degrees(NOISE))}
    return make_spectrum(omega_grid(), k, mean_force, 1e-10, stderr=stderr, dims=dims,
                         source="simulation")


def problem_at(position: float, material, grid_factor: float = 1.0) -> vf.ContactProblem:
    """The paper's system on the default grid, or one with ``grid_factor`` × its mean spacing."""
    kw = dict(sphere=Sphere(PAPER.R), surface_force=paper_pressure_law(), material=material,
              deepest_position=position)
    if grid_factor == 1.0:
        return vf.ContactProblem.create(**kw)
    grid = vf.ContactProblem.create(**kw).grid
    return vf.ContactProblem.create(**kw, grid_spacing=grid_factor * grid.outer_radius / grid.size)


def one_mode() -> StandardLinearSolid:
    return StandardLinearSolid(E0, E_INF, TAU)


def two_mode() -> PronySeries:
    t = TWO_MODE
    return PronySeries.from_moduli([t["E0"], t["E_1"], t["E_inf"]], [t["tau_1"], t["tau_2"]])


def svda_truth_k() -> np.ndarray:
    return svda_complex_stiffness(omega_grid(), H0_PRE, E0, E_INF, TAU, PAPER.R, PAPER.P,
                                  PAPER.debye_length)


def cases(rng: np.random.Generator, grid_factor: float = 1.0,
          rows: tuple[dict, ...] = CASES) -> list[dict]:
    """The single-fit cases of ``rows``: name, model, modes, fixed inputs, spectrum, truth."""
    out = []
    for row in rows:
        if row["part"] != "single":
            continue
        name, model, modes, h0 = row["case"], row["model"], row["modes"], row["position"]
        case = {"case": name, "model": model, "modes": modes, "position": h0}
        if model == "svda":
            out.append({**case, "fixed": dict(SVDA_FIXED),
                        "ds": spectrum(noisy(svda_truth_k(), rng), 1e-7),
                        "truth": {"E0": E0, "E_inf": E_INF, "tau": TAU}})
        elif modes == 1:
            problem = problem_at(h0, one_mode(), grid_factor)
            k, force = linear_stiffness(problem, h0, omega_grid())
            out.append({**case, "fixed": {"problem": problem, "position": h0},
                        "ds": spectrum(noisy(k, rng), force),
                        "truth": {"E0": E0, "E_inf": E_INF, "tau": TAU}})
        else:
            problem = problem_at(h0, one_mode(), grid_factor)  # its material is not used
            k, force = linear_stiffness(problem.with_material(two_mode()), h0, omega_grid())
            out.append({**case, "fixed": {"problem": problem, "position": h0},
                        "ds": spectrum(noisy(k, rng), force), "truth": dict(TWO_MODE)})
    return out


# ── timing ───────────────────────────────────────────────────────────────────────────────────────

def clear_states() -> None:
    linearized_state.cache_clear()


def time_runs(fn, repeats: int, *, cold: bool) -> tuple[object, dict]:
    """Median/min wall and CPU time of ``fn()``; the state cache cleared before each run if cold."""
    wall, cpu, result = [], [], None
    with gc_paused():
        for _ in range(repeats):
            if cold:
                clear_states()
            c0, t0 = time.process_time(), time.perf_counter()
            out = fn()
            t1, c1 = time.perf_counter(), time.process_time()
            wall.append(t1 - t0)
            cpu.append(c1 - c0)
            result = out if result is None else result
    return result, {"time_median_s": statistics.median(wall), "time_min_s": min(wall),
                    "cpu_median_s": statistics.median(cpu), "repeats": repeats}


def rel_errors(values: dict, truth: dict) -> dict:
    return {n: abs(values[n] - v) / abs(v) for n, v in truth.items() if n in values}


# ── the plain least-squares fit ──────────────────────────────────────────────────────────────────

def decode(layout, internal: dict) -> dict:
    """SPEC values from internal (``log_``) values, as the lmfit expressions of ``_params`` do."""
    out = {}
    for item in layout:
        if isinstance(item, _params.Chain):
            first, *rest = item.names
            value = 10.0 ** internal[f"log_{first}"]
            out[first] = value
            for name in rest:
                value = value * 10.0 ** internal[f"log_{name}"]
                out[name] = value
        else:
            out[item.name] = internal[item.name]
    return out


def plain_fit(case: dict, method: str) -> dict:
    """``least_squares`` on the weighted complex residual from the model's guess."""
    data = spectrum_data(case["ds"])
    model = make_model(case["model"], case["modes"], **case["fixed"])
    params = model.guess(data.y, data.x)
    free = [p for p in params.values() if p.vary and p.expr is None]
    names = [p.name for p in free]
    fixed = {p.name: p.value for p in params.values() if not p.vary and p.expr is None}
    x0 = np.array([p.value for p in free])
    lo, hi = np.array([p.min for p in free]), np.array([p.max for p in free])
    w_re, w_im = data.weights.real, data.weights.imag
    calls = [0]

    def residual(x):
        calls[0] += 1
        values = decode(model.layout, {**fixed, **dict(zip(names, x, strict=True))})
        d = data.y - model.func(data.x, **values)
        return np.concatenate([d.real * w_re, d.imag * w_im])

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        if method == "lm":
            res = least_squares(residual, x0, method="lm")
        else:
            res = least_squares(residual, x0, method="trf", bounds=(lo, hi), x_scale="jac")
    values = decode(model.layout, {**fixed, **dict(zip(names, res.x, strict=True))})
    return {"values": values, "nfev": calls[0], "cost": float(2 * res.cost),
            "success": bool(res.success), "status": int(res.status)}


def lmfit_fit(case: dict):
    return fit_spectrum(case["ds"], case["model"], modes=case["modes"], **case["fixed"])


def bench_single(case: dict, repeats: int, *, warm_up: bool = True) -> dict:
    """lmfit and plain fits of one case: times, evaluations, parameters, errors.

    ``warm_up=False`` (--quick) skips the untimed first fit (imports, kernel build): the first
    cold time then includes them.
    """
    cold = case["model"] == "exact"
    row = {"case": case["case"], "model": case["model"], "modes": case["modes"],
           "position": case["position"], "n_omega": N_OMEGA}
    try:
        if warm_up:
            lmfit_fit(case)  # warm-up: imports, kernel build
        ds, stats = time_runs(lambda: lmfit_fit(case), repeats, cold=cold)
        _, warm = time_runs(lambda: lmfit_fit(case), repeats, cold=False)
    except Exception as exc:  # the exact model may be mid-edit: report, do not crash
        row.update({"status": f"error: {type(exc).__name__}", "message": str(exc)[:300]})
        print(f"{case['case']:>11}: lmfit fit FAILED: {type(exc).__name__}: {exc}", flush=True)
        return row
    names = list(case["truth"])
    values = {n: float(ds[n].values) for n in names}
    stderr = {n: float(ds[f"{n}_stderr"].values) for n in names}
    row.update({"status": "ok", "message": "", **stats,
                "warm_time_median_s": warm["time_median_s"], "nfev": int(ds.attrs["nfev"]),
                "redchi": float(ds["redchi"].values),
                "chisqr": float(ds["redchi"].values) * (2 * N_OMEGA - len(names)),
                "values": values, "stderr": stderr,
                "truth": case["truth"], "rel_error": rel_errors(values, case["truth"]),
                "error_over_stderr": {n: abs(values[n] - case["truth"][n]) / stderr[n]
                                      if stderr[n] > 0 else math.nan for n in names}})
    row["max_rel_error"] = max(row["rel_error"].values())
    plain = {}
    for method in ("lm", "trf"):
        try:
            fit, st = time_runs(lambda m=method: plain_fit(case, m), repeats, cold=cold)
        except Exception as exc:
            plain[method] = {"status": f"error: {type(exc).__name__}", "message": str(exc)[:300]}
            continue
        diff = {n: abs(fit["values"][n] - values[n]) / abs(values[n]) for n in names}
        plain[method] = {"status": "ok", **st, "nfev": fit["nfev"], "chisqr": fit["cost"],
                         "success": fit["success"], "values": {n: fit["values"][n]
                                                                for n in names},
                         "rel_diff_to_lmfit": diff, "max_rel_diff_to_lmfit": max(diff.values()),
                         "rel_error": rel_errors(fit["values"], case["truth"]),
                         "speedup_vs_lmfit": stats["time_median_s"] / st["time_median_s"]}
    row["plain"] = plain
    lm = plain.get("lm", {})
    print(f"{case['case']:>11} {1e3 * row['time_median_s']:9.1f} {1e3 * row['warm_time_median_s']:9.1f}"
          f" {row['nfev']:5d} {1e3 * lm.get('time_median_s', math.nan):9.1f} "
          f"{lm.get('nfev', -1):5d} {1e3 * plain.get('trf', {}).get('time_median_s', math.nan):9.1f}"
          f" {plain.get('trf', {}).get('nfev', -1):5d} {lm.get('max_rel_diff_to_lmfit', math.nan):9.1e}"
          f" {row['max_rel_error']:9.1e}", flush=True)
    return row


SINGLE_HEAD = (f"{'case':>11} {'lmfit ms':>9} {'warm ms':>9} {'nfev':>5} {'lm ms':>9} {'nfev':>5} "
               f"{'trf ms':>9} {'nfev':>5} {'lm≠lmfit':>9} {'max err':>9}")


# ── profiles ─────────────────────────────────────────────────────────────────────────────────────

#: cProfile entries whose cumulative time is "uncertainties propagation" (no callbacks inside).
UNCERTAINTIES = ("correlated_values", "correlation_matrix")


class StepTimers:
    """Wall time and calls of library functions during one fit (wrapped, restored on exit).

    ``evaluations``: the model function (svda closed form or exact k* via the linearised state,
    which includes the state builds); ``states``: ``linearized_state`` (cache look-ups and the
    static solve + eigen-decomposition on a miss, counted as ``state_builds`` from
    ``linearized_state.cache_info()``); ``guess``, ``spectrum_data``,
    ``result_dataset``: those steps of fit_spectrum. The wrapper's own cost (≈ 1 µs a call) is
    included.
    """

    def __init__(self):
        from viscoforce import svda
        from viscoforce.experiments import linear_response
        from viscoforce.fitting import fit, models

        try:  # the exact model's own module, which calls exact_stiffness (issue 36 item 1)
            from viscoforce.fitting.models import exact as exact_model
        except ImportError:  # the layout before: the builder in spectrum_models
            from viscoforce.fitting import spectrum_models as exact_model

        self.targets = {"evaluations": [(svda, "svda_stiffness_kernel"),
                                        (exact_model, "exact_stiffness")],
                        "states": [(linear_response, "linearized_state")],
                        "guess": [(models.FitModel, "guess")],
                        "spectrum_data": [(fit, "spectrum_data")],
                        "result_dataset": [(fit, "result_dataset")]}
        self.seconds = {k: 0.0 for k in self.targets}
        self.calls = {k: 0 for k in self.targets}
        self._saved: list[tuple[object, str, object]] = []

    def _wrap(self, key: str, fn):
        @functools.wraps(fn)
        def timed_fn(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                self.seconds[key] += time.perf_counter() - t0
                self.calls[key] += 1
        return timed_fn

    def __enter__(self) -> StepTimers:
        for key, places in self.targets.items():
            for owner, name in places:
                fn = getattr(owner, name)
                self._saved.append((owner, name, fn))
                setattr(owner, name, self._wrap(key, fn))
        return self

    def __exit__(self, *exc) -> None:
        for owner, name, fn in reversed(self._saved):
            setattr(owner, name, fn)
        self._saved.clear()


def profile_case(case: dict, path: Path, repeats: int = 3, *, quick: bool = False) -> dict:
    """Where one cold fit's time goes: instrumented steps (median of runs) and a cProfile listing.

    The split comes from :class:`StepTimers` on unprofiled runs; the top ``PROFILE_TOP``
    functions by cumulative time of one cProfile run go to ``path`` (cProfile inflates
    call-heavy Python such as lmfit and asteval, so its shares are not used for the split).
    ``quick``: a single fit, instrumented and profiled at once (its split is inflated too).
    """
    runs = []
    prof = cProfile.Profile()
    for _ in range(1 if quick else repeats):
        clear_states()
        with gc_paused(), StepTimers() as timers:
            if quick:
                prof.enable()
            t0 = time.perf_counter()
            lmfit_fit(case)
            total = time.perf_counter() - t0
            if quick:
                prof.disable()
        calls = dict(timers.calls, state_builds=linearized_state.cache_info()["misses"])
        runs.append((total, dict(timers.seconds), calls))
    total, seconds, calls = sorted(runs, key=lambda r: r[0])[len(runs) // 2]  # the median run
    if not quick:
        clear_states()
        prof.enable()
        lmfit_fit(case)
        prof.disable()
    text = io.StringIO()
    stats = pstats.Stats(prof, stream=text)
    stats.sort_stats("cumulative").print_stats(PROFILE_TOP)
    path.write_text(text.getvalue())
    profiled = max(ct for (_, _, fn), (_, _, _, ct, _) in stats.stats.items()
                   if fn == "fit_spectrum")
    unc = sum(ct for (f, _, fn), (_, _, _, ct, _) in stats.stats.items()
              if "uncertainties" in f and fn in UNCERTAINTIES)
    guess_eval = 0.0  # guesses evaluate the model too: measured apart
    with StepTimers() as g:
        model = make_model(case["model"], case["modes"], **case["fixed"])
        data = spectrum_data(case["ds"])
        clear_states()
        model.guess(data.y, data.x)
    guess_eval = g.seconds["evaluations"]
    fitting = total - seconds["spectrum_data"] - seconds["result_dataset"] - seconds["guess"]
    split = {"total": total,
             "spectrum_data (read the dataset)": seconds["spectrum_data"],
             "guess (incl. its model evaluations)": seconds["guess"],
             "model evaluations in the lmfit fits": seconds["evaluations"] - guess_eval,
             "lmfit overhead (fits minus their model evaluations)":
                 fitting - (seconds["evaluations"] - guess_eval),
             "result_dataset (summary, uncertainties, best-fit curve, make_fit_result)":
                 seconds["result_dataset"],
             "uncertainties (cProfile, scaled)": unc * total / profiled if profiled else math.nan}
    return {"case": case["case"], "total_s": total, "split_s": split,
            "share": {k: v / total for k, v in split.items() if k != "total"},
            "evaluations": calls["evaluations"], "guess_evaluations": g.calls["evaluations"],
            "state_calls": calls["states"], "state_builds": calls["state_builds"],
            "states_s": seconds["states"],
            "profiled_fit_s": profiled, "file": str(path)}


# ── maps ─────────────────────────────────────────────────────────────────────────────────────────

class MemorySampler:
    """Peak summed RSS [bytes] of this process and its (recursive) children, sampled in a thread."""

    def __init__(self, period: float = SAMPLE_PERIOD):
        self.period = period
        self.peak = 0
        self.peak_processes = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self.method = ("psutil: summed RSS of this process and its children, sampled every "
                       f"{1e3 * period:g} ms" if psutil is not None else
                       "resource.getrusage: ru_maxrss of self + largest waited-for child")

    def _sample(self) -> None:
        me = psutil.Process()
        total, n = 0, 0
        for p in [me, *me.children(recursive=True)]:
            try:
                total += p.memory_info().rss
                n += 1
            except (psutil.NoSuchProcess, psutil.AccessDenied):
                continue
        if total > self.peak:
            self.peak, self.peak_processes = total, n

    def _run(self) -> None:
        while not self._stop.is_set():
            self._sample()
            self._stop.wait(self.period)

    def __enter__(self) -> MemorySampler:
        if psutil is not None:
            self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        if psutil is not None:
            self._stop.set()
            self._thread.join()
        else:  # KiB on Linux
            self.peak = 1024 * (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
                                + resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)


@contextlib.contextmanager
def timed_cluster(box: dict, scheduler: str | None = None, workers: int | None = None):
    """``fitting.maps.cluster`` with its phases timed into ``box`` (start-up, work, teardown)."""
    t0 = time.perf_counter()
    with _LIBRARY_CLUSTER(scheduler, workers) as client:
        box["startup_s"] = time.perf_counter() - t0
        blas = client.run(_blas_threads)
        box["worker_blas_threads"] = sorted({t for v in blas.values() for t in v})
        cpu0 = children_cpu()
        t1 = time.perf_counter()
        yield client
        box["work_s"] = time.perf_counter() - t1
        cpu1 = children_cpu()
        box["worker_cpu_s"] = sorted((cpu1[p] - cpu0[p] for p in cpu1 if p in cpu0),
                                     reverse=True)
        t2 = time.perf_counter()
    box["teardown_s"] = time.perf_counter() - t2


def children_cpu() -> dict[int, float]:
    """User + system CPU time [s] of each child process (the workers), by pid (psutil only)."""
    if psutil is None:
        return {}
    out = {}
    for p in psutil.Process().children(recursive=True):
        try:
            cpu = p.cpu_times()
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
        out[p.pid] = cpu.user + cpu.system
    return out


def _blas_threads() -> list:
    return sorted({d.get("num_threads") for d in threadpool_info() if d.get("user_api") == "blas"})


_LIBRARY_CLUSTER = maps.cluster


def svda_map(n: int, rng: np.random.Generator):
    k = np.broadcast_to(svda_truth_k(), (n, n, N_OMEGA))
    return spectrum(noisy(k, rng), 1e-7, dims=("y", "x", "omega"))


def exact_map(n: int, rng: np.random.Generator, grid_factor: float = 1.0):
    problem = problem_at(H0_PRE, one_mode(), grid_factor)
    k, force = linear_stiffness(problem, H0_PRE, omega_grid())
    return spectrum(noisy(np.broadcast_to(k, (n, n, N_OMEGA)), rng), force,
                    dims=("y", "x", "omega")), {"problem": problem, "position": H0_PRE}


def bench_map(label: str, ds, model: str, fixed: dict, workers: int, truth: dict) -> dict:
    n_pix = int(ds.sizes["y"] * ds.sizes["x"])
    row = {"map": label, "model": model, "ny": int(ds.sizes["y"]), "nx": int(ds.sizes["x"]),
           "pixels": n_pix, "workers": workers}
    box: dict = {}
    try:
        t0 = time.perf_counter()
        pixel_data(ds, model)  # the in-process split into per-pixel FitData (part of fit_map)
        split = time.perf_counter() - t0
        maps.cluster = functools.partial(timed_cluster, box)  # fit_map's own cluster, timed
        load_before = load_average()
        try:
            with MemorySampler() as mem:
                t0, c0 = time.perf_counter(), time.process_time()
                res = fit_map(ds, model, scheduler=None, workers=workers, progress=False,
                              **fixed)
                total, own_cpu = time.perf_counter() - t0, time.process_time() - c0
        finally:
            maps.cluster = _LIBRARY_CLUSTER
    except Exception as exc:
        row.update({"status": f"error: {type(exc).__name__}", "message": str(exc)[:300]})
        print(f"{label:>10} {workers}: FAILED {type(exc).__name__}: {exc}", flush=True)
        return row
    if "startup_s" not in box:  # the cost model fitted the map in this process: no cluster
        box.update(startup_s=0.0, teardown_s=0.0, work_s=total,
                   worker_blas_threads=_blas_threads())
    start = {"startup_s": box["startup_s"], "up_down_s": box["startup_s"] + box["teardown_s"],
             "worker_blas_threads": box["worker_blas_threads"]}
    fit_s = total - start["up_down_s"]
    errs = {n: float(np.nanmedian(np.abs(res[n].values - v) / v)) for n, v in truth.items()}
    row.update({"status": "ok", "message": "", "total_s": total, "startup_s": start["startup_s"],
                "startup_teardown_s": start["up_down_s"], "teardown_s": box["teardown_s"],
                "fit_s": fit_s, "in_cluster_s": box["work_s"],
                "pixel_split_s": split, "per_pixel_s": fit_s / n_pix,
                "worker_blas_threads": start["worker_blas_threads"],
                "n_failed": int(res.attrs["n_failed"]), "median_rel_error": errs,
                "peak_rss_bytes": mem.peak, "peak_rss_processes": mem.peak_processes,
                "memory_method": mem.method, "client_cpu_s": own_cpu,
                "worker_cpu_s": box.get("worker_cpu_s", []),
                "loadavg_before": load_before, "loadavg_after": load_average()})
    # cores the workers got while the cluster was up and working: 1 per worker at best
    cpu = row["worker_cpu_s"][:workers]
    row["worker_core_share"] = (sum(cpu) / (workers * box["work_s"]) if cpu and box["work_s"] > 0
                                else math.nan)
    print(f"{label:>10} {workers:3d} {n_pix:6d} {total:8.2f} {start['startup_s']:8.2f} "
          f"{start['up_down_s']:8.2f} {fit_s:8.2f} {split:7.2f} {1e3 * fit_s / n_pix:8.2f} "
          f"{mem.peak / 2 ** 20:8.0f} {row['n_failed']:4d} {errs.get('tau', math.nan):9.1e} "
          f"{row['worker_core_share']:6.2f} {own_cpu:7.1f} {row['loadavg_before'][0]:5.2f}",
          flush=True)
    return row


MAP_HEAD = (f"{'map':>10} {'wk':>3} {'pixels':>6} {'total s':>8} {'start s':>8} {'up+dn s':>8} "
            f"{'fit s':>8} {'split s':>7} {'ms/pix':>8} {'RSS MiB':>8} {'fail':>4} "
            f"{'tau err':>9} {'cores':>6} {'cli cpu':>7} {'load':>5}")


# ── figure ───────────────────────────────────────────────────────────────────────────────────────

def plot(single: list[dict], maps: list[dict], path: Path) -> None:
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.8))
    ok = [r for r in single if r.get("status") == "ok"]
    x = np.arange(len(ok))
    width = 0.27
    series = (("lmfit (cold)", [r["time_median_s"] for r in ok]),
              ("least_squares lm", [r["plain"].get("lm", {}).get("time_median_s", np.nan)
                                    for r in ok]),
              ("least_squares trf", [r["plain"].get("trf", {}).get("time_median_s", np.nan)
                                     for r in ok]))
    for j, (label, vals) in enumerate(series):
        bars = ax1.bar(x + (j - 1) * width, np.asarray(vals) * 1e3, width, label=label)
        if j == 0:
            for b, r in zip(bars, ok, strict=True):
                ax1.annotate(f"{r['nfev']}", (b.get_x() + b.get_width() / 2, b.get_height()),
                             ha="center", va="bottom", fontsize=7)
    for key, style in (("svda_fit_s", ":"), ("exact_1mode_fit_s", "--"),
                       ("exact_2mode_fit_s", "-.")):
        ax1.axhline(1e3 * TARGETS[key], color="k", ls=style, lw=0.8, label=f"target {key}")
    ax1.set_xticks(x, [r["case"] for r in ok], rotation=20)
    ax1.set_yscale("log")
    ax1.set_ylabel("median wall time per fit [ms] (numbers: lmfit nfev)")
    ax1.set_title(f"single fits, {N_OMEGA} points, 1 BLAS thread")
    ax1.legend(fontsize=7)
    okm = [r for r in maps if r.get("status") == "ok"]
    labels = [f"{r['map']}\n{r['ny']}x{r['nx']}, {r['workers']} wk" for r in okm]
    start = [r["startup_teardown_s"] for r in okm]
    fit = [r["fit_s"] for r in okm]
    ax2.bar(labels, start, label="cluster start-up + teardown")
    ax2.bar(labels, fit, bottom=start, label="fitting (incl. split, scatter, gather)")
    for i, r in enumerate(okm):
        ax2.annotate(f"{r['total_s']:.1f} s\n{r['peak_rss_bytes'] / 2 ** 20:.0f} MiB",
                     (i, r["total_s"]), ha="center", va="bottom", fontsize=7)
    ax2.axhline(TARGETS["svda_map_s"], color="k", ls=":", lw=0.8,
                label=f"target 64x64 svda map, 2 workers ({TARGETS['svda_map_s']:g} s)")
    ax2.set_ylabel("wall time [s]")
    ax2.set_title("fit_map on a local cluster")
    ax2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ── main ─────────────────────────────────────────────────────────────────────────────────────────

def summarise(single: list[dict], maps: list[dict], quick: bool) -> dict:
    by = {r["case"]: r for r in single}

    def worst(prefix: str) -> float:
        times = [r["time_median_s"] for c, r in by.items() if c.startswith(prefix)
                 and r.get("status") == "ok"]
        return max(times) if times else math.nan

    def map_row(label: str, workers: int) -> dict:
        return next((r for r in maps if r["map"] == label and r["workers"] == workers
                     and r.get("status") == "ok"), {})

    svda1, svda2, ex2 = map_row("svda", 1), map_row("svda", 2), map_row("exact", 2)
    s = {"svda_fit_s": worst("svda"), "exact_1mode_fit_s": worst("exact1"),
         "exact_2mode_fit_s": worst("exact2"),
         "svda_map_s": svda2.get("total_s", math.nan),
         "svda_map_startup_s": svda2.get("startup_s", math.nan),
         "svda_map_speedup": svda1.get("total_s", math.nan) / svda2.get("total_s", math.nan),
         "svda_map_speedup_fit_only": svda1.get("fit_s", math.nan) / svda2.get("fit_s", math.nan),
         "exact_map_s": ex2.get("total_s", math.nan),
         "map_memory_bytes": svda2.get("peak_rss_bytes", math.nan)}
    checks = {"svda_fit_s": s["svda_fit_s"] <= TARGETS["svda_fit_s"],
              "exact_1mode_fit_s": s["exact_1mode_fit_s"] <= TARGETS["exact_1mode_fit_s"],
              "exact_2mode_fit_s": s["exact_2mode_fit_s"] <= TARGETS["exact_2mode_fit_s"]}
    if not quick:  # the map targets are for the full sizes
        checks.update({"svda_map_s": s["svda_map_s"] <= TARGETS["svda_map_s"],
                       "svda_map_speedup": s["svda_map_speedup"] >= TARGETS["svda_map_speedup"],
                       "exact_map_s": s["exact_map_s"] <= TARGETS["exact_map_s"],
                       "map_memory_bytes": s["map_memory_bytes"] <= TARGETS["map_memory_bytes"]})
    s["checks"] = {k: bool(v) for k, v in checks.items()}
    s["passed"] = all(s["checks"].values())
    s["verdict"] = pf(s["passed"])
    errors = [r["case"] for r in single if r.get("status") != "ok"] + [
        f"{r['map']}/{r['workers']}" for r in maps if r.get("status") != "ok"]
    s["errors"] = errors
    return s


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv, doc=__doc__, min_repeats=2,
                      quick_help="smoke run: 8x8 svda and 4x4 exact maps, 1 repeat, no "
                                 "warm-up, one profiled fit per profile",
                      repeats_help=f"timed runs per single fit (default {REPEATS}, "
                                   f"{QUICK_REPEATS} with --quick; at least 2, the targets "
                                   "need >= 5)")
    quick = args.quick
    repeats = args.repeats or (QUICK_REPEATS if quick else REPEATS)
    rows = QUICK_CASES if quick else CASES
    map_rows = [r for r in rows if r["part"] == "map"]
    n_svda = next(r["n"] for r in map_rows if r["map"] == "svda")
    n_exact = next(r["n"] for r in map_rows if r["map"] == "exact")
    profiled = {r["case"] for r in rows if r["part"] == "single" and r["profiled"]}
    grid_factor = QUICK_GRID_FACTOR if quick else 1.0
    args.out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    rng = np.random.default_rng(SEED)

    with threadpool_limits(limits=1):
        machine = machine_facts()
        print(f"viscoforce {machine['viscoforce']} fit benchmark{' (quick)' if quick else ''}")
        print_machine(machine)
        print(f"data: {N_OMEGA} omega log-spaced in [{OMEGA_MIN:g}, {OMEGA_MAX:g}] rad/s, "
              f"{100 * NOISE:g} % complex noise (seed {SEED}); load average "
              f"{machine['loadavg_start']}")
        if grid_factor != 1.0:
            print(f"quick: the exact model on {grid_factor:g} x the default grid spacing "
                  "(its times are not the default grid's)")

        print(f"\n1. Single fits: median of {repeats} runs (exact: state cache cleared before "
              "each, 'warm' = cache kept); plain least_squares from the same guess")
        print(SINGLE_HEAD)
        single_cases = cases(rng, grid_factor, rows)
        single = [bench_single(c, repeats, warm_up=not quick) for c in single_cases]

        print("\n2. Where the time goes (one cold fit each: instrumented steps; cProfile listing)")
        profiles = []
        for c in single_cases:
            if c["case"] not in profiled:
                continue
            try:
                p = profile_case(c, args.out / f"fit_profile_{c['case']}.txt", quick=quick)
            except Exception as exc:
                print(f"{c['case']}: profile FAILED {type(exc).__name__}: {exc}")
                continue
            profiles.append(p)
            share = "; ".join(f"{k.split(' (')[0]} {1e3 * v:.1f} ms"
                              for k, v in p["split_s"].items() if k != "total")
            print(f"{c['case']:>11}: {1e3 * p['total_s']:.1f} ms, {p['evaluations']} model "
                  f"evaluations ({p['guess_evaluations']} in the guess), {p['state_builds']} "
                  f"state builds, linearized_state {1e3 * p['states_s']:.1f} ms; {share}")

        print("\n3. Maps: fit_map(scheduler=None) on a LocalCluster (start-up timed inside the run)")
        print(MAP_HEAD)
        maps = []
        truth1 = {"E0": E0, "E_inf": E_INF, "tau": TAU}
        for row in map_rows:
            if row["map"] == "svda":
                ds_map, fixed_map = svda_map(row["n"], rng), SVDA_FIXED
            else:
                ds_map, fixed_map = exact_map(row["n"], rng, grid_factor)
            for workers in row["workers"]:
                maps.append(bench_map(row["map"], ds_map, row["map"], fixed_map, workers, truth1))
            del ds_map

    summary = {**summarise(single, maps, quick), **run_end(t_start)}
    png = args.out / "fit_timings.png"
    plot(single, maps, png)
    single_csv, maps_csv = args.out / "fit_single.csv", args.out / "fit_maps.csv"
    flat = []
    for r in single:
        f = {k: v for k, v in r.items() if not isinstance(v, dict)}
        for n, e in r.get("rel_error", {}).items():
            f[f"rel_error_{n}"] = e
        for m, p in r.get("plain", {}).items():
            for k in ("time_median_s", "nfev", "max_rel_diff_to_lmfit"):
                f[f"{m}_{k}"] = p.get(k)
        flat.append(f)
    write_csv(flat, single_csv)
    write_csv([{k: v for k, v in r.items() if not isinstance(v, dict | list)} for r in maps],
              maps_csv)
    json_path = args.out / "fit_benchmark.json"
    report = {
        **report_head(SCHEMA, quick, machine),
        "target": TARGETS,
        "settings": {"n_omega": N_OMEGA, "omega_min": OMEGA_MIN, "omega_max": OMEGA_MAX,
                     "noise": NOISE, "seed": SEED, "repeats": repeats, "radius": PAPER.R,
                     "one_mode": {"E0": E0, "E_inf": E_INF, "tau": TAU}, "two_mode": TWO_MODE,
                     "positions": [H0_PRE, H0_CONTACT], "svda_map": n_svda,
                     "exact_map": n_exact, "exact_grid_factor": grid_factor,
                     "rss_sample_s": SAMPLE_PERIOD,
                     "memory_method": maps[0].get("memory_method") if maps else None},
        "single": single,
        "profiles": profiles,
        "maps": maps,
        "summary": summary,
        "files": {"png": str(png), "single_csv": str(single_csv), "maps_csv": str(maps_csv),
                  "json": str(json_path), "profiles": [p["file"] for p in profiles]},
    }
    write_json(report, json_path)
    print(f"\nwrote {json_path}, {single_csv}, {maps_csv}, {png}")
    s, t = summary, TARGETS
    c = s["checks"]

    def mark(key: str) -> str:
        return pf(c[key]) if key in c else "not judged (quick)"

    print(f"SUMMARY: svda fit {1e3 * s['svda_fit_s']:.1f} ms [{mark('svda_fit_s')}, <= "
          f"{1e3 * t['svda_fit_s']:g} ms]; exact 1-mode {1e3 * s['exact_1mode_fit_s']:.0f} ms "
          f"[{mark('exact_1mode_fit_s')}, <= {t['exact_1mode_fit_s']:g} s]; exact 2-mode "
          f"{1e3 * s['exact_2mode_fit_s']:.0f} ms [{mark('exact_2mode_fit_s')}, <= "
          f"{t['exact_2mode_fit_s']:g} s]")
    print(f"SUMMARY: svda map {n_svda}x{n_svda}, 2 workers: {s['svda_map_s']:.1f} s incl. "
          f"start-up {s['svda_map_startup_s']:.1f} s [{mark('svda_map_s')}, <= "
          f"{t['svda_map_s']:g} s]; speed-up 2 vs 1 worker {s['svda_map_speedup']:.2f}x "
          f"(fit only {s['svda_map_speedup_fit_only']:.2f}x) [{mark('svda_map_speedup')}, >= "
          f"{t['svda_map_speedup']:g}]; memory {s['map_memory_bytes'] / 2 ** 20:.0f} MiB "
          f"[{mark('map_memory_bytes')}, <= 1 GiB]; exact map {n_exact}x{n_exact}: "
          f"{s['exact_map_s']:.1f} s [{mark('exact_map_s')}, <= {t['exact_map_s']:g} s] "
          f"-> {s['verdict']}")
    if s["errors"]:
        print(f"ERRORS in: {', '.join(s['errors'])} (see the JSON 'message' entries)")
    print(f"SUMMARY: wall {s['wall_time_s']:.1f} s, load average {s['loadavg_end']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
