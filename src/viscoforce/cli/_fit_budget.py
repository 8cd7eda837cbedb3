"""What ``fit`` adds to a single fit: the height record the data support, and the error budget.

A force curve of a file that records the tip's height twice (a calibrated sensor and the piezo's
own, ``height``) is fitted with both unless ``--height-channel`` names one: the record kept is the
one whose fit leaves the smaller residual (the same forces are fitted, so the residuals compare
directly), the output says which and why, and the other fit's values are the ``height_record``
source of the budget. Every single fit then carries its systematic budget
(:mod:`viscoforce.fitting.budget`: the calibration sources, with ``--uncertainty SOURCE=REL``
replacing the field's defaults).
"""

from __future__ import annotations

import argparse
import math
import warnings
from collections.abc import Callable
from typing import Any

from viscoforce.cli._args import UsageError
from viscoforce.exceptions import ViscoforceError

#: A record whose fit leaves a residual more than this many times the other's is settled by the
#: data (it does not describe them): it is not a systematic of the result.
SETTLED_RATIO = 2.0
#: ``--height-channel`` → the reader's height_channel (None: the first calibrated sensor).
HEIGHT_RECORDS = {"sensor": None, "piezo": "height"}


def height_channel(args: argparse.Namespace) -> str | None:
    """The reader's ``height_channel`` of ``--height-channel`` (None: the default sensor)."""
    return HEIGHT_RECORDS[args.height_channel] if getattr(args, "height_channel", None) else None


def uncertainty_type(text: str) -> tuple[str, float]:
    """``--uncertainty SOURCE=REL`` (``spring-constant=0.05``, ``tip=5%``)."""
    source, sep, value = text.partition("=")
    key = source.strip().replace("-", "_")
    try:
        rel = float(value[:-1]) / 100 if value.strip().endswith("%") else float(value)
    except ValueError:
        rel = math.nan
    if not sep or not 0.0 <= rel < 1.0:
        raise argparse.ArgumentTypeError(
            f"expected SOURCE=REL with REL a relative uncertainty in [0, 1) or a percentage "
            f"(spring-constant=0.05, tip=10%), got {text!r}")
    return key, rel


def _residual_rms(result) -> float:
    """√(χ²/(n − k)) of an unweighted curve fit [N].

    Its residuals are forces: two fits of the same forces with the same parameters compare by it.
    """
    redchi = float(result["redchi"]) if "redchi" in result else math.nan
    return math.sqrt(redchi) if redchi >= 0 else math.nan


def choose_height_record(args: argparse.Namespace, ds, kind: str, result,
                         fit: Callable[[argparse.Namespace, Any, str], Any],
                         read: Callable[..., Any]):
    """(result kept, the other record's result or None, a sentence) for a force curve.

    The other record's result is None where its residual is more than :data:`SETTLED_RATIO`
    times the kept one's: the data settle the choice.

    Only where ``--height-channel`` is not given, the data are curves, and the file has both a
    sensor and the piezo height: otherwise ``(result, None, "")``.
    """
    used = str(ds.attrs.get("height_channel", ""))
    if kind != "curves" or getattr(args, "height_channel", None) or not used:
        return result, None, ""
    other = "height" if used != "height" else None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            alt_ds = read(args.data, args.format, height_channel=other)
            if args.curve is not None and "curve" in alt_ds.dims:
                from viscoforce.schema import select_curve

                alt_ds = select_curve(alt_ds, args.curve)
            if str(alt_ds.attrs.get("height_channel", "")) == used:
                return result, None, ""
            alt = fit(args, alt_ds, kind)
    except (UsageError, ViscoforceError, OSError, ValueError):  # no second record: no choice
        return result, None, ""
    name = str(alt_ds.attrs.get("height_channel", other))
    a, b = _residual_rms(result), _residual_rms(alt)
    if not (math.isfinite(a) and math.isfinite(b)):
        return result, None, ""
    keep_alt = b < a
    kept, dropped = (alt, result) if keep_alt else (result, alt)
    kept_name, dropped_name = (name, used) if keep_alt else (used, name)
    unit = next((str(kept[v].attrs.get("units", "")) for v in kept.data_vars
                 if str(v).startswith("fit_")), "")
    ratio = max(a, b) / min(a, b) if min(a, b) > 0 else math.inf
    why = (f"height record {_label(kept_name)}: its fit leaves a residual rms of "
           f"{min(a, b):.3g} {unit} against {max(a, b):.3g} {unit} with "
           f"{_label(dropped_name)}").replace("  ", " ")
    if ratio > SETTLED_RATIO:  # the data settle the choice: not a systematic of these data
        why += (f" ({ratio:.3g}x larger: the data settle the choice, it is not in the error "
                "budget; --height-channel sensor|piezo to choose)")
        dropped = None
    else:
        why += (" (the data do not settle the choice: the other record's values are in the "
                "error budget; --height-channel sensor|piezo to choose)")
    kept.attrs["height_record"] = why
    return kept, dropped, why


