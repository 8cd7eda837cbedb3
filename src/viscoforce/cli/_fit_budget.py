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
import copy
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from viscoforce.cli._args import UsageError
from viscoforce.cli._fit_report import recorded
from viscoforce.exceptions import ViscoforceError

#: A record whose fit leaves a residual more than this many times the other's is settled by the
#: data (it does not describe them): it is not a systematic of the result.
SETTLED_RATIO = 2.0
#: Half-width [m] of the window a contact point is held in where its model has no fixed input.
HELD = 1e-12
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


@dataclass
class Kept:
    """The fit kept and what belongs to it: its data, its warnings (texts and records)."""

    result: Any
    data: Any
    texts: list[str] = field(default_factory=list)
    caught: list[Any] = field(default_factory=list)


def _quiet(fit: Callable[..., Any], *args: Any) -> Any:
    """A refit of the budget, its warnings not shown; None where it fails on the data."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return fit(*args)
    except (UsageError, ViscoforceError, ValueError):  # the refit fails: no source
        return None


def choose_height_record(args: argparse.Namespace, kept: Kept, kind: str,
                         fit: Callable[[argparse.Namespace, Any, str], Any],
                         read: Callable[..., Any]) -> tuple[Kept, Any, str]:
    """(the fit kept, the other record's result or None, a sentence) for a force curve.

    The other record's result is None where its residual is more than :data:`SETTLED_RATIO`
    times the kept one's: the data settle the choice.

    Only where ``--height-channel`` is not given, the data are curves, and the file has both a
    sensor and the piezo height: otherwise ``(kept, None, "")``.
    """
    ds, result = kept.data, kept.result
    used = str(ds.attrs.get("height_channel", ""))
    if kind != "curves" or getattr(args, "height_channel", None) or not used:
        return kept, None, ""
    other = "height" if used != "height" else None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            alt_ds = read(args.data, args.format, height_channel=other)
            if args.curve is not None and "curve" in alt_ds.dims:
                from viscoforce.schema import select_curve

                alt_ds = select_curve(alt_ds, args.curve)
            if str(alt_ds.attrs.get("height_channel", "")) == used:
                return kept, None, ""
        alt, alt_texts, alt_caught = recorded(fit, args, alt_ds, kind)
    except (UsageError, ViscoforceError, OSError, ValueError):  # no second record: no choice
        return kept, None, ""
    name = str(alt_ds.attrs.get("height_channel", other))
    a, b = _residual_rms(result), _residual_rms(alt)
    if not (math.isfinite(a) and math.isfinite(b)):
        return kept, None, ""
    keep_alt = b < a
    if keep_alt:
        kept, dropped = Kept(alt, alt_ds, alt_texts, alt_caught), result
    else:
        dropped = alt
    kept_name, dropped_name = (name, used) if keep_alt else (used, name)
    unit = next((str(kept.result[v].attrs.get("units", "")) for v in kept.result.data_vars
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
    kept.result.attrs["height_record"] = why
    return kept, dropped, why


def _same_modes(args: argparse.Namespace, result) -> argparse.Namespace:
    """A copy of ``args`` whose refits keep the fit's number of modes (``--modes auto`` fixed)."""
    out = copy.copy(args)
    if getattr(args, "modes", None) == "auto" and "modes" in result.attrs:
        out.modes = int(result.attrs["modes"])
    return out


def choice_alternatives(args: argparse.Namespace, kept: Kept, kind: str,
                        fit: Callable[[argparse.Namespace, Any, str], Any]
                        ) -> tuple[dict[str, Any], dict[str, str]]:
    """The refits of the fit window, the contact point method and the sample height.

    ({source: the refit's result}, {source: a sentence}); a source is left out where its refit
    cannot be made (too few points left, no contact rise found, the refit fails) or where the
    data settle it (a contact point held at the rise that leaves more than
    :data:`SETTLED_RATIO` times the fitted one's residual).
    """
    from viscoforce.fitting.budget import CALIBRATION_DEFAULTS
    from viscoforce.fitting.budget_choices import (
        depth_range_alternative,
        narrowed_window,
        other_contact_point,
    )

    data, result = kept.data, kept.result
    base = _same_modes(args, result)
    alts: dict[str, Any] = {}
    text: dict[str, str] = {}
    narrowed = depth_range_alternative(result)
    if narrowed is not None:
        alts["fit_window"], text["fit_window"] = narrowed
    else:
        narrowed = narrowed_window(data, result, kind)
    if narrowed is not None and "fit_window" not in alts:
        alt = _quiet(fit, base, narrowed[0], kind)
        if alt is not None:
            alts["fit_window"], text["fit_window"] = alt, narrowed[1]
    if kind == "curves" and getattr(args, "contact_point", None) is None and args.model in (
            "ting", "hertz"):
        other = other_contact_point(data, result)
        if other is not None:
            held = copy.copy(base)
            if args.model == "hertz":  # held in a window a picometre wide
                held.contact_window = (other[0] - HELD, other[0] + HELD)
            else:
                held.contact_point = other[0]
            alt = _quiet(fit, held, data, kind)
            a, b = _residual_rms(result), _residual_rms(alt) if alt is not None else math.nan
            if alt is not None and math.isfinite(b) and b <= SETTLED_RATIO * a:
                alts["contact_point"], text["contact_point"] = alt, other[1]
            elif alt is not None:
                text["contact_point"] = other[1] + (
                    f" (its residual rms {b:.3g} against {a:.3g}: the data settle the choice, "
                    "not in the error budget)")
    height = getattr(args, "sample_height", None)
    if height is not None:
        given = dict(getattr(args, "uncertainty", None) or [])
        rel = given.get("sample_height", CALIBRATION_DEFAULTS["sample_height"][0])
        thicker = copy.copy(base)
        thicker.sample_height = height * (1.0 + rel)
        alt = _quiet(fit, thicker, data, kind) if rel > 0 else None
        if alt is not None:
            alts["sample_height"] = alt
            text["sample_height"] = f"+-{100 * rel:.3g} %" + (
                " (given)" if "sample_height" in given else
                f" ({CALIBRATION_DEFAULTS['sample_height'][1]})")
    return alts, text


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
            alt_ds = sensor_phase_data(ds)
            if alt_ds is None:  # a spectrum without the sensor's phase: made again
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


def sensor_phase_data(ds):
    """The spectrum against the sensor's own phase, from the variables it carries, or None.

    A spectrum referred to the piezo or a fitted delay keeps the same points against the
    sensor (``stiffness_sensor``, ``phase_sensor`` and their stderr): the phase reference's
    alternative without reading and demodulating the file again.
    """
    names = ("stiffness", "phase", "drive_amplitude")
    if not all(f"{n}_sensor" in ds for n in names):
        return None
    out = ds.copy()
    for n in names:
        out[n] = ds[f"{n}_sensor"].assign_attrs(ds[n].attrs)
        if f"{n}_stderr" in ds and f"{n}_sensor_stderr" in ds:
            out[f"{n}_stderr"] = ds[f"{n}_sensor_stderr"].assign_attrs(ds[f"{n}_stderr"].attrs)
    for n in ("stiffness", "phase", "drive_amplitude"):
        out = out.drop_vars([f"{n}_sensor", f"{n}_sensor_stderr"], errors="ignore")
    return out.assign_attrs(phase_reference_mode="sensor",
                            phase_reference="sensor (the budget's alternative)")


def _label(channel: str) -> str:
    return f"piezo ({channel})" if channel == "height" else f"sensor ({channel})"


def budgeted(args: argparse.Namespace, kept: Kept, kind: str,
             fit: Callable[[argparse.Namespace, Any, str], Any], read: Callable[..., Any]
             ) -> tuple[Kept, Any, str]:
    """(the fit kept, its result with the budget, the height record's sentence) of a single fit.

    ``--budget full`` (default): the height record chosen (:func:`choose_height_record`), the
    phase reference, fit window, contact point and sample height refitted the other way
    (:func:`phase_reference_alternative`, :func:`choice_alternatives`), then the calibration
    sources; ``--budget calibration``: those alone, no refit.
    """
    other, why, phase, phase_why, alternatives, described = None, "", None, "", {}, {}
    if getattr(args, "budget", "full") == "full":
        kept, other, why = choose_height_record(args, kept, kind, fit, read)
        phase, phase_why = phase_reference_alternative(args, kept.data, kind, kept.result,
                                                       fit, read)
        alternatives, described = choice_alternatives(args, kept, kind, fit)
    result = with_budget(args, kept.result, {"height_record": other, "phase_reference": phase,
                                             **alternatives},
                         {"height_record": why, "phase_reference": phase_why, **described})
    free = described.get("fit_window", "").startswith("the depth range")  # the depth check's
    result.attrs["budget_refits"] = int((other is not None) + (phase is not None) - free
                                        + sum(1 for v in alternatives.values() if v is not None))
    if phase_why:
        result.attrs["phase_reference_budget"] = phase_why
    for source in ("fit_window", "contact_point", "sample_height"):
        if source in described and source not in alternatives:  # settled: said, not counted
            result.attrs[f"{source}_budget"] = described[source]
    return kept, result, why


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


def map_alternatives(args: argparse.Namespace, ds, kind: str, result,
                     fit: Callable[[Any], Any], read: Callable[..., Any]
                     ) -> tuple[Any, dict[str, Any], dict[str, str]]:
    """(the map kept, {source: shift per pixel}, {source: a sentence}) of a map's choices.

    The height record or the phase reference (:func:`_map_record_or_phase`), and a Hertz map's
    depth range: each pixel's depth check (E refitted up to 50 % of the maximum contact force)
    is its ``fit_window`` shift, with no refit.
    """
    result, shifts, text = _map_record_or_phase(args, ds, kind, result, fit, read)
    if getattr(args, "budget", "full") == "full" and "depth_check_relative" in result and (
            "E" in result):
        rel = result["depth_check_relative"]
        shifts["fit_window"] = {n: result[n] * rel for n in result.data_vars
                                if n == "E" or n in ("E_young", "E_shear")}
        text["fit_window"] = ("the depth range: each pixel's E refitted up to 50 % of its "
                              "maximum contact force (its depth check)")
    return result, shifts, text


def _map_record_or_phase(args: argparse.Namespace, ds, kind: str, result,
                         fit: Callable[[Any], Any], read: Callable[..., Any]
                         ) -> tuple[Any, dict[str, Any], dict[str, str]]:
    """(the map kept, {source: shift per pixel}, {source: a sentence}) of the map's record.

    The height record of a curves map (no ``--height-channel``): the map is fitted with the
    other record too, the record whose fits leave the smaller median residual is kept, and the
    other's values are the ``height_record`` shift on the pixels where the residuals are within
    :data:`SETTLED_RATIO` of each other (elsewhere the pixel's data settle it). The phase
    reference of a spectrum map referred to the piezo or a fitted delay (no
    ``--phase-reference``): refitted against the sensor's own phase, the shift where its reduced
    χ² is within :data:`SETTLED_RATIO` times the kept one's.
    """
    import numpy as np

    from viscoforce.fitting.budget import alternative_shifts

    if getattr(args, "budget", "full") != "full" or "redchi" not in result:
        return result, {}, {}
    if kind == "curves" and not getattr(args, "height_channel", None) and ds.attrs.get(
            "height_channel"):
        used = str(ds.attrs["height_channel"])
        other = "height" if used != "height" else None
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                alt_ds = read(args.data, args.format, height_channel=other)
        except (UsageError, ViscoforceError, OSError, ValueError):
            return result, {}, {}
        name = str(alt_ds.attrs.get("height_channel", ""))
        alt = _quiet(fit, alt_ds) if name and name != used else None
        if alt is None or "redchi" not in alt:
            return result, {}, {}
        rms_a, rms_b = np.sqrt(result["redchi"]), np.sqrt(alt["redchi"])
        med_a, med_b = float(rms_a.median()), float(rms_b.median())
        if med_b < med_a:
            result, alt, used, name = alt, result, name, used
            rms_a, rms_b, med_a, med_b = rms_b, rms_a, med_b, med_a
        ratio = np.maximum(rms_a, rms_b) / np.minimum(rms_a, rms_b)
        open_ = (ratio <= SETTLED_RATIO).drop_vars(list(ratio.coords), errors="ignore")
        n, m = int(result["redchi"].notnull().sum()), int(open_.sum())
        why = (f"height record {_label(used)} kept: its fits leave a median residual rms of "
               f"{med_a:.3g} N against {med_b:.3g} N with {_label(name)}; the other record's "
               f"values are in the error budget on the {m} of {n} pixels whose residuals are "
               f"within {SETTLED_RATIO:g}x of each other (--height-channel sensor|piezo to "
               "choose)")
        result = result.assign_attrs(height_record=why)
        shifts = alternative_shifts(result, alt, where=open_.values)
        return result, ({"height_record": shifts} if m else {}), {"height_record": why}
    mode = str(ds.attrs.get("phase_reference_mode", ""))
    if kind == "spectrum" and getattr(args, "phase_reference", None) is None and mode in (
            "delay", "piezo"):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                alt_ds = sensor_phase_data(ds)
                if alt_ds is None:
                    alt_ds = read(args.data, args.format, phase_reference="sensor")
        except (UsageError, ViscoforceError, OSError, ValueError):
            return result, {}, {}
        alt = _quiet(fit, alt_ds)
        if alt is None or "redchi" not in alt:
            return result, {}, {}
        open_ = (alt["redchi"] <= SETTLED_RATIO * result["redchi"])
        n, m = int(result["redchi"].notnull().sum()), int(open_.sum())
        why = (f"phase reference {mode} (the default where the data show the sensor's lag) "
               f"against the sensor's own phase: median reduced chi-square "
               f"{float(result['redchi'].median()):.3g} against "
               f"{float(alt['redchi'].median()):.3g}; the sensor-phase values are in the error "
               f"budget on the {m} of {n} pixels where its reduced chi-square is within "
               f"{SETTLED_RATIO:g}x")
        result = result.assign_attrs(phase_reference_budget=why)
        shifts = alternative_shifts(result, alt, where=open_.values)
        return result, ({"phase_reference": shifts} if m else {}), {"phase_reference": why}
    return result, {}, {}


def with_map_budget(args: argparse.Namespace, result, fixed: dict[str, Any],
                    alternatives: dict[str, Any] | None = None,
                    descriptions: dict[str, str] | None = None):
    """A map's fit result with its tip recorded and its budget per pixel."""
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
        return add_map_budget(result, dict(getattr(args, "uncertainty", None) or []),
                              alternatives, descriptions)
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
            "budget_refits": int(result.attrs.get("budget_refits", 0)),
            "budget_notes": [] if notes == "none" else notes.split(" | ")}
