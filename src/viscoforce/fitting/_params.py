"""Parameter layouts: the SPEC's names as lmfit expressions of internal log10 parameters.

A fit of relaxation times and moduli spans decades, and the physics orders them (E0 > E_1 > … >
E_inf, τ_1 < τ_2 < …). lmfit has bounds but no inequalities, so every model here varies internal
parameters and exposes the SPEC names as expressions of them:

- a positive quantity ``q``: ``log_q`` = log10 q, bounded to a physical window;
- an ordered chain ``a < b < c``: ``log_a`` = log10 a, ``log_b`` = log10(b/a) ≥ 0, …, so that
  ``b = a*10**log_b``;
- a signed quantity (a force): varied as itself.

The SPEC names carry the values, stderr (propagated by lmfit through the expressions with the full
covariance) and correlations that the result reports; the ``log_`` parameters are bookkeeping.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import lmfit

from viscoforce.exceptions import ParameterError

#: Closest bounds of a parameter (absolute and relative), as lmfit's ``Parameter`` refuses them.
BOUNDS_RESOLUTION = 1e-13
#: Widest decade window of a positive parameter around its guess (bounds: guess·10^±WINDOW).
WINDOW_DECADES = 6.0


@dataclass(frozen=True)
class Chain:
    """Positive quantities that increase along ``names`` (first: the smallest).

    ``bounds`` is the (low, high) window of the smallest one [SI]; None: ±WINDOW_DECADES around the
    guess. The ratios of neighbours are ≥ 1 and at most 10^``max_ratio_decades``.
    """

    names: tuple[str, ...]
    bounds: tuple[float, float] | None = None
    max_ratio_decades: float = 2 * WINDOW_DECADES


@dataclass(frozen=True)
class Signed:
    """A real quantity varied as itself (forces)."""

    name: str


@dataclass(frozen=True)
class Bounded:
    """A real quantity within (low, high), varied as itself (the power-law exponent m)."""

    name: str
    low: float
    high: float


Item = Chain | Signed | Bounded


def reported_names(layout: Sequence[Item]) -> list[str]:
    """The SPEC names of ``layout`` in order of appearance."""
    names: list[str] = []
    for item in layout:
        names.extend(item.names if isinstance(item, Chain) else (item.name,))
    return names


@dataclass(slots=True)
class Internal:
    """One internal parameter, with the attributes of :class:`lmfit.Parameter` the fits read.

    Unlike lmfit's: assigning ``value`` directly does not clip it (:meth:`set` does; the fitting
    engine assigns values its bound transforms keep inside the window), and bounds out of order
    or NaN are refused rather than swapped. Bounds closer than lmfit's 1e-13
    (:data:`BOUNDS_RESOLUTION`) are refused, as lmfit refuses them: a ParameterError, since
    such a window comes from data that span too little (a contact point within 1e-14 m).
    """

    name: str
    value: float
    min: float = -math.inf
    max: float = math.inf
    vary: bool = True
    stderr: float | None = None
    correl: dict[str, float] | None = None
    expr: None = None  # never an expression (lmfit's attribute, read by the engine)

    def __post_init__(self) -> None:
        if not self.min < self.max:
            raise ValueError(f"parameter {self.name!r} needs min < max, got [{self.min!r}, "
                             f"{self.max!r}]")
        if math.isclose(self.min, self.max, rel_tol=BOUNDS_RESOLUTION,
                        abs_tol=BOUNDS_RESOLUTION):
            # a window the data set (a contact point within a 1e-14 m approach): the data's
            # span is below what the fit can bound (lmfit refuses it too, in SI)
            raise ParameterError(
                f"parameter {self.name!r} needs min < max by more than {BOUNDS_RESOLUTION:g} "
                f"(lmfit's resolution of bounds), got [{self.min!r}, {self.max!r}]: the data "
                "span too little of it to fit (check their units and spans)")
        self.value = min(max(float(self.value), self.min), self.max)  # as lmfit: clipped

    def set(self, *, value: float | None = None, vary: bool | None = None) -> None:
        """Move the value (clipped to the bounds) or hold it, as lmfit's ``Parameter.set``."""
        if value is not None:
            self.value = min(max(float(value), self.min), self.max)
        if vary is not None:
            self.vary = bool(vary)


