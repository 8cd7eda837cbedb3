r"""A Bruker Nanoscope force-curve file (``.spm``) as the curve :func:`viscoforce.io.bruker.read_uff` reads.

:func:`nanoscope_curve` reads the header (:mod:`viscoforce.io._bruker_nanoscope`), checks that
the file holds one ramp force curve, reads its binary deflection with :func:`numpy.frombuffer`
and returns the same in-memory curve (:class:`~viscoforce.io._bruker_uff_header._Uff`: segments
of rows, header fields) that the UFF text export of that curve gives, so that both go through one
assembly (:func:`viscoforce.io.bruker.read_nanoscope`). Why it is written here rather than
imported (afmreader, nanoscope, pyfmreader, SciFiReaders): ``docs/bruker-spm.md``.

The scaling chain (Nanoscope manual; the same as pyfmreader's, checked against the UFF export of
the real file to 1e-7)
-----------------------------------------------------------------------------------------------
Sections are ``\*Ciao scan list`` (S), ``\*Ciao force list`` (F) and the deflection channel's
``\*Ciao force image list`` (I, the one whose ``@4:Image Data`` names a deflection):

* samples: I ``Samps/line: <approach> <retract>`` (two equal counts n; unequal counts are refused:
  the readers disagree on which is which); the data block of I ``Data length`` bytes at
  ``Data offset`` holds the approach then the retract, ``Data length`` / 2n bytes per sample,
  little-endian signed integers. Nanoscope 9.2 writes 4-byte samples under ``Bytes/pixel: 2``,
  so the width comes from the length, as pyfmreader does (SciFiReaders trusts ``Bytes/pixel``
  and reads such a file wrongly); 4-byte samples outside the 16-bit range are refused (the
  hard scale is per 16-bit LSB).
* deflection [V] = raw × the hard scale of I ``@4:Z scale: V [Sens. DeflSens] (0.000375 V/LSB)``;
  the sensitivity [m/V] = ``\@Sens. DeflSens`` (nm/V; written without a unit). The ``Deflection
  Sensitivity Correction`` (F) is recorded in the attrs and not applied (NanoScope Analysis and
  the UFF export do not apply it either).
* height [m]: the ramp, row i at i × ramp / n from the turnaround, ramp = the hard value of I
  ``@4:Ramp Size: V [Sens. Zsens] (…) 227.2211 V`` × ``\@Sens. Zsens`` (13.203 nm/V): 3 µm.
  Each segment's rows run from the turnaround (the most extended piezo) outward, as in the UFF
  export, and are put in time order by the shared assembly.
* velocity [m/s] = F ``Forward vel.`` (approach) / ``Reverse vel.`` (retract) [V/s] × Zsens;
  the sample times are derived from the ramp as for the UFF export.
* spring constant [N/m] = I ``Spring Constant``; position = S ``X Offset`` / ``Y Offset``.

Refused with a specific :class:`~viscoforce.exceptions.InstrumentFormatError`: a force volume
(operating mode ``Force Volume``, or an image section beside the force data; see the docs page),
an image or PeakForce capture file, a surface hold, a truncated file (the data block beyond the
end), a header missing any of the fields above or with one out of range.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from viscoforce.exceptions import InstrumentFormatError
from viscoforce.io._bruker_nanoscope import (
    NanoscopeHeader,
    _number,
    read_header,
    scaled,
)
from viscoforce.io._bruker_uff_header import _Column, _Segment, _Uff

#: translated field names: spring constant, sensitivity (the Nanoscope keys, for messages)
K_FIELD = "Spring Constant (N/m)"
S_FIELD = "@Sens. DeflSens (m/V)"
#: header fields kept as ``meta_nanoscope_<key>`` attrs (section-less keys, first occurrence)
_META_KEYS = ("Version", "Date", "Microscope", "Scanner file", "Operating mode", "Start context",
              "Spring Constant", "@Sens. DeflSens", "@Sens. Zsens",
              "Deflection Sensitivity Correction", "Forward vel.", "Reverse vel.", "Scan rate",
              "Trigger mode", "Ramp Size", "Z scale", "Image Data", "Samps/line", "Bytes/pixel",
              "Data offset", "Data length", "X Offset", "Y Offset", "Z direction")
_INT16 = (-(2**15), 2**15 - 1)
_OFFSET_UNITS = {"nm": 1e-9, "~m": 1e-6, "um": 1e-6}


def _fail(path: Path, text: str) -> InstrumentFormatError:
    return InstrumentFormatError(f"{path}: Bruker Nanoscope file: {text}")


def _required(header: NanoscopeHeader, fields: dict[str, str], name: str, where: str) -> str:
    value = header.get(fields, name)
    if value is None or not value.strip():
        raise _fail(header.path, f"the {where} lacks '\\{name}'")
    return value


def _positive(header: NanoscopeHeader, fields: dict[str, str], name: str, where: str) -> float:
    text = _required(header, fields, name, where)
    value = _number(text)
    if value is None or not (math.isfinite(value) and value > 0):
        raise _fail(header.path, f"'\\{name}' = {text!r} in the {where} is not a positive "
                                 "number")
    return value


def _one_curve(header: NanoscopeHeader) -> dict[str, str]:
    """The deflection channel's force image section of a single ramp curve; refuse the rest."""
    path = header.path
    scan = next(iter(header.all("Ciao scan list")), {})
    mode = (header.get(scan, "Operating mode") or "").strip()
    forces = header.all("Ciao force image list")
    images = header.all("Ciao image list")
    if mode.lower() == "force volume" or (forces and images):
        grid = (f"{header.get(images[0], 'Samps/line')} x "
                f"{header.get(images[0], 'Number of lines')} pixels" if images else "a grid")
        raise _fail(path, f"a force volume ({grid}, operating mode {mode!r}): this reader reads "
                          "single force curves. The curves' byte layout is known (consecutive "
                          "approach+retract blocks), but neither the readers nor a reference "
                          "export settle which pixel each curve belongs to, so a map is not "
                          "read rather than guessed (docs/bruker-spm.md); export the curves "
                          "from NanoScope Analysis as UFF or ASCII text")
    if not forces:
        what = "an image" if images else "no force data"
        raise _fail(path, f"{what} (operating mode {mode!r}, no '\\*Ciao force image list' "
                          "section): only force curves are read")
    if mode and mode.lower() != "force":
        raise _fail(path, f"operating mode {mode!r}: only ramp force curves (operating mode "
                          "'Force') are read; PeakForce capture and scripted ramps are not")
    for fields in forces:
        image_data = header.get(fields, "Image Data") or ""
        if "deflection" in image_data.lower():
            return fields
    names = [header.get(f, "Image Data") for f in forces]
    raise _fail(path, f"no deflection channel among the force data channels {names}")


