"""What every fit model shares: :class:`ModelSpec`, :class:`FitModel`, the parameter names.

:class:`FitModel` is an lmfit Model with a SPEC parameter layout; :func:`moduli_names`,
:func:`tau_names` and :func:`material_from` name a material's parameters and rebuild it.

The models themselves are registered in :mod:`viscoforce.fitting.models` (one module each,
:mod:`viscoforce.fitting.registry`) and built by :func:`viscoforce.fitting.models.make_model`.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import lmfit
import numpy as np

from viscoforce.exceptions import ParameterError
from viscoforce.fitting import _params as P
from viscoforce.physics.materials import PronySeries, StandardLinearSolid, ViscoelasticMaterial

#: Materials of the ``contact`` model (``--material``).
CONTACT_MATERIALS = ("sls", "prony", "power-law", "structural")


#: Reference frequency f_ref [Hz] of the structural material's E_ref (default of the fixed input).
REFERENCE_FREQUENCY = 1.0


#: Window of the power-law exponents (alpha, m): open (0, 1), kept off the singular ends.
EXPONENT_BOUNDS = (1e-3, 0.999)


#: Largest number of modes tried by ``modes="auto"``.
MAX_AUTO_MODES = 4
#: Most relaxation modes of one model (a fit needs several data points per mode).
MAX_MODES = 12


#: Decades beyond the measured window that a relaxation time may reach (its bounds).
TAU_MARGIN_DECADES = 3.0


#: Modulus window [Pa] of every fit (a soft gel to diamond).
MODULUS_BOUNDS = (1.0, 1e13)


@dataclass(frozen=True)
class ModelSpec:
    """What defines a model: its name, number of modes and fixed inputs (SI).

    ``fixed`` holds e.g. ``position`` or ``mean_force``, ``radius``, ``indentation``, ``drag``,
    ``material``, ``segment``; ``problem`` (a ContactProblem) for the exact and step models.
    """

    name: str
    modes: int = 1
    fixed: Mapping[str, Any] = field(default_factory=dict)


class FitModel(lmfit.Model):
    """An lmfit Model with a SPEC parameter layout and a data-driven :meth:`guess`.

    Attributes
    ----------
    spec : ModelSpec
        Name, modes and fixed inputs.
    layout : list
        The parameter layout (:mod:`viscoforce.fitting._params`).
    independent : str
        ``"omega"`` (spectrum models) or ``"t"`` (curve models).
    """

    def __init__(self, spec: ModelSpec, function: Callable[..., np.ndarray],
                 layout: Sequence[P.Item], independent: str,
                 guesser: Callable[[np.ndarray, np.ndarray], dict[str, float]],
                 tau_window: Callable[[np.ndarray], tuple[float, float]] | None = None,
                 bounded_windows: Callable[..., dict[str, tuple[float, float]]] | None = None):
        self.spec = spec
        self._bounded_windows = bounded_windows
        self.layout = list(layout)
        self.independent = independent
        self._guesser = guesser
        self._tau_window = tau_window
        #: ``raw(x, values)``: the model function on a mapping of SPEC values (no signature
        #: binding: what the fit loop calls).
        self.raw = function
        names = P.reported_names(layout)
        super().__init__(_signed(function, independent, names), independent_vars=[independent],
                         name=spec.name)

    @property
    def names(self) -> list[str]:
        """The SPEC parameter names, in layout order."""
        return P.reported_names(self.layout)

    def parameters_from(self, values: Mapping[str, float], x: np.ndarray, *,
                        expressions: bool = True, y: np.ndarray | None = None
                        ) -> lmfit.Parameters:
        """Parameters starting at ``values`` (SPEC names), with the bounds for data over ``x``.

        ``expressions=False``: the internal parameters only (see
        :func:`viscoforce.fitting._params.build_parameters`). ``y``: the data, for models whose
        bounded parameters take their window from it (hertz: baseline, slope).
        """
        return P.build_parameters(self._fitted_layout(x, y), values, expressions=expressions)

    def _fitted_layout(self, x: np.ndarray, y: np.ndarray | None) -> list[P.Item]:
        """The layout with the windows that data over ``x`` (and ``y``) give its parameters."""
        layout = self.layout
        if self._bounded_windows is not None:
            windows = self._bounded_windows(x, y)
            layout = [P.Bounded(i.name, *windows[i.name]) if isinstance(i, P.Bounded)
                      and i.name in windows else i for i in layout]
        if self._tau_window is not None:
            window = self._tau_window(x)
            layout = [P.Chain(i.names, window) if isinstance(i, P.Chain) and i.names[0].startswith(
                "tau") else i for i in layout]
        return [P.Chain(i.names, MODULUS_BOUNDS) if isinstance(i, P.Chain) and i.names[0] in (
            "E_inf", "E0", "E") else i for i in layout]

    def guess(self, data: np.ndarray, x: np.ndarray | None = None, **kws: Any) -> lmfit.Parameters:
        """Starting parameters from the data alone (complex k* over ω, or F over t)."""
        if x is None:
            x = kws.get(self.independent)
        if x is None:
            raise ParameterError(f"guess needs the independent variable {self.independent!r}")
        x = np.asarray(x, dtype=float)
        return self.parameters_from(self._guesser(np.asarray(data), x), x, y=np.asarray(data))

    def internal_guess(self, data: np.ndarray, x: np.ndarray) -> P.InternalParameters:
        """The internal (``log_…``) parameters of :meth:`guess`, without the expressions.

        What the fitting engine varies (``.to_lmfit()`` for lmfit's own minimiser).
        """
        x = np.asarray(x, dtype=float)
        y = np.asarray(data)
        guess = self._guesser(y, x)  # first: its errors name the data's problem
        return P.internal_parameters(self._fitted_layout(x, y), guess)

    def internal_start(self, values: Mapping[str, float], data: np.ndarray,
                       x: np.ndarray) -> P.InternalParameters:
        """The internal parameters starting at ``values`` (SPEC names), in the data's windows.

        As :meth:`internal_guess` with given values instead of the guesser's (clipped into the
        windows that these data give).
        """
        x = np.asarray(x, dtype=float)
        return P.internal_parameters(self._fitted_layout(x, np.asarray(data)), values)


def _signed(function: Callable[..., np.ndarray], independent: str,
            names: Sequence[str]) -> Callable[..., np.ndarray]:
    """``function(x, **params)`` with an explicit signature, which lmfit reads for the names."""

    def model(*args: Any, **kwargs: Any) -> np.ndarray:
        bound = signature.bind(*args, **kwargs)
        values = dict(bound.arguments)
        return function(values.pop(independent), values)

    signature = _model_signature(independent, tuple(names))
    model.__signature__ = signature  # type: ignore[attr-defined]
    model.__name__ = "viscoforce_model"
    return model


@functools.lru_cache(maxsize=256)
def _model_signature(independent: str, names: tuple[str, ...]) -> inspect.Signature:
    """``(independent, name_1=1.0, …)``: built once per layout (signatures are immutable)."""
    par = inspect.Parameter
    return inspect.Signature([par(independent, par.POSITIONAL_OR_KEYWORD)]
                             + [par(n, par.POSITIONAL_OR_KEYWORD, default=1.0) for n in names])


def moduli_names(modes: int) -> list[str]:
    """E0, E_1 … E_{n−1}, E_inf (descending moduli) of an n-mode material."""
    return ["E0", *(f"E_{i}" for i in range(1, modes)), "E_inf"]


def tau_names(modes: int, *, single: str = "tau") -> list[str]:
    """``tau`` for one mode (``single``), else tau_1 … tau_n (ascending)."""
    return [single] if modes == 1 and single else [f"tau_{i}" for i in range(1, modes + 1)]


def material_names(modes: int, material: str | None = None) -> list[str]:
    """The reported names of an n-mode material (``material``: unused, the registry's signature).

    tau, E0, E_inf for one mode; E0, E_1 … E_inf, tau_1 … tau_n for n modes.
    """
    return ["tau", "E0", "E_inf"] if modes == 1 else [*moduli_names(modes), *tau_names(modes)]


def material_layout(modes: int) -> list[P.Item]:
    """The parameter layout of an n-mode material: the moduli chain, then the times chain."""
    return [P.Chain(tuple(reversed(moduli_names(modes)))), P.Chain(tuple(tau_names(modes)))]


def material_from(values: Mapping[str, float], modes: int) -> ViscoelasticMaterial:
    """The Prony material of an n-mode parameter set (SPEC names)."""
    if modes == 1:
        return StandardLinearSolid(values["E0"], values["E_inf"], values["tau"])
    moduli = [values[n] for n in moduli_names(modes)]
    return PronySeries.from_moduli(moduli, [values[n] for n in tau_names(modes)])


def need(spec: ModelSpec, *names: str) -> list[Any]:
    """The fixed inputs ``names`` of a model's spec (raise naming those it lacks)."""
    missing = [n for n in names if spec.fixed.get(n) is None]
    if missing:
        raise ParameterError(f"model {spec.name!r} needs {', '.join(missing)}")
    return [spec.fixed[n] for n in names]