class InternalParameters(dict):
    """The internal parameters of a fit (name → :class:`Internal`), as lmfit's Parameters reads.

    The fitting engine (:mod:`viscoforce.fitting._engine`) needs values, bounds and ``vary``
    only; lmfit's container also builds an expression interpreter, which costs a closed-form fit
    a tenth of its time (issue 22). :meth:`to_lmfit` gives lmfit's Parameters where lmfit
    itself minimises (profiles, the step model).
    """

    def add(self, name: str, *, value: float, min: float = -math.inf,  # noqa: A002
            max: float = math.inf) -> None:  # noqa: A002
        self[name] = Internal(name, value, min, max)

    def valuesdict(self) -> dict[str, float]:
        return {name: p.value for name, p in self.items()}

    def copy(self) -> InternalParameters:
        """An independent copy (each parameter copied; correlations shared read-only)."""
        out = InternalParameters()
        for name, p in self.items():
            out[name] = Internal(p.name, p.value, p.min, p.max, p.vary, p.stderr, p.correl)
        return out

    def to_lmfit(self) -> lmfit.Parameters:
        """The same parameters as :class:`lmfit.Parameters` (values, bounds, vary, stderr)."""
        params = lmfit.Parameters()
        for name, p in self.items():
            params.add(name, value=p.value, min=p.min, max=p.max, vary=p.vary)
            params[name].stderr, params[name].correl = p.stderr, p.correl
        return params


#: Either container of a fit's parameters: what the fitting engine and the profiles read.
ParameterSet = lmfit.Parameters | InternalParameters


def as_lmfit(params: ParameterSet) -> lmfit.Parameters:
    """A copy of ``params`` as lmfit's Parameters (what ``lmfit.minimize`` takes)."""
    return params.to_lmfit() if isinstance(params, InternalParameters) else params.copy()


def build_parameters(layout: Sequence[Item], guess: Mapping[str, float], *,
                     expressions: bool = True) -> lmfit.Parameters:
    """Lmfit Parameters for ``layout`` starting at ``guess`` (SPEC name → value in SI).

    Chain values out of order in ``guess`` are pushed apart to keep every ratio ≥ 1.
    ``expressions=False`` leaves out the SPEC names of chains (their expressions): the internal
    parameters only (:func:`internal_parameters` holds the same without lmfit's container).
    """
    return _fill(lmfit.Parameters(), layout, guess, expressions)


def internal_parameters(layout: Sequence[Item], guess: Mapping[str, float]
                        ) -> InternalParameters:
    """The internal parameters of :func:`build_parameters`, in the light container.

    What a fit varies, without an expression interpreter per fit (issue 22).
    """
    return _fill(InternalParameters(), layout, guess, False)


def _fill(params: ParameterSet, layout: Sequence[Item], guess: Mapping[str, float],
          expressions: bool) -> ParameterSet:
    for item in layout:
        if isinstance(item, Signed):
            params.add(item.name, value=float(guess[item.name]))
        elif isinstance(item, Bounded):
            value = min(max(float(guess[item.name]), item.low), item.high)
            params.add(item.name, value=value, min=item.low, max=item.high)
        else:
            _add_chain(params, item, guess, expressions)
    return params