def _samples(header: NanoscopeHeader, image: dict[str, str]) -> int:
    where = "force image list"
    text = _required(header, image, "Samps/line", where)
    counts = text.split()
    if len(counts) != 2 or not all(c.isdigit() and int(c) >= 2 for c in counts):
        raise _fail(header.path, f"'\\Samps/line' = {text!r} in the {where} is not two sample "
                                 "counts >= 2 (approach, retract)")
    if counts[0] != counts[1]:
        raise _fail(header.path, f"'\\Samps/line' = {text!r}: unequal approach and retract "
                                 "counts are not read (the readers disagree on which is which)")
    force = next(iter(header.all("Ciao force list")), {})
    for name in ("Hold Samples", "Hold Time"):
        hold = _number(header.get(force, name) or "0") or 0.0
        if hold != 0:
            raise _fail(header.path, f"'\\{name}' = {header.get(force, name)!r}: a curve with "
                                     "a surface hold is not read (only approach + retract)")
    return int(counts[0])


def _raw(header: NanoscopeHeader, image: dict[str, str], n: int, file_size: int
         ) -> tuple[np.ndarray, int]:
    """The 2n raw samples (approach then retract) and the bytes per sample."""
    path, where = header.path, "force image list"
    offset = int(_positive(header, image, "Data offset", where))
    length = int(_positive(header, image, "Data length", where))
    width, rest = divmod(length, 2 * n)
    if rest or width not in (2, 4):
        raise _fail(path, f"'\\Data length' = {length} bytes for 2 x {n} samples "
                          f"('\\Samps/line'): not 2 or 4 bytes per sample")
    if offset < header.size or offset + length > file_size:
        raise _fail(path, f"the force data are at bytes {offset} to {offset + length} "
                          f"('\\Data offset', '\\Data length'), the file has {file_size} bytes "
                          f"and a {header.size}-byte header: truncated or damaged")
    try:
        with path.open("rb") as fh:
            fh.seek(offset)
            data = fh.read(length)
    except OSError as exc:
        raise _fail(path, f"cannot read the force data ({exc.strerror or exc})") from None
    if len(data) != length:
        raise _fail(path, f"the force data end after {len(data)} of {length} bytes: truncated")
    raw = np.frombuffer(data, dtype="<i2" if width == 2 else "<i4")
    if width == 4 and (raw.min() < _INT16[0] or raw.max() > _INT16[1]):
        i = int(np.argmax((raw < _INT16[0]) | (raw > _INT16[1])))
        raise _fail(path, f"4-byte sample {i} is {int(raw[i])}, outside the 16-bit range the "
                          "hard scale (V/LSB) is given for: an unknown data encoding or damaged "
                          "data")
    return raw.astype(float), width


