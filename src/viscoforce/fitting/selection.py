"""Choosing among fits by an information criterion: the one loop, the ΔBIC rule, one explanation.

Every chooser that compares fits by BIC or AIC ends here: ``modes="auto"`` of any model with
several modes (:func:`viscoforce.fitting.fit.select`, the ``ting`` fit) and the measured-data
chooser of ``model="auto"`` (contact materials compared,
:mod:`viscoforce.fitting.measured`). Each hands :func:`compare` its candidates as *families*
— lists of models in order of size (1, 2, 3 … modes) — and :func:`keep` applies the rule;
:func:`explain` returns the :class:`~viscoforce.choice.Choice` every chooser of the project
returns (the theory chooser's, by estimated model error, included: :func:`viscoforce.choice.finish`).

The loop (:func:`compare`): a family grows while its criterion improves, and stops

- when the criterion has not improved on the family's best twice in a row;
- when the next model's parameters would leave fewer than ``min_dof`` degrees of freedom in the
  data (a note says so; a single candidate is fitted anyway, and
  :func:`~viscoforce.fitting.outcome.fit_once` refuses it when the data are too few);
- at a fit that fails (``on_failure="stop"``; the first fit failing raises) or, with
  ``on_failure="skip"``, after noting it and going on.

When more than one candidate is compared each fit tries all its starts (``settle=False`` of
:func:`~viscoforce.fitting.outcome.fit_once`: the choice rests on differences in χ²). Curve fits
share one effective sample size (:func:`share_effective_size`) so that their criteria stay
comparable.

The rule (:func:`keep`): the candidate with the lowest criterion is the best; the one kept is the
SIMPLEST (fewest free parameters, then the lowest criterion) within ``margin`` of the best. The
modes choosers use margin 0 (the lowest criterion); the measured-data chooser ΔBIC 6 ("strong"
evidence on the Kass–Raftery scale).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from viscoforce.choice import Choice
from viscoforce.exceptions import ConvergenceError, ParameterError
from viscoforce.fitting.data import FitData
from viscoforce.fitting.outcome import Outcome, fit_once

__all__ = ["CRITERIA", "HALVES_Z", "Candidate", "Tried", "block_halves", "block_length", "check_criterion",
           "compare", "explain", "halves_z", "keep", "mode_robustness", "share_effective_size"]

#: Information criteria a chooser compares by.
CRITERIA = ("bic", "aic")
#: A time moving more than this many standard errors (of the difference) between the two halves
#: of the data is not robust (a 2σ rule: 5 % false alarms per time for honest Gaussian stderr).
HALVES_Z = 2.0
#: Fewest blocks of the block split-half (alternate blocks make each half; each spans the window).
HALVES_BLOCKS = 16


def check_criterion(criterion: Any) -> str:
    """``criterion`` if it is one of :data:`CRITERIA`, else a ParameterError naming it."""
    if criterion not in CRITERIA:
        raise ParameterError(f"criterion must be one of {', '.join(CRITERIA)}, got {criterion!r}")
    return str(criterion)


@dataclass(frozen=True)
class Candidate:
    """A model to try: its label, how to build it, the inputs that make it (reported back)."""

    label: str
    build: Callable[[], Any]
    inputs: dict[str, Any] = field(default_factory=dict)


@dataclass
class Tried:
    """A candidate after :func:`compare`: its outcome, or why it has none."""

    label: str
    outcome: Outcome | None = None
    note: str = ""
    inputs: dict[str, Any] = field(default_factory=dict)
    #: False: fitted, but its modes are not robust (:func:`mode_robustness`): never kept.
    robust: bool = True

    def score(self, criterion: str) -> float:
        """Its criterion (inf when it was not fitted)."""
        return math.inf if self.outcome is None else float(self.outcome.criterion[criterion])

    @property
    def modes(self) -> int:
        """Its number of modes."""
        return int(self.outcome.model.spec.modes) if self.outcome is not None else 0


def share_effective_size(outcomes: Sequence[Outcome]) -> None:
    """Curve fits: one effective sample size n (1 − ρ1)/(1 + ρ1) for every candidate.

    ρ1 is the residual lag-1 autocorrelation of the candidate with the smallest χ² (the least
    misfit, so the closest to the noise's own), so that the criteria stay comparable.
    """
    curve = [o for o in outcomes if math.isfinite(o.lag1)]
    if not curve:
        return
    rho = min(curve, key=lambda o: float(o.result.chisqr)).lag1
    n = curve[0].n_values
    n_eff = n * (1.0 - rho) / (1.0 + rho) if rho > 0 else float(n)
    # one m for all (the criteria differ by m ln(χ²_a/χ²_b): unit-free only with a common m)
    n_eff = min(max(n_eff, max(o.n_free for o in curve) + 2.0), float(n))
    for o in curve:
        o.n_effective = n_eff


def compare(families: Sequence[Sequence[Candidate]], data: FitData, criterion: str, *,
            min_dof: int = 1, on_failure: Literal["stop", "skip"] = "stop",
            failures: tuple[type[BaseException], ...] = (ConvergenceError,),
            after: Callable[[Outcome], None] | None = None,
            robust: Callable[[Outcome], str | None] | None = None) -> list[Tried]:
    """Fit each family's candidates in order of size (module docstring: when a family stops).

    Parameters
    ----------
    families : sequence of sequences of Candidate
        Each a growing family (e.g. 1, 2, 3 modes); a single model is a family of one.
    data : FitData
        The data every candidate fits.
    criterion : {"bic", "aic"}
        What a family's growth is judged by.
    min_dof : int
        Fewest degrees of freedom a candidate must leave in the data.
    on_failure : {"stop", "skip"}
        A failed fit ends its family ("stop"; the first fit of all failing raises) or is noted
        and passed over ("skip").
    failures : tuple of exception types
        What counts as a failed fit (anything else propagates).
    after : callable, optional
        ``after(outcome)`` on each fit before it is scored (e.g. a stderr correction).
    robust : callable, optional
        ``robust(outcome) -> reason or None``: a family's later candidates (more modes) whose
        modes are not robust (:func:`mode_robustness`) end its growth, noted with the reason.

    Returns
    -------
    list of Tried
        Every candidate reached, in the order tried, with its outcome or a note.
    """
    check_criterion(criterion)
    comparing = sum(len(f) for f in families) > 1
    tried: list[Tried] = []
    for family in families:
        fitted: list[float] = []
        worse = 0
        for candidate in family:
            model = candidate.build()
            if comparing and len(model.names) > data.n_values - min_dof:
                tried.append(Tried(candidate.label, note=(
                    f"not tried: {len(model.names)} parameters leave fewer than {min_dof} "
                    f"degrees of freedom in {data.n_values} values"), inputs=candidate.inputs))
                break
            try:
                outcome = fit_once(model, data, settle=not comparing)
            except failures as exc:
                if on_failure == "stop" and not any(t.outcome for t in tried):
                    raise
                tried.append(Tried(candidate.label, note=f"failed: {str(exc).splitlines()[0]}",
                                   inputs=candidate.inputs))
                if on_failure == "stop":
                    break
                continue
            if after is not None:
                after(outcome)
            # one effective sample size for every candidate fitted, kept or not (comparable)
            share_effective_size([*(t.outcome for t in tried if t.outcome is not None), outcome])
            reason = robust(outcome) if robust is not None and comparing and fitted else None
            if reason is not None:
                tried.append(Tried(candidate.label, outcome, note=f"not robust: {reason}",
                                   inputs=candidate.inputs, robust=False))
                break
            tried.append(Tried(candidate.label, outcome, inputs=candidate.inputs))
            share_effective_size([t.outcome for t in tried if t.outcome is not None])
            score = outcome.criterion[criterion]
            worse = worse + 1 if fitted and score >= min(fitted) else 0
            fitted.append(score)
            if worse >= 2:
                break
    return tried


def keep(tried: Sequence[Tried], criterion: str, margin: float = 0.0) -> Tried:
    """The simplest candidate within ``margin`` of the lowest criterion (module docstring).

    Raises
    ------
    ConvergenceError
        No candidate was fitted (the notes say why).
    """
    fitted = [t for t in tried if t.outcome is not None and t.robust]
    if not fitted:
        raise ConvergenceError("no candidate could be fitted: " + "; ".join(
            f"{t.label} {t.note}" for t in tried))
    best = min(t.score(criterion) for t in fitted)
    within = [t for t in fitted if t.score(criterion) <= best + margin]
    return min(within, key=lambda t: (t.outcome.n_free, t.score(criterion)))


def explain(tried: Sequence[Tried], kept: Tried, criterion: str, margin: float,
            subject: str) -> Choice:
    """The :class:`~viscoforce.choice.Choice` of a comparison by criterion.

    ``considered`` holds (label, criterion − the best's, verdict) per candidate (inf: not
    fitted); ``score`` names the criterion; ``options`` the kept one's modes and inputs.
    """
    best = min(t.score(criterion) for t in tried if t.robust)
    name = criterion.upper()
    rows, parts = [], []
    for t in tried:
        if t.outcome is None:
            rows.append((t.label, math.inf, t.note))
            parts.append(f"{t.label}: {t.note}")
            continue
        o, score = t.outcome, t.score(criterion)
        verdict = ("kept" if t is kept else t.note if not t.robust else
                   f"{'+' if score >= best else ''}{score - best:.3g} from the best")
        rows.append((t.label, score - best, verdict))
        p = o.pvalue
        parts.append(f"{t.label} ({o.n_free} parameters): {name} {score:.4g}, "
                     f"redchi {float(o.result.redchi):.3g}"
                     + (f", p {p:.2g}" if math.isfinite(p) else "") + f" [{verdict}]")
    rule = (f"the simplest within {margin:g} of the best" if margin > 0 else
            f"the lowest {name}")
    if any(not t.robust for t in tried):
        rule += " among the candidates whose modes are robust"
    explanation = f"{subject} compared by {name}; kept {kept.label}, {rule}. " + "; ".join(parts)
    return Choice(kept.label, {"modes": kept.modes, **kept.inputs}, math.nan, math.nan,
                  explanation, tuple(rows), score=name)


# ── robustness of the modes (issue 37 item 4) ───────────────────────────────────────────────────

def _stderr(outcome: Outcome) -> dict[str, float]:
    """Each parameter's stderr (NaN where the covariance is singular).

    The covariance of a curve fit already carries its AR(1) factor (``fitting.outcome``).
    """
    names = outcome.model.names
    if outcome.covariance is None:
        return {n: math.nan for n in names}
    var = np.diag(outcome.covariance)
    return {n: float(math.sqrt(v)) if v >= 0 else math.nan
            for n, v in zip(names, var, strict=True)}


def _times(outcome: Outcome) -> list[str]:
    return [n for n in outcome.model.names if n == "tau" or n.startswith("tau_")]


def sampled_span(data: FitData) -> tuple[float, float]:
    """The times [s] the data resolve.

    (finest sample spacing, window length) of a time series; (1/ω_max, 1/ω_min) of a spectrum.
    """
    x = np.sort(np.asarray(data.x, dtype=float))
    if np.iscomplexobj(data.y):
        return 1.0 / float(x[-1]), 1.0 / float(x[0])
    steps = np.diff(x)
    steps = steps[steps > 0]
    return (float(steps.min()) if steps.size else 0.0), float(x[-1] - x[0])


def block_length(outcome: Outcome) -> int:
    """Samples per block of the split-half: a few correlation lengths of the residuals.

    3(1 + ρ1)/(1 − ρ1) samples (ρ1 the residuals' lag-1 autocorrelation; 1 for white noise or a
    spectrum), at most a sixteenth of the data, so that both halves span the window in many
    short blocks (the information of a decay sits at its start) with nearly independent noise.
    """
    rho = outcome.lag1
    n = int(np.asarray(outcome.data.x).size)
    if not (math.isfinite(rho) and rho > 0):
        return 1
    length = math.ceil(3.0 * (1.0 + rho) / max(1.0 - rho, 1e-6))
    return max(1, min(length, n // HALVES_BLOCKS))


def block_halves(data: FitData, block: int = 1) -> tuple[FitData, FitData]:
    """Two halves of the data: alternate blocks of ``block`` samples (in x order) each.

    Both span the whole window; blocks longer than the residuals' correlation keep the two
    halves' noise nearly independent where it is autocorrelated (a measured series in time).
    """
    order = np.argsort(np.asarray(data.x, dtype=float), kind="stable")
    which = np.empty(order.size, dtype=int)
    which[order] = (np.arange(order.size) // max(int(block), 1)) % 2
    halves = []
    for parity in (0, 1):
        keep = which == parity
        weights = None if data.weights is None else np.asarray(data.weights)[keep]
        dof = None if data.sigma_dof is None else np.asarray(data.sigma_dof)[keep]
        halves.append(FitData(np.asarray(data.x)[keep], np.asarray(data.y)[keep], weights,
                              data.source, data.weighting, data.notes, dof))
    return halves[0], halves[1]


def halves_z(outcome: Outcome, refit: Callable[[FitData], Outcome],
             names: Sequence[str] | None = None) -> dict[str, float]:
    """(a − b)/√(σa² + σb²) of each parameter fitted on the two block halves (NaN: no stderr).

    Raises what ``refit`` raises when a half cannot be fitted.
    """
    a, b = (refit(h) for h in block_halves(outcome.data, block_length(outcome)))
    sa, sb = _stderr(a), _stderr(b)
    out = {}
    for n in names if names is not None else outcome.model.names:
        spread = math.hypot(sa[n], sb[n])
        out[n] = (a.values[n] - b.values[n]) / spread if spread > 0 else math.nan
    return out


def mode_robustness(outcome: Outcome, refit: Callable[[FitData], Outcome] | None = None
                    ) -> str | None:
    """Why the modes of ``outcome`` are not robust, or None.

    Not robust: a time (``tau``, ``tau_i``) outside the span the data resolve
    (:func:`sampled_span`); amplitudes (``dF_i``, ``dz_i``) of both signs (a relaxation or a
    creep of one sign cannot need a mode running the other way); with ``refit`` (a fit of the
    same model to other data), a time moving more than :data:`HALVES_Z` standard errors of the
    difference between the two block halves (:func:`block_halves`), or a half that cannot be
    fitted.
    """
    values, times = outcome.values, _times(outcome)
    lo, hi = sampled_span(outcome.data)
    outside = [n for n in times if not lo <= values[n] <= hi]
    if outside:
        return (", ".join(f"{n} = {values[n]:.3g} s" for n in outside)
                + f" outside the span the data resolve [{lo:.3g}, {hi:.3g}] s")
    amplitudes = [values[n] for n in outcome.model.names if n.startswith(("dF_", "dz_"))]
    if len(amplitudes) > 1 and min(amplitudes) < 0 < max(amplitudes):
        return "amplitudes of both signs (a mode runs against the others)"
    if refit is None:
        return None
    try:
        z = halves_z(outcome, refit, times)
    except (ConvergenceError, ParameterError) as exc:
        return f"cannot be fitted on each half of the data ({str(exc).splitlines()[0]})"
    moved = {n: v for n, v in z.items() if math.isfinite(v) and abs(v) > HALVES_Z}
    if moved:
        return ", ".join(f"{n} moves {v:+.1f} standard errors" for n, v in moved.items()) + (
            " between the two halves of the data")
    return None
