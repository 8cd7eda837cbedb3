"""Shared machinery of the dataset contracts: variable specs, attribute cleaning, generic checks.

Pure: imports only numpy, xarray and :mod:`viscoforce.exceptions`.
"""

from __future__ import annotations

import functools
from collections.abc import Collection, Iterable, Mapping
from typing import Any, NamedTuple

import numpy as np
import xarray as xr
from xarray.indexes import PandasIndex

from viscoforce.exceptions import SchemaError

#: Placeholder in :attr:`VariableSpec.dims` for a dataset's extra dims (``curve``, ``y``, ``x``, …).
EXTRA = "..."

_INT32 = np.iinfo(np.int32)


class VariableSpec(NamedTuple):
    """Contract of one variable (or coordinate) of a dataset kind.

    Attributes
    ----------
    units : str
        CF/UDUNITS unit string in ``attrs["units"]`` (``""`` for text, which carries none).
    long_name : str
        Default CF ``long_name``.
    dims : tuple of str
        Dimensions in order; :data:`EXTRA` stands for the dataset's extra dims.
    dtype : {"f", "i", "U"}
        Real floating point, integer (netCDF3: int8/int32) or text.
    required : bool
        Whether :func:`validate` requires it by default.
    broadcast : bool
        The variable may span any subset of ``dims`` (e.g. a scalar drive amplitude).
    """

    units: str
    long_name: str
    dims: tuple[str, ...]
    dtype: str = "f"
    required: bool = True
    broadcast: bool = False


def describe(value: Any) -> str:
    """Short text for a rejected value in a message: ``None``, ``str 'abc'``, ``list [1, 2]``."""
    if value is None:
        return "None"
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 60 else text[:57] + '...'}"