def _calibrations(header: NanoscopeHeader, image: dict[str, str]
                  ) -> tuple[float, float, str, float, float, str]:
    """(V/LSB, sensitivity m/V, its text, ramp m, Zsens m/V, what the channel is)."""
    path, where = header.path, "force image list"
    z_text = _required(header, image, "Z scale", where)
    z_scale = scaled(path, "@4:Z scale", z_text)
    if z_scale.hard_unit != "V/LSB" or not (math.isfinite(z_scale.hard) and z_scale.hard > 0):
        raise _fail(path, f"the deflection's '\\@4:Z scale' = {z_text!r} has no positive hard "
                          "scale in V/LSB")
    s, s_text = header.sensitivity(z_scale.soft or "Sens. DeflSens",
                                   "deflection's '\\@4:Z scale'")
    ramp_text = _required(header, image, "Ramp Size", where)
    ramp = scaled(path, "@4:Ramp Size", ramp_text)
    if ramp.unit != "V" or not (math.isfinite(ramp.value) and ramp.value > 0):
        raise _fail(path, f"'\\@4:Ramp Size' = {ramp_text!r} is not a positive value in V")
    z_sens, z_text_sens = header.sensitivity(ramp.soft or "Sens. Zsens", "'\\@4:Ramp Size'")
    name = _quoted(header.get(image, "Image Data") or "") or "deflection"
    return (z_scale.hard, s, s_text, ramp.value * z_sens, z_sens,
            f"{name} [V] = raw x {z_scale.hard:g} V/LSB ('@4:Z scale'); ramp = "
            f"{ramp.value:g} V x {z_text_sens} ('@4:Ramp Size' x '@{ramp.soft or 'Sens. Zsens'}')")


def _quoted(text: str) -> str:
    """``S [DeflectionError] "Deflection Error"`` → ``Deflection Error``."""
    parts = text.split('"')
    return parts[1].strip() if len(parts) >= 3 else ""


def _meta(header: NanoscopeHeader) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name in _META_KEYS:
        value = None
        for section in ("Ciao force image list", "Ciao force list", "Ciao scan list",
                        "Force file list", "File list", "Equipment list", "Scanner list"):
            for fields in header.all(section):
                if value is None:
                    value = header.get(fields, name)
        if value is None:
            value = header.anywhere(name)
        if value is not None:
            key = "meta_nanoscope_" + "_".join(
                "".join(c if c.isalnum() else " " for c in name.lstrip("@")).lower().split())
            try:
                number = float(value)
            except ValueError:
                number = math.nan
            out[key] = number if math.isfinite(number) else value
    return out


def nanoscope_curve(path: Path) -> tuple[_Uff, dict[str, Any]]:
    """Read a Nanoscope force-curve file as the curve its UFF export holds.

    Returns
    -------
    uff : _Uff
        Two segments (Approach, Retract), rows (height [m], deflection [V]) from the
        turnaround outward, and the translated fields the shared assembly reads (spring
        constant, sensitivity, velocities, position).
    meta : dict
        ``meta_nanoscope_<key>`` attrs: the header fields that describe the curve.
    """
    try:
        file_size = path.stat().st_size
    except OSError as exc:
        raise InstrumentFormatError(f"{path}: cannot read ({exc.strerror or exc})") from None
    header = read_header(path, file_size)
    image = _one_curve(header)
    n = _samples(header, image)
    volts_per_lsb, s, s_text, ramp, z_sens, how = _calibrations(header, image)
    raw, width = _raw(header, image, n, file_size)
    fields = {"Entry_tot_nb_curve": "1", S_FIELD: repr(s)}
    k = _number(header.get(image, "Spring Constant") or "")
    if k is not None and math.isfinite(k) and k > 0:  # else the caller's, or refused
        fields[K_FIELD] = repr(k)
    force = next(iter(header.all("Ciao force list")), {})
    scan = next(iter(header.all("Ciao scan list")), {})
    for i, key in enumerate(("Forward vel.", "Reverse vel.")):
        velocity = _positive(header, force, key, "force list") * z_sens
        fields[f"Recording_segment_{i}_velocity(m/s)"] = repr(velocity)
    for axis in ("X", "Y"):  # the scan area's offset: where a single ramp is taken
        text = (header.get(scan, f"{axis} Offset") or "").split()
        factor = _OFFSET_UNITS.get(text[-1]) if len(text) == 2 else None
        value = _number(text[0]) if factor is not None else None
        if value is not None and math.isfinite(value):
            fields[f"Recording_{axis.lower()}position(m)"] = repr(value * factor)
    height = np.arange(n) * (ramp / n)
    columns = [_Column("Z displacement (ramp)", "m"), _Column("Deflection", "V")]
    segments = []
    for i, (kind, code) in enumerate((("Approach", "AP"), ("Retract", "RE"))):
        rows = np.column_stack([height, raw[i * n:(i + 1) * n] * volts_per_lsb])
        segments.append(_Segment(index=i, code=code, kind=kind, number=str(i), n_points=n,
                                 columns=list(columns), rows=rows))
    declared = header.get(image, "Bytes/pixel")
    notes = {"nanoscope_scaling": how + f"; {width}-byte samples"
             + (f" (the header's Bytes/pixel says {declared})"
                if declared is not None and _number(declared) != width else "")}
    return _Uff(path=path, fields=fields, segments=segments, notes=notes), _meta(header)
