"""The Hertz-contact spectrum: k*(ω) = √(Rδ0)/C*(ω) at the indentation δ0 = −h̄0 (deep contact).

One of :data:`viscoforce.experiments.spectroscopy.SPECTRUM_METHODS` (``"contact"``); the limit
of the exact linear response deep in contact, with its error estimated against it.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from viscoforce._validation import require_finite, require_positive
from viscoforce.choice import WARN_ERROR, contact_error
from viscoforce.exceptions import ApproximationWarning, ModelValidityError
from viscoforce.experiments._checks import require_frequencies, require_number, require_problem
from viscoforce.problem import ContactProblem
from viscoforce.schema import make_spectrum

__all__ = ["contact_spectrum"]


def contact_spectrum(problem: ContactProblem, position: float, eta: float,
                     omega: ArrayLike) -> xr.Dataset:
    """Hertz-contact spectrum k*(ω) = √(Rδ0)/C*(ω) at the indentation δ0 = −h̄0 (deep contact only).

    The surface force enters only as a hard contact: the compliance of the force layer and the
    force outside the contact are neglected (estimated error
    :func:`~viscoforce.choice.contact_error`, ≈ 2 × 1.5 (|E*(ω)|/E_inf)/(κδ0) at the
    highest ω). The mean force is the relaxed Hertz load (2/3)E_inf√R δ0^{3/2} (the paper's E,
    twice Johnson's E*).

    Parameters
    ----------
    problem : ContactProblem
        System: sphere radius and any Prony material (the grid is not used).
    position : float
        Mean position h̄0 [m], < 0 (indentation δ0 = −h̄0).
    eta : float
        Drive amplitude η [m], > 0 (scales ``force_amplitude`` and ``amplitude`` only).
    omega : array_like
        Angular frequencies [rad/s], > 0.

    Returns
    -------
    xarray.Dataset
        Spectrum with ``method = "contact"``, ``indentation`` and ``estimated_error`` in attrs.

    Raises
    ------
    ModelValidityError
        If h̄0 ≥ 0 (no indentation).

    Warns
    -----
    ModelValidityWarning
        If the estimated error exceeds 1 %.
    """
    problem = require_problem(problem)
    position = require_number("position", position, require_finite,
                              "finite [m] (h0 < 0: the indentation is -h0)")
    eta = require_number("eta", eta, require_positive, "> 0 [m] (finite)")
    omega = require_frequencies(omega, allow_zero=False)
    if not position < 0:
        raise ModelValidityError(
            f"the Hertz-contact spectrum needs an indentation: position {position!r} m is not "
            "< 0; use method 'linear' (exact) or 'svda' before contact")
    depth = -position
    error, _ = contact_error(problem, position, float(np.max(omega)))
    if error > WARN_ERROR:
        warnings.warn(
            f"Hertz contact is about {100 * error:.2g} % off the exact model at indentation "
            f"{depth * 1e9:.4g} nm (estimate 2 x 1.5 |E*(omega_max)|/E_inf / (kappa delta0); "
            f"above {100 * WARN_ERROR:g} %): the surface-force layer is not stiff against the contact; "
            "use method 'linear' (exact)", ApproximationWarning, stacklevel=2)
    material, radius = problem.material, problem.sphere.radius
    k = math.sqrt(radius * depth) / material.complex_compliance(omega)
    mean = 2.0 / 3.0 * material.relaxed_modulus * math.sqrt(radius) * depth ** 1.5
    attrs = dict(problem.parameters())
    attrs.update({"method": "contact", "position": position, "eta": eta, "indentation": depth,
                  "estimated_error": error})
    return make_spectrum(omega, k, mean, eta, attrs=attrs)
