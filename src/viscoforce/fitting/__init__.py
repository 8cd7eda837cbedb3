"""Fitting: lmfit models of the SPEC's Models table, model selection, fits over maps.

The only layer that imports lmfit (and, in :mod:`viscoforce.fitting.maps`, dask.distributed).
"""

from viscoforce.fitting.base import CONTACT_MATERIALS, MODEL_NAMES, FitModel, ModelSpec
from viscoforce.fitting.data import spectrum_data
from viscoforce.fitting.fit import CRITERIA, fit_data, fit_spectrum
from viscoforce.fitting.models import make_model

__all__ = ["CONTACT_MATERIALS", "CRITERIA", "MODEL_NAMES", "FitModel", "ModelSpec", "fit_data",
           "fit_spectrum", "make_model", "spectrum_data"]
