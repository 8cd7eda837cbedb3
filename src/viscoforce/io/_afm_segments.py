"""Segments of an afmformats curve: the Igor wave note, or its segment column (:mod:`viscoforce.io.afm`).

An Igor binary wave's note gives its segments (``Indexes``) and their directions (``Direction``:
1 → approach, −1 → retract, 0 → pause), read with igor2 (afmformats' own dependency, imported on
first use); without a usable note the curve is split after its lowest height. Other formats take
afmformats' ``segment`` column (0 → approach, 1 → retract).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np


def _igor_segments(path: Path, n: int) -> list[tuple[int, int, float]] | None:
    """(start, stop, direction) per segment from the Igor wave note, or None if unusable."""
    from igor2 import binarywave  # afmformats' own dependency

    note = binarywave.load(str(path))["wave"]["note"]
    if isinstance(note, bytes):
        note = note.decode("latin-1")
    fields: dict[str, str] = {}
    for line in re.split(r"\r\n|\r|\n", str(note)):
        key, sep, value = line.partition(":")
        if sep:
            fields[key.strip()] = value.strip()
    try:
        indexes = [int(float(v)) for v in fields["Indexes"].split(",") if v.strip()]
        directions = [float(v) for v in fields["Direction"].split(",") if v.strip()]
    except (KeyError, ValueError):
        return None
    if (len(indexes) < 2 or len(directions) < len(indexes) or indexes[0] != 0
            or indexes[-1] != n - 1 or np.any(np.diff(indexes) <= 0)):
        return None
    bounds = [0] + [i + 1 for i in indexes[1:]]
    return [(bounds[k], bounds[k + 1], directions[k + 1]) for k in range(len(bounds) - 1)]


def _segments(kind: str, path: Path, data: Any, n: int, height: np.ndarray,
              notes: dict[str, str]) -> tuple[list[tuple[str, str]], np.ndarray]:
    local = np.zeros(n, dtype=np.int32)
    if kind == "igor":
        parts = _igor_segments(path, n)
        if parts is None:
            split = int(np.argmin(height)) + 1
            notes["segments_from"] = "split after the lowest height (the note has no Indexes)"
            local[split:] = 1
            return [("approach", "extend"), ("retract", "retract")], local
        notes["segments_from"] = "wave note Indexes and Direction"
        table: list[tuple[str, str]] = []
        for start, stop, direction in parts:
            row = (("approach", "extend") if direction > 0 else ("retract", "retract")
                   if direction < 0 else ("pause", "dwell"))
            if row not in table:
                table.append(row)
            local[start:stop] = table.index(row)
        return table, local
    raw = np.asarray(data["segment"]).astype(np.int64)
    labels = {0: ("approach", "afmformats segment 0 (approach)"),
              1: ("retract", "afmformats segment 1 (retract)")}
    table = []
    for value in np.unique(raw):
        row = labels.get(int(value), ("other", f"afmformats segment {int(value)}"))
        table.append(row)
        local[raw == value] = len(table) - 1
    notes["segments_from"] = "afmformats segment column"
    return table, local
