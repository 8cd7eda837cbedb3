"""The spectrum of a big JPK map with bounded memory: demodulate chunks of curves, then join them.

:func:`~viscoforce.experiments.modulation.modulation_spectrum` of a whole archive decodes every
curve before it demodulates any (a 64×64 map is several GiB of samples). :func:`stream_spectrum`
reads :func:`~viscoforce.io.stream.chunk_size` curves at a time (about
:data:`~viscoforce.io.stream.DEFAULT_CHUNK_BYTES`), demodulates them with the same function and
options, keeps only their spectra (a few kB per curve) and joins them along ``curve``. The
result is the spectrum of the whole selection: every number is computed per curve (the
corrections are per frequency, the same for every chunk), so the values are identical; what
summarises all curves is made again over the whole: the ``quality_summary`` attribute, the
``contact_point`` attribute (how many curves have a contact point) and whether
``mean_indentation`` is kept; the height channel is chosen once for the whole selection (as
:func:`~viscoforce.io.curves.jpk_to_curves` chooses it), not per chunk.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.experiments.modulation import contact_point_summary, modulation_spectrum
from viscoforce.io.curves import _select, check_height_channel
from viscoforce.io.jpk import JPKArchive, read_jpk
from viscoforce.io.quality import quality_notes
from viscoforce.io.stream import DEFAULT_CHUNK_BYTES, chunk_size, curve_chunks, selection_height
from viscoforce.schema import validate_spectrum

__all__ = ["stream_spectrum"]

#: Variables over ``curve`` that a chunk has only when one of its curves has a contact point.
_CONTACT_VARIABLES = ("mean_indentation", "contact_position")


def stream_spectrum(data: JPKArchive | str | Path, *,
                    curves: int | Iterable[int] | None = None, chunk: int | None = None,
                    memory_bytes: int = DEFAULT_CHUNK_BYTES, settle_periods: float = 1.0,
                    settle: float | None = None, detrend: str | None = "linear",
                    phase_lag: float | Mapping[float, float] | None = None,
                    drag: float | None = None, subtract_baseline: bool = True,
                    height_channel: str | None = None,
                    phase_reference: xr.Dataset | None = None,
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
    options = {"settle_periods": settle_periods, "settle": settle, "detrend": detrend,
               "phase_lag": phase_lag, "drag": drag, "subtract_baseline": subtract_baseline,
               "phase_reference": phase_reference, "contact_point": contact_point}
    picked = _select(data, curves)
    size = chunk_size(data, memory_bytes=memory_bytes) if chunk is None else chunk
    chunks = curve_chunks(picked, size)
    if len(chunks) == 1:  # one chunk: the function itself
        return modulation_spectrum(data, curves=picked, height_channel=height_channel, **options)
    height = height_channel if height_channel is not None else selection_height(data, picked)
    parts = []
    for indices in chunks:
        part = modulation_spectrum(data, curves=indices, height_channel=height_channel, **options)
        if part.attrs.get("height_channel") != height:  # this chunk alone has a better sensor
            part = modulation_spectrum(data, curves=indices, height_channel=height, **options)
        _check_frequencies(parts[0] if parts else part, part)
        parts.append(part)
    return _joined(parts, contact_point)


def _check_frequencies(first: xr.Dataset, part: xr.Dataset) -> None:
    a, b = (np.asarray(d["frequency"].values, dtype=float) for d in (first, part))
    if a.shape != b.shape or not np.allclose(a, b, rtol=1e-9, atol=0.0):
        sets = sorted({tuple(a.tolist()), tuple(b.tolist())})
        raise ParameterError(f"the curves modulate different frequency sets {sets}; select "
                             "curves with the same set")


def _joined(parts: list[xr.Dataset], contact_point: bool | Mapping[str, Any]) -> xr.Dataset:
    """The chunks' spectra as one, with the attributes that summarise all curves made again."""
    template = next((p for p in parts if _CONTACT_VARIABLES[0] in p.variables), None)
    if template is not None:  # chunks without any contact point: NaN there, as one run gives
        parts = [p if _CONTACT_VARIABLES[0] in p.variables else p.assign(
            {name: (template[name].dims, np.full([p.sizes[d] for d in template[name].dims],
                                                 np.nan), template[name].attrs)
             for name in _CONTACT_VARIABLES}) for p in parts]
    spec = xr.concat(parts, dim="curve", data_vars="minimal", coords="minimal",
                     compat="override", combine_attrs="override", join="exact")
    spec.attrs = dict(parts[0].attrs)
    if template is not None and "indentation_definition" in template.attrs:
        spec.attrs["indentation_definition"] = template.attrs["indentation_definition"]
    notes = quality_notes(spec["quality"].transpose(..., "omega").values,
                          spec["phase"].transpose(..., "omega").values,
                          np.asarray(spec["frequency"].values), corrections="", basis="")
    spec.attrs["quality_summary"] = notes["summary"]
    if contact_point is not False:
        _contact_attrs(spec, contact_point)
    return validate_spectrum(spec)


def _contact_attrs(spec: xr.Dataset, contact_point: bool | Mapping[str, Any]) -> None:
    """``attrs["contact_point"]`` over all curves, as one ``modulation_spectrum`` writes it."""
    options = dict(contact_point) if isinstance(contact_point, Mapping) else {}
    z = (np.asarray(spec["contact_position"].values, dtype=float)
         if "contact_position" in spec.variables else np.full(spec.sizes["curve"], np.nan))
    text, keep = contact_point_summary(z, spec["curve"].values,
                                       str(spec.attrs.get("source", "jpk")), options)
    spec.attrs["contact_point"] = text
    if not keep:
        for name in _CONTACT_VARIABLES:
            if name in spec.variables:
                del spec[name]
        spec.attrs.pop("indentation_definition", None)