def as_mapping(name: str, value: Any) -> Mapping[Any, Any]:
    """Return ``value`` (``{}`` for None), raising unless it is a mapping (a dict)."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise SchemaError(f"{name} must be a mapping (dict) or None, got {describe(value)}")
    return value


def as_names(name: str, value: Any, *, unique: bool = True) -> tuple[str, ...] | None:
    """Return ``value`` as a tuple of strings, distinct if ``unique`` (None stays None).

    A single string is refused (``("omega",)``, not ``"omega"``): iterating it would give its
    characters.
    """
    if value is None:
        return None
    if isinstance(value, str | bytes) or not isinstance(value, Iterable):
        raise SchemaError(
            f"{name} must be a tuple or list of names (strings), e.g. ('omega',), or None; got "
            f"{describe(value)}")
    names = tuple(value)
    bad = [v for v in names if not isinstance(v, str)]
    if bad:
        raise SchemaError(f"{name} must hold names (strings), got {describe(bad[0])} in "
                          f"{describe(value)}")
    if unique and len(set(names)) != len(names):
        raise SchemaError(f"{name} must not repeat a name, got {names}")
    return tuple(str(v) for v in names)


def as_flag(name: str, value: Any, *, allow_none: bool = False) -> bool | None:
    """Return ``value`` as a bool, raising unless it is True or False (or None if allowed)."""
    if value is None and allow_none:
        return None
    if not isinstance(value, bool | np.bool_):
        allowed = "True, False or None" if allow_none else "True or False"
        raise SchemaError(f"{name} must be {allowed}, got {describe(value)}")
    return bool(value)


def as_text(name: str, value: Any, *, allow_none: bool = False) -> str | None:
    """Return ``value``, raising unless it is a string (or None if allowed)."""
    if value is None and allow_none:
        return None
    if not isinstance(value, str):
        allowed = "a string or None" if allow_none else "a string"
        raise SchemaError(f"{name} must be {allowed}, got {describe(value)}")
    return str(value)


def require_values(name: str, arr: np.ndarray, *, allow_nan: bool = False,
                   minimum: float | None = None, strict: bool = False,
                   nan_hint: str = "") -> np.ndarray:
    """Return ``arr``, raising if it holds ±inf or NaN, or is below ``minimum``.

    ``allow_nan`` lets NaN (an unknown value) pass; ``strict`` refuses ``minimum`` itself.
    ``nan_hint`` is appended to the message about a non-finite entry.
    """
    bad = np.isinf(arr) if allow_nan else ~np.isfinite(arr)
    if np.any(bad):
        i = int(np.flatnonzero(bad.ravel())[0])
        what = "must not be infinite" if allow_nan else "must be finite"
        raise SchemaError(f"{name} {what}; entry {i} is {float(arr.ravel()[i])!r}{nan_hint}")
    if minimum is not None:
        with np.errstate(invalid="ignore"):
            low = (arr <= minimum) if strict else (arr < minimum)
        if np.any(low):
            i = int(np.flatnonzero(low.ravel())[0])
            op = ">" if strict else ">="
            raise SchemaError(f"{name} must be {op} {minimum:g}; entry {i} is "
                              f"{float(arr.ravel()[i])!r}")
    return arr


def clean_attrs(attrs: Mapping[str, Any] | None) -> dict[str, Any]:
    """Return ``attrs`` with every value netCDF3-serialisable (raise :class:`SchemaError` if not).

    Strings, finite or non-finite floats and int32 integers pass; booleans become 0/1, numpy
    scalars Python numbers, numeric sequences 1-D arrays. None, mappings, text sequences and
    integers beyond int32 raise, naming the attribute; ``attrs`` itself must be a mapping or
    None.
    """
    out: dict[str, Any] = {}
    for key, value in as_mapping("attrs", attrs).items():
        if not isinstance(key, str):
            raise SchemaError(f"attribute names must be strings, got {key!r}")
        out[key] = _attr_value(key, value)
    return out


def _attr_value(key: str, value: Any) -> Any:
    if isinstance(value, str):
        return value
    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, int | np.integer):
        if not _INT32.min <= value <= _INT32.max:
            raise SchemaError(f"attribute {key!r} = {value!r} does not fit netCDF3's int32; "
                              "store it as a float or a string")
        return int(value)
    if isinstance(value, float | np.floating):
        return float(value)
    if isinstance(value, np.ndarray | list | tuple):
        arr = np.asarray(value)
        if arr.ndim == 1 and arr.dtype.kind in "biuf":
            return arr.astype(np.int32 if arr.dtype.kind in "biu" else np.float64)
    raise SchemaError(f"attribute {key!r} of type {type(value).__name__} is not netCDF-"
                      "serialisable (use a string, a number or a 1-D numeric array)")


#: NumPy dtype of each :class:`VariableSpec` dtype code.
_SPEC_DTYPES = {"f": np.float64, "i": np.int32, "U": np.str_}


def variable(values: Any, dims: tuple[str, ...], spec: VariableSpec, *, name: str = "",
             long_name: str | None = None, attrs: Mapping[str, Any] | None = None) -> xr.Variable:
    """A Variable with the spec's units, long_name (or ``long_name``) and dtype.

    A bare :class:`xarray.Variable`, not a DataArray: the dataset built from it needs no
    alignment of per-variable coordinates (a DataArray costs ≈ 2× to build and to merge).
    """
    if spec.dtype == "i":
        raw = np.asarray(values)
        if raw.dtype.kind not in "biu":
            raise SchemaError(f"{name or spec.long_name} must be integers, got {raw!r}")
    data = np.asarray(values, dtype=_SPEC_DTYPES[spec.dtype])
    meta = {"long_name": long_name or spec.long_name}
    if spec.units:
        meta = {"units": spec.units, **meta}
    meta.update(attrs or {})
    # a plain array of a float, integer or text dtype: what plain_variable hands xarray as is
    return xr.Variable(tuple(dims), data, meta, fastpath=True)


def plain_variable(dims: str | tuple[str, ...], values: Any,
                   attrs: Mapping[str, Any] | None = None) -> xr.Variable:
    """``xr.Variable(dims, values, attrs)`` of plain numbers or text, without xarray's checks.

    Numbers, booleans and text become a NumPy array here, which xarray takes as it is
    (``fastpath``): its conversion checks (datetimes, masked and pandas arrays) concern none of
    them, and cost a 0-d variable 2–3 µs of the ≈ 50 that a fit's result holds (issue 22).

    Parameters
    ----------
    dims : str or tuple of str
        Dimension names, as for :class:`xarray.Variable`.
    values : array_like
        A plain NumPy array (not a subclass such as a masked array), a Python or NumPy number,
        bool or text, or a list of them; anything else (and any dtype but bool, integer, float
        or text) takes the public constructor.
    attrs : mapping, optional
        The variable's attributes.

    Returns
    -------
    xarray.Variable
        The same variable as ``xr.Variable(dims, values, attrs)``.
    """
    plain = (type(values) is np.ndarray
             or isinstance(values, float | int | str | bool | np.number | np.bool_ | list))
    data = np.asarray(values) if plain else None
    if data is None or data.dtype.kind not in "biufU":
        return xr.Variable(dims, values, attrs)
    return xr.Variable((dims,) if isinstance(dims, str) else tuple(dims), data, attrs,
                       fastpath=True)


def index_values(ds: xr.Dataset, name: str) -> np.ndarray:
    """The values of coordinate ``name``, read through its pandas index if it has one.

    The values of ``ds.variables[name].values``: an index coordinate's variable hands them out
    through an adapter that re-parses NumPy's version on every read (≈ 2 µs, a float ω; text
    labels take ≈ 7 µs), which a small fit does several times (issue 22). Other coordinates and
    indexes of another dtype are read from the variable.

    Parameters
    ----------
    ds : xarray.Dataset
        The dataset.
    name : str
        One of its coordinates (or variables).

    Returns
    -------
    numpy.ndarray
        A read-only view of the values (the index's or the variable's own memory: writing into
        it would change the dataset, whatever pandas' copy-on-write setting).
    """
    values = None
    index = ds.xindexes.get(name)
    if isinstance(index, PandasIndex) and index.dim == name:
        values = index.index.to_numpy()
        if values.dtype != index.coord_dtype:
            values = None
    if values is None:
        values = np.asarray(ds.variables[name].values)
    view = values.view()
    view.flags.writeable = False
    return view


def parameter_names(ds: xr.Dataset) -> list[str]:
    """A fit result's parameter names (its ``param_i`` labels), as text.

    Read through the ``param_i`` index where it has one (:func:`index_values`' reason), else
    from the variable (a result without indexes).

    Parameters
    ----------
    ds : xarray.Dataset
        A fit result (:mod:`viscoforce.schema.fit`).

    Returns
    -------
    list of str
        The parameter names in ``param_i`` order.
    """
    index = ds.xindexes.get("param_i")
    labels = index.index if isinstance(index, PandasIndex) else ds.variables["param_i"].values
    return [str(n) for n in labels]


def as_float(name: str, values: Any) -> np.ndarray:
    """``values`` as a float array (raise naming ``name`` if they are not real numbers).

    None, text, mappings, booleans and complex numbers are refused (numpy would turn them into
    NaN, parse them, or drop the imaginary part with a warning).
    """
    if values is None or isinstance(values, str | bytes | Mapping):
        raise SchemaError(f"{name} must be real numbers, got {values!r}")
    try:
        raw = np.asarray(values)
        if raw.dtype.kind in "bcSUV":
            raise TypeError
        arr = raw.astype(float, copy=False)
    except (TypeError, ValueError):
        raise SchemaError(f"{name} must be real numbers, got {values!r}") from None
    return arr


def per_point(name: str, values: Any, shape: tuple[int, ...], dims: tuple[str, ...],
              *, keep_scalar: bool = False) -> tuple[np.ndarray, tuple[str, ...]]:
    """Broadcast ``values`` to ``shape`` (or keep a scalar as a scalar with ``keep_scalar``)."""
    arr = as_float(name, values)
    if keep_scalar and arr.ndim == 0:
        return arr, ()
    try:
        return np.broadcast_to(arr, shape).copy(), dims
    except ValueError:
        sizes = dict(zip(dims, shape, strict=True))
        raise SchemaError(f"{name} of shape {arr.shape} does not broadcast to {sizes}") from None


def shaped(name: str, values: Any, shape: tuple[int, ...], dims: tuple[str, ...]) -> np.ndarray:
    """``values`` as a float array of exactly ``shape`` (raise naming ``name`` and the dims)."""
    arr = as_float(name, values)
    if arr.shape != shape:
        raise SchemaError(f"{name} must have shape {shape} over {dims}, got {arr.shape}")
    return arr


def coordinate(name: str, values: Any) -> np.ndarray:
    """A 1-D float coordinate (raise naming it if not 1-D)."""
    arr = as_float(name, values)
    if arr.ndim != 1:
        raise SchemaError(f"{name} must be 1-D, got shape {arr.shape}")
    return arr


def require_dataset(ds: Any, kind: str) -> xr.Dataset:
    """Raise unless ``ds`` is an :class:`xarray.Dataset`."""
    if not isinstance(ds, xr.Dataset):
        raise SchemaError(f"{kind} must be an xarray.Dataset, got {type(ds).__name__}")
    return ds


def _label(name: str, table: Mapping[str, VariableSpec]) -> str:
    spec = table.get(name)
    return f"'{name}' [{spec.units}]" if spec is not None and spec.units else f"'{name}'"


def check_present(ds: xr.Dataset, kind: str, table: Mapping[str, VariableSpec],
                  require: Iterable[str] | None, hint: str = "") -> None:
    """Raise naming every required variable that ``ds`` lacks (default: the table's required)."""
    given = as_names("require", require)
    names = [n for n, s in table.items() if s.required] if given is None else list(given)
    missing = [n for n in names if n not in ds.variables]
    if missing:
        raise SchemaError(f"{kind} is missing {', '.join(_label(n, table) for n in missing)}"
                          + (f" {hint}" if hint else ""))


def check_variables(ds: xr.Dataset, kind: str, table: Mapping[str, VariableSpec],
                    extra: tuple[str, ...] = ()) -> None:
    """Units, dtype and dims of every table variable present, and of their ``_stderr`` twins."""
    for name, spec in table.items():
        if name in ds.variables:
            check_one(ds, kind, name, spec, extra)
    for name in ds.variables:
        base = str(name).removesuffix("_stderr")
        if base != name and base in table:
            check_one(ds, kind, str(name), table[base]._replace(broadcast=True), extra)


def check_one(ds: xr.Dataset, kind: str, name: str, spec: VariableSpec,
              extra: tuple[str, ...] = ()) -> None:
    """Raise if variable ``name`` has the wrong units, dtype or dims."""
    var = ds.variables[name]
    unit = var.attrs.get("units")
    if spec.units and unit != spec.units:
        raise SchemaError(f"{kind}: '{name}' must have units {spec.units!r}, got {unit!r}")
    dkind = var.dtype.kind
    ok = {"f": dkind == "f", "i": dkind in "iu", "U": dkind in "USO"}[spec.dtype]
    if not ok:
        want = {"f": "real floats", "i": "integers", "U": "text"}[spec.dtype]
        raise SchemaError(f"{kind}: '{name}' must hold {want}, got dtype {var.dtype}")
    expected = expand_dims(spec.dims, extra)
    if spec.broadcast:
        if not set(var.dims) <= set(expected):
            raise SchemaError(
                f"{kind}: '{name}' must have dims within {expected}, got {var.dims}")
    elif var.dims != expected:
        raise SchemaError(f"{kind}: '{name}' must have dims {expected}, got {var.dims}")


def expand_dims(dims: tuple[str, ...], extra: tuple[str, ...]) -> tuple[str, ...]:
    """Replace the :data:`EXTRA` placeholder of a spec's dims by the dataset's extra dims."""
    out: list[str] = []
    for d in dims:
        out.extend(extra if d == EXTRA else (d,))
    return tuple(out)


def check_attrs(ds: xr.Dataset, kind: str) -> None:
    """Raise if a dataset attribute would not survive netCDF3."""
    try:
        clean_attrs(ds.attrs)
    except SchemaError as exc:
        raise SchemaError(f"{kind}: {exc}") from None


def check_flags(ds: xr.Dataset, kind: str, name: str) -> None:
    """A CF flag variable: integer, ``flag_values``/``flag_meanings`` set, values among them."""
    var = ds.variables[name]
    values = var.attrs.get("flag_values")
    meanings = var.attrs.get("flag_meanings")
    if values is None or not isinstance(meanings, str):
        raise SchemaError(f"{kind}: '{name}' needs the CF attributes flag_values and flag_meanings")
    values = np.atleast_1d(np.asarray(values))
    if len(meanings.split()) != values.size:
        raise SchemaError(f"{kind}: '{name}' has {values.size} flag_values but "
                          f"{len(meanings.split())} flag_meanings")
    bad = np.setdiff1d(np.unique(np.asarray(var.values)), values)
    if bad.size:
        raise SchemaError(f"{kind}: '{name}' holds {bad.tolist()}, not among its flag_values "
                          f"{values.tolist()}")


def flag_attrs(flags: Mapping[int, str], dtype: type = np.int8) -> dict[str, Any]:
    """CF ``flag_values`` and ``flag_meanings`` of a code → meaning table."""
    return {"flag_values": np.array(list(flags), dtype=dtype),
            "flag_meanings": " ".join(flags.values())}


def flag_meanings(var: xr.Variable) -> dict[int, str]:
    """Code → meaning of a CF flag variable (``flag_values``, ``flag_meanings``; {} without).

    The inverse of :func:`flag_attrs`: a map's ``quality`` carries
    :data:`viscoforce.fitting.pixels.MAP_QUALITY` this way, so a map read from a file names its
    codes as the fit that wrote it did.
    """
    values = np.atleast_1d(np.asarray(var.attrs.get("flag_values", []))).tolist()
    meanings = str(var.attrs.get("flag_meanings", "")).split()
    if len(values) != len(meanings):
        return {}
    return {int(v): m for v, m in zip(values, meanings, strict=True)}


def assemble(data_vars: Mapping[str, Any], coords: Mapping[str, Any] | None = None,
             attrs: Mapping[str, Any] | None = None, *,
             fresh: Collection[str] = ()) -> xr.Dataset:
    """``xr.Dataset(data_vars, coords=coords, attrs=attrs)``, built without xarray's merge.

    The library builds its datasets from fresh :class:`xarray.Variable` objects (from
    :func:`variable`) that need no alignment, yet the public constructor spends most of a small
    fit's time merging them (issue 22). When every entry is a Variable, a DataArray without
    coordinates or a ``(dims, values[, attrs])`` tuple, this assembles the dataset directly: the
    dimension sizes are checked here, each 1-D coordinate named after its dim gets the default
    pandas index, and xarray's ``Dataset._construct_direct`` (private, and used by xarray's own
    methods since 0.x) makes the object. Anything else, or an xarray without that constructor,
    takes the public one. ``tests/schema/test_schema_assemble.py`` checks that both give identical
    datasets.

    Parameters
    ----------
    data_vars, coords, attrs
        As for :class:`xarray.Dataset`.
    fresh : collection of str
        Names of Variables the caller made for this dataset: they are taken over. Every other
        Variable or DataArray is copied (shallow, as the public constructor does), so that
        changing the dataset's attributes leaves the caller's objects alone.

    Raises
    ------
    SchemaError
        A dimension with two sizes, or arguments the public constructor refuses (the message
        says why).
    """
    coords = dict(coords or {})
    fast = _direct_variables(data_vars, coords, set(fresh))
    construct = getattr(xr.Dataset, "_construct_direct", None)
    if fast is None or construct is None:
        return _public_dataset(data_vars, coords, attrs)
    variables, coord_names = fast
    dims: dict[str, int] = {}
    owner: dict[str, str] = {}
    for name, var in variables.items():
        for dim, size in zip(var.dims, var.shape, strict=True):
            if dims.setdefault(dim, size) != size:
                raise SchemaError(f"dataset variables disagree: dimension {dim!r} has size "
                                  f"{dims[dim]} in {owner[dim]!r} but {size} in {name!r}")
            owner.setdefault(dim, name)
    indexes = {}
    for name in coord_names:
        var = variables[name]
        if var.dims == (name,):
            if var.dtype.kind == "U" and var.size <= TEXT_INDEX_CACHE_LABELS:
                index, made = _text_index(name, tuple(var.values.tolist()), var.dtype.str)
                if not var.attrs and not var.encoding:  # what create_variables would make
                    variables[name] = made.copy(deep=False)
                    indexes[name] = index
                    continue
            elif var.dtype == np.float64 and type(var.data) is np.ndarray:
                index = _float_index(name, var.data)
            else:
                index = PandasIndex.from_variables({name: var}, options={})
            variables.update(index.create_variables({name: var}))
            indexes[name] = index
    try:
        return construct(variables, coord_names, dims, dict(attrs or {}), indexes)
    except TypeError:  # the private signature changed: the public constructor
        return _public_dataset(data_vars, coords, attrs)


def _public_dataset(data_vars: Mapping[str, Any], coords: Mapping[str, Any],
                    attrs: Mapping[str, Any] | None) -> xr.Dataset:
    """``xr.Dataset(...)``, its refusals as SchemaError."""
    try:
        return xr.Dataset(dict(data_vars), coords=coords, attrs=dict(attrs or {}))
    except (TypeError, ValueError) as exc:
        raise SchemaError(f"dataset variables disagree: {exc}") from None


def _float_index(dim: str, values: np.ndarray) -> PandasIndex:
    """The pandas index of a float64 coordinate (a best-fit curve's ω), as ``from_variables``.

    The same index (a float64 ``pd.Index`` named ``dim``, the coordinate's dtype) without the
    public constructor's casts, which concern datetimes, text and extension arrays only
    (they were a quarter of assembling a small fit's dataset, issue 22).
    ``tests/schema/test_schema_assemble.py`` compares both.
    """
    return PandasIndex(_pandas_index_type()(values, copy=True, name=dim), dim, values.dtype,
                       fastpath=True)


@functools.cache
def _pandas_index_type() -> type:
    """The pandas ``Index`` type, as xarray's own indexes hold it (the schema imports xarray only)."""
    probe = xr.Variable(("x",), np.zeros(1))
    return type(PandasIndex.from_variables({"x": probe}, options={}).index)


#: Longest text coordinate whose pandas index :func:`assemble` keeps for reuse (the parameter
#: names of a fit; a map's text labels are built each time).
TEXT_INDEX_CACHE_LABELS = 32


@functools.lru_cache(maxsize=64)
def _text_index(dim: str, labels: tuple[str, ...], dtype: str
                ) -> tuple[PandasIndex, xr.IndexVariable]:
    """The pandas index of a short text coordinate (the parameter names) and its variable.

    Built once per labels; the variable has no attributes.
    Indexes are immutable and xarray shares them between datasets (``copy``, ``isel``); the
    variable's data (the index's adapter) is immutable too, and each dataset takes a shallow
    copy of it (its own attributes).
    """
    var = xr.Variable((dim,), np.array(labels, dtype=dtype))
    index = PandasIndex.from_variables({dim: var}, options={})
    return index, index.create_variables({dim: var})[dim]


def _direct_variables(data_vars: Mapping[str, Any], coords: Mapping[str, Any],
                      fresh: set[str]) -> tuple[dict[str, xr.Variable], set[str]] | None:
    """All entries as Variables and the coordinate names, or None where the public path must.

    Variables not named in ``fresh`` and every DataArray's Variable are shallow copies.
    """
    variables: dict[str, xr.Variable] = {}
    for group in (data_vars, coords):  # the public constructor's order of variables and dims
        for name, value in group.items():
            if isinstance(value, xr.DataArray):
                if value.coords:
                    return None
                value = value.variable.copy(deep=False)
            elif isinstance(value, xr.Variable):
                if name not in fresh:
                    value = value.copy(deep=False)
            elif isinstance(value, tuple):
                try:
                    value = xr.Variable(*value)
                except (TypeError, ValueError):
                    return None
            if not isinstance(value, xr.Variable) or not isinstance(name, str) or (
                    name in variables):
                return None
            if name in value.dims and (value.dims != (name,) or group is data_vars):
                return None  # xarray's rules: an index coordinate, or a refusal
            variables[name] = value
    return variables, set(coords)
