"""Effort limits: work beyond these is refused up front, with the estimate in the message.

The limits bound what one call may cost on an ordinary workstation (minutes, not hours; a few GB,
not the whole machine). Each public entry point estimates its work *before* computing and calls
:func:`check_effort`; a refused request raises :class:`~viscoforce.exceptions.EffortError`
(exit status 2 on the command line). Long legitimate runs below the limits show progress.
"""

from __future__ import annotations

from viscoforce.exceptions import EffortError

#: Most time steps one simulation may take (≈ 10 min at ≈ 0.1 ms per step on the default grid).
MAX_STEPS = 5_000_000
#: Most output samples (time points or frequencies) one result may hold.
MAX_SAMPLES = 10_000_000
#: Most memory one result or one working array may take [bytes].
MAX_MEMORY_BYTES = 2 * 1024**3


def check_effort(what: str, estimate: float, limit: float, *, unit: str = "",
                 hint: str = "") -> None:
    """Raise :class:`EffortError` when ``estimate`` exceeds ``limit``.

    Parameters
    ----------
    what : str
        The work being estimated, e.g. ``"time steps of simulate"``.
    estimate : float
        The estimate (same unit as ``limit``).
    limit : float
        The limit.
    unit : str
        Unit shown after the numbers (``"bytes"``, ``""`` for counts).
    hint : str
        How to reduce the work (a complete sentence fragment, e.g. ``"raise dt"``).

    Raises
    ------
    EffortError
        If ``estimate > limit``.
    """
    if not estimate <= limit:  # also refuses NaN estimates
        suffix = f" {unit}" if unit else ""
        message = (f"{what}: about {estimate:.3g}{suffix} needed, beyond the limit of "
                   f"{limit:.3g}{suffix}; refused before computing")
        if hint:
            message += f" ({hint})"
        raise EffortError(message, estimate=float(estimate), limit=float(limit))
