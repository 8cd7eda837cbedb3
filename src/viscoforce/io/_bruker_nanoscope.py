"""Bruker Nanoscope binary files, recognised and refused (the Nanoscope part of :mod:`viscoforce.io.bruker`).

:func:`detect_nanoscope` recognises a Nanoscope file by its header; :func:`refuse_nanoscope` reads
the few header values it quotes (version, operating mode, spring constant, sensitivity) and raises
an :class:`~viscoforce.exceptions.InstrumentFormatError` that says what would read the curve. Why
viscoforce does not parse the Nanoscope binary: see :mod:`viscoforce.io.bruker`.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, NoReturn

from viscoforce._validation import require_path
from viscoforce.exceptions import InstrumentFormatError

_HEAD = 4096
_NANOSCOPE_MAGIC = (b"\\*Force file list", b"\\*File list", b"\\*EC File list")


def _head(path: Path, size: int = _HEAD) -> bytes:
    try:
        with path.open("rb") as fh:
            return fh.read(size)
    except OSError:
        return b""


# ── Nanoscope binary: recognised, refused ──────────────────────────────────────────────────────


def detect_nanoscope(path: str | Path) -> bool:
    r"""True if ``path`` starts like a Bruker Nanoscope file (``\*Force file list``, ``\*File list``).

    Never raises (an unreadable file gives False).
    """
    head = _head(Path(path), 64).removeprefix(b"\xef\xbb\xbf")
    return head.startswith(_NANOSCOPE_MAGIC)


def _nanoscope_header(path: Path) -> dict[str, str]:
    """The few header values the refusal quotes (version, mode, spring constant, sensitivity)."""
    wanted = {"\\Version:": "version", "\\Operating mode:": "mode",
              "\\Spring Constant:": "spring_constant", "\\@Sens. DeflSens:": "deflection_sens"}
    found: dict[str, str] = {}
    try:
        with path.open("rb") as fh:
            for _ in range(5000):
                raw = fh.readline()
                if not raw:
                    break
                line = raw.decode("latin-1").strip()
                if line.startswith("\\*File list end"):
                    break
                for prefix, key in wanted.items():
                    if line.startswith(prefix) and key not in found:
                        found[key] = line[len(prefix):].strip()
    except OSError:
        pass
    return found


def _number(text: str) -> float | None:
    match = re.search(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?", text)
    return float(match.group(0)) if match else None


def refuse_nanoscope(path: str | Path, *, spring_constant: Any = None,
                     sensitivity: Any = None) -> NoReturn:
    """Raise: viscoforce does not read Nanoscope binary files; the message says what would.

    Parameters
    ----------
    path : str or Path
        A Bruker Nanoscope file (``.spm``, ``.000`` …); only its text header is read.
    spring_constant, sensitivity : optional
        Accepted (so that ``load --spring-constant …`` reaches this message) and not used.

    Raises
    ------
    InstrumentFormatError
        Always: names the file, what it is (header version, operating mode), why it is not read
        and how to load the curve (a text export, or a UFF text file).
    """
    del spring_constant, sensitivity  # the refusal does not depend on them
    path = require_path("path", path)
    header = _nanoscope_header(path)
    first = _head(path, 64).removeprefix(b"\xef\xbb\xbf").split(b"\r")[0].split(b"\n")[0]
    what = [f"'{first.decode('latin-1')}'"]
    if "version" in header:
        what.append(f"version {header['version']}")
    if "mode" in header:
        what.append(f"operating mode {header['mode']}")
    calibration = []
    k = _number(header.get("spring_constant", ""))
    if k is not None:
        calibration.append(f"--spring-constant {k:g}N/m")
    s = _number(header.get("deflection_sens", ""))
    if s is not None:
        calibration.append(f"--sensitivity {s:g}nm/V")
    flags = (f" with the header's calibration, {' '.join(calibration)}" if calibration
             else " with --spring-constant and --sensitivity")
    raise InstrumentFormatError(
        f"{path}: Bruker Nanoscope binary file ({', '.join(what)}): viscoforce does not read "
        "Nanoscope binary data, because no maintained, permissively licensed Python package "
        "reads calibrated Nanoscope force curves (afmformats, MIT, has no Bruker format; "
        "pyfmreader 0.1.3, MIT, reads them but has had no release since July 2023 and subtracts "
        "a baseline while reading; Bruker's own 'nanoscope' package runs on Windows only). To load "
        "the curve, export it from NanoScope Analysis as ASCII text with 'name (unit)' column "
        "headers, e.g. 'time (s),height (nm),deflection (V)', and load that as format csv-curves"
        f"{flags}; or load a UFF text export (.uff) of the curve (format uff)")
