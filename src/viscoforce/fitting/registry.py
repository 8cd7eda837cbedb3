"""The model registry: one :class:`ModelEntry` per fit model, everything known about it in one place.

Each fit model lives in its own module of :mod:`viscoforce.fitting.models` and declares there, in
one :func:`register` call: its name (``--model``), the kind of data it fits (a spectrum, a
segment of a measured force curve, a trajectory), its builder, its fixed inputs (each with its
check, unit and command-line flag), its parameters and their units, whether it has several
modes and which material families it takes, how it cuts its data from a curves dataset, what its
validity rests on, and whether its residuals are autocorrelated (a measured series in time).
Everything else — the library's checks, the CLI, the choosers — reads the entry.

:func:`register` checks an entry when it is registered: a new name, a known kind of data, a
check for every fixed input, a flag that maps to one input only, and a unit for every parameter
of every mode count and material the entry allows. :data:`MODELS` holds the entries in the order
they were registered (the SPEC's Models table).

Adding a model: write ``viscoforce/fitting/models/<name>.py`` with its builder and its
``register(ModelEntry(...))``, import it in :mod:`viscoforce.fitting.models` (the package's list
of modules), and test it; nothing else changes (tests/fitting/test_registry.py shows a tiny
model registered from a test).
"""

from __future__ import annotations

import keyword
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from viscoforce.exceptions import ParameterError, SchemaError
from viscoforce.schema.fit import parameter_units

__all__ = ["DATA_KINDS", "MODELS", "Input", "ModelEntry", "entries", "entry", "register",
           "unregister"]

#: What a model fits: a spectrum (k* over ω), one segment of a measured force curve, or a
#: trajectory (force over time along a known drive).
DataKind = Literal["spectrum", "curve", "trajectory"]
DATA_KINDS: tuple[str, ...] = ("spectrum", "curve", "trajectory")


@dataclass(frozen=True)
class Input:
    """A fixed input of a model (not fitted): its key, check, unit and command-line flag.

    Attributes
    ----------
    key : str
        The keyword of :func:`viscoforce.fitting.models.make_model` (``radius``, ``tip``, …).
    check : callable
        ``check(key, value) -> value``: the value validated and normalised, or a
        :class:`~viscoforce.exceptions.ParameterError` naming ``key`` and the allowed range.
    unit : str
        CF unit of a quantity [SI], ``""`` for anything else (a tip, a flag, a problem).
    help : str
        One line: what it is.
    flag : str or None
        The ``viscoforce fit`` flag that sets it (None: library only).
    """

    key: str
    check: Callable[[str, Any], Any]
    unit: str
    help: str
    flag: str | None = None


@dataclass(frozen=True)
class ModelEntry:
    """Everything the library and the command line know about one fit model.

    Attributes
    ----------
    name : str
        ``--model`` name, also the fit result's ``model`` attribute.
    data : {"spectrum", "curve", "trajectory"}
        What it fits (:data:`DATA_KINDS`).
    summary : str
        One line: what it fits and how.
    build : callable
        ``build(spec) -> FitModel`` (:class:`~viscoforce.fitting.base.ModelSpec`: name, modes,
        checked fixed inputs).
    inputs : tuple of Input
        Its fixed inputs.
    parameters : callable
        ``parameters(modes, material) -> list of str``: the parameter names a fit reports (for
        ``material`` None where the model has no material families).
    units : mapping
        Units of parameters that :func:`viscoforce.schema.parameter_units` does not know.
    max_modes : int
        Largest number of modes (1: a single-mode model).
    materials : tuple of str
        Material families (``--material``); empty where the model has none.
    cut : callable or None
        Curve models: ``cut(curves, *, curve, segment) -> FitData``, the segment it fits.
    validity : str
        What its model error rests on, where no estimate is made (``attrs["validity"]``).
    autocorrelated : bool
        Its residuals are a measured series in time: stderr are corrected for their lag-1
        autocorrelation.
    """

    name: str
    data: DataKind
    summary: str
    build: Callable[[Any], Any]
    inputs: tuple[Input, ...] = ()
    parameters: Callable[[int, str | None], list[str]] = field(default=None)  # type: ignore[assignment]
    units: Mapping[str, str] = field(default_factory=dict)
    max_modes: int = 1
    materials: tuple[str, ...] = ()
    cut: Callable[..., Any] | None = None
    validity: str = "not estimated"
    autocorrelated: bool = False

    @property
    def modal(self) -> bool:
        """Whether it takes more than one mode (``--modes``)."""
        return self.max_modes > 1

    @property
    def keys(self) -> tuple[str, ...]:
        """Its fixed inputs' keys."""
        return tuple(i.key for i in self.inputs)

    @property
    def flags(self) -> dict[str, str]:
        """Command-line flag → fixed input key."""
        return {i.flag: i.key for i in self.inputs if i.flag is not None}

    def check_fixed(self, fixed: Mapping[str, Any]) -> dict[str, Any]:
        """The fixed inputs validated by their checks (None means not given).

        Raises
        ------
        TypeError
            An input the model does not take.
        ParameterError
            A value out of range (the message names it and the range).
        """
        checks = {i.key: i.check for i in self.inputs}
        unknown = sorted(set(fixed) - set(checks))
        if unknown:
            raise TypeError(f"model {self.name!r} takes no input {', '.join(unknown)}; its "
                            f"inputs: {', '.join(checks) or 'none'}")
        return {k: (None if v is None else checks[k](k, v)) for k, v in fixed.items()}

    def parameter_unit(self, name: str) -> str:
        """The unit of parameter ``name`` (its own table, then the schema's)."""
        return parameter_units(name, self.units)


