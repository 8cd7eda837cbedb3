"""Vendor force curves read through the MIT library `afmformats` into a schema *curves* dataset.

Formats (detected by content, :func:`detect_afmformats`; read by :func:`read_afmformats`):

* Asylum Research / Igor binary wave ``.ibw`` (force from the ``Defl`` column times the file's
  ``SpringConstant``; ``ZSnsr`` height; segments from the wave note ``Indexes`` / ``Direction``);
* AFM Workshop ``.csv`` (``Force-Distance Curve`` header; force in nN, or photodiode T-B in V,
  which needs ``spring_constant`` and ``sensitivity``), and zips of them (a map);
* Optics11 Chiaro ``.txt`` (``Device:<tab>Chiaro`` header), also inside a zip (one curve per
  member);
* NT-MDT Nova text export ``.txt`` (three numeric columns, decimal commas, no header): there is no
  calibration in the file, so ``spring_constant`` and ``sensitivity`` must be given.

What goes where (SI; the file is opened read-only and never modified; zip members are copied to a
temporary directory because afmformats reads paths, one at a time, each removed once read):

* per sample: ``time`` [s] (the file's where it has one; Igor: sample / ``NumPtsPerSec``;
  AFM Workshop and NT-MDT record none: the sample index is used, 1 s per sample, and
  ``attrs["time_channel"]`` says so), ``force`` [N] as the file gives it (no baseline
  subtracted), ``height`` [m] (afmformats' convention, as JPK's: it grows away from the sample;
  the measured/sensor height where there is one, see ``attrs["height_channel"]``),
  ``deflection`` [m] = force / spring constant (``attrs["deflection_channel"]``; NaN when the file
  gives force but no spring constant), ``tip_position`` = −height − deflection (NaN then too:
  ``attrs["tip_position_channel"]`` says what is missing, the spring constant, and how to give
  it), ``segment``;
* per curve: ``spring_constant`` [N/m], ``sensitivity`` [m/V] (NaN where unknown), ``x``, ``y``
  [m] where the file has a position, and a ``curve`` coordinate (index in the file);
* ``segment_table``: afmformats segment 0 → ``approach``, 1 → ``retract`` (Igor: note direction
  1 → approach, −1 → retract, 0 → pause), ``segment_type`` the file's own label;
* ``attrs``: ``source`` = ``"afmformats:<maker> (<description>)"``, ``file``, ``n_curves``,
  ``afmformats_version``, the channels used, and every afmformats metadata value that is a
  number or a string as ``meta_<key>``, as afmformats gives it (mostly SI; its Chiaro loader
  leaves ``setpoint`` in µN, speeds in µm/s and ``z range`` in nm; spaces → underscores;
  per-curve numbers that differ become arrays, differing strings are joined with ``" | "``).

Calibration given by the caller (a missing one is told with :func:`~viscoforce.io._afm_formats.
calibration_hint`: the reader's arguments, and on the command line ``viscoforce load FILE
--spring-constant K --sensitivity S --out curves.nc`` then ``fit curves.nc``, as ``fit`` takes no
calibration flags): NT-MDT needs both (``sensitivity`` as Nova displays it, "nm/V",
which is really nm per nA of photodiode current; afmformats wants it in m/A, hence ×1e9);
AFM Workshop uses them where its columns are volts and for the deflection of force columns; for
Igor they *recalibrate* (deflection × sensitivity/file sensitivity, force = k × deflection), for
Chiaro ``spring_constant`` recalibrates the force and ``sensitivity`` does not apply.

Bounded reading: a file, and each zip member, is refused (:class:`~viscoforce.exceptions.EffortError`)
beyond :data:`~viscoforce._limits.MAX_PARSED_BYTES`, a zip whose members sum to more than
:data:`~viscoforce._limits.MAX_PARSED_TOTAL_BYTES`, both on the sizes the zip declares and before
anything is decompressed; the copy to the temporary directory counts the bytes and stops at the
declared size (zipfile stops there and checks the CRC: a header that lies is refused as corrupt).
Calibrations in the file or given by the caller are refused outside
:data:`~viscoforce._limits.SPRING_CONSTANT_RANGE` / :data:`~viscoforce._limits.SENSITIVITY_RANGE`,
and a non-finite time, force or height sample names the file (and member), the curve, the segment
and the channel; so does a sample beyond :data:`~viscoforce.io.quality.PHYSICAL_RANGES`, or a
channel whose every sample is below its smallest scale (:data:`~viscoforce.io.quality.
SMALLEST_SCALES`).

afmformats' exceptions derive from ``BaseException``; they are caught by name
(``afmformats.errors.AFMFileFormatError`` and its subclasses, ``MissingMetaDataError``) together
with the ordinary errors its parsers raise on broken input, and re-raised as
:class:`~viscoforce.exceptions.InstrumentFormatError` naming the file (and member).
"""

