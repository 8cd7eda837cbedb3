"""Cases of bench_regression.py, imported by both workers of benchmarks/_previous.py.

Every case builds the paper's system (R = 10 µm sphere, SLS material, DoubleLayer + SoftWall
pressure law) on the default grid, ``ContactProblem.create(..., deepest_position=h0)``, and
times one public call. Only API present in the previous release (``PREVIOUS_RELEASE`` of
_previous.py) and in the current tree is used: ``ContactProblem.create``, ``PAPER``,
``paper_pressure_law``, ``static_equilibrium``, ``linear_response(problem, position, eta,
omega)``, ``experiments.linear_response.linear_stiffness`` and ``solvers.static.equilibrium_gap``.

Cold calls (``cold=True``): before each timed call, untimed, a new ``ContactProblem`` is built
and every cache of the linear response is emptied (whatever the version has:
``linearized_state``'s LRU of static states; in the current tree also the decompositions and
the finite-amplitude modes and results, :data:`LINEAR_MODULES`). That is what a user's first
call on a problem costs once the grid's kernel exists: the unit kernel
(``kernel._node_matrix_unit``, 30–55 ms, the same code in both versions, paid once per panel
count and order) stays built. Warm calls (``cold=False``) repeat the call on
one problem with the caches filled.

The reference (:func:`reference_spectrum`) is the textbook route, independent of the library's
linear-response module: the library's static Newton solve at E_inf (the one shared step), then
one dense complex LU solve per frequency of the linearised viscoelastic problem for k*(ω), and
the finite-amplitude check by direct dense solves (four per checked frequency, as the oracle of
tests/theory/test_amplitude_bias_modal.py). No eigen-decomposition, no cache.
"""

from __future__ import annotations

import importlib
import types
import warnings

import numpy as np
from _previous import Case

import viscoforce as vf
from viscoforce.experiments import linear_response as linear_module  # imported up front
from viscoforce.solvers.static import equilibrium_gap

#: Longest list of frequencies the finite-amplitude check solves (both ends kept).
CHECK_FREQUENCIES = 32
#: Finite-difference step of p″, p‴ in units of the shortest decay length of the law's terms.
FD_STEP = 1e-3
#: Bias η² max|b| above which the small-amplitude spectrum is flagged (1 %).
WARN_ERROR = 0.01
OMEGA_MIN, OMEGA_MAX = 1.0, 1e6  # [rad/s]


def omegas(n_omega: int) -> np.ndarray:
    """``n_omega`` frequencies log-spaced in [OMEGA_MIN, OMEGA_MAX] [rad/s]."""
    return np.geomspace(OMEGA_MIN, OMEGA_MAX, n_omega)


def paper_problem(position: float) -> vf.ContactProblem:
    """The paper's system on the default grid reaching ``position`` [m]."""
    return vf.ContactProblem.create(sphere=vf.PAPER.sphere(), surface_force=vf.paper_pressure_law(),
                                    material=vf.PAPER.material(), deepest_position=position)


#: The modules whose caches a cold call empties, by the version that has them: the previous
#: release keeps every cache in ``linear_response``; the current tree also in ``_modal`` (the
#: decompositions) and ``finite_amplitude`` (the finite-amplitude modes and results).
LINEAR_MODULES = ("viscoforce.experiments.linear_response", "viscoforce.experiments._modal",
                  "viscoforce.experiments.finite_amplitude")


def _linear_modules() -> list:
    """The modules of :data:`LINEAR_MODULES` this version has (imported up front)."""
    found = []
    for name in LINEAR_MODULES:
        try:
            found.append(importlib.import_module(name))
        except ModuleNotFoundError:
            continue
    return found


def _caches() -> dict[str, object]:
    """Label → cache of every linear-response module (see :func:`linear_caches`)."""
    out: dict[str, object] = {}
    seen: set[int] = set()
    for module in _linear_modules():
        prefix = "" if module is linear_module else module.__name__.rsplit(".", 1)[-1] + "."
        for name, obj in vars(module).items():
            if isinstance(obj, type | types.ModuleType) or id(obj) in seen:
                continue
            if isinstance(obj, dict):
                cache = name.endswith("_RESULTS")
            elif isinstance(obj, types.FunctionType):  # functools caches: the module's own only
                cache = (callable(getattr(obj, "cache_clear", None))
                         and obj.__module__ == module.__name__)
            else:  # a state cache object (clear and info), wherever its class is defined
                cache = (callable(getattr(obj, "clear", None))
                         and callable(getattr(obj, "info", None)))
            if cache:
                seen.add(id(obj))
                out[prefix + name] = obj
    return out


