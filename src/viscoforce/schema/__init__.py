"""Dataset contracts: where every viscoforce dataset is made and checked.

Each kind has a variable table (name → :class:`VariableSpec`: CF/UDUNITS ``units``,
``long_name``, dims, dtype), a builder ``make_<kind>(...)`` taking plain arrays in SI, and a
validator ``validate_<kind>(ds) -> ds`` raising :class:`~viscoforce.exceptions.SchemaError` that
names the missing variable, the wrong unit or the wrong dims. Every kind round-trips through
netCDF3 (``ds.to_netcdf(path, engine="scipy")``) losslessly: integers are int8/int32, flags are
CF ``flag_values``/``flag_meanings`` integers (no bool), text lives in attrs or string
coordinates, and builders refuse attributes netCDF cannot store.

=================  ===========================================  ==================================
kind               dims                                         variables
=================  ===========================================  ==================================
equilibrium        ``r``; scalars                               gap, deformation, pressure,
                                                                undeformed_gap; position, force,
                                                                force_rigid, u_center, h_center,
                                                                contact_radius
trajectory         ``time``; (``profile_time``, ``r``)          position, force, u_center,
                                                                h_center, contact_radius; gap,
                                                                deformation, pressure
spectrum           (extra…, ``omega``)                          stiffness, phase, mean_force,
                                                                force_amplitude, amplitude,
                                                                drive_amplitude, mean_indentation,
                                                                quality, ``<name>_stderr``
curves             ``sample`` (ragged), ``curve``,              time, force, height, deflection,
                   ``segment_table``                            tip_position, segment,
                                                                sample_count, segment_name
fit result         extra…; (extra…, ``param_i``, ``param_j``)   ``<param>``, ``<param>_stderr``,
                                                                correlation, success, redchi,
                                                                aic, bic, modes, fit_stiffness,
                                                                fit_phase (or fit_force)
=================  ===========================================  ==================================

Spectrum units: stiffness |F1|/|δ̂| [N/m], phase χ [degree] (:data:`PHASE_CONVENTION`: the lead of
the force over the compression/indentation, > 0 for a viscoelastic sample), mean_force [N],
force_amplitude [N], amplitude a = |F1|/F̄ [1], drive_amplitude [m], mean_indentation [m].

Pure: imports only numpy, xarray and :mod:`viscoforce.exceptions`.
"""

from __future__ import annotations

from viscoforce.exceptions import SchemaError
from viscoforce.schema._core import (
    EXTRA,
    VariableSpec,
    clean_attrs,
    flag_attrs,
    flag_meanings,
    index_values,
    parameter_names,
    plain_variable,
)
from viscoforce.schema.curves import (
    CURVES_VARIABLES,
    SEGMENT_NAMES,
    make_curves,
    select_curve,
    validate_curves,
)
from viscoforce.schema.equilibrium import (
    EQUILIBRIUM_VARIABLES,
    SIGN_CONVENTION,
    make_equilibrium,
    validate_equilibrium,
)
from viscoforce.schema.fit import (
    FIT_VARIABLES,
    PARAMETER_UNITS,
    SUCCESS_FLAGS,
    make_fit_result,
    parameter_units,
    validate_fit_result,
)
from viscoforce.schema.spectrum import (
    PHASE_CONVENTION,
    QUALITY_COMMENT,
    QUALITY_FLAGS,
    SPECTRUM_VARIABLES,
    complex_stiffness,
    make_spectrum,
    phase_quality,
    validate_spectrum,
)
from viscoforce.schema.tables import data_kind, flat_over
from viscoforce.schema.trajectory import (
    PROFILE_VARIABLES,
    TRAJECTORY_VARIABLES,
    make_trajectory,
    validate_trajectory,
)

__all__ = [
    "SchemaError", "VariableSpec", "EXTRA", "clean_attrs", "plain_variable", "flag_attrs",
    "flag_meanings", "data_kind", "flat_over", "index_values", "parameter_names",
    "EQUILIBRIUM_VARIABLES", "SIGN_CONVENTION", "make_equilibrium", "validate_equilibrium",
    "TRAJECTORY_VARIABLES", "PROFILE_VARIABLES", "make_trajectory", "validate_trajectory",
    "SPECTRUM_VARIABLES", "PHASE_CONVENTION", "QUALITY_FLAGS", "QUALITY_COMMENT", "make_spectrum",
    "validate_spectrum", "complex_stiffness", "phase_quality",
    "CURVES_VARIABLES", "SEGMENT_NAMES", "make_curves", "validate_curves", "select_curve",
    "FIT_VARIABLES", "SUCCESS_FLAGS", "PARAMETER_UNITS", "parameter_units", "make_fit_result",
    "validate_fit_result",
]