from __future__ import annotations

import math
import re
import tempfile
import warnings
import zipfile
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from viscoforce import _limits
from viscoforce._limits import check_effort
from viscoforce.exceptions import InstrumentFormatError, ParameterError
from viscoforce.io._afm_checks import (  # noqa: F401 (re-exported)
    _CALIBRATIONS,
    _file_calibration,
    _finite_or_nan,
    _optional_calibration,
    _require_finite_samples,
    _require_physical,
)
from viscoforce.io._afm_formats import (  # noqa: F401 (re-exported)
    _HEAD,
    _IGOR_VERSIONS,
    _MAKER_CHIARO,
    _MAKER_IGOR,
    _MAKER_NTMDT,
    _MAKER_WORKSHOP,
    _MEMBER_EXTENSIONS,
    _NUMBER,
    _PARSE_ERRORS,
    _SAFE_COMPRESSIONS,
    _afmformats,
    _kind_of,
    _read_head,
    _translated,
    _zip_members,
    calibration_hint,
)
from viscoforce.io._afm_segments import _igor_segments, _segments  # noqa: F401 (re-exported)
from viscoforce.schema import make_curves

__all__ = ["AFMFORMATS_EXTENSIONS", "detect_afmformats", "read_afmformats"]

#: File extensions :func:`read_afmformats` handles (content decides, see :func:`detect_afmformats`).
AFMFORMATS_EXTENSIONS = (".ibw", ".csv", ".txt", ".zip")
#: bytes copied per step from a zip member to the temporary directory
_COPY_CHUNK = 1024**2


# ── detection ─────────────────────────────────────────────────────────────────────────────────


