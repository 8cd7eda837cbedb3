"""The afmformats formats recognised by content; afmformats' errors translated (:mod:`viscoforce.io.afm`).

Which format a file's first bytes are (:func:`_kind_of`: Igor ``.ibw``, AFM Workshop ``.csv``,
Chiaro or NT-MDT ``.txt``), the members of a zip that are read (:func:`_zip_members`, only
stored, deflate and LZMA members: :data:`_SAFE_COMPRESSIONS`) and a member's first bytes; the
afmformats package imported on first use (:func:`_afmformats`, so that importing viscoforce does
not import it) and its ``BaseException``-derived errors, with the ordinary errors its parsers
raise on broken input, re-raised as :class:`~viscoforce.exceptions.InstrumentFormatError`
(:func:`_translated`).
"""

from __future__ import annotations

import logging
import re
import shlex
import struct
import zipfile
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from viscoforce.exceptions import InstrumentFormatError, ViscoforceError

_MEMBER_EXTENSIONS = (".ibw", ".csv", ".txt")
_HEAD = 65536
#: zip compressions read: zipfile decompresses a bzip2 read whole, without an output limit (a few
#: kB of bzip2 can expand to gigabytes), so bzip2 members are refused
_SAFE_COMPRESSIONS = (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED, zipfile.ZIP_LZMA)
_IGOR_VERSIONS = (1, 2, 3, 5)
_NUMBER = re.compile(r"^[+-]?(\d+([.,]\d*)?|[.,]\d+)([eE][+-]?\d+)?$")
_MAKER_NTMDT = "NT-MDT Spectrum Instruments"
_MAKER_WORKSHOP = "AFM workshop"
_MAKER_IGOR = "Asylum Research"
_MAKER_CHIARO = "Optics11 Life"
#: errors the afmformats parsers (numpy.loadtxt, igor2, zipfile, its own asserts) raise on bad input
_PARSE_ERRORS = (ValueError, TypeError, KeyError, IndexError, AssertionError, AttributeError,
                 ArithmeticError,
                 OSError, EOFError, UnicodeError, struct.error, zipfile.BadZipFile, zlib.error)
#: The calibrations a file may lack: (reader argument [unit], load flag, example value).
_CALIBRATION_FLAGS = {"spring_constant": ("spring_constant [N/m]", "--spring-constant K", "K",
                                          "0.1N/m"),
                      "sensitivity": ("sensitivity [m/V]", "--sensitivity S", "S", "50nm/V")}


def calibration_hint(file: str | Path,
                     names: tuple[str, ...] = ("spring_constant", "sensitivity")) -> str:
    """How to give ``file`` the calibration ``names`` it lacks, as a sentence for an error.

    The reader's arguments, and the command-line route that takes them: they are flags of
    ``load`` (not of ``fit``), so the route is ``viscoforce load FILE --spring-constant K
    --sensitivity S --out curves.nc``, then ``viscoforce fit curves.nc ...``. ``file`` is quoted
    for a shell where it needs it.
    """
    rows = [_CALIBRATION_FLAGS[n] for n in names]
    arguments = " and ".join(r[0] for r in rows)
    flags = " ".join(r[1] for r in rows)
    values = " and ".join(r[2] for r in rows)
    examples = " and ".join(r[3] for r in rows)
    these = "these are `load` flags" if len(rows) > 1 else "it is a `load` flag"
    return (f"pass {arguments} to the reader; on the command line {these}: run `viscoforce "
            f"load {shlex.quote(str(file))} {flags} --out curves.nc` ({values}: your "
            f"cantilever's, e.g. {examples}), then `viscoforce fit curves.nc ...`")


# ── detection ─────────────────────────────────────────────────────────────────────────────────


def _kind_of(suffix: str, head: bytes) -> str | None:
    """Which afmformats format ``head`` (the first bytes of a file named ``*suffix``) is, or None."""
    suffix = suffix.lower()
    if suffix == ".ibw":
        if len(head) < 64:
            return None
        le, be = struct.unpack("<h", head[:2])[0], struct.unpack(">h", head[:2])[0]
        return "igor" if le in _IGOR_VERSIONS or be in _IGOR_VERSIONS else None
    text = head.decode("latin-1")
    if suffix == ".csv":
        first = text.lstrip("\ufeff\xef\xbb\xbf").splitlines()[:1]
        return "workshop" if first and first[0].strip() == "Force-Distance Curve" else None
    if suffix == ".txt":
        if "Device:\tChiaro" in text:
            return "chiaro"
        lines = [ln for ln in text.splitlines() if ln.strip()]
        if len(head) == _HEAD and lines:
            lines = lines[:-1]  # the last line may be cut
        lines = lines[:10]
        if lines and all(len(tok := ln.split()) == 3 and all(_NUMBER.match(t) for t in tok)
                         for ln in lines):
            return "ntmdt"
    return None


def _zip_members(zf: zipfile.ZipFile) -> list[zipfile.ZipInfo]:
    return [info for info in zf.infolist()
            if not info.is_dir() and Path(info.filename).suffix.lower() in _MEMBER_EXTENSIONS
            and not info.filename.startswith("__MACOSX/")
            and not Path(info.filename).name.startswith(".")]


def _read_head(zf: zipfile.ZipFile, info: zipfile.ZipInfo) -> bytes:
    if info.compress_type not in _SAFE_COMPRESSIONS:
        return b""
    with zf.open(info) as fh:
        return fh.read(_HEAD)


def _afmformats():
    try:
        import afmformats
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise InstrumentFormatError("reading Igor/AFM Workshop/Chiaro/NT-MDT files needs the "
                                    "afmformats package: pip install afmformats") from exc
    for name in ("afmformats", "igor2"):
        # afmformats logs a traceback (logger.exception) and igor2 an error with the raw bytes
        # before raising on a broken file; with no handler configured, logging's last resort
        # would print them on stderr although we raise a clean InstrumentFormatError. Records
        # still propagate to the application's own handlers.
        logger = logging.getLogger(name)
        if not logger.handlers:
            logger.addHandler(logging.NullHandler())
    return afmformats


@contextmanager
def _translated(where: str, file: str | Path | None = None) -> Iterator[None]:
    """Turn afmformats' BaseException-derived errors and parser errors into InstrumentFormatError.

    ``file`` is the file the caller gave (a zip for one of its members; default ``where``), which
    a missing calibration's hint tells to ``viscoforce load``.
    """
    afmformats = _afmformats()
    errors = afmformats.errors
    try:
        yield
    except ViscoforceError:
        raise
    except errors.MissingMetaDataError as exc:
        keys = " and ".join(getattr(exc, "meta_keys", []) or ["calibration"])
        raise InstrumentFormatError(f"{where}: the file lacks the {keys}; "
                                    f"{calibration_hint(where if file is None else file)}"
                                    ) from None
    except errors.FileFormatNotSupportedError as exc:
        raise InstrumentFormatError(f"{where}: not a file afmformats can read ({exc})") from None
    except errors.AFMFileFormatError as exc:
        raise InstrumentFormatError(f"{where}: corrupt or unsupported file: "
                                    f"{type(exc).__name__}: {exc}") from None
    except _PARSE_ERRORS as exc:
        raise InstrumentFormatError(f"{where}: corrupt, truncated or unexpected content "
                                    f"({type(exc).__name__}: {exc})") from None
