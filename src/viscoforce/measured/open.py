"""From a measured file to the data a model fits, in one call: :func:`open_data`.

The route (what ``viscoforce load``, ``fit`` and ``bode`` do with a file):

1. **Read.** A netCDF file (``*.nc``, no ``format``) is read as written, whole with a bound
   (:func:`~viscoforce.io.netcdf.open_netcdf`); measured data in it pass
   :func:`~viscoforce.io.quality.check_measured`. It is never demodulated again: it holds what
   ``load`` chose (a spectrum, or curves written with ``--raw``). A JPK archive (detected or
   ``format="jpk"``) without calibration options is read in chunks of curves, so memory stays
   bounded by a chunk whatever the map's size; the values are those of reading it whole. Any
   other file is read whole by :func:`~viscoforce.io.instruments.load_instrument`.
2. **Demodulate.** Curves with sine-modulation segments become a spectrum over (``curve``,
   ``omega``) (:func:`~viscoforce.experiments.modulation.modulation_spectrum`, in chunks:
   :func:`~viscoforce.experiments.stream.stream_spectrum`), unless ``raw``.
   The phase of the indentation refers to the height sensor, to the piezo, or to the sensor
   advanced by its fitted delay (``phase_reference``; by default the one the data support:
   :mod:`~viscoforce.experiments.phase_reference`).
3. **Correct.** The instrument phase lag (``phase_lag`` or a hard-surface ``phase_reference``)
   and the hydrodynamic drag (``drag``, or fitted from out-of-contact spectra at several
   ``drag_heights``: :func:`~viscoforce.experiments.drag.drag_from_heights`) are subtracted,
   on the way (step 2) or from a spectrum file
   (:func:`~viscoforce.experiments.modulation.correct_spectrum`).
4. **Moduli.** With ``tip``: E′, E″, G′, G″ per point
   (:func:`~viscoforce.experiments.moduli.add_complex_modulus`).

:func:`read_measured` does the same and also tells what it made (format, kind, dims, the drag
fit), the summary ``viscoforce load --json`` prints; with ``out`` it writes the dataset, the
curves of a JPK archive chunk by chunk.
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from os import PathLike
from typing import Any

import xarray as xr

from viscoforce.experiments.phase_reference import REFERENCES
from viscoforce.measured._options import (
    OptionError,
    check_options,
    expand_phase_lag,
    has_modulation,
    is_netcdf,
    literal,
)
from viscoforce.measured._read import (
    curves_streamed,
    open_streamable,
    read_netcdf,
    read_whole,
    streamed_spectrum,
)

__all__ = ["MeasuredData", "OptionError", "has_modulation", "open_data", "open_streamable",
           "read_measured", "streamed_spectrum"]

_CORRECTIONS = "{drag}, {drag_heights}, {phase_lag} and {phase_reference} correct a spectrum"
_MODULI = "{tip} and {poisson} give the complex modulus of a spectrum"
#: The words ``phase_reference`` takes as a reference mode (any other text is a file).
MODES = ("auto", *REFERENCES)


@dataclass(frozen=True)
class MeasuredData:
    """What :func:`read_measured` made of a file.

    Attributes
    ----------
    dataset : xarray.Dataset or None
        The analysable dataset: a spectrum or curves. None only when ``keep_streamed`` was
        False and the curves of a JPK archive were streamed (to ``out``, or just counted).
    source : str
        The format read (``attrs["source"]``: ``"jpk"``, ``"csv-spectrum"`` …; for a netCDF
        file, its own ``source``).
    kind : str
        ``"spectrum"`` or ``"curves"`` (``"trajectory"`` for a simulation's netCDF).
    dims : dict
        Dimension sizes of the dataset (also when it was streamed and not kept).
    variables : tuple of str
        Its data variables, sorted.
    drag_fit : DragFit or None
        The drag fitted from ``drag_heights`` (:class:`~viscoforce.experiments.drag.DragFit`).
    streamed : bool
        Whether the file was read in chunks of curves.
    """

    dataset: xr.Dataset | None
    source: str
    kind: str
    dims: dict[str, int]
    variables: tuple[str, ...]
    drag_fit: Any = None
    streamed: bool = False

    def summary(self) -> dict[str, Any]:
        """``format``, ``kind``, ``n_curves``, ``dims``, ``variables`` (+ the drag at contact).

        The object ``viscoforce load --json`` prints; ``drag_at_contact`` and
        ``drag_at_contact_stderr`` [N·s/m] only with a drag fitted from ``drag_heights``.
        """
        out: dict[str, Any] = {"format": self.source, "kind": self.kind,
                               "n_curves": int(self.dims.get("curve", 1)),
                               "dims": dict(self.dims), "variables": list(self.variables)}
        if self.drag_fit is not None:
            out.update(drag_at_contact=self.drag_fit.drag_at_contact,
                       drag_at_contact_stderr=self.drag_fit.drag_at_contact_stderr)
        return out


def open_data(path: str | PathLike[str], *, format: str | None = None, raw: bool = False,
              height_channel: str | None = None, spring_constant: float | str | None = None,
              sensitivity: float | str | None = None,
              phase_lag: float | Mapping[float, float] | None = None,
              phase_reference: str | PathLike[str] | xr.Dataset | None = None,
              drag: float | None = None,
              drag_heights: Sequence[tuple[float, str | PathLike[str]]] | None = None,
              tip: Any = None, poisson: float | None = None,
              sample_height: float | None = None, sample_base: str | None = None,
              out: str | PathLike[str] | None = None) -> xr.Dataset:
    """The analysable dataset of a measured file: a spectrum, or curves (module docstring).

    ``viscoforce load FILE --out data.nc`` writes what this returns; ``fit`` and ``bode`` fit
    it. Three lines from a file to a fit::

        import viscoforce as vf
        from viscoforce.measured import open_data
        result = vf.fit(open_data("curve.jpk-force"), "contact", tip="sphere:5um")

    Parameters
    ----------
    path : str or Path
        An instrument file (JPK, CSV, Asylum, UFF …; opened read-only) or a netCDF file
        (``*.nc``: what ``load`` wrote, read as written).
    format : str, optional
        The instrument format (:data:`~viscoforce.io.instruments.FORMATS`); default: detected
        from the content (and netCDF for ``*.nc``).
    raw : bool
        Return the curves, not the spectrum of their modulation segments.
    height_channel : str, optional
        The height channel of a JPK archive (default: the calibrated sensor), one of
        :data:`~viscoforce.io.curves.HEIGHT_CHANNELS`; refused for other formats.
    spring_constant : float or str, optional
        Cantilever spring constant [N/m] (or text with a unit, ``"0.1N/m"``), for files
        without calibration (text formats); refused by files that carry their own.
    sensitivity : float or str, optional
        Deflection sensitivity [m/V] (or ``"50nm/V"``), as ``spring_constant``.
    phase_lag : float or mapping of float to float, optional
        Instrument phase lag [degree] subtracted from the phase: one value for every
        frequency, or frequency [Hz] → lag for some of the file's frequencies (0 at the others;
        a frequency the file does not have is refused).
    phase_reference : {"auto", "sensor", "piezo", "delay"}, str, Path or xarray.Dataset, optional
        What the phase of the indentation refers to, for a file demodulated here
        (:mod:`~viscoforce.experiments.phase_reference`): ``"sensor"`` (the height channel as
        recorded), ``"piezo"`` (the sensor's amplitude, the piezo record's phase),
        ``"delay"`` (the sensor advanced by its delay behind the piezo, one fitted per file);
        None or ``"auto"`` (default): the one the data support, said in
        ``attrs["phase_reference_choice"]``. Or a hard-surface measurement (any other text or
        a Path: any file this function reads, read with ``phase_reference="sensor"``; or its
        spectrum dataset, referred to the sensor) whose median phase per frequency is the
        instrument lag to subtract; the phase of the data is then referred to the sensor too.
        The words are the modes: a file named ``piezo`` is ``Path("piezo")`` or ``"./piezo"``.
    drag : float, optional
        Hydrodynamic drag B [N·s/m], subtracted from the spectrum as iωB.
    drag_heights : sequence of (float, path), optional
        Out-of-contact measurements as (height above the surface [m], file), at least 3: the
        drag b(h) = 6πηa_eff²/(h + h_eff) fitted to them (with ``phase_lag`` or
        ``phase_reference`` applied) is extrapolated to contact and subtracted (instead of
        ``drag``); the fit is in the dataset's ``drag*`` attrs.
    tip : Tip or str, optional
        The tip (``"sphere:5um"``, ``"cone:35"`` … or a :class:`~viscoforce.physics.tips.Tip`):
        adds E_storage, E_loss, G_storage, G_loss [Pa] per point of the spectrum.
    poisson : float, optional
        The sample's Poisson's ratio in [0, 0.5] for those moduli (default 0.5); needs ``tip``.
    sample_height : float, optional
        The sample's thickness [m] on its rigid support: those moduli divided by the
        bottom-effect stiffness factor at each point's operating indentation
        (:mod:`viscoforce.physics.bottom_effect`); needs ``tip``.
    sample_base : {"bonded", "sliding"}, optional
        With ``sample_height``: the layer bonded to (default) or sliding on its support.
    out : str or Path, optional
        Also write the dataset there (netCDF, atomically). The curves of a JPK archive are
        written chunk by chunk, and the dataset returned is then that file opened lazily
        (memory stays bounded; close it when done).

    Returns
    -------
    xarray.Dataset
        A spectrum over (``curve``, ``omega``) when the file has modulation segments (or is
        a spectrum) and not ``raw``; else the curves dataset (a netCDF file: as written).

    Raises
    ------
    OptionError
        A :class:`~viscoforce.exceptions.ParameterError` naming the parameters: both ``drag``
        and ``drag_heights``, corrections or moduli asked of curves, a ``phase_lag`` frequency
        the file lacks, a calibration option the format does not take, a missing or unreadable
        netCDF file …
    InstrumentFormatError, ParameterError, UnitError, SchemaError, EffortError
        As :func:`~viscoforce.io.instruments.load_instrument`,
        :func:`~viscoforce.experiments.modulation.modulation_spectrum`,
        :func:`~viscoforce.experiments.drag.drag_from_heights` and
        :func:`~viscoforce.experiments.moduli.add_complex_modulus` raise them.
    OSError
        ``out`` cannot be written (it is left as it was).
    """
    return read_measured(
        path, format=format, raw=raw, height_channel=height_channel,
        spring_constant=spring_constant, sensitivity=sensitivity, phase_lag=phase_lag,
        phase_reference=phase_reference, drag=drag, drag_heights=drag_heights, tip=tip,
        poisson=poisson, sample_height=sample_height, sample_base=sample_base, out=out).dataset


def read_measured(path: str | PathLike[str], *, format: str | None = None, raw: bool = False,
                  height_channel: str | None = None,
                  spring_constant: float | str | None = None,
                  sensitivity: float | str | None = None,
                  phase_lag: float | Mapping[float, float] | None = None,
                  phase_reference: str | PathLike[str] | xr.Dataset | None = None,
                  drag: float | None = None,
                  drag_heights: Sequence[tuple[float, str | PathLike[str]]] | None = None,
                  tip: Any = None, poisson: float | None = None,
                  sample_height: float | None = None, sample_base: str | None = None,
                  out: str | PathLike[str] | None = None,
                  keep_streamed: bool = True) -> MeasuredData:
    """:func:`open_data`, with what it made: :class:`MeasuredData` (the ``load --json`` summary).

    Parameters
    ----------
    path, format, raw, height_channel, spring_constant, sensitivity, phase_lag, \
