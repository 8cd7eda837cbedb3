"""viscoforce: viscoelastic particles interacting through finite-ranged surface forces.

Exact axisymmetric solver (elastic half-space kernel + viscoelastic time stepping), force
spectroscopy, the slowly-varying-deformation approximation and analysis tools, following
P. Attard, "Interaction and deformation of viscoelastic particles: Nonadhesive particles".

Units are SI everywhere; see :mod:`viscoforce.units` for the sign and phase conventions.
"""

from __future__ import annotations

from viscoforce.exceptions import (
    ConvergenceError,
    EffortError,
    GapClosureError,
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
from viscoforce.physics.particle import Sphere
from viscoforce.physics.surface_forces import DoubleLayer, SoftWall, SumOfLaws
from viscoforce.problem import ContactProblem, default_grid
from viscoforce.radial_grid import RadialGrid
from viscoforce.solvers.static import static_equilibrium

__version__ = "0.1.0"

__all__ = [
    "ContactProblem",
    "ConvergenceError",
    "EffortError",
    "DoubleLayer",
    "Elastic",
    "GapClosureError",
    "InstrumentFormatError",
    "ModelValidityError",
    "ModelValidityWarning",
    "PAPER",
    "PaperParameters",
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
    "paper_pressure_law",
    "static_equilibrium",
    "__version__",
]