def linear_caches() -> list[str]:
    """Names of the linear-response caches that :func:`clear_linear_caches` empties.

    In every module of :data:`LINEAR_MODULES` present: anything with a ``cache_clear``
    (``linearized_state``), any object with ``clear`` and ``info`` (the LRUs of static states,
    decompositions or finite-amplitude modes) and any dict whose name ends in ``_RESULTS``
    (cached finite-amplitude results), whatever the version calls them. Names outside
    ``linear_response`` carry their module's last part (``finite_amplitude._BIAS_MODES``).
    """
    return sorted(_caches())


def clear_linear_caches() -> None:
    """Empty every cache named by :func:`linear_caches`."""
    for obj in _caches().values():
        (getattr(obj, "cache_clear", None) or obj.clear)()


def _complex_stiffness(spectrum) -> np.ndarray:
    """k* = stiffness · e^{i phase} [N/m] of a Spectrum (phase in degrees)."""
    return (spectrum["stiffness"].values
            * np.exp(1j * np.deg2rad(spectrum["phase"].values)))


def _complex_list(z) -> dict:
    z = np.asarray(z, dtype=complex)
    return {"re": z.real.tolist(), "im": z.imag.tolist()}


# ── the independent reference ────────────────────────────────────────────────────────────────────

def check_frequencies(omega: np.ndarray) -> np.ndarray:
    """The frequencies the check solves: all if ≤ 32, else 32 evenly spaced in index (ends kept)."""
    omega = np.sort(omega)
    if omega.size <= CHECK_FREQUENCIES:
        return omega
    return omega[np.unique(np.rint(np.linspace(0, omega.size - 1, CHECK_FREQUENCIES)).astype(int))]


