"""lmfit all the way: ``ds.lmfit`` on a single fit's result gives lmfit's own objects.

A fit result is an :class:`xarray.Dataset` (values, stderr, limits, the best-fit curve), which
is what files keep. The dataset a fit returns in this session also carries the fit itself, so
that lmfit's tools work on it::

    ds = vf.fit_spectrum(spectrum, "contact", radius=5e-6, indentation=5e-7)
    print(ds.lmfit.fit_report())        # lmfit's report, with the SPEC names
    ci = ds.lmfit.conf_interval()        # lmfit's confidence intervals (F-test)
    ds.lmfit.uvars["E0"]                 # uncertainties.ufloat with the correlations
    ds.lmfit.result, ds.lmfit.minimizer  # lmfit.MinimizerResult and lmfit.Minimizer

The minimiser varies the internal parameters (``log_E_inf``, ``log_E0`` = log10 of E0/E_inf,
…; :mod:`viscoforce.fitting._params`); the lmfit result has those and the SPEC names as lmfit
expressions of them, so the report and ``uvars`` give both, with lmfit's propagation of the
covariance. It is lmfit's own view, made by one more ``leastsq`` from the best fit (a few
evaluations, the first time it is asked for): its stderr are the covariance's, scaled by the
reduced χ² when the data have no stderr — the curve fits' correction for autocorrelated
residuals (``attrs["stderr_correction"]``) is in the dataset's ``<name>_stderr``, not here.

A dataset read back from a file, unpickled (sent to another process), or made by an operation
that returns a new dataset (``isel``, ``assign``, …), has only its variables: ``ds.lmfit`` then
raises a ParameterError that says so.
A map keeps each pixel's report as text on request (``fit_map(..., reports=True)``: the variable
``fit_report``), which files keep.
:func:`attach` is how the fitting functions give a result dataset its fit.
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, Any

import lmfit
import xarray as xr

from viscoforce.exceptions import ParameterError

if TYPE_CHECKING:  # pragma: no cover
    from viscoforce.fitting.outcome import Outcome

__all__ = ["LmfitAccessor", "attach", "fit_report"]


@xr.register_dataset_accessor("lmfit")
class LmfitAccessor:
    """``ds.lmfit``: lmfit's result, report, confidence intervals and ``uvars`` of a fit."""

    def __init__(self, ds: xr.Dataset):
        self._ds = ds
        self._outcome: Outcome | None = None
        self._minimizer: lmfit.Minimizer | None = None
        self._result: lmfit.minimizer.MinimizerResult | None = None

    def __reduce__(self) -> tuple[Any, tuple[xr.Dataset]]:
        """Pickled without the fit (its closures cannot travel).

        A dataset sent to another process (dask, multiprocessing, ``pickle``) keeps its
        variables, as a file does.
        """
        return (LmfitAccessor, (self._ds,))

    @property
    def available(self) -> bool:
        """Whether this dataset carries its fit (made by a fit in this session)."""
        return self._outcome is not None

    def _require(self) -> Outcome:
        if self._outcome is None:
            raise ParameterError(
                "this dataset carries no lmfit result: only the dataset a single fit returns "
                "(fit_spectrum, fit_curve, fit_hold, fit_data) has one, in the session that "
                "made it — not one read from a file or derived by isel/assign; fit again for "
                "fit_report, conf_interval or uvars")
        return self._outcome

    @property
    def minimizer(self) -> lmfit.Minimizer:
        """The :class:`lmfit.Minimizer` of the fit (internal and SPEC parameters)."""
        if self._minimizer is None:
            self._minimizer = lmfit_minimizer(self._require())
        return self._minimizer

    @property
    def result(self) -> lmfit.minimizer.MinimizerResult:
        """Lmfit's :class:`~lmfit.minimizer.MinimizerResult` at the best fit."""
        if self._result is None:
            self._result = lmfit_result(self.minimizer)
        return self._result

    def fit_report(self, **kwargs: Any) -> str:
        """:func:`lmfit.fit_report` of :attr:`result` (its keyword arguments pass through)."""
        return lmfit.fit_report(self.result, **kwargs)

    def conf_interval(self, **kwargs: Any) -> dict[str, list[tuple[float, float]]]:
        """:func:`lmfit.conf_interval` of the fit (its keyword arguments pass through).

        The intervals are over the varied (internal, log10) parameters; see lmfit for
        ``sigmas``, ``p_names`` and ``trace``.
        """
        return lmfit.conf_interval(self.minimizer, self.result, **kwargs)

    @property
    def uvars(self) -> dict[str, Any]:
        """Every parameter as an ``uncertainties`` variable, correlated (lmfit's ``uvars``)."""
        return dict(self.result.uvars)


def lmfit_minimizer(outcome: Outcome) -> lmfit.Minimizer:
    """An :class:`lmfit.Minimizer` of a fit, at its best values, with the SPEC names too."""
    from viscoforce.fitting.outcome import _residual

    model = outcome.model
    params = model.parameters_from(outcome.values, outcome.data.x, expressions=True,
                                   y=outcome.data.y)
    for name, value in outcome.result.params.valuesdict().items():
        params[name].set(value=value)  # start at the best fit itself
    return lmfit.Minimizer(_residual(model, outcome.data), params,
                           scale_covar=not outcome.data.sigma_known)


def lmfit_result(minimizer: lmfit.Minimizer) -> lmfit.minimizer.MinimizerResult:
    """Lmfit's own result of ``minimizer`` (one more ``leastsq`` from the best fit)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return minimizer.minimize(method="leastsq")


def fit_report(outcome: Outcome) -> str:
    """:func:`lmfit.fit_report` of a fit (``ds.lmfit.fit_report()``; a map's pixels on request)."""
    return lmfit.fit_report(lmfit_result(lmfit_minimizer(outcome)))


def attach(ds: xr.Dataset, outcome: Outcome) -> xr.Dataset:
    """Give the result dataset ``ds`` its fit (``ds.lmfit``); returns ``ds``."""
    _accessor(ds)._outcome = outcome
    return ds


def carry(source: xr.Dataset, target: xr.Dataset) -> xr.Dataset:
    """``target`` (made from ``source`` by assign/update) with ``source``'s fit, if it has one."""
    outcome = _accessor(source)._outcome
    if outcome is not None:
        _accessor(target)._outcome = outcome
    return target


def _accessor(ds: xr.Dataset) -> LmfitAccessor:
    """``ds.lmfit``, put in xarray's accessor cache directly.

    The first ``ds.lmfit`` of a new dataset looks ``_cache`` up through the dataset's
    ``__getattr__``, whose miss builds a did-you-mean message over every variable name (issue
    22: a sizeable part of a small fit). The cache is the slot xarray's accessor descriptor
    reads, so ``ds.lmfit`` afterwards returns this same object (``tests/fitting/test_fit_engine.py``).
    """
    try:
        cache = object.__getattribute__(ds, "_cache")
    except AttributeError:
        cache = {}
        ds._cache = cache
    accessor = cache.get("lmfit")
    if accessor is None:
        accessor = cache["lmfit"] = LmfitAccessor(ds)
    return accessor
