"""Plots of simulated trajectories (paper Figs. 1, 5–8) and of spectra; compute and draw apart.

Every function takes a viscoforce dataset (a *trajectory* from
:func:`viscoforce.solvers.simulate.simulate`, or spectra and a fit result for :func:`bode_plot`),
draws on ``ax`` (or on a new figure when ``ax`` is None) and returns a :class:`PlotHandle`
holding the figure, the axes and the artists it drew, so that callers can restyle, annotate or
save the result. Nothing here computes physics, changes global state or calls ``plt.show()``.

Inputs are checked against the dataset contracts of :mod:`viscoforce.schema`
(:func:`~viscoforce.schema.validate_trajectory`, :func:`~viscoforce.schema.validate_spectrum`,
:func:`~viscoforce.schema.validate_fit_result`), so a wrong unit or dim raises
:class:`~viscoforce.exceptions.SchemaError` before anything is drawn.

Data stay in SI inside; conversion happens only for display: positions and gaps in nm, forces in
µN (or ``force_unit``), times in ms (or ``time_unit``), fit parameters in a unit suited to each
value. Axis labels carry the unit.

Modules: :mod:`~viscoforce.plotting._common` (the handle, option checks, display units),
:mod:`~viscoforce.plotting.trajectories` (loops, profiles, force against time),
:mod:`~viscoforce.plotting.bode` (spectra, data against fit), :mod:`~viscoforce.plotting.maps`
(a fitted variable over the map's pixels). matplotlib is imported lazily
inside the functions, so ``import viscoforce.plotting`` is cheap.
"""

from __future__ import annotations

from viscoforce.plotting._common import ForceUnit as ForceUnit
from viscoforce.plotting._common import LengthUnit as LengthUnit
from viscoforce.plotting._common import PlotHandle
from viscoforce.plotting._common import TimeUnit as TimeUnit
from viscoforce.plotting.bode import FrequencyUnit as FrequencyUnit
from viscoforce.plotting.bode import Magnitude as Magnitude
from viscoforce.plotting.bode import bode_plot, fit_curve_plot
from viscoforce.plotting.maps import map_plot
from viscoforce.plotting.trajectories import LOADING_STYLE as LOADING_STYLE
from viscoforce.plotting.trajectories import STATIC_MARKERS as STATIC_MARKERS
from viscoforce.plotting.trajectories import UNLOADING_STYLE as UNLOADING_STYLE
from viscoforce.plotting.trajectories import _branches as _branches
from viscoforce.plotting.trajectories import (
    contact_radius_plot,
    force_time_plot,
    hysteresis_plot,
    profile_plot,
)

__all__ = [
    "PlotHandle",
    "hysteresis_plot",
    "contact_radius_plot",
    "profile_plot",
    "force_time_plot",
    "bode_plot",
    "fit_curve_plot",
    "map_plot",
]