def _add_chain(params: ParameterSet, chain: Chain, guess: Mapping[str, float],
               expressions: bool = True) -> None:
    first, *rest = chain.names
    start = float(guess[first])
    if not (start > 0 and math.isfinite(start)):
        raise ValueError(f"guess for {first!r} must be > 0 and finite, got {start!r}")
    lo, hi = chain.bounds or (start * 10 ** -WINDOW_DECADES, start * 10 ** WINDOW_DECADES)
    start = min(max(start, lo), hi)
    params.add(f"log_{first}", value=math.log10(start), min=math.log10(lo), max=math.log10(hi))
    if expressions:
        params.add(first, expr=f"10**log_{first}")
    previous, value = first, start
    for name in rest:
        wanted = float(guess[name])
        ratio = wanted / value if wanted > value and math.isfinite(wanted) else 1.5
        log_ratio = min(math.log10(ratio), chain.max_ratio_decades - 1e-9)
        params.add(f"log_{name}", value=log_ratio, min=0.0, max=chain.max_ratio_decades)
        if expressions:
            params.add(name, expr=f"{previous}*10**log_{name}")
        previous, value = name, value * 10 ** log_ratio


def at_bound(params: ParameterSet, *, rtol: float = 1e-6) -> list[str]:
    """Varied parameters that ended on a bound (their SPEC names, without ``log_``)."""
    hits = []
    for p in params.values():
        if not p.vary:
            continue
        span = (p.max - p.min) if math.isfinite(p.max) and math.isfinite(p.min) else math.nan
        # relative to the window (a contact point's window is micrometres, a log window decades)
        tol = rtol * (abs(span) if math.isfinite(span) and span > 0 else max(abs(p.value), 1.0))
        if (math.isfinite(p.min) and p.value - p.min <= tol) or (
                math.isfinite(p.max) and p.max - p.value <= tol):
            hits.append(p.name.removeprefix("log_"))
    return hits


def reported_values(layout: Sequence[Item], internal: Mapping[str, float]) -> dict[str, float]:
    """SPEC values from internal values (:func:`to_reported` without the derivatives)."""
    return decoder(layout, (), internal)(())


def decoder(layout: Sequence[Item], varied: Sequence[str], fixed: Mapping[str, float]
            ) -> Callable[[Sequence[float]], dict[str, float]]:
    """:func:`reported_values` as a function of the varied internal values alone.

    ``varied``: the internal names in the order of the values the function gets; ``fixed``:
    the other internal values (:func:`reported_values` is the decoder with every value fixed).
    A fit's inner loop calls it without building a mapping of internal values per evaluation.
    """
    slots = {name: i for i, name in enumerate(varied)}
    plan: list[tuple[str, bool | None, int | None, float | None]] = []
    for item in layout:
        entries = ([(name, k == 0, f"log_{name}") for k, name in enumerate(item.names)]
                   if isinstance(item, Chain) else [(item.name, None, item.name)])
        for name, first, key in entries:
            if key not in slots and key not in fixed:
                raise KeyError(f"internal parameter {key!r} is neither varied nor fixed")
            plan.append((name, first, slots.get(key), fixed.get(key)))

    def decode(values: Sequence[float]) -> dict[str, float]:
        out: dict[str, float] = {}
        total = 0.0
        for name, first, slot, constant in plan:
            value = values[slot] if slot is not None else constant
            if first is None:
                out[name] = value
            else:  # a chain: 10**(the sum of the logs up to here)
                total = (0.0 if first else total) + value
                out[name] = 10.0 ** total
        return out

    return decode


def to_reported(layout: Sequence[Item], internal: Mapping[str, float]
                ) -> tuple[dict[str, float], dict[str, dict[str, float]]]:
    """SPEC values from internal values, and their derivatives d(SPEC)/d(internal).

    A chain member is 10**(Σ of the logs up to it), so d q_k / d log_j = ln 10 · q_k for every
    j up to k; a signed or bounded quantity is itself.
    """
    values = {name: float(v) for name, v in reported_values(layout, internal).items()}
    grads: dict[str, dict[str, float]] = {}
    ln10 = math.log(10.0)
    for item in layout:
        if isinstance(item, Chain):
            logs: list[str] = []
            for name in item.names:
                logs.append(f"log_{name}")
                grads[name] = {lg: ln10 * values[name] for lg in logs}
        else:
            grads[item.name] = {item.name: 1.0}
    return values, grads