phase_reference, drag, drag_heights, tip, poisson, sample_height, sample_base, out
        As :func:`open_data`.
    keep_streamed : bool
        False: the curves of a JPK archive streamed to ``out`` are not opened again, and
        without ``out`` they are only counted, chunk by chunk (``dataset`` None; the dims and
        variables are given). What ``viscoforce load --raw`` does on a map of any size.

    Returns
    -------
    MeasuredData

    Raises
    ------
    As :func:`open_data`.
    """
    from viscoforce.io.curves import check_height_channel

    tip, heights = check_options(path=path, raw=raw, drag=drag, drag_heights=drag_heights,
                                 phase_lag=phase_lag, phase_reference=phase_reference, tip=tip,
                                 poisson=poisson)
    check_height_channel(height_channel)
    if (sample_height is not None or sample_base is not None) and tip is None:
        raise OptionError("{sample_height} and {sample_base} correct the complex modulus of a "
                          "contact: give {tip} too")
    if sample_base is not None and sample_height is None:
        raise OptionError("{sample_base} says how the layer of {sample_height} lies on its "
                          "support: give {sample_height} too")
    options = {k: v for k, v in (("spring_constant", spring_constant),
                                 ("sensitivity", sensitivity),
                                 ("height_channel", height_channel)) if v is not None}
    if is_netcdf(path, format):
        if options:
            raise OptionError(" and ".join("{" + k + "}" for k in options) + ": "
                              f"{literal(path)} is a netCDF file, read as written (they are "
                              "for instrument files)")
        archive, data = None, read_netcdf(path)
    else:
        calibration = {k: v for k, v in options.items() if k != "height_channel"}
        opened = open_streamable(path, format, calibration, height_channel=height_channel)
        archive, data = opened if opened is not None else (None, read_whole(path, format,
                                                                            options))
    with archive if archive is not None else contextlib.nullcontext():
        return _analysed(
            path, data, archive, netcdf=is_netcdf(path, format), format=format, raw=raw,
            options=options, phase_lag=phase_lag, phase_reference=phase_reference, drag=drag,
            drag_heights=heights, tip=tip, poisson=poisson, out=out,
            keep_streamed=keep_streamed, layer={"sample_height": sample_height,
                                                "sample_base": sample_base})


def _analysed(path, data: xr.Dataset, archive, *, netcdf: bool, format, raw: bool,
              options: dict, phase_lag, phase_reference, drag, drag_heights, tip, poisson,
              out, keep_streamed: bool, layer: dict | None = None) -> MeasuredData:
    """Steps 2 to 4 of the module docstring on ``data`` (the whole file, or a JPK probe)."""
    from viscoforce._files import write_netcdf
    from viscoforce.experiments.modulation import correct_spectrum, modulation_spectrum

    source = str(data.attrs.get("source", format or ""))
    curves = "omega" not in data.dims and (raw or netcdf or not has_modulation(data))
    why = ("this netCDF file holds curves (it is read as written)" if netcdf and not raw
           else "this file gives curves (no modulation segments, or {raw})")
    mode = phase_reference if isinstance(phase_reference, str) and phase_reference in MODES \
        else None
    corrections = not (drag is None and phase_lag is None and drag_heights is None
                       and mode in (None, "auto", "sensor") and not _is_file(phase_reference))
    if corrections and curves:
        raise OptionError(f"{_CORRECTIONS}; {why}")
    if curves and (tip is not None or poisson is not None):
        raise OptionError(f"{_MODULI}; {why}")
    if curves and archive is not None:  # the curves of a JPK archive: chunk by chunk
        return _streamed_curves(path, data, archive, format, options, out, keep_streamed)
    lag = expand_phase_lag(phase_lag, data)  # a frequency the file lacks: before any work
    if "omega" in data.dims and mode not in (None, "auto", _mode_of(data)):
        raise OptionError("{phase_reference} " + f"{mode!r}: the phase is referred while each "
                          "modulation segment is demodulated; this file is a spectrum already, "
                          f"its phase referred to {literal(_mode_of(data))!r} (attrs "
                          "phase_reference_mode)")
    reference = mode if mode is not None else _reference(phase_reference)
    hard = reference if isinstance(reference, xr.Dataset) else None
    if "omega" in data.dims and hard is not None and _mode_of(data) != "sensor":
        raise OptionError("{phase_reference}: a hard-surface reference subtracts a lag measured "
                          "against the sensor; this spectrum's phase refers to "
                          f"{literal(_mode_of(data))!r}: make it with the sensor as its phase "
                          "reference")
    drag_fit = _drag_fit(drag_heights, phase_lag, reference)
    if drag_fit is not None:
        drag = drag_fit.drag_at_contact
    height_channel = options.get("height_channel")
    if curves or ("omega" in data.dims and drag is None and lag is None and hard is None):
        ds = data
    elif "omega" in data.dims:  # a spectrum CSV or netCDF: the same corrections
        ds = correct_spectrum(data, phase_lag=lag, drag=drag, phase_reference=hard)
        if _mode_of(data) != "sensor" and "phase_reference" in data.attrs:  # its name kept
            ds.attrs["phase_reference"] = str(data.attrs["phase_reference"]) + (
                "" if lag is None else "; the phase_lag given is subtracted from this phase")
    elif archive is not None:
        from viscoforce.experiments.stream import stream_spectrum

        ds = stream_spectrum(archive, phase_lag=lag, drag=drag, phase_reference=reference,
                             height_channel=height_channel)
    else:
        ds = modulation_spectrum(data, phase_lag=lag, drag=drag, phase_reference=reference,
                                 height_channel=height_channel)
    if drag_fit is not None:
        ds.attrs.update(drag_fit.as_attrs())
    if tip is not None:
        from viscoforce.experiments.moduli import add_complex_modulus

        ds = add_complex_modulus(ds, tip, poisson=None if poisson is None else float(poisson),
                                 **(layer or {}))
    if out:
        write_netcdf(ds, out)
    return MeasuredData(ds, source, _kind(ds), {str(k): int(v) for k, v in ds.sizes.items()},
                        tuple(sorted(str(v) for v in ds.data_vars)), drag_fit,
                        archive is not None)


def _streamed_curves(path, probe: xr.Dataset, archive, format, options: dict, out,
                     keep_streamed: bool) -> MeasuredData:
    """The curves of a JPK archive: streamed to ``out``, counted, or (kept, no ``out``) whole."""
    height_channel = options.get("height_channel")
    if keep_streamed and not out:
        ds = read_whole(path, format, options)
        return MeasuredData(ds, "jpk", "curves", {str(k): int(v) for k, v in ds.sizes.items()},
                            tuple(sorted(str(v) for v in ds.data_vars)), None, False)
    summary = curves_streamed(archive, out, {k: probe.attrs[k] for k in ("source", "file")},
                              height_channel)
    ds = xr.open_dataset(out, engine="h5netcdf") if keep_streamed else None
    return MeasuredData(ds, "jpk", "curves", dict(summary["dims"]),
                        tuple(summary["variables"]), None, True)


def _kind(ds: xr.Dataset) -> str:
    from viscoforce.schema import data_kind

    return "spectrum" if "omega" in ds.dims else data_kind(ds) or "curves"


def _is_file(phase_reference: Any) -> bool:
    """Whether ``phase_reference`` names a hard-surface measurement (a path or a dataset)."""
    return phase_reference is not None and not (isinstance(phase_reference, str)
                                                and phase_reference in MODES)


def _mode_of(spectrum: xr.Dataset) -> str:
    """What a spectrum's phase refers to (``attrs["phase_reference_mode"]``; else the sensor)."""
    return str(spectrum.attrs.get("phase_reference_mode", "sensor"))


