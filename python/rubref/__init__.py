"""rubref: numerical reference for partial rotor-stator rub (docs/python.md).

The C++ library's front doors, as the command line has them: SI units, the paper's parameters by
default, parameters overridden by keyword arguments named as in a parameter file
(``rubref.default_parameters()``: ``m_kg``, ``clearance_m``, ``mu``, ``k1_N_m``, ...;
``clearance=`` is a shorthand for ``clearance_m``). Arrays are numpy arrays; every JSON the command
line writes comes back as the same dict. Bad input raises ``rubref.InputError`` (a ``ValueError``)
with the library's one-line message; a failed integration raises ``rubref.NumericalError`` (a
``RuntimeError``).
"""

import json as _json

import numpy as _np

from ._rubref import (  # noqa: F401  (re-exported)
    InputError,
    NumericalError,
    __version__,
    commit,
    continuation,
    default_parameters,
    orbit,
    rig,
    simulate,
    variants,
)
from . import _rubref

__all__ = [
    "InputError", "NumericalError", "__version__", "commit", "continuation", "default_parameters", "identify", "loop", "orbit",
    "read_order_table", "read_record", "rig", "simulate", "simulate_batch", "study", "study_merge", "validate", "variants", "write_record",
]

_REQUIRED_COLUMNS = ("t_s", "x_m", "y_m", "speed_rpm")


def _paths(paths):
    if isinstance(paths, (str, bytes)) or hasattr(paths, "__fspath__"):
        paths = [paths]
    return [str(p) for p in paths]


def identify(paths, **settings):
    """Identification of paper section 4 on record files (one path or a list): the same dict as
    ``rubref identify``'s identification.json. Settings: clearance, linear (a dict of the linear
    part's parameters, as a parameter file has them, when it is known), averaging ('auto', 'on', 'off'),
    law_method ('auto', 'samples', 'weak-form'), library, rho, orbit_fit, reidentify, bootstrap."""
    return _rubref.identify(_paths(paths), **settings)


_TABLE_SETTINGS = ("amplitude", "amplitude_unit", "phase", "phase_unit", "scale", "probe_angle")


def _table_conventions(settings):
    unknown = [k for k in settings if k not in _TABLE_SETTINGS]
    if unknown:
        raise InputError(f"unknown setting '{unknown[0]}' for an order-tracked table (known: {', '.join(_TABLE_SETTINGS)})")
    angle = settings.pop("probe_angle", None)
    if angle is None:
        angles = {}
    elif isinstance(angle, dict):
        angles = {str(k): float(v) for k, v in angle.items()}
    else:
        angles = {"": float(angle)}
    return dict(settings, probe_angles=angles)


def read_order_table(path, **conventions):
    """An order-tracked table (docs/data-format.md) as ``{'rpm': array, 'orders': [{'probe', 'order',
    'probe_angle_deg', 'vector_m': complex array (0-to-peak, m; the reading is Re(v e^{j k theta}),
    theta the shaft angle after the keyphasor), ...}], 'notes', 'conventions'}``, rows in rising
    speed. Conventions the file does not declare: amplitude ('0-peak', 'pk-pk', 'rms'),
    amplitude_unit ('m', 'mm', 'um', 'mil', 'V', 'mV'), phase ('lead', 'lag'), phase_unit ('deg',
    'rad'), scale (mV/um, for volts), probe_angle (degrees, or {probe: degrees})."""
    return _rubref.read_order_table(str(path), **_table_conventions(dict(conventions)))


def loop(paths, **settings):
    """The loop on record files (one path or a list): fit, residual trace, effects, refit; the
    same dict as ``rubref loop``'s report.json. Settings: clearance, mass, max_effects. On one
    order-tracked table (docs/real-data.md) the settings are its conventions, as
    ``read_order_table`` takes them."""
    paths = _paths(paths)
    if any(_rubref.is_order_table(p) for p in paths):
        if len(paths) != 1:
            raise InputError(f"an order-tracked table is fitted alone: give one table, not {len(paths)} files")
        return _rubref.loop_table(paths[0], **_table_conventions(dict(settings)))
    return _rubref.loop(paths, **settings)


