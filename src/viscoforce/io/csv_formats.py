"""Generic CSV/TSV readers with ``name (unit)`` headers: curves, spectra, drive traces, Prony tables.

Table rules (every reader):

* The first line that is neither blank nor a ``#`` comment is the header; every cell reads
  ``name (unit)`` (the header grammar shared by every table reader here), except the label
  columns ``curve`` and ``segment``, which take no unit. A column without a unit is an error
  (:class:`~viscoforce.exceptions.UnitError`), so is a unit unknown for the column's quantity
  (the message names the column). Columns whose name is not known here are ignored and listed in
  ``attrs["ignored_columns"]``.
* The delimiter is sniffed from the header line: tab, then semicolon, then comma (the one that
  splits it into the most cells). With a semicolon or tab delimiter, decimal commas (``1,5``) are
  accepted as well as points.
* Units are converted to SI with :func:`viscoforce.units.unit_factor`; a phase takes ``deg``,
  ``degree``, ``°`` or ``rad`` and is stored in degrees.
* An empty or non-numeric cell is an error naming the column, the data row and the file line (the
  only exception: empty ``mean_force`` cells of a spectrum, NaN = unknown); so is a line with
  more fields than the header, or too few for a column read. One trailing delimiter (on the
  header, the data rows or both) is an unnamed empty column; a value in it is an error.
* A value beyond the physical range of its quantity (:data:`viscoforce.io.quality.
  PHYSICAL_RANGES`, in SI after the unit conversion, which may not overflow) is an error naming
  the column, the row, the cell and the range: e.g. a stiffness must be finite, > 0 and <= 1e10
  N/m, a phase within ±360°, a frequency > 0 and <= 1 GHz. Such values are no measurement (a
  wrong unit, a damaged file) and would overflow downstream. So is a column whose largest
  magnitude is below the smallest scale of its quantity (:data:`viscoforce.io.quality.
  SMALLEST_SCALES`, e.g. a force column of 1e-309 N: it underflows downstream), and a time series
  that steps by less than :data:`~viscoforce._limits.MIN_TIME_STEP`. A spring constant or
  sensitivity given to the reader lies in :data:`~viscoforce._limits.SPRING_CONSTANT_RANGE` /
  :data:`~viscoforce._limits.SENSITIVITY_RANGE`.
* Bounded reading: a file above :data:`~viscoforce._limits.MAX_CSV_BYTES` (1 GB) is refused
  before it is read, a table of more than :data:`~viscoforce._limits.MAX_CSV_ROWS` (1e7) rows
  (a drive trace: :data:`~viscoforce._limits.MAX_TRACE_ROWS`) before it is parsed (estimated
  from the size and the first lines) or after that many rows; the numeric columns are parsed
  straight to float64 by pandas' C parser and unknown columns are skipped, so reading takes a
  small multiple of the data it returns (about 3x for curves and traces, 6x for a spectrum with
  its derived variables). A 1e6-row table (~30 MB) reads in about 0.3 s. The first
  :data:`_PROBE_ROWS` rows are parsed first, so a file of text is refused at once; text further
  down is found chunk by chunk (:data:`_CHUNK_ROWS` rows), not by turning whole columns into
  Python strings.
* Text encodings: UTF-8 (with or without a BOM), else Latin-1; UTF-16/32 text is refused with
  "save it as UTF-8".
* The file is only read (opened read-only, never written).

Time series (:func:`read_curves_csv`): ``time`` [time], ``force`` [force] and/or ``deflection``
[length, or V with ``sensitivity``], ``height`` (or ``position`` / ``z``) [length], optional
``segment`` labels (mapped to approach / pause / modulation / retract / other; the label itself
is kept in ``segment_type``), optional ``curve`` labels (several curves in one file, each curve's
rows in file order), optional per-curve ``x``, ``y`` [length]. Time must increase strictly within
each curve (a repeated time is named as a duplicated row, a curve label that starts again after
other curves as a duplicated curve); it is kept as recorded. A curve that repeats an earlier one
sample for sample is refused.

Spectra (:func:`read_spectrum_csv`, the SPEC's "Spectrum CSV"): ``frequency (Hz)`` or ``omega
(rad/s)``; a magnitude ``stiffness (N/m)``, or ``amplitude (1)`` (relative a = |F1|/F̄, needs
``mean_force`` and a drive amplitude), or ``force_amplitude (N)`` with ``drive_amplitude (m)``;
``phase (deg)`` or ``phase (rad)``; optional ``<column>_stderr (<unit>)`` (converted like the
column, stored as ``<name>_stderr``; a derived stiffness gets its stderr by error propagation
when the inputs' stderrs are given), ``mean_force (N)`` (else NaN), ``drive_amplitude (m)``,
``mean_indentation (m)``, and a ``curve`` label column that adds a ``curve`` dim (every curve must
have the same frequencies). A ``phase (rad)`` column whose values are evidently degrees is refused
(:data:`RAD_PHASE_LIMIT`). The spectrum gets the ``quality`` flags, their comment and the
``phase_lag``, ``drag``, ``phase_reference`` and ``quality_summary`` attrs that a JPK modulation
spectrum gets (:mod:`viscoforce.io.quality`; one function for both readers):
no correction is applied here (``viscoforce.experiments.modulation.correct_spectrum`` does it),
and the height signal the file's phase was measured against is unknown.

Quality of a measured spectrum (:func:`viscoforce.io.quality.spectrum_quality`, shared with
:mod:`viscoforce.experiments.modulation`): 1 ``phase_outside_passive_range`` where the phase as
stored (after whatever correction was applied) is outside (0°, 90°), which a passive viscoelastic
sample cannot give; else 2 ``low_signal`` where ``stiffness`` < 3·``stiffness_stderr``; else 0.
Points are flagged, never dropped.

Layout: this module is the readers' public home and re-exports every name it has always had; the
code lives in :mod:`viscoforce.io._csv_header` (header grammar, encoding, format detection's
messages), :mod:`viscoforce.io._csv_table` (the bounded table reader ``_Table``, its checks),
:mod:`viscoforce.io._csv_columns` (units, options, curve groups),
:mod:`viscoforce.io.csv_curves`, :mod:`viscoforce.io.csv_spectrum` and
:mod:`viscoforce.io.csv_small_tables` (drive traces, Prony tables); a setting is changed where
it is used (e.g. ``_csv_table.MAX_CSV_ROWS``, ``csv_small_tables.MAX_TRACE_ROWS``).
"""