#: The registered models, by name, in registration order.
MODELS: dict[str, ModelEntry] = {}


def _check_entry(e: ModelEntry) -> None:
    """Raise :class:`SchemaError` saying what is wrong with an entry (:func:`register`)."""
    where = f"model entry {e.name!r}"
    if not isinstance(e.name, str) or not e.name.isidentifier() or keyword.iskeyword(e.name):
        raise SchemaError(f"model entry name must be an identifier, got {e.name!r}")
    if e.name in MODELS or e.name == "auto":
        raise SchemaError(f"{where}: the name is taken")
    if e.data not in DATA_KINDS:
        raise SchemaError(f"{where}: data must be one of {', '.join(DATA_KINDS)}, got {e.data!r}")
    if not callable(e.build) or not callable(e.parameters):
        raise SchemaError(f"{where}: build and parameters must be callable")
    if not isinstance(e.max_modes, int) or e.max_modes < 1:
        raise SchemaError(f"{where}: max_modes must be an integer >= 1, got {e.max_modes!r}")
    if (e.cut is not None) != (e.data == "curve"):
        raise SchemaError(f"{where}: a curve model has a cut (how it takes its segment), the "
                          "others none")
    keys: set[str] = set()
    flags: dict[str, str] = {}
    for i in e.inputs:
        if not isinstance(i, Input):
            raise SchemaError(f"{where}: inputs must be Input, got {i!r}")
        if i.key in keys:
            raise SchemaError(f"{where}: input {i.key!r} is declared twice")
        keys.add(i.key)
        if not callable(i.check):
            raise SchemaError(f"{where}: input {i.key!r} has no check")
        if i.flag is not None:
            if not i.flag.startswith("--") or i.flag in flags:
                raise SchemaError(f"{where}: input {i.key!r}: flag {i.flag!r} must start with "
                                  "'--' and set one input only")
            flags[i.flag] = i.key
    for modes in range(1, min(e.max_modes, 3) + 1):
        for material in e.materials or (None,):
            names = e.parameters(modes, material)
            if not names:
                raise SchemaError(f"{where}: no parameters for modes={modes}, "
                                  f"material={material!r}")
            for name in names:
                try:
                    e.parameter_unit(name)
                except SchemaError:
                    raise SchemaError(f"{where}: parameter {name!r} has no unit (give it in "
                                      "units=)") from None


def register(e: ModelEntry) -> ModelEntry:
    """Check ``e`` (:func:`_check_entry`) and add it to :data:`MODELS`; return it.

    Raises
    ------
    SchemaError
        What is wrong with the entry: a taken name, an unknown kind of data, an input without a
        check, a flag that sets two inputs, a parameter without a unit.
    """
    _check_entry(e)
    MODELS[e.name] = e
    return e


def unregister(name: str) -> None:
    """Remove model ``name`` from :data:`MODELS` (a test's model, once tested)."""
    MODELS.pop(name, None)


def entry(name: Any) -> ModelEntry:
    """The entry of model ``name``, or :class:`ParameterError` listing the models."""
    if not isinstance(name, str) or name not in MODELS:
        raise ParameterError(f"model must be one of {', '.join(MODELS)}, got {name!r}")
    return MODELS[name]


def entries(*, data: str | None = None, modal: bool | None = None,
            autocorrelated: bool | None = None) -> tuple[str, ...]:
    """The names of the registered models with these properties (None: either)."""
    return tuple(n for n, e in MODELS.items()
                 if (data is None or e.data == data) and (modal is None or e.modal == modal)
                 and (autocorrelated is None or e.autocorrelated == autocorrelated))
