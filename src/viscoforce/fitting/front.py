"""One front door: :func:`fit` fits any data viscoforce reads with any registered model.

The data decide the route (:func:`data_kind`): a spectrum (``stiffness`` over ``omega``) goes to
:func:`~viscoforce.fitting.fit.fit_spectrum`, a spectrum with more dims (a map) to
:func:`~viscoforce.fitting.maps.fit_map`; a curves dataset (``sample``) of one curve to
:func:`~viscoforce.fitting.curves.fit_curve` (``ting``: :func:`~viscoforce.fitting.ting.fit_ting`),
of several curves to :func:`~viscoforce.fitting.maps.fit_map`; a trajectory (``position`` over
``time``) to :func:`~viscoforce.fitting.curves.fit_step`. The model must fit that kind of data
(its entry's ``data``, :mod:`viscoforce.fitting.registry`); ``"auto"`` is the spectrum choosers'.
The options are those of the function the route ends in.
"""

from __future__ import annotations

from typing import Any

import xarray as xr

from viscoforce._validation import describe_value
from viscoforce.exceptions import ParameterError
from viscoforce.fitting.curves import fit_curve, fit_step
from viscoforce.fitting.fit import fit_spectrum
from viscoforce.fitting.maps import fit_map
from viscoforce.fitting.registry import entries, entry
from viscoforce.fitting.ting import fit_ting
from viscoforce.schema import data_kind as schema_kind

__all__ = ["data_kind", "fit"]

#: The registry's kind of data of each kind of dataset.
_ENTRY_DATA = {"spectrum": "spectrum", "curves": "curve", "trajectory": "trajectory"}


def data_kind(data: Any) -> str:
    """``"spectrum"``, ``"curves"`` or ``"trajectory"``: what kind of dataset ``data`` is.

    Raises
    ------
    ParameterError
        Not an :class:`xarray.Dataset` of one of these kinds.
    """
    if not isinstance(data, xr.Dataset):
        raise ParameterError(f"data must be an xarray.Dataset (a spectrum, curves or a "
                             f"trajectory: viscoforce.load(path)), got {describe_value(data)}")
    kind = schema_kind(data)
    if kind is not None:
        return kind
    raise ParameterError("data is neither a spectrum (stiffness over omega), curves (over "
                         "sample) nor a trajectory (position over time)")


def fit(data: xr.Dataset, model: str, **options: Any) -> xr.Dataset:
    """Fit ``data`` with ``model``: a spectrum, a map, one or several force curves, a trajectory.

    Parameters
    ----------
    data : xarray.Dataset
        What :func:`viscoforce.load` (or ``viscoforce load``) gives: a spectrum (over ``omega``
        and any extra dims), a curves dataset, or a trajectory (``viscoforce simulate --out``).
    model : str
        A registered model (:data:`viscoforce.fitting.MODELS`) that fits this kind of data, or
        ``"auto"`` (one spectrum).
    **options
        The model's fixed inputs and the options of the route's function (``modes``,
        ``criterion``, ``tip``, ``curve``, ``scheduler``, …; see the module docstring).

    Returns
    -------
    xarray.Dataset
        The fit result (:mod:`viscoforce.schema.fit`), over the map's dims for a map.

    Raises
    ------
    ParameterError
        Data of no known kind, or a model that does not fit it (the message lists those that
        do).
    """
    kind = data_kind(data)
    allowed = entries(data=_ENTRY_DATA[kind]) + (("auto",) if kind == "spectrum" else ())
    if model not in allowed:
        entry(model)  # an unknown model: the list of all of them
        raise ParameterError(f"model {model!r} does not fit {kind} data; for {kind}: "
                             f"{', '.join(allowed)}")
    if kind == "spectrum":
        extra = [d for d in data["stiffness"].dims if d != "omega"]
        return fit_map(data, model, **options) if extra else fit_spectrum(data, model, **options)
    if kind == "trajectory":
        return fit_step(data, **options)
    if int(data.sizes.get("curve", 1)) > 1 and "curve" not in options:
        return fit_map(data, model, **options)
    if model == "ting":
        return fit_ting(data, **options)
    return fit_curve(data, model, **options)
