"""Fitting: lmfit models of the SPEC's Models table, model selection, fits over maps.

The only layer that imports lmfit (and, in :mod:`viscoforce.fitting.maps`, dask.distributed).
"""

# the choosers of model "auto" register themselves with fit_spectrum (fitting.fit.AUTO_CHOOSERS)
from viscoforce.fitting import auto, measured  # noqa: F401
from viscoforce.fitting.base import CONTACT_MATERIALS, FitModel, ModelSpec
from viscoforce.fitting.data import spectrum_data
from viscoforce.fitting.fit import CRITERIA, fit_data, fit_spectrum
from viscoforce.fitting.models import MODELS, make_model
from viscoforce.fitting.registry import ModelEntry, register

#: The registered model names, in the SPEC's order (:data:`MODELS`' keys).
MODEL_NAMES = tuple(MODELS)

__all__ = ["CONTACT_MATERIALS", "CRITERIA", "MODELS", "MODEL_NAMES", "FitModel", "ModelEntry",
           "ModelSpec", "fit_data", "register",
           "fit_spectrum", "make_model", "spectrum_data"]
