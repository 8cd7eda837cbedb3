"""Exception hierarchy of viscoforce.

Every error raised on purpose derives from :class:`ViscoforceError`; mix-ins keep the usual
handlers (``except ValueError``) working.
"""

from __future__ import annotations


class ViscoforceError(Exception):
    """Base class of every error viscoforce raises on purpose."""


class ParameterError(ViscoforceError, ValueError):
    """A parameter is outside its allowed range (the message names it and the range)."""


class ConvergenceError(ViscoforceError, RuntimeError):
    """An iterative solver did not converge.

    Parameters
    ----------
    message : str
        What failed and a suggested fix.
    time : float or None
        Simulation time at which it failed [s] (None for a static solve).
    iterations : int
        Iterations performed.
    residual_norm : float
        Last residual norm (max-norm of the gap update) [m].
    """

    def __init__(self, message: str, *, time: float | None = None, iterations: int = 0,
                 residual_norm: float = float("nan")):
        super().__init__(message)
        self.time = time
        self.iterations = iterations
        self.residual_norm = residual_norm


class GapClosureError(ConvergenceError):
    """The gap between the surfaces went through zero (the surface law cannot hold it open)."""


class StabilityError(ViscoforceError, RuntimeError):
    """A time stepper became unstable (the message names the step and the fix)."""


class ClusterError(ViscoforceError, RuntimeError):
    """The dask cluster of a map fit failed (a worker died, the scheduler went away).

    The message names what failed and which pixels were lost; no partial result is returned.
    """


class SchemaError(ViscoforceError, ValueError):
    """A dataset misses a variable or carries a wrong unit."""


class UnitError(ViscoforceError, ValueError):
    """A quantity string has an unknown unit or the wrong dimension."""


class EffortError(ViscoforceError, ValueError):
    """A request needs more work (steps, samples, memory) than a stated limit; refused up front.

    Parameters
    ----------
    message : str
        What was estimated, the limit, and how to reduce the work.
    estimate : float
        The estimated amount of work.
    limit : float
        The limit it exceeds.
    """

    def __init__(self, message: str, *, estimate: float = float("nan"),
                 limit: float = float("nan")):
        super().__init__(message)
        self.estimate = estimate
        self.limit = limit


class ModelValidityError(ViscoforceError, ValueError):
    """A result lies outside the model's domain of validity (e.g. the half-space small-slope model).

    The numbers may be exact for the equations solved, but the equations no longer describe the
    physical system; the message gives the offending numbers and the limit.
    """


class ModelValidityWarning(UserWarning):
    """A result approaches the edge of the model's domain of validity (see ModelValidityError)."""


class AccuracyWarning(UserWarning):
    """A result computed without error control (a fixed time step) whose estimated error is large.

    The equations are valid but their numerical solution is not converged; the message gives the
    estimate and the fix (a smaller step, or an adaptive method).
    """


class ApproximationWarning(ModelValidityWarning):
    """An approximation's own error estimate exceeds 1 % here (a ModelValidityWarning).

    Raised by the SVDA, Hertz contact and the small-amplitude spectrum; the message gives the
    estimate and the exact route to use. ``method="auto"`` silences it for the route it chose.
    """


class GoodnessOfFitWarning(UserWarning):
    """A fit whose χ² goodness-of-fit p-value is below 1e-3: the model does not describe the data.

    Its stderr and information criteria assume that it does. The message gives χ², the degrees
    of freedom and the p-value; the usual causes are a wrong model (a material family, a
    geometry) or stderr that are too small for the data.
    """


class DataWarning(UserWarning):
    """The data lack something the analysis needs, and a named fallback was used instead.

    E.g. stderr missing or zero at some points (weights from the others), a NaN point left out,
    strongly autocorrelated residuals (stderr corrected by an effective sample size).
    """


class InstrumentFormatError(ViscoforceError, ValueError):
    """An instrument file is empty, truncated, corrupt, or lacks what the reader needs.

    The message names the file, the archive member and what is wrong.
    """
