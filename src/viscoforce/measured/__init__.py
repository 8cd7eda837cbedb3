"""Measured data: the path from an instrument file to the data a model fits.

One call, :func:`open_data`, reads a file (JPK, CSV, Asylum, UFF …, or a netCDF file that
``viscoforce load`` wrote) and returns the analysable dataset: the spectrum of its modulation
segments, corrected for the instrument phase lag and the hydrodynamic drag, with the complex
modulus when the tip is given; or the force curves. A JPK map is read in chunks of curves
(memory bounded by a chunk). It is what ``viscoforce load`` writes and what ``fit`` and
``bode`` fit::

    from viscoforce.measured import open_data
    spectrum = open_data("map.jpk-force-map", tip="sphere:5um")  # phase: the fitted sensor delay

:func:`read_measured` does the same and also tells what it made (:class:`MeasuredData`: format,
kind, dims, the drag fit). Errors about the options are :class:`OptionError`, a
:class:`~viscoforce.exceptions.ParameterError` naming the parameters.

The steps it chains are here too, for a user who wants one of them:

==========================  ====================================================================
:func:`load_instrument`     read a file in any known format to SI (curves or a spectrum)
:func:`detect_format`       which format a file is in (by its content)
:func:`has_modulation`      whether a curves dataset has sine-modulation segments
:func:`modulation_spectrum` demodulate the modulation segments into k*(ω) over (curve, omega)
:func:`stream_spectrum`     the same, a JPK archive read in chunks of curves (bounded memory)
:func:`correct_spectrum`    subtract a phase lag and a drag from a spectrum already made
:func:`drag_from_heights`   the drag at contact from out-of-contact spectra at several heights
:func:`add_complex_modulus` E′, E″, G′, G″ per point of a spectrum, given the tip
:func:`check_measured`      refuse values no measurement gives (the readers' physical ranges)
==========================  ====================================================================

The modules behind them stay where they are (:mod:`viscoforce.io`,
:mod:`viscoforce.experiments`); this package sits above them and below
:mod:`viscoforce.fitting` and the command line, which it never imports.
"""

from __future__ import annotations

from viscoforce.experiments.drag import DragFit, drag_from_heights
from viscoforce.experiments.modulation import correct_spectrum, modulation_spectrum
from viscoforce.experiments.moduli import add_complex_modulus
from viscoforce.experiments.stream import stream_spectrum
from viscoforce.io.instruments import FORMATS, detect_format, load_instrument
from viscoforce.io.quality import check_measured
from viscoforce.measured.open import (
    MeasuredData,
    OptionError,
    has_modulation,
    open_data,
    read_measured,
)

__all__ = [
    "FORMATS",
    "DragFit",
    "MeasuredData",
    "OptionError",
    "add_complex_modulus",
    "check_measured",
    "correct_spectrum",
    "detect_format",
    "drag_from_heights",
    "has_modulation",
    "load_instrument",
    "modulation_spectrum",
    "open_data",
    "read_measured",
    "stream_spectrum",
]