def _derivatives(law, gap: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """p′ (exact) and p″, p‴ by central differences of p′."""
    terms = getattr(law, "terms", (law,))
    step = FD_STEP * min(t.decay_length for t in terms)
    d1 = law.pressure_derivative(gap)
    up, down = law.pressure_derivative(gap + step), law.pressure_derivative(gap - step)
    return d1, (up - down) / (2.0 * step), (up - 2.0 * d1 + down) / (step * step)


def reference_spectrum(problem: vf.ContactProblem, position: float, eta: float,
                       omega: np.ndarray) -> dict:
    """k*(ω), mean force and finite-amplitude check by dense solves (module docstring).

    Linearised about the static E_inf gap h̄ with c = 2C*(ω) and unit separation increase δh0 = 1:
    (I − c A diag(p′)) δu = −c A p′ and k* = −2π Σ W p′ (1 − δu) (per unit compression).
    The check: b(ω) of the third-order harmonic balance (four solves per checked frequency) and
    ``warns`` = η² max|b| > 1 %.

    Returns
    -------
    dict
        ``k`` (complex [N/m], per ω), ``mean_force`` [N], ``check_omega`` [rad/s], ``bias``
        (b [1/m²] per checked ω), ``warns`` (bool).
    """
    material = problem.material
    e_inf = material.relaxed_modulus
    sol = equilibrium_gap(problem, position, e_inf)  # the shared static step
    gap = sol.gap
    d1, d2, d3 = _derivatives(problem.surface_force, gap)
    a = problem.influence
    n = gap.size
    load_weights = 2.0 * np.pi * problem.grid.area_weights
    mean_force = float(load_weights @ problem.surface_force.pressure(gap))
    a_d1 = a * d1[None, :]
    eye = np.eye(n)
    compliance = 2.0 * np.asarray(material.complex_compliance(omega), dtype=complex)
    k = np.empty(omega.size, dtype=complex)
    drive = -a_d1.sum(axis=1)
    for i, c in enumerate(compliance):  # one dense complex LU solve per frequency
        du = np.linalg.solve(eye - c * a_d1, c * drive)
        k[i] = -(load_weights @ (d1 * (1.0 - du)))

    def solve(c, pressure=None, rhs=None):
        m = eye - 2.0 * c * a_d1
        return np.linalg.solve(m, rhs if rhs is not None else 2.0 * c * (a @ pressure))

    w_check = check_frequencies(omega)
    bias = np.empty(w_check.size, dtype=complex)
    ones = np.ones(n, dtype=complex)
    for i, w in enumerate(w_check):
        c_w, c_2w = (complex(c) for c in material.complex_compliance(np.array([w, 2.0 * w])))
        h1 = solve(c_w, rhs=ones)
        h2_0 = solve(1.0 / e_inf, d2 * np.abs(h1) ** 2 / 4.0)
        h2_2 = solve(c_2w, d2 * h1 ** 2 / 4.0)
        q3 = d2 * (h1 * h2_0 + np.conj(h1) * h2_2 / 2.0) + d3 * np.abs(h1) ** 2 * h1 / 8.0
        h3 = solve(c_w, q3)
        bias[i] = (load_weights @ (d1 * h3 + q3)) / (load_weights @ (d1 * h1))
    warns = bool(eta * eta * np.max(np.abs(bias)) > WARN_ERROR)
    return {"k": k, "mean_force": mean_force, "check_omega": w_check, "bias": bias,
            "warns": warns}


# ── the cases ────────────────────────────────────────────────────────────────────────────────────

class _Problem:
    """The case's problem: a new one before each cold call (caches emptied), else one."""

    def __init__(self, position: float, cold: bool):
        self.position, self.cold = position, cold
        self.problem = paper_problem(position)

    def reset(self) -> None:
        self.problem = paper_problem(self.position)
        clear_linear_caches()


def _case(run, holder: _Problem, value) -> Case:
    return Case(run=run, reset=holder.reset if holder.cold else None, value=value)


def linear_response_case(position: float, eta: float, n_omega: int, cold: bool) -> Case:
    """``vf.linear_response(problem, position, eta, omega)``."""
    holder, omega = _Problem(position, cold), omegas(n_omega)

    def run():
        return vf.linear_response(holder.problem, position, eta, omega)

    def value():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            ds = run()
        return {"k": _complex_list(_complex_stiffness(ds)),
                "mean_force": float(np.asarray(ds["mean_force"]).ravel()[0]),
                "warned": any("finite-amplitude" in str(w.message) for w in caught),
                "caches": linear_caches()}

    return _case(run, holder, value)


def linear_stiffness_case(position: float, n_omega: int, cold: bool) -> Case:
    """``experiments.linear_response.linear_stiffness(problem, position, omega)``."""
    holder, omega = _Problem(position, cold), omegas(n_omega)
    stiffness = linear_module.linear_stiffness

    def run():
        return stiffness(holder.problem, position, omega)

    def value():
        k, mean = run()
        return {"k": _complex_list(k), "mean_force": float(mean)}

    return _case(run, holder, value)


def static_equilibrium_case(position: float) -> Case:
    """``vf.static_equilibrium(problem, position)`` on one problem (nothing cached but A)."""
    problem = paper_problem(position)

    def run():
        return vf.static_equilibrium(problem, position)

    def value():
        ds = run()
        return {name: float(ds[name]) for name in ("force", "u_center", "contact_radius")
                if name in ds}

    return Case(run=run, value=value)


def reference_case(position: float, eta: float, n_omega: int) -> Case:
    """:func:`reference_spectrum` on a new problem each call (it caches nothing itself)."""
    holder, omega = _Problem(position, True), omegas(n_omega)

    def run():
        return reference_spectrum(holder.problem, position, eta, omega)

    def value():
        out = run()
        return {"k": _complex_list(out["k"]), "mean_force": out["mean_force"],
                "check_omega": out["check_omega"].tolist(), "bias": _complex_list(out["bias"]),
                "warned": out["warns"]}

    return Case(run=run, reset=holder.reset, value=value)


def amplitude_bias_case(position: float, n_omega: int) -> Case:
    """The library's b(ω) at the reference's check frequencies (value only; current tree)."""
    from viscoforce.experiments.finite_amplitude import amplitude_bias as bias

    problem, omega = paper_problem(position), omegas(n_omega)

    def run():
        return bias(problem, position, check_frequencies(omega))

    return Case(run=run, value=lambda: _complex_list(run()))


CASES = {
    "linear_response": linear_response_case,
    "linear_stiffness": linear_stiffness_case,
    "static_equilibrium": static_equilibrium_case,
    "reference": reference_case,
    "amplitude_bias": amplitude_bias_case,
}
