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

from viscoforce.choice import Choice
from viscoforce.exceptions import ConvergenceError, ParameterError
from viscoforce.fitting.data import FitData
from viscoforce.fitting.outcome import Outcome, fit_once

__all__ = ["CRITERIA", "Candidate", "Tried", "check_criterion", "compare", "explain", "keep",
           "share_effective_size"]

#: Information criteria a chooser compares by.
CRITERIA = ("bic", "aic")


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
            after: Callable[[Outcome], None] | None = None) -> list[Tried]:
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
    fitted = [t for t in tried if t.outcome is not None]
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
    best = min(t.score(criterion) for t in tried)
    name = criterion.upper()
    rows, parts = [], []
    for t in tried:
        if t.outcome is None:
            rows.append((t.label, math.inf, t.note))
            parts.append(f"{t.label}: {t.note}")
            continue
        o, score = t.outcome, t.score(criterion)
        verdict = ("kept" if t is kept else
                   f"{'+' if score >= best else ''}{score - best:.3g} from the best")
        rows.append((t.label, score - best, verdict))
        p = o.pvalue
        parts.append(f"{t.label} ({o.n_free} parameters): {name} {score:.4g}, "
                     f"redchi {float(o.result.redchi):.3g}"
                     + (f", p {p:.2g}" if math.isfinite(p) else "") + f" [{verdict}]")
    rule = (f"the simplest within {margin:g} of the best" if margin > 0 else
            f"the lowest {name}")
    explanation = f"{subject} compared by {name}; kept {kept.label}, {rule}. " + "; ".join(parts)
    return Choice(kept.label, {"modes": kept.modes, **kept.inputs}, math.nan, math.nan,
                  explanation, tuple(rows), score=name)