def detect_afmformats(path: str | Path) -> bool:
    """True if ``path`` is a file :func:`read_afmformats` reads, judged by content.

    Igor binary wave version in the first two bytes (``.ibw``), the ``Force-Distance Curve`` first
    line (AFM Workshop ``.csv``), ``Device:<tab>Chiaro`` in the header (Chiaro ``.txt``), three
    numeric columns (NT-MDT ``.txt``); a ``.zip`` whose first member with one of those extensions
    is one of them. Never raises for unreadable files (returns False).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in AFMFORMATS_EXTENSIONS or not path.is_file():
        return False
    try:
        if suffix != ".zip":
            with path.open("rb") as fh:
                return _kind_of(suffix, fh.read(_HEAD)) is not None
        with zipfile.ZipFile(path) as zf:
            members = _zip_members(zf)
            return bool(members) and _kind_of(Path(members[0].filename).suffix,
                                               _read_head(zf, members[0])) is not None
    except (OSError, EOFError, zipfile.BadZipFile, zipfile.LargeZipFile, zlib.error,
            NotImplementedError, RuntimeError):
        return False


# ── loading ───────────────────────────────────────────────────────────────────────────────────


@dataclass
class _Curve:
    """One curve in SI, ready for make_curves."""

    time: np.ndarray
    force: np.ndarray
    height: np.ndarray
    deflection: np.ndarray
    segments: list[tuple[str, str]]  # (segment_name, segment_type) per local segment id
    local_segment: np.ndarray
    spring_constant: float
    sensitivity: float
    metadata: dict[str, Any]
    x: float = math.nan
    y: float = math.nan
    notes: dict[str, str] = field(default_factory=dict)


#: Where each format's height comes from, as its file names it (for the notes).
_HEIGHT_SOURCES = {"workshop": "the Z-Sense column", "ntmdt": "the first column",
                   "igor": "ZSnsr", "chiaro": "the piezo position"}


def _convert(kind: str, fmt: str, path: Path, afm: Any, k_user: float | None,
             s_user: float | None, where: str, index: int, dropped: str,
             origin: Path) -> _Curve:
    """Curve ``index`` of the file (``where`` names it in errors; ``dropped``: afmformats' notes).

    ``origin`` is the file the caller gave (the zip of a member), which a hint tells to ``load``.
    """
    meta = dict(afm.metadata)
    columns = list(afm.columns)
    n = len(afm)
    notes: dict[str, str] = {}
    if "force" not in columns:
        raise InstrumentFormatError(f"{where}: afmformats gives no force column ({columns}){dropped}")
    force = np.asarray(afm["force"], dtype=float)
    height_order = (("height (piezo)", "height (measured)") if kind == "chiaro"
                    else ("height (measured)", "height (piezo)"))
    hname = next((c for c in height_order if c in columns), None)
    if hname is None:
        raise InstrumentFormatError(f"{where}: afmformats gives no height column ({columns}){dropped}")
    height = np.asarray(afm[hname], dtype=float)
    notes["height_channel"] = hname
    if kind == "chiaro":
        notes["height_note"] = ("Chiaro's 'height (measured)' is the file's Indentation column "
                                "(zero before contact), so the piezo height is used")
    elif kind == "ntmdt":
        notes["height_note"] = "NT-MDT's first column (piezo height, nm) as afmformats reads it"
    if "time" in columns:
        time = np.asarray(afm["time"], dtype=float)
        notes["time_channel"] = "time (from the file)"
        if time.size > 1 and np.any(np.diff(time) <= 0):
            raise InstrumentFormatError(f"{where}: curve {index}: the file's time column does not "
                                        "increase")
    elif kind == "igor" and _finite_or_nan(meta.get("rate approach")) > 0:
        rate = float(meta["rate approach"])
        time = np.arange(n) / rate
        notes["time_channel"] = f"sample index / NumPtsPerSec ({rate:g} Hz)"
    else:
        time = np.arange(n, dtype=float)
        notes["time_channel"] = "sample index (the file records no time; 1 s per sample placeholder)"

    k_file = _file_calibration(meta, "spring constant", where, kind != "ntmdt")
    s_file = _file_calibration(meta, "sensitivity", where, kind != "ntmdt")
    k, s = k_file, s_file
    if kind == "ntmdt":
        s = float(s_user)  # afmformats holds it in m/A (x1e9); keep the user's value
        notes["sensitivity_note"] = ("meta_sensitivity is afmformats' value in m/A (nm per nA of "
                                     "photodiode current) = 1e9 x the sensitivity variable [m/V]")
    if math.isfinite(k) and k > 0:
        deflection = force / k
        notes["deflection_channel"] = ("photodiode signal x sensitivity (= force / spring constant)"
                                       if kind == "ntmdt"
                                       else "force / spring constant (the file gives force)")
    else:
        deflection = np.full(n, math.nan)
        notes["deflection_channel"] = ("unavailable: the file gives force but no spring constant "
                                       "(pass spring_constant)")
        notes["tip_position_channel"] = (
            f"unavailable: the file has a height ({_HEIGHT_SOURCES.get(kind, hname)}, read as "
            f"'{hname}') and the force but no spring constant, so the deflection (force / spring "
            "constant) and the tip position (-height - deflection) are unknown; "
            + calibration_hint(origin, ("spring_constant",)))
    if kind in ("igor", "chiaro"):  # afmformats does not take overrides here: recalibrate
        if s_user is not None:
            if not math.isfinite(s_file):
                raise ParameterError(f"{where}: {fmt} has no deflection sensitivity to override "
                                     "(its deflection is measured directly); drop sensitivity")
            deflection = deflection * (s_user / s_file)
            s = s_user
            notes["recalibrated_sensitivity"] = f"file {s_file:g} m/V -> {s_user:g} m/V"
        if k_user is not None:
            force = k_user * deflection
            notes["recalibrated_spring_constant"] = f"file {k_file:g} N/m -> {k_user:g} N/m"
            k = k_user
        elif s_user is not None:
            force = k * deflection
    table, local = _segments(kind, path, afm, n, height, notes)
    for channel, values in (("time", time), ("force", force), ("height", height)):
        _require_finite_samples(values, channel, where, index, table, local)
        _require_physical(values, channel, where, index)
    x = _finite_or_nan(meta.get("position x"))
    y = _finite_or_nan(meta.get("position y"))
    return _Curve(time=time, force=force, height=height, deflection=deflection, segments=table,
                  local_segment=local, spring_constant=k, sensitivity=s, metadata=meta, x=x, y=y,
                  notes=notes)


def _load_file(path: Path, where: str, k_user: float | None, s_user: float | None,
               display: Path, origin: Path | None = None) -> tuple[str, list[_Curve]]:
    """Load one real file (``path``) through afmformats; ``where`` names it in errors.

    ``origin`` is the file the caller gave (default ``path``; the zip of a member): the one a
    missing calibration's hint tells to ``viscoforce load``.
    """
    origin = path if origin is None else origin
    afmformats = _afmformats()
    with _translated(where, origin):
        suffix = path.suffix.lower()
        if suffix == ".zip":
            kind = "workshop"
        else:
            with path.open("rb") as fh:
                kind = _kind_of(suffix, fh.read(_HEAD)) or ""
        if not kind:
            raise InstrumentFormatError(f"{where}: not an Igor .ibw, AFM Workshop .csv, Chiaro or "
                                        "NT-MDT .txt file (content not recognised)")
        recipe = afmformats.formats.get_recipe(path, modality="force-distance")
        fmt = f"{recipe.maker} ({recipe.descr})"
        override: dict[str, float] = {}
        if recipe.maker == _MAKER_NTMDT:
            if k_user is None or s_user is None:
                missing = " and ".join(name for name, v in (("spring_constant", k_user),
                                                            ("sensitivity", s_user)) if v is None)
                raise InstrumentFormatError(f"{where}: NT-MDT text exports carry no calibration; "
                                            f"{missing} missing: {calibration_hint(origin)}")
            override = {"spring constant": k_user, "sensitivity": s_user * 1e9}
        elif recipe.maker == _MAKER_WORKSHOP:
            override = {key: v for key, v in (("spring constant", k_user),
                                              ("sensitivity", s_user)) if v is not None}
        elif recipe.maker not in (_MAKER_IGOR, _MAKER_CHIARO):
            raise InstrumentFormatError(f"{where}: afmformats reads it as {fmt}, which this reader "
                                        "does not handle (use viscoforce.io.read_jpk for JPK)")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            loaded = afmformats.load_data(path, meta_override=override, modality="force-distance")
        for warning in caught:  # passed on; kept to explain a column afmformats dropped
            warnings.warn_explicit(warning.message, warning.category, warning.filename,
                                   warning.lineno)
        dropped = "".join(f"; afmformats: {str(w.message).replace(str(path), where)}"
                          for w in caught if "column" in str(w.message).lower())
        if not loaded:
            raise InstrumentFormatError(f"{where}: no force-distance curve in the file")
        curves = [_convert(kind, fmt, path, afm, k_user, s_user, where, i, dropped, origin)
                  for i, afm in enumerate(loaded)]
    for curve in curves:
        curve.metadata["path"] = str(display)
    return fmt, curves


def _check_sizes(path: Path, infos: Sequence[zipfile.ZipInfo]) -> None:
    """Refuse members (and their sum) beyond the parsing limits, from the sizes the zip declares."""
    hint = ("the size the zip's directory declares; afmformats parses a member whole (about 16x "
            "its size in memory); a damaged or hostile zip, or raise viscoforce._limits.{}")
    for info in infos:
        if info.compress_type not in _SAFE_COMPRESSIONS:
            raise InstrumentFormatError(
                f"{path}!{info.filename}: zip compression method {info.compress_type} is not "
                "read (only stored, deflate and LZMA: zipfile decompresses bzip2 without an "
                "output limit, a zip-bomb risk); re-zip the files with deflate")
        check_effort(f"{path}!{info.filename}: decompressing this member", info.file_size,
                     _limits.MAX_PARSED_BYTES, unit="bytes", hint=hint.format("MAX_PARSED_BYTES"))
    check_effort(f"{path}: decompressing the zip's {len(infos)} member(s)",
                 sum(info.file_size for info in infos), _limits.MAX_PARSED_TOTAL_BYTES,
                 unit="bytes", hint=hint.format("MAX_PARSED_TOTAL_BYTES"))


def _copy_member(zf: zipfile.ZipFile, info: zipfile.ZipInfo, target: Path, where: str) -> None:
    """Copy ``info`` to ``target``, counting: never more than its declared size is written."""
    written = 0
    with zf.open(info) as src, target.open("wb") as dst:
        while chunk := src.read(min(_COPY_CHUNK, info.file_size - written + 1)):
            written += len(chunk)
            if written > info.file_size:  # zipfile stops at the declared size; in case not
                raise InstrumentFormatError(f"{where}: decompresses to more than the "
                                            f"{info.file_size} bytes the zip declares: corrupt zip")
            dst.write(chunk)


def _load_zip(path: Path, k_user: float | None, s_user: float | None) -> tuple[str, list[_Curve]]:
    try:
        with zipfile.ZipFile(path) as zf:
            members = _zip_members(zf)
            if not members:
                raise InstrumentFormatError(f"{path}: zip holds no .ibw, .csv or .txt member")
            if all(Path(m.filename).suffix.lower() == ".csv" for m in members):
                _check_sizes(path, [i for i in zf.infolist() if not i.is_dir()])  # it reads all
                return _load_file(path, str(path), k_user, s_user, path)  # AFM Workshop map
            _check_sizes(path, members)
            fmts: list[str] = []
            curves: list[_Curve] = []
            with tempfile.TemporaryDirectory(prefix="viscoforce-afm-") as tmp:
                for i, info in enumerate(members):  # one member in the folder at a time
                    where = f"{path}!{info.filename}"
                    target = Path(tmp) / f"{i:05d}{Path(info.filename).suffix.lower()}"
                    try:
                        _copy_member(zf, info, target, where)
                        fmt, got = _load_file(target, where, k_user, s_user, Path(where),
                                              origin=path)
                    except (zipfile.BadZipFile, zlib.error, EOFError) as exc:
                        raise InstrumentFormatError(
                            f"{where}: cannot be decompressed ({type(exc).__name__}: {exc}): the "
                            "zip is damaged (truncated, or the member is not the "
                            f"{info.file_size} bytes its header declares)") from None
                    finally:
                        target.unlink(missing_ok=True)
                    fmts.append(fmt)
                    curves += got
    except (zipfile.BadZipFile, zipfile.LargeZipFile, zlib.error, EOFError,
            NotImplementedError, RuntimeError) as exc:
        with path.open("rb") as handle:
            starts_as_zip = handle.read(4) == b"PK\x03\x04"
        cut = (": it starts as a zip but its central directory (the member list at its end) is "
               "missing or damaged, so the file is truncated"
               if starts_as_zip and isinstance(exc, zipfile.BadZipFile)
               and "not a zip file" in str(exc) else "")
        raise InstrumentFormatError(f"{path}: corrupt or unreadable zip "
                                    f"({type(exc).__name__}: {exc}){cut}") from None
    if len(set(fmts)) != 1:
        raise InstrumentFormatError(f"{path}: zip mixes formats {sorted(set(fmts))}; read the "
                                    "members one by one")
    return fmts[0], curves


# ── assembly ──────────────────────────────────────────────────────────────────────────────────


def _attr_key(key: str) -> str:
    return "meta_" + re.sub(r"[^0-9A-Za-z]+", "_", str(key)).strip("_").lower()


def _scalar(value: Any) -> float | int | str | None:
    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, int | np.integer):
        v = int(value)
        return v if -(2**31) <= v < 2**31 else float(v)
    if isinstance(value, float | np.floating):
        return float(value)
    if isinstance(value, str):
        return value
    return None


def _meta_attrs(curves: Sequence[_Curve]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    keys = dict.fromkeys(k for c in curves for k in c.metadata if k != "path")
    for key in keys:
        values = [_scalar(c.metadata.get(key)) for c in curves]
        if any(v is None for v in values):
            continue
        if all(isinstance(v, str) for v in values):
            distinct = list(dict.fromkeys(values))
            out[_attr_key(key)] = " | ".join(str(v) for v in distinct)
        elif all(not isinstance(v, str) for v in values):
            if len(set(values)) == 1:
                out[_attr_key(key)] = values[0]
            else:
                out[_attr_key(key)] = np.asarray(values, dtype=float)
    return out


def read_afmformats(path: str | Path, *, spring_constant: float | None = None,
                    sensitivity: float | None = None) -> xr.Dataset:
    """Read an Igor ``.ibw``, AFM Workshop ``.csv``, Chiaro ``.txt`` / ``.zip`` or NT-MDT ``.txt``.

    Parameters
    ----------
    path : str or Path
        The file (opened read-only, never modified).
    spring_constant : float, optional
        Cantilever spring constant [N/m]. Required for NT-MDT text (and AFM Workshop files in
        volts); recalibrates Igor and Chiaro files (force = k × deflection).
    sensitivity : float, optional
        Deflection sensitivity [m/V] (NT-MDT: the value Nova displays as nm/V, in SI). Required
        for NT-MDT text; rescales the deflection of Igor files.

    Returns
    -------
    xarray.Dataset
        Curves dataset (:func:`viscoforce.schema.make_curves`), one ``curve`` per curve in the
        file, ``attrs["source"] = "afmformats:<format>"``; see the module docstring for details.

    Raises
    ------
    InstrumentFormatError
        If the file is missing, not one of these formats, corrupt or truncated, or lacks the
        calibration it needs (NT-MDT without ``spring_constant`` / ``sensitivity``); the message
        names the file (and zip member).
    ParameterError
        If ``spring_constant`` / ``sensitivity`` is not a positive number within
        :data:`~viscoforce._limits.SPRING_CONSTANT_RANGE` / :data:`~viscoforce._limits.SENSITIVITY_RANGE`,
        or ``sensitivity`` is given for a file that measures deflection directly (Chiaro).
    EffortError
        If the file, a zip member or a zip's members together are larger than
        :data:`~viscoforce._limits.MAX_PARSED_BYTES` / ``MAX_PARSED_TOTAL_BYTES`` (checked before
        reading).
    """
    k_user = _optional_calibration("spring_constant", spring_constant, "N/m",
                                   _limits.SPRING_CONSTANT_RANGE)
    s_user = _optional_calibration("sensitivity", sensitivity, "m/V", _limits.SENSITIVITY_RANGE)
    path = Path(path)
    if not path.is_file():
        raise InstrumentFormatError(f"{path}: no such file")
    suffix = path.suffix.lower()
    if suffix not in AFMFORMATS_EXTENSIONS:
        raise InstrumentFormatError(f"{path}: extension {path.suffix!r} is not one of "
                                    f"{AFMFORMATS_EXTENSIONS}")
    size = path.stat().st_size
    if size == 0:
        raise InstrumentFormatError(f"{path}: the file is empty")
    if suffix != ".zip":
        check_effort(f"{path}: parsing the file", size, _limits.MAX_PARSED_BYTES, unit="bytes",
                     hint="afmformats parses it whole, about 16x its size in memory; raise "
                          "viscoforce._limits.MAX_PARSED_BYTES")
    fmt, curves = (_load_zip(path, k_user, s_user) if suffix == ".zip"
                   else _load_file(path, str(path), k_user, s_user, path))
    table: list[tuple[str, str]] = []
    seg_parts = []
    for c in curves:
        rows = []
        for row in c.segments:
            if row not in table:
                table.append(row)
            rows.append(table.index(row))
        seg_parts.append(np.asarray(rows, dtype=np.int32)[c.local_segment])
    per_curve: dict[str, Any] = {
        "spring_constant": [c.spring_constant for c in curves],
        "sensitivity": [c.sensitivity for c in curves],
    }
    if all(math.isfinite(c.x) and math.isfinite(c.y) for c in curves):
        per_curve["x"] = [c.x for c in curves]
        per_curve["y"] = [c.y for c in curves]
    attrs: dict[str, Any] = {"file": str(path), "n_curves": len(curves),
                             "afmformats_version": str(_afmformats().__version__),
                             "force_baseline_subtracted": 0}
    for key, value in curves[0].notes.items():
        attrs[key] = value
    attrs.update(_meta_attrs(curves))
    if fmt.startswith("chiaro") or "chiaro" in str(attrs.get("meta_instrument", "")).lower():
        attrs.update(_chiaro_tip(path))
    ds = make_curves(np.concatenate([c.time for c in curves]),
                     np.concatenate([c.force for c in curves]),
                     np.concatenate([c.height for c in curves]),
                     np.concatenate([c.deflection for c in curves]),
                     segment=np.concatenate(seg_parts),
                     segment_names=[r[0] for r in table], segment_types=[r[1] for r in table],
                     sample_count=[c.time.size for c in curves], per_curve=per_curve,
                     attrs=attrs, source=f"afmformats:{fmt}")
    return ds.assign_coords(curve=np.arange(len(curves), dtype=np.int32))


_CHIARO_TIP = re.compile(rb"Tip radius \(um\)\s+([0-9]+(?:\.[0-9]*)?(?:[eE][+-]?[0-9]+)?)")


def _chiaro_tip(path: Path) -> dict[str, Any]:
    """The spherical probe an Optics11 Chiaro header records (``Tip radius (um)``), as tip attrs.

    afmformats does not read it; the header is the first few kB of the text (or of the zip's one
    text member). Nothing when the line is absent or not a positive number.
    """
    try:
        if path.suffix.lower() == ".zip":
            with zipfile.ZipFile(path) as zf:
                members = [i for i in zf.infolist() if i.filename.lower().endswith(".txt")
                           and i.compress_type in _SAFE_COMPRESSIONS]
                if not members:
                    return {}
                with zf.open(members[0]) as handle:
                    head = handle.read(8192)
        else:
            with open(path, "rb") as handle:
                head = handle.read(8192)
    except (OSError, zipfile.BadZipFile):
        return {}
    match = _CHIARO_TIP.search(head)
    if match is None:
        return {}
    radius = float(match.group(1)) * 1e-6
    if not (math.isfinite(radius) and radius > 0):
        return {}
    return {"tip_shape": "sphere", "tip_radius": radius,
            "tip_note": "the Chiaro header's 'Tip radius (um)' (a spherical probe)"}