def phase_reference_alternative(args: argparse.Namespace, ds, kind: str, result,
                                fit: Callable[[argparse.Namespace, Any, str], Any],
                                read: Callable[..., Any]):
    """(the sensor-phase fit or None, a sentence) of a spectrum referred to the piezo by default.

    Where the data's phase reference was chosen by the data (``delay`` or ``piezo``, no
    ``--phase-reference``), the spectrum is made again against the sensor's own phase and refitted:
    its values are the ``phase_reference`` source of the budget, unless its reduced χ² is more than
    :data:`SETTLED_RATIO` times the kept one's (the data settle the choice).
    """
    mode = str(ds.attrs.get("phase_reference_mode", ""))
    if kind != "spectrum" or getattr(args, "phase_reference", None) is not None or mode not in (
            "delay", "piezo"):
        return None, ""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            alt_ds = read(args.data, args.format, phase_reference="sensor")
            if args.curve is not None and "curve" in alt_ds.dims:
                from viscoforce.cli._fit_inputs import _select_curve

                alt_ds = _select_curve(alt_ds, kind, args.curve)
            alt = fit(args, alt_ds, kind)
    except (UsageError, ViscoforceError, OSError, ValueError):  # no sensor spectrum: no source
        return None, ""
    a = float(result["redchi"]) if "redchi" in result else math.nan
    b = float(alt["redchi"]) if "redchi" in alt else math.nan
    if not (math.isfinite(a) and math.isfinite(b) and a > 0):
        return None, ""
    why = (f"phase reference {mode} (the default where the data show the sensor's lag) against "
           f"the sensor's own phase: reduced chi-square {a:.3g} against {b:.3g}")
    if b > SETTLED_RATIO * a:
        return None, why + " (the data settle the choice: not in the error budget)"
    return alt, why + " (the sensor-phase fit's values are in the error budget)"


def _label(channel: str) -> str:
    return f"piezo ({channel})" if channel == "height" else f"sensor ({channel})"


def with_budget(args: argparse.Namespace, result, alternatives: dict[str, Any] | None = None,
                descriptions: dict[str, str] | None = None):
    """The single fit with its systematic budget (:func:`viscoforce.fitting.budget.add_budget`)."""
    from viscoforce.exceptions import ParameterError
    from viscoforce.fitting.budget import (
        add_budget,
        alternative_shifts,
        calibration_descriptions,
        calibration_shifts,
    )

    given = dict(getattr(args, "uncertainty", None) or [])
    try:
        shifts = calibration_shifts(result, given)
        text = calibration_descriptions(given)
    except ParameterError as exc:
        raise UsageError(f"--uncertainty: {exc}") from None
    for source, other in (alternatives or {}).items():
        if other is not None:
            shifts[source] = alternative_shifts(result, other)
            text[source] = (descriptions or {}).get(source, source)
    return add_budget(result, shifts, text)


def with_map_budget(args: argparse.Namespace, result, fixed: dict[str, Any]):
    """A map's fit result with its tip recorded and its calibration budget per pixel."""
    from viscoforce.exceptions import ParameterError
    from viscoforce.fitting.budget import add_map_budget
    from viscoforce.physics.tips import tip_from

    tip = fixed.get("tip")
    if tip is not None and "tip_shape" not in result.attrs:
        tip = tip_from(tip)
        result = result.assign_attrs(**tip.as_attrs(), tip=tip.describe())
    elif fixed.get("radius") is not None and "tip_shape" not in result.attrs:
        result = result.assign_attrs(tip_shape="paraboloid", tip_radius=float(fixed["radius"]))
    try:
        return add_map_budget(result, dict(getattr(args, "uncertainty", None) or []))
    except ParameterError as exc:
        raise UsageError(f"--uncertainty: {exc}") from None


def budget_json(result, params: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """``params.<name>.systematic`` {source: shift}, ``interval``, ``determined``; the notes."""
    if "budget_source" not in result.coords:
        return {}
    sources = [str(s) for s in result["budget_source"].values]
    for name, entry in params.items():
        if f"{name}_systematic" not in result:
            continue
        row = result[f"{name}_systematic"].values
        entry["systematic"] = {s: float(v) for s, v in zip(sources, row, strict=True)}
        entry["interval"] = [float(result[f"{name}_budget_lower"]),
                             float(result[f"{name}_budget_upper"])]
        entry["determined"] = bool(int(result[f"{name}_budget_determined"]))
    notes = str(result.attrs.get("budget_notes", "none"))
    return {"budget_sources": str(result.attrs.get("budget_sources", "")),
            "budget_notes": [] if notes == "none" else notes.split(" | ")}