from __future__ import annotations

from viscoforce._limits import MAX_CSV_BYTES as MAX_CSV_BYTES
from viscoforce._limits import MAX_CSV_ROWS as MAX_CSV_ROWS
from viscoforce._limits import MAX_TRACE_ROWS as MAX_TRACE_ROWS
from viscoforce.io._csv_columns import _ANGLE as _ANGLE
from viscoforce.io._csv_columns import _CALIBRATION_RANGES as _CALIBRATION_RANGES
from viscoforce.io._csv_columns import _curve_coord as _curve_coord
from viscoforce.io._csv_columns import _factor as _factor
from viscoforce.io._csv_columns import _groups as _groups
from viscoforce.io._csv_columns import _ignored as _ignored
from viscoforce.io._csv_columns import _option as _option
from viscoforce.io._csv_columns import _quantity as _quantity
from viscoforce.io._csv_columns import _sensitivity as _sensitivity
from viscoforce.io._csv_header import _DELIMITERS as _DELIMITERS
from viscoforce.io._csv_header import _EXAMPLE_UNITS as _EXAMPLE_UNITS
from viscoforce.io._csv_header import _HEAD_BYTES as _HEAD_BYTES
from viscoforce.io._csv_header import _HEADER as _HEADER
from viscoforce.io._csv_header import _LABELS as _LABELS
from viscoforce.io._csv_header import _MAX_HEADER_SCAN as _MAX_HEADER_SCAN
from viscoforce.io._csv_header import _SPECTRUM_MAGNITUDES as _SPECTRUM_MAGNITUDES
from viscoforce.io._csv_header import _delimiter as _delimiter
from viscoforce.io._csv_header import _encoding as _encoding
from viscoforce.io._csv_header import _excerpt as _excerpt
from viscoforce.io._csv_header import _find_header as _find_header
from viscoforce.io._csv_header import _first_data_line as _first_data_line
from viscoforce.io._csv_header import _header_cells as _header_cells
from viscoforce.io._csv_header import _split as _split
from viscoforce.io._csv_header import encoding_problem as encoding_problem
from viscoforce.io._csv_header import header_names as header_names
from viscoforce.io._csv_header import header_problem as header_problem
from viscoforce.io._csv_header import sniff_header as sniff_header
from viscoforce.io._csv_table import _CHUNK_ROWS as _CHUNK_ROWS
from viscoforce.io._csv_table import _PROBE_ROWS as _PROBE_ROWS
from viscoforce.io._csv_table import _SPECIAL_STARTS as _SPECIAL_STARTS
from viscoforce.io._csv_table import _bad_line as _bad_line
from viscoforce.io._csv_table import _chunks as _chunks
from viscoforce.io._csv_table import _Column as _Column
from viscoforce.io._csv_table import _head_of as _head_of
from viscoforce.io._csv_table import _more_delimiters as _more_delimiters
from viscoforce.io._csv_table import _odd_lines as _odd_lines
from viscoforce.io._csv_table import _parse as _parse
from viscoforce.io._csv_table import _parse_header as _parse_header
from viscoforce.io._csv_table import _read_table as _read_table
from viscoforce.io._csv_table import _refuse_text as _refuse_text
from viscoforce.io._csv_table import _scale as _scale
from viscoforce.io._csv_table import _size as _size
from viscoforce.io._csv_table import _skipped_lines as _skipped_lines
from viscoforce.io._csv_table import _Table as _Table
from viscoforce.io._csv_table import _TextCell as _TextCell
from viscoforce.io.csv_curves import _SEGMENT_SHORT as _SEGMENT_SHORT
from viscoforce.io.csv_curves import _SEGMENT_WORDS as _SEGMENT_WORDS
from viscoforce.io.csv_curves import CURVES_COLUMNS as CURVES_COLUMNS
from viscoforce.io.csv_curves import _refuse_repeated_curves as _refuse_repeated_curves
from viscoforce.io.csv_curves import read_curves_csv as read_curves_csv
from viscoforce.io.csv_curves import segment_label as segment_label
from viscoforce.io.csv_small_tables import MAX_PRONY_ROWS as MAX_PRONY_ROWS
from viscoforce.io.csv_small_tables import PRONY_COLUMNS as PRONY_COLUMNS
from viscoforce.io.csv_small_tables import TRACE_COLUMNS as TRACE_COLUMNS
from viscoforce.io.csv_small_tables import _required as _required
from viscoforce.io.csv_small_tables import _table_for as _table_for
from viscoforce.io.csv_small_tables import read_prony_moduli as read_prony_moduli
from viscoforce.io.csv_small_tables import read_trace as read_trace
from viscoforce.io.csv_spectrum import RAD_PHASE_LIMIT as RAD_PHASE_LIMIT
from viscoforce.io.csv_spectrum import SPECTRUM_COLUMNS as SPECTRUM_COLUMNS
from viscoforce.io.csv_spectrum import _check_rad_phase as _check_rad_phase
from viscoforce.io.csv_spectrum import _refuse_repeated_frequency as _refuse_repeated_frequency
from viscoforce.io.csv_spectrum import _relative as _relative
from viscoforce.io.csv_spectrum import _stderr_map as _stderr_map
from viscoforce.io.csv_spectrum import read_spectrum_csv as read_spectrum_csv

__all__ = ["CURVES_COLUMNS", "RAD_PHASE_LIMIT", "SPECTRUM_COLUMNS", "read_curves_csv",
           "read_spectrum_csv", "segment_label", "sniff_header"]
