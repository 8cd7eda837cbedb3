"""The fit models of the SPEC's Models table, one module each, and :func:`make_model`.

svda, exact, contact, prony, relaxation, step, hertz, creep and ting. Each model's module
(``viscoforce/fitting/models/<name>.py``) registers its :class:`~viscoforce.fitting.registry.ModelEntry`:
name, kind of data, builder, fixed inputs (check, unit, flag), parameters and their units, modes
and material families, the segment it cuts from a curve, its validity note, whether its residuals
are autocorrelated. Importing this package registers them all, in this order:
:data:`viscoforce.fitting.registry.MODELS` (also ``viscoforce.fitting.MODELS``).

Each model is an :class:`lmfit.Model` over plain functions of the project's physics whose
parameters carry the SPEC's exact names (``tau``, ``E0``, ``E_inf``; ``E_1``…, ``tau_1``…;
``k_inf``, ``dk_i``; ``F_inf``, ``dF_i``; ``C1``, ``m``; ``E``, ``contact_point``; ``z_inf``,
``dz_i``). The spectrum models return the complex stiffness k*(ω) = F̂/δ̂ [N/m] (phase = lead of
the force over the indentation); the curve models a force [N] over time (relaxation, step), a
force [N] over the tip position (hertz) or a tip position [m] over time (creep).
:meth:`~viscoforce.fitting.base.FitModel.guess` derives a start from the data alone
(:mod:`viscoforce.fitting.guesses`), with the ordering constraints of
:mod:`viscoforce.fitting._params`.

Build a model with :func:`make_model`; the ``spec`` (name, modes, fixed inputs) is what travels to
dask workers, which rebuild the model there (closures over a problem do not pickle cheaply).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from viscoforce.exceptions import ParameterError
from viscoforce.fitting.base import MAX_MODES, FitModel, ModelSpec

# isort: off
# each registers its model; this order is MODELS' order (the SPEC's Models table)
from viscoforce.fitting.models import svda, exact, contact, prony  # noqa: F401
from viscoforce.fitting.models import relaxation, step, hertz, creep, ting  # noqa: F401
# isort: on
from viscoforce.fitting.registry import MODELS, entries, entry

__all__ = ["MODELS", "check_fixed", "make_model"]


def check_fixed(name: str, fixed: Mapping[str, Any]) -> dict[str, Any]:
    """The fixed inputs of model ``name``, validated (:meth:`.registry.ModelEntry.check_fixed`)."""
    return entry(name).check_fixed(fixed)


def make_model(name: str, modes: int = 1, **fixed: Any) -> FitModel:
    """The lmfit model ``name`` (one of :data:`MODELS`) with ``modes`` modes.

    Parameters
    ----------
    name : str
        ``svda``, ``exact``, ``contact``, ``prony``, ``relaxation``, ``step``, ``hertz`` or
        ``creep``.
    modes : int
        Relaxation modes (≥ 1; only the models whose entry has ``max_modes`` > 1 take more
        than one).
    **fixed
        Fixed inputs in SI: ``position`` or ``mean_force`` (svda, exact); ``radius``, ``P``,
        ``debye_length`` (svda); ``problem`` (exact, step); ``radius``, ``indentation``,
        ``drag``, ``material`` (contact: ``sls``, ``prony``, ``power-law``, ``structural``),
        ``newtonian`` (contact power-law: fit a viscosity ``mu`` too), ``reference_frequency``
        [Hz] (contact structural: f_ref of ``E_ref``, default 1 Hz), ``debye_length`` (contact:
        the validity estimate); ``position_trace`` = (t, h0) (step); ``tip`` (hertz: a
        :class:`~viscoforce.physics.tips.Tip` or its text, required) and ``contact_window`` =
        (low, high) [m] (hertz: where the contact point may lie; default the approach).

    Raises
    ------
    ParameterError
        Unknown model, bad modes, or a missing fixed input (the message names it).
    ModelValidityError
        The model cannot describe the scene (contact at no indentation).
    """
    model = entry(name)
    if isinstance(modes, bool) or not isinstance(modes, int | np.integer) or not (
            1 <= modes <= MAX_MODES):
        raise ParameterError(f"modes must be an integer in [1, {MAX_MODES}], got {modes!r}")
    fixed = model.check_fixed(fixed)
    if modes > model.max_modes:
        raise ParameterError(f"model {name!r} has one mode (modes=1), got modes={modes}; "
                             f"models with several: {', '.join(entries(modal=True))}")
    if name == "contact" and modes > 1 and fixed.get("material", "sls") != "prony":
        raise ParameterError("contact with modes > 1 needs material='prony' (--material prony)")
    built = model.build(ModelSpec(name, int(modes), fixed))
    built.autocorrelated = model.autocorrelated
    return built
