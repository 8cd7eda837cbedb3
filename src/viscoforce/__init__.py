"""viscoforce: viscoelastic particles interacting through finite-ranged surface forces.

Exact axisymmetric solver (elastic half-space kernel + viscoelastic time stepping), force
spectroscopy, the slowly-varying-deformation approximation and analysis tools, following
P. Attard, "Interaction and deformation of viscoelastic particles: Nonadhesive particles".

Units are SI everywhere; see :mod:`viscoforce.units` for the sign and phase conventions.
"""

from __future__ import annotations

from viscoforce.exceptions import (
    AccuracyWarning,
    ApproximationWarning,
    ConvergenceError,
    DataWarning,
    EffortError,
    GapClosureError,
    GoodnessOfFitWarning,
    InstrumentFormatError,
    ModelValidityError,
    ModelValidityWarning,
    ParameterError,
    SchemaError,
    StabilityError,
    UnitError,
    ViscoforceError,
)
from viscoforce.physics.materials import Elastic, PronySeries, StandardLinearSolid
from viscoforce.physics.paper import PAPER, PaperParameters, paper_pressure_law
from viscoforce.physics.particle import Particle, Sphere
from viscoforce.physics.surface_forces import (
    DoubleLayer,
    LennardJones,
    SoftWall,
    SumOfLaws,
    lennard_jones_pressure_law,
)
from viscoforce.problem import ContactProblem, default_grid
from viscoforce.radial_grid import RadialGrid
from viscoforce.solvers.static import static_equilibrium

__version__ = "0.1.0"

#: Entry points imported on first use (``vf.simulate``, ``vf.fit_spectrum``, …): ``import
#: viscoforce`` stays cheap, and lmfit, dask or matplotlib load only for the jobs that need them.
_LAZY = {
    "Hold": "viscoforce.experiments.drives", "Ramp": "viscoforce.experiments.drives",
    "Step": "viscoforce.experiments.drives", "Triangle": "viscoforce.experiments.drives",
    "Sinusoid": "viscoforce.experiments.drives", "Sequence": "viscoforce.experiments.drives",
    "MeasuredTrace": "viscoforce.experiments.drives",
    "simulate": "viscoforce.solvers.simulate",
    "spectrum": "viscoforce.experiments.spectroscopy",
    "sweep": "viscoforce.experiments.spectroscopy",
    "linear_response": "viscoforce.experiments.linear_response",
    "load": "viscoforce.io.instruments",
    "modulation_spectrum": "viscoforce.experiments.modulation",
    "stream_spectrum": "viscoforce.experiments.stream",
    "fit": "viscoforce.fitting.front",
    "open_data": "viscoforce.measured.open",
    "fit_curve": "viscoforce.fitting.curves",
    "fit_creep": "viscoforce.fitting.creep",
    "fit_ting": "viscoforce.fitting.ting",
    "add_complex_modulus": "viscoforce.experiments.moduli",
    "read_jpk": "viscoforce.io.jpk",
    "write_spectrum_csv": "viscoforce.io.csv_tables",
    "spectrum_table": "viscoforce.io.csv_tables",
    "export_fits": "viscoforce.io.fit_tables",
    "fit_curves_table": "viscoforce.io.fit_tables",
    "fit_spectrum": "viscoforce.fitting.fit",
    "fit_hold": "viscoforce.fitting.curves",
    "fit_step": "viscoforce.fitting.curves",
    "fit_map": "viscoforce.fitting.maps",
    "map_summary": "viscoforce.fitting.pixels",
    "make_model": "viscoforce.fitting.models",
    "bode_plot": "viscoforce.plotting", "hysteresis_plot": "viscoforce.plotting",
    "contact_radius_plot": "viscoforce.plotting", "profile_plot": "viscoforce.plotting",
    "force_time_plot": "viscoforce.plotting", "fit_curve_plot": "viscoforce.plotting",
    "map_plot": "viscoforce.plotting",
    "example_path": "viscoforce.data",
}
#: Public names whose attribute in the module differs (``vf.load`` is ``load_instrument``).
_RENAMED = {"load": "load_instrument"}


def __getattr__(name: str):
    """Import a lazy entry point (PEP 562)."""
    if name not in _LAZY:
        raise AttributeError(f"module 'viscoforce' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(_LAZY[name]), _RENAMED.get(name, name))
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "AccuracyWarning",
    "ApproximationWarning",
    "ContactProblem",
    "ConvergenceError",
    "DataWarning",
    "EffortError",
    "DoubleLayer",
    "Elastic",
    "GapClosureError",
    "GoodnessOfFitWarning",
    "InstrumentFormatError",
    "LennardJones",
    "ModelValidityError",
    "ModelValidityWarning",
    "PAPER",
    "PaperParameters",
    "Particle",
    "ParameterError",
    "PronySeries",
    "RadialGrid",
    "SchemaError",
    "SoftWall",
    "SumOfLaws",
    "Sphere",
    "StabilityError",
    "StandardLinearSolid",
    "UnitError",
    "ViscoforceError",
    "default_grid",
    "lennard_jones_pressure_law",
    "paper_pressure_law",
    "static_equilibrium",
    "__version__",
    *_LAZY,
]
