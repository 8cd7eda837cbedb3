"""The spectrum of a big JPK map with bounded memory: demodulate chunks of curves, then join them.

:func:`~viscoforce.experiments.modulation.modulation_spectrum` of a whole archive decodes every
curve before it demodulates any (a 64×64 map is several GiB of samples). :func:`stream_spectrum`
reads :func:`~viscoforce.io.stream.chunk_size` curves at a time (about
:data:`~viscoforce.io.stream.DEFAULT_CHUNK_BYTES`), puts them through the same lock-in, keeps
only what it gives per point (a few hundred bytes) and makes the spectrum of all of them at
once, as :func:`~viscoforce.experiments.modulation.modulation_spectrum` does: so the result is
the spectrum of the whole selection, value for value and attribute for attribute. What needs
every curve is made over all of them: the phase reference (the sensor's delay is fitted over
the whole map, :mod:`viscoforce.experiments.phase_reference`), the ``quality_summary``, the
``contact_point`` attribute and whether ``mean_indentation`` is kept; the height channel is
chosen once for the whole selection (as :func:`~viscoforce.io.curves.jpk_to_curves` chooses it),
not per chunk.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.experiments.modulation import _checked, _demodulate, _joined, _spectrum
from viscoforce.io.curves import _select, check_height_channel
from viscoforce.io.jpk import JPKArchive, read_jpk
from viscoforce.io.stream import DEFAULT_CHUNK_BYTES, chunk_size, curve_chunks, selection_height

__all__ = ["stream_spectrum"]


def stream_spectrum(data: JPKArchive | str | Path, *,
                    curves: int | Iterable[int] | None = None, chunk: int | None = None,
                    memory_bytes: int = DEFAULT_CHUNK_BYTES, settle_periods: float = 1.0,
                    settle: float | None = None, detrend: str | None = "linear",
                    phase_lag: float | Mapping[float, float] | None = None,
                    drag: float | None = None, subtract_baseline: bool = True,
                    height_channel: str | None = None,
                    phase_reference: str | xr.Dataset | None = None,
                    contact_point: bool | Mapping[str, Any] = True) -> xr.Dataset:
    """:func:`~viscoforce.experiments.modulation.modulation_spectrum` of an archive, in chunks.

    Peak memory is that of one chunk of curves (plus the spectra made so far), whatever the
    number of curves; the result equals ``modulation_spectrum(data, ...)`` with the same
    options (see the module docstring).

    Parameters
    ----------
    data : JPKArchive, str or Path
        A JPK archive (:func:`~viscoforce.io.jpk.read_jpk`) or its path (opened and closed
        here).
    curves : int or iterable of int, optional
        Curves to use (default all).
    chunk : int, optional
        Curves per chunk, >= 1; default :func:`~viscoforce.io.stream.chunk_size` of
        ``memory_bytes``. It changes memory and speed, not the result.
    memory_bytes : int
        Memory budget of one chunk [bytes] when ``chunk`` is not given, >= 1 MiB.
    settle_periods, settle, detrend, phase_lag, drag, subtract_baseline, height_channel, \
phase_reference, contact_point
        As :func:`~viscoforce.experiments.modulation.modulation_spectrum`.

    Returns
    -------
    xarray.Dataset
        The valid spectrum over (``curve``, ``omega``) of the selected curves.

    Raises
    ------
    ParameterError
        ``data`` is not an archive or a path, bad ``chunk`` or ``memory_bytes``, curves whose
        frequency sets differ between chunks, and whatever ``modulation_spectrum`` raises.
    """
    check_height_channel(height_channel)  # before the file is opened
    if isinstance(data, str | Path):
        with read_jpk(data) as archive:
            return stream_spectrum(
                archive, curves=curves, chunk=chunk, memory_bytes=memory_bytes,
                settle_periods=settle_periods, settle=settle, detrend=detrend,
                phase_lag=phase_lag, drag=drag, subtract_baseline=subtract_baseline,
                height_channel=height_channel, phase_reference=phase_reference,
                contact_point=contact_point)
    if not isinstance(data, JPKArchive):
        raise ParameterError(f"stream_spectrum needs a JPKArchive or a path to one, got "
                             f"{type(data).__name__} (a curves dataset in memory: "
                             "modulation_spectrum)")
    options = _checked(settle_periods=settle_periods, settle=settle, detrend=detrend,
                       phase_lag=phase_lag, drag=drag, subtract_baseline=subtract_baseline,
                       phase_reference=phase_reference, contact_point=contact_point)
    picked = _select(data, curves)
    size = chunk_size(data, memory_bytes=memory_bytes) if chunk is None else chunk
    chunks = curve_chunks(picked, size)
    if len(chunks) == 1:  # one chunk: the function itself
        return _spectrum(_demodulate(data, picked, height_channel, options), options)
    height = height_channel if height_channel is not None else selection_height(data, picked)
    parts = []
    for indices in chunks:
        part = _demodulate(data, indices, height_channel, options)
        if part.attrs.get("height_channel") != height:  # this chunk alone has a better sensor
            part = _demodulate(data, indices, height, options)
        parts.append(part)
    return _spectrum(_joined(parts), options)