def study(spec, out, shard="1/1", threads=0):
    """A parameter study (docs/studies.md) into the folder ``out``: ``spec`` is a SPEC file's
    path or the same object as a dict. Resumes a folder of the same study; ``shard="i/N"``
    computes one shard of a job array. Returns {"computed", "already", "complete", "summary"}:
    the summary (summary.json as a dict) once the whole study is in, else None. The table is
    ``out/points.csv`` (``read_record`` does not read it: it is a table; use numpy or pandas)."""
    if isinstance(spec, dict):
        text, source = _json.dumps(spec), "<dict>"
    else:
        with open(spec, encoding="utf-8") as f:
            text, source = f.read(), str(spec)
    return _rubref._study(text, source, str(out), str(shard), int(threads))


def study_merge(dirs, out=None, threads=0):
    """Assembles a study's shards from one or more folders into ``out`` (default: the first);
    returns the summary (summary.json as a dict)."""
    dirs = _paths(dirs)
    return _rubref._study_merge(dirs, str(out) if out is not None else dirs[0], int(threads))


def validate(case, candidate):
    """Another code's output (a record file) against a golden case file: the same dict as
    ``rubref validate --json`` gives for one case (verdict, errors, diagnosis)."""
    return _rubref.validate(str(case), str(candidate))


def read_record(path):
    """A record file (docs/data-format.md) as ``{'columns': {name: array}, 'metadata': {key: text}}``."""
    return _rubref.read_record(str(path))


def write_record(path, columns, metadata=None):
    """Writes a record file: ``columns`` maps names to equal-length 1-D arrays and must hold
    t_s, x_m, y_m and speed_rpm (written first, in that order); ``metadata`` maps keys to values
    (numbers are written in the shortest form that reads back exactly). The file is checked to
    read back before it replaces anything (written atomically)."""
    cols = {str(k): _np.asarray(v, dtype=float) for k, v in columns.items()}
    for name, values in cols.items():
        if values.ndim != 1:
            raise InputError(f"column '{name}' must be 1-D (got shape {values.shape})")
    order = [c for c in _REQUIRED_COLUMNS if c in cols] + [c for c in cols if c not in _REQUIRED_COLUMNS]
    meta = {}
    for k, v in (metadata or {}).items():
        meta[str(k)] = repr(float(v)) if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v)
    _rubref.write_record(str(path), {k: v.tolist() for k, v in cols.items()}, meta, order)


def simulate_batch(rpm, variant="identified", clearance=None, settle_revs=200, revs=20, samples_per_rev=128, stepper="dopri5",
                   threads=0, **params):
    """Steady runs over arrays: ``rpm`` and any parameter (``clearance`` or a parameter file's key)
    may be a scalar or a 1-D array; arrays must have one length n, scalars are repeated. The n
    runs go to the thread pool with the GIL released (``threads``: 0 = RUBREF_THREADS, else every
    core; the results do not depend on it). Returns a dict of length-n arrays of the orbit
    summaries (max_radius_m, max_y_m, max_normal_force_N, period_revs, ..., regime,
    backward_whirl), in row order."""
    if clearance is not None:
        if "clearance_m" in params:
            raise InputError("give the clearance once: clearance or clearance_m")
        params["clearance_m"] = clearance
    columns = {"rpm": rpm, **params}
    arrays = {k: _np.asarray(v, dtype=float) for k, v in columns.items()}
    n = None
    for k, a in arrays.items():
        if a.ndim > 1:
            raise InputError(f"'{k}' must be a scalar or a 1-D array (got shape {a.shape})")
        if a.ndim == 1:
            if n is not None and a.shape[0] != n:
                raise InputError(f"'{k}' has {a.shape[0]} values, another array has {n}")
            n = a.shape[0]
    n = 1 if n is None else n
    full = {k: (_np.full(n, float(a)) if a.ndim == 0 else a).tolist() for k, a in arrays.items()}
    speeds = full.pop("rpm")
    if threads < 0:
        raise InputError("threads must be >= 0")
    return _rubref._simulate_batch(variant, speeds, full, settle_revs, revs, samples_per_rev, stepper, threads)
