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

# Archives and instrument files (zip bombs, lying headers): each member's size is checked against
# the zip's declared size before it is decompressed, and decompression stops at that size.
#: Largest decompressed size of one archive member [bytes]: a JPK channel, a zip member read by
#: afmformats, or a JPK archive inside a zip of archives (which is held in memory whole, one at a
#: time: its size once, decompressed chunk by chunk; refused up front when that exceeds
#: MAX_MEMORY_BYTES).
MAX_MEMBER_BYTES = 1024**3
#: Largest decompressed size of one JPK properties header [bytes] (real ones: 3-60 kB).
MAX_HEADER_BYTES = 16 * 1024**2
#: Largest sum of the decompressed sizes of one archive's members [bytes]. JPK maps are decoded
#: one curve at a time, so this bounds the reading work, not the memory.
MAX_ARCHIVE_BYTES = 16 * 1024**3
#: Largest file or zip member parsed whole by afmformats [bytes]: its text readers take about
#: 16x the text in memory (a Chiaro .txt: 0.84 MB of text, 13 MB peak).
MAX_PARSED_BYTES = 128 * 1024**2
#: Largest sum of the members of one zip read through afmformats [bytes] (all its curves are
#: held in memory at once).
MAX_PARSED_TOTAL_BYTES = 1024**3

# Plausible ranges of the calibrations an instrument file states (outside: refused as corrupt).
#: Cantilever spring constant [N/m].
SPRING_CONSTANT_RANGE = (1e-5, 1e3)
#: Deflection sensitivity [m/V].
SENSITIVITY_RANGE = (1e-12, 1e-3)

# Plausible ranges of what a user states about the probe and the measurement (outside: refused
# naming the parameter and the range). Each is far wider than any instrument, and far inside the
# double-precision range, so that nothing computed from them underflows or overflows.
#: Radius of a sphere, paraboloid or flat-punch tip [m]: a sharp tip's apex (nm) to a
#: macroscopic sphere (a surface force apparatus' cylinders are cm).
TIP_RADIUS_RANGE = (1e-9, 1.0)
#: Half-angle of a cone or pyramid tip [degree] (real tips: 5-45°).
TIP_HALF_ANGLE_RANGE = (0.1, 89.9)
#: Hydrodynamic drag coefficient B [N·s/m]: 0 (none) to far beyond the lubrication drag of a
#: centimetre sphere at a nanometre from a wall in water, 6πηR²/h ≈ 2e3 N·s/m.
DRAG_RANGE = (0.0, 1e6)
#: Mean (static) force of a measurement, the setpoint [N]: an attonewton (below the thermal
#: noise of any force probe) to a kilonewton.
MEAN_FORCE_RANGE = (1e-18, 1e3)
#: Shortest sample interval of a measured time series [s] (no instrument samples at a THz); a
#: shorter step is a wrong time unit or a damaged column, and its reciprocal overflows downstream.
MIN_TIME_STEP = 1e-12
#: A position a fit holds fixed [m] (``contact_point``, ``indentation``): no piezo, stage or
#: cantilever moves a metre (the readers' range of a measured position).
POSITION_RANGE = (-1.0, 1.0)
#: Operating indentation δ0 of the contact model [m]: a picometre (far below any detectable
#: indentation; at 5e-320 m the contact stiffness √(Rδ0) underflows to 0) to a metre.
INDENTATION_RANGE = (1e-12, 1.0)
#: Reference frequency f_ref of the structural (power-law) material [Hz]: a period of 12 days
#: (the readers' smallest measured frequency) to a GHz (beyond any mechanical drive).
REFERENCE_FREQUENCY_RANGE = (1e-6, 1e9)
#: Radius R of the paper's sphere (contact problem, svda) [m]: that of a tip.
SPHERE_RADIUS_RANGE = TIP_RADIUS_RANGE
#: Lengths of the surface-force laws [m]: the Debye length λ_D and the soft-wall length z0. A
#: picometre (far below an atom) to a metre (pure water's Debye length is ~1 µm); the paper's are
#: 1 nm and 0.5 nm.
SURFACE_FORCE_LENGTH_RANGE = (1e-12, 1.0)
#: Pressure scales of the surface-force laws [Pa]: the double layer's P and the soft wall's Pw.
#: A millipascal to a terapascal (beyond any material's strength); the paper's are 1e7 Pa.
SURFACE_PRESSURE_RANGE = (1e-3, 1e12)
#: Smallest span of the tip position over a fitted force curve [m] (a picometre, the readers'
#: smallest scale of a height): a fit bounds the contact point within it, and lmfit refuses
#: bounds closer than 1e-13.
MIN_POSITION_SPAN = 1e-12
#: Smallest span of the force over a fitted force curve [N] (0.1 pN, below the thermal noise of
#: any force probe but optical tweezers): a fit bounds the force baseline within a few spans.
MIN_FORCE_SPAN = 1e-13
#: Smallest span of a fitted curve relative to its largest magnitude (a 30-bit converter): below
#: it the windows a fit bounds its parameters with are narrower than lmfit's 1e-13 relative.
MIN_RELATIVE_SPAN = 1e-9


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


# Text tables (CSV/TSV: curves, spectra, drive traces, Prony tables): the size is checked before
# reading, the rows while reading (numeric columns parse straight to float64).
#: Largest text table read [bytes]: a 1e7-row curves table (MAX_CSV_ROWS) of time, force and
#: height at 9 significant digits is ~0.3 GB; a 1e6-row one (a long measurement) ~30 MB.
MAX_CSV_BYTES = 1_000_000_000
#: Most data rows of one text table (the samples one result may hold, MAX_SAMPLES).
MAX_CSV_ROWS = MAX_SAMPLES
#: Most rows of a measured drive trace: each sample is at least one time step of simulate.
MAX_TRACE_ROWS = MAX_STEPS
#: Thickness h of a sample layer on a rigid support [m] (the bottom-effect correction,
#: :mod:`viscoforce.physics.bottom_effect`): a nanometre film to a metre (beyond it every tip sees
#: a half-space); cells are 2-10 µm, gels tens of µm to mm.
SAMPLE_HEIGHT_RANGE = (1e-9, 1.0)