def _reference(phase_reference) -> xr.Dataset | None:
    """The hard-surface spectrum of ``phase_reference`` (a file read as :func:`open_data` does).

    A file is demodulated with the sensor as its phase reference: the lag it measures is the
    one against the sensor, and the data are referred to the sensor with it.
    """
    if phase_reference is None:
        return None
    from viscoforce.experiments.modulation import modulation_spectrum

    reference = (phase_reference if isinstance(phase_reference, xr.Dataset)
                 else open_data(phase_reference, phase_reference="sensor"))
    if "omega" not in reference.dims:  # refused with its reason: no modulation
        reference = modulation_spectrum(reference, phase_reference="sensor")
    return reference


def _drag_fit(heights: list[tuple[float, Any]] | None, phase_lag, reference):
    """The DragFit of the out-of-contact spectra at ``heights`` (None without them).

    Each file is read as the data are (a JPK archive in chunks, with its piezo record), with
    the same ``phase_lag`` and ``reference`` (a phase reference mode, None: each file's own
    default, or a hard-surface spectrum).
    """
    if heights is None:
        return None
    from viscoforce.experiments.drag import drag_from_heights

    spectra = []
    for height, path in heights:
        opened = None if is_netcdf(path, None) else open_streamable(path)
        if opened is not None:
            archive, data = opened
        else:
            archive, data = None, (read_netcdf(path) if is_netcdf(path, None)
                                   else read_whole(path, None, {}))
        with archive if archive is not None else contextlib.nullcontext():
            if "omega" not in data.dims and not has_modulation(data):
                raise OptionError("{drag_heights} " + f"{height:g}m={literal(path)}: the file has "
                                  "no modulation segments (a spectrum measured out of contact is "
                                  "needed)")
            spectra.append(_spectrum_of(data, archive, expand_phase_lag(phase_lag, data),
                                        reference))
    return drag_from_heights(spectra, [h for h, _ in heights])


def _spectrum_of(data: xr.Dataset, archive, lag, reference) -> xr.Dataset:
    """The spectrum of a file with modulation (``archive``: its JPK archive) or of a spectrum."""
    from viscoforce.experiments.modulation import correct_spectrum, modulation_spectrum

    hard = reference if isinstance(reference, xr.Dataset) else None
    if "omega" in data.dims:
        if isinstance(reference, str) and reference not in ("auto", _mode_of(data)):
            raise OptionError("{phase_reference} " + f"{reference!r}: a spectrum file already "
                              f"refers its phase to {literal(_mode_of(data))!r}")
        return data if lag is None and hard is None else correct_spectrum(
            data, phase_lag=lag, phase_reference=hard)
    if archive is not None:
        from viscoforce.experiments.stream import stream_spectrum

        return stream_spectrum(archive, phase_lag=lag, phase_reference=reference)
    return modulation_spectrum(data, phase_lag=lag, phase_reference=reference)
