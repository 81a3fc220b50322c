"""rubref: numerical reference for partial rotor-stator rub (docs/python.md).

The C++ library's front doors, as the command line has them: SI units, the paper's parameters by
default, parameters overridden by keyword arguments named as in a parameter file
(``rubref.default_parameters()``: ``m_kg``, ``clearance_m``, ``mu``, ``k1_N_m``, ...;
``clearance=`` is a shorthand for ``clearance_m``). Arrays are numpy arrays; every JSON the command
line writes comes back as the same dict. Bad input raises ``rubref.InputError`` (a ``ValueError``)
with a one-line message; a failed integration raises ``rubref.NumericalError`` (a
``RuntimeError``). Ctrl-C stops a long call within a fraction of a second (KeyboardInterrupt),
leaving nothing partial. ``help(rubref.simulate)`` lists each argument's unit, default and range.
"""

import functools as _functools
import inspect as _inspect
import json as _json
import logging as _logging
import numbers as _numbers
import os as _os

import numpy as _np

from ._rubref import (  # noqa: F401  (re-exported)
    InputError,
    NumericalError,
    __version__,
    commit,
    default_parameters,
    steppers,
    variants,
)
from . import _rubref

__all__ = [
    "InputError", "NumericalError", "__version__", "commit", "continuation", "default_parameters", "golden_dir", "identify", "loop",
    "orbit", "read_order_table", "read_record", "rig", "simulate", "simulate_batch", "steppers", "study", "study_merge", "validate",
    "variants", "write_record",
]

_SETTINGS = _rubref._settings()
_DEFAULTS = _rubref._defaults()
_PARAMETER_KEYS = list(default_parameters())
_REQUIRED_COLUMNS = ("t_s", "x_m", "y_m", "speed_rpm")
_log = _logging.getLogger("rubref")


_row = _rubref._setting  # the registry's row (ref/model/settings.hpp) of a name in a scope, else the shared one


def _default(scope, name):
    r = _row(scope, name)
    return int(r["default"]) if r["whole"] else r["default"]


# ---------------------------------------------------------------------------------------------
# Arguments: each public function declares its keywords' kinds; the wrapper checks names (with the
# library's did-you-mean), converts types (one-line InputError) and writes the docstring.

class _Arg:
    """One argument: its kind (how it is checked), its text, and the registry row it documents."""

    def __init__(self, kind, text="", row=None, unit=None, optional=False):
        self.kind, self.text, self.row, self.unit, self.optional = kind, text, row, unit, optional

    def doc(self, name, default):
        if self.row is not None:
            r = _row(*self.row)
            text = r["description"] + (f" [{r['unit']}]" if r["unit"] not in ("", "-") else "")
            valid = r["range"]
            shown = _default(*self.row)
        else:
            text, valid, shown = self.text + (f" [{self.unit}]" if self.unit else ""), "", default
        if default is _inspect.Parameter.empty:
            tail = "required"
        elif default is None and self.row is not None:
            tail = f"default {shown!r} (None: the library's)"
        else:
            tail = f"default {default!r}"
        return f"    {name} ({_KIND_WORDS[self.kind]}): {text}; {tail}" + (f"; valid: {valid}" if valid else "")


_KIND_WORDS = {
    "number": "number", "count": "whole number", "text": "str", "flag": "bool", "numbers": "1-D array of numbers",
    "texts": "str or list of str", "paths": "path or list of paths", "path": "path", "dict": "dict", "progress": "None, bool or callable",
    "columns": "dict of name: 1-D array", "any": "object", "arrays": "number or 1-D array",
}


def _type_name(v):
    return type(v).__name__


def _is_real(v):
    return isinstance(v, _numbers.Real) and not isinstance(v, (bool, _np.bool_))


def _convert(where, name, kind, value, optional):
    """``value`` as the kind the library takes, or InputError naming the argument and what it got."""
    if value is None and optional:
        return None
    shown = repr(value) if len(repr(value)) <= 40 else repr(value)[:37] + "..."
    bad = f"{where}: '{name}' must be a {_KIND_WORDS[kind]} (got {_type_name(value)} {shown})"
    if kind == "number":
        if not _is_real(value):
            raise InputError(bad)
        return float(value)
    if kind == "count":
        if isinstance(value, _numbers.Integral) and not isinstance(value, (bool, _np.bool_)):
            return int(value)
        if _is_real(value) and float(value).is_integer():
            return int(value)
        raise InputError(bad)
    if kind in ("text", "path"):
        if kind == "path" and hasattr(value, "__fspath__"):
            value = _os.fspath(value)
        if not isinstance(value, str):
            raise InputError(bad)
        return value
    if kind == "flag":
        if not isinstance(value, (bool, _np.bool_)):
            raise InputError(bad)
        return bool(value)
    if kind == "numbers":
        a = _np.asarray(value) if not isinstance(value, str) else None
        if a is None or a.ndim != 1 or not (_np.issubdtype(a.dtype, _np.number) and not _np.issubdtype(a.dtype, _np.bool_)):
            raise InputError(bad)
        return [float(v) for v in a]
    if kind == "arrays":
        if _is_real(value):
            return float(value)
        a = _np.asarray(value) if not isinstance(value, str) else None
        if a is None or not _np.issubdtype(a.dtype, _np.number) or _np.issubdtype(a.dtype, _np.bool_):
            raise InputError(bad)
        return a.astype(float)
    if kind == "texts":
        if isinstance(value, str):
            return [value]
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise InputError(bad)
        return list(value)
    if kind == "paths":
        items = [value] if isinstance(value, (str, bytes)) or hasattr(value, "__fspath__") else value
        try:
            items = [_os.fspath(p) for p in items]
        except TypeError:
            raise InputError(bad) from None
        if not all(isinstance(p, str) for p in items):
            raise InputError(bad)
        return items
    if kind in ("dict", "columns"):
        if not isinstance(value, dict):
            raise InputError(bad)
        return value
    if kind == "progress":
        if value is None or isinstance(value, bool) or callable(value):
            return value
        raise InputError(bad)
    return value


def _front_door(args, params=None, returns="", renamed=None):
    """Checks a public function's keywords and types and writes its docstring. ``args``: {name:
    _Arg}; ``params``: the kind of the model parameters taken as **keywords (None: none);
    ``renamed``: {old: message} for names the library spells otherwise."""

    def wrap(f):
        sig = _inspect.signature(f)
        named = [n for n, p in sig.parameters.items() if p.kind is not p.VAR_KEYWORD]
        where = f.__name__

        @_functools.wraps(f)
        def call(*a, **kw):
            for k in kw:
                if k in named or (params is not None and k in _PARAMETER_KEYS):
                    continue
                if renamed and k in renamed:
                    raise InputError(f"{where}: unknown keyword '{k}': {renamed[k]}")
                candidates = named + (_PARAMETER_KEYS if params is not None else [])
                raise InputError(f"{where}: unknown keyword '{k}'" + (_rubref._did_you_mean(k, candidates) or _by_meaning(k, args, params)))
            try:
                bound = sig.bind(*a, **kw)
            except TypeError as e:
                raise InputError(f"{where}: {e}") from None
            bound.apply_defaults()
            for name, value in list(bound.arguments.items()):
                if sig.parameters[name].kind is _inspect.Parameter.VAR_KEYWORD:
                    bound.arguments[name] = {k: _convert(where, k, params, v, False) for k, v in value.items()}
                else:
                    spec = args[name]
                    bound.arguments[name] = _convert(where, name, spec.kind, value, spec.optional or sig.parameters[name].default is None)
            return f(*bound.args, **bound.kwargs)

        lines = [_inspect.cleandoc(f.__doc__ or ""), "", "Arguments:"]
        for name in named:
            lines.append(args[name].doc(name, sig.parameters[name].default))
        if params is not None:
            lines.append("    **params: model parameters by their parameter-file keys (default_parameters(): "
                         + ", ".join(_PARAMETER_KEYS) + ")" + ("; each a number or a 1-D array" if params == "arrays" else ""))
        if returns:
            lines += ["", "Returns: " + returns]
        call.__doc__ = "\n".join(lines)
        return call

    return wrap


def _by_meaning(word, args, params):
    """"; did you mean 'rpm' (shaft speed [rpm])?" for a word that is no keyword's spelling but
    names what one is (its registry row's file key or description): 'speed' is the rpm."""
    for r in _SETTINGS:  # a model parameter by its command-line flag or field name: k1 is k1_N_m
        if params is not None and r["scope"] == "model" and word in (r["name"], r["flag"]) and r["key"] != word:
            return f"; did you mean '{r['key']}' (the parameter file's key of --{r['flag']})?"
    for name, spec in args.items():
        if spec.row is None:
            continue
        r = _row(*spec.row)
        if word.lower() in r["key"].lower().split("_") + r["description"].lower().replace(",", " ").split():
            return f"; did you mean '{name}' ({r['description']} [{r['unit']}])?"
    return ""


def _progress_sink(progress, default_on):
    """A long call's progress lines: True (or None where on by default) to the 'rubref' logger at
    INFO (silent until logging is configured), a callable gets each line, False none."""
    if progress is None:
        progress = default_on
    if progress is True:
        return _log.info
    return progress or None


# The arguments several functions share, documented from the registry.
_VARIANT = _Arg("text", "contact law: one of " + ", ".join(variants()))
_CLEARANCE = _Arg("number", row=("model", "clearance"), optional=True)
_RECORDS_CLEARANCE = _Arg("number", "the clearance, for records whose metadata has no clearance_m (None: theirs)", unit="m", optional=True)
_STEPPER = _Arg("text", "integrator: one of " + ", ".join(steppers()))
_INTEGRATION = {"rtol": _Arg("number", row=("integration", "rtol"), optional=True),
                "atol": _Arg("number", row=("integration", "atol"), optional=True),
                "dt": _Arg("number", row=("integration", "dt"), optional=True)}
_INITIAL = _Arg("numbers", "start x, y, vx, vy at t = 0", unit="m, m, m/s, m/s", optional=True)
_PROGRESS = _Arg("progress", "progress lines: True for the 'rubref' logger (INFO), a callable for each line, False for none")
_SUMMARY_KEYS = ("max_radius_m, max_y_m, peak_to_peak_x_m, peak_to_peak_y_m, max_normal_force_N, max_penetration_m, "
                 "contact_episodes_per_rev, contact_fraction, period_revs, backward_whirl, regime")


@_front_door({"variant": _VARIANT, "rpm": _Arg("number", row=("run", "rpm")), "clearance": _CLEARANCE,
              "settle_revs": _Arg("count", row=("run", "settle_revs")), "revs": _Arg("count", row=("run", "record_revs")),
              "samples_per_rev": _Arg("count", row=("run", "samples_per_rev")), "stepper": _STEPPER, **_INTEGRATION, "initial": _INITIAL},
             params="number",
             returns="dict: t (s), x, y (m), vx, vy (m/s), fn (N) as arrays at the recorded samples, and summary (the dict of "
                     "`rubref simulate --summary`: " + _SUMMARY_KEYS + ", ...)")
def simulate(variant="identified", rpm=_default("run", "rpm"), clearance=None, settle_revs=_default("run", "settle_revs"),
             revs=_default("run", "record_revs"), samples_per_rev=_default("run", "samples_per_rev"), stepper="dopri5", rtol=None,
             atol=None, dt=None, initial=None, **params):
    """One steady run (Eq. 1-2): settle_revs revolutions from rest (or ``initial``), then revs recorded."""
    return _rubref._simulate(variant, rpm, clearance, settle_revs, revs, samples_per_rev, stepper, rtol, atol, dt, initial, params)


@_front_door({"rpm": _Arg("arrays", row=("run", "rpm")), "variant": _VARIANT, "clearance": _Arg("arrays", row=("model", "clearance"), optional=True),
              "settle_revs": _Arg("count", row=("run", "settle_revs")), "revs": _Arg("count", row=("run", "record_revs")),
              "samples_per_rev": _Arg("count", row=("run", "samples_per_rev")), "stepper": _STEPPER,
              "threads": _Arg("count", "threads: 0 = RUBREF_THREADS, else every core; the results do not depend on it"),
              "progress": _PROGRESS},
             params="arrays",
             returns="dict of length-n arrays, in row order: " + _SUMMARY_KEYS + " (regime a list of str)")
def simulate_batch(rpm, variant="identified", clearance=None, settle_revs=_default("run", "settle_revs"), revs=_default("run", "record_revs"),
                   samples_per_rev=_default("run", "samples_per_rev"), stepper="dopri5", threads=0, progress=False, **params):
    """Steady runs over arrays: ``rpm`` and any parameter may be a scalar or a 1-D array; arrays
    must have one length n, scalars are repeated. The n runs share the thread pool with the GIL
    released. Progress (off by default) is a line at every twentieth of the runs."""
    if clearance is not None:
        if "clearance_m" in params:
            raise InputError("simulate_batch: give the clearance once: clearance or clearance_m")
        params["clearance_m"] = clearance
    arrays = {k: _np.asarray(v, dtype=float) for k, v in {"rpm": rpm, **params}.items()}
    n = None
    for k, a in arrays.items():
        if a.ndim > 1:
            raise InputError(f"simulate_batch: '{k}' must be a scalar or a 1-D array (got shape {a.shape})")
        if a.ndim == 1:
            if n is not None and a.shape[0] != n:
                raise InputError(f"simulate_batch: '{k}' has {a.shape[0]} values, another array has {n}")
            n = a.shape[0]
    n = 1 if n is None else n
    full = {k: (_np.full(n, float(a)) if a.ndim == 0 else a).tolist() for k, a in arrays.items()}
    speeds = full.pop("rpm")
    return _rubref._simulate_batch(variant, speeds, full, settle_revs, revs, samples_per_rev, stepper, threads,
                                   _progress_sink(progress, False))


@_front_door({"variant": _VARIANT, "rpm": _Arg("number", row=("run", "rpm")), "clearance": _CLEARANCE,
              "periods": _Arg("count", row=("shooting", "periods")), "tolerance": _Arg("number", row=("shooting", "tolerance")),
              "samples_per_rev": _Arg("count", row=("run", "samples_per_rev")), "stepper": _STEPPER, **_INTEGRATION,
              "initial": _Arg("numbers", "first Newton start x, y, vx, vy at t = 0", unit="m, m, m/s, m/s", optional=True)},
             params="number",
             returns="dict: one period's t, x, y, vx, vy, fn arrays and summary (`rubref orbit`'s summary JSON: converged, "
                     "stable, floquet_multipliers [{modulus, ...}], ...)")
def orbit(variant="identified", rpm=_default("run", "rpm"), clearance=None, periods=_default("shooting", "periods"),
          tolerance=_DEFAULTS["shooting_tolerance"], samples_per_rev=_default("run", "samples_per_rev"), stepper="dopri5", rtol=None,
          atol=None, dt=None, initial=None, **params):
    """The steady orbit as a fixed point of the revolution map (Newton shooting), with its Floquet multipliers."""
    return _rubref._orbit(variant, rpm, clearance, periods, tolerance, samples_per_rev, stepper, rtol, atol, dt, initial, params)


_RANGE_RENAMED = "a continuation's range is from_ and to (the command line's --from and --to)"


@_front_door({"variant": _VARIANT, "parameter": _Arg("text", "the parameter followed: speed, clearance, unbalance or mu"),
              "from_": _Arg("number", row=("continuation", "from"), optional=True),
              "to": _Arg("number", row=("continuation", "to"), optional=True),
              "direction": _Arg("text", "up or down"), "rpm": _Arg("number", row=("continuation", "rpm")), "clearance": _CLEARANCE,
              "periods": _Arg("count", row=("continuation", "periods")), "max_step": _Arg("number", row=("continuation", "max_step")),
              "max_points": _Arg("count", row=("continuation", "max_points")),
              "tolerance": _Arg("number", row=("shooting", "tolerance"))},
             params="number", renamed={"start": _RANGE_RENAMED, "end": _RANGE_RENAMED, "from": _RANGE_RENAMED},
             returns="dict: branch (branch.csv's columns as arrays: speed_rpm (or the parameter's column), x0_m, y0_m, vx0_m_s, "
                     "vy0_m_s, max_radius_m, stable, ...) and summary (summary.json: folds [{speed_rpm, ...}], grazings, period doublings)")
def continuation(variant="identified", parameter="speed", from_=None, to=None, direction="up", rpm=_default("continuation", "rpm"),
                 clearance=None, periods=_default("continuation", "periods"), max_step=_default("continuation", "max_step"),
                 max_points=_default("continuation", "max_points"), tolerance=_DEFAULTS["shooting_tolerance"], **params):
    """A branch of periodic orbits followed over a parameter (pseudo-arclength continuation), with its folds."""
    return _rubref._continuation(variant, parameter, from_, to, direction, rpm, clearance, periods, max_step, max_points, tolerance, params)


@_front_door({"path": _Arg("path", "a record file (docs/data-format.md)")},
             returns="dict: columns ({name: array}) and metadata ({key: text})")
def read_record(path):
    """A record file as arrays and metadata."""
    return _rubref._read_record(path)


@_front_door({"path": _Arg("path", "the record file to write"), "columns": _Arg("columns", "name: equal-length 1-D arrays; t_s, x_m, y_m, speed_rpm required"),
              "metadata": _Arg("dict", "key: value (numbers written in the shortest form that reads back exactly)", optional=True),
              "force": _Arg("flag", "replace a file rubref did not write (as the command line's --force)")})
def write_record(path, columns, metadata=None, force=False):
    """Writes a record file: t_s, x_m, y_m and speed_rpm first, in that order. The file is checked
    to read back before it replaces anything (written atomically); an existing file that rubref
    did not write is refused unless ``force``."""
    cols = {str(k): _np.asarray(v, dtype=float) for k, v in columns.items()}
    for name, values in cols.items():
        if values.ndim != 1:
            raise InputError(f"write_record: column '{name}' must be 1-D (got shape {values.shape})")
    order = [c for c in _REQUIRED_COLUMNS if c in cols] + [c for c in cols if c not in _REQUIRED_COLUMNS]
    meta = {}
    for k, v in (metadata or {}).items():
        meta[str(k)] = repr(float(v)) if _is_real(v) else str(v)
    _rubref._write_record(path, {k: v.tolist() for k, v in cols.items()}, meta, order, force)


@_front_door({"effects": _Arg("texts", "effects to add, e.g. 'preload:F_y=-5' (docs/loop.md)"),
              "speeds": _Arg("numbers", "dwell speeds (None: " + ", ".join(f"{v:g}" for v in _DEFAULTS["rig_speeds"]) + ")", unit="rpm",
                             optional=True),
              "noise": _Arg("number", row=("rig", "noise"), optional=True), "keyphasor": _Arg("flag", "write the keyphasor column"),
              "carry_over": _Arg("flag", "each dwell starts from the previous one's state"),
              "settle_revs": _Arg("count", row=("rig", "settle_revs")), "revs": _Arg("count", row=("rig", "record_revs")),
              "seed": _Arg("count", "the noise's seed: same seed, same bits"), "variant": _VARIANT, "clearance": _CLEARANCE},
             params="number",
             returns="dict: the measurement record's columns and metadata (as read_record gives), and truth (the truth file's dict)")
def rig(effects=(), speeds=None, noise=None, keyphasor=True, carry_over=False, settle_revs=_default("rig", "settle_revs"),
        revs=_default("rig", "record_revs"), seed=_DEFAULTS["rig_seed"], variant="identified", clearance=None, **params):
    """A virtual rig's dwells (one per speed), measured by noisy probes."""
    return _rubref._rig(effects, speeds, noise, keyphasor, carry_over, settle_revs, revs, seed, variant, clearance, params)


@_front_door({"paths": _Arg("paths", "record files"), "clearance": _RECORDS_CLEARANCE,
              "linear": _Arg("dict", "the linear part when it is known, as a parameter file's keys", optional=True),
              "averaging": _Arg("text", "'auto', 'on' or 'off'"), "law_method": _Arg("text", "'auto', 'samples' or 'weak-form'"),
              "library": _Arg("text", "candidate terms (Eq. 4)"), "rho": _Arg("number", row=("frols", "rho")),
              "orbit_fit": _Arg("flag", "refine by fitting the orbit"), "reidentify": _Arg("flag", "re-identify the law's parameters on the orbits"),
              "reid_fit": _Arg("texts", "the parameters re-identified: any of k1, k3, c2, mu, e, clearance (the command line's --reid-fit)"),
              "bootstrap": _Arg("count", row=("identify", "bootstrap"))},
             returns="dict: identification.json's (estimates [{term, value, ...}], linear, law, warnings, ...)")
def identify(paths, clearance=None, linear=None, averaging="auto", law_method="auto", library=_DEFAULTS["identify_library"],
             rho=_default("frols", "rho"), orbit_fit=True, reidentify=False, reid_fit=tuple(_DEFAULTS["identify_reid_fit"]),
             bootstrap=_default("identify", "bootstrap")):
    """The identification of paper section 4 (Eq. 3-5) on record files."""
    return _rubref._identify(paths, clearance, linear, averaging, law_method, library, rho, orbit_fit, reidentify, reid_fit, bootstrap)


_TABLE_ARGS = {
    "amplitude": _Arg("text", "an order table's amplitude: '0-peak', 'pk-pk' or 'rms' (None: as the file declares)", optional=True),
    "amplitude_unit": _Arg("text", "'m', 'mm', 'um', 'mil', 'V' or 'mV'", optional=True),
    "phase": _Arg("text", "'lead' or 'lag'", optional=True), "phase_unit": _Arg("text", "'deg' or 'rad'", optional=True),
    "scale": _Arg("number", "probe sensitivity, for volts", unit="mV/um", optional=True),
    "probe_angle": _Arg("any", "degrees, or {probe: degrees}", optional=True),
}


def _conventions(where, amplitude, amplitude_unit, phase, phase_unit, scale, probe_angle):
    if probe_angle is None:
        angles = {}
    elif isinstance(probe_angle, dict):
        angles = {str(k): _convert(where, "probe_angle", "number", v, False) for k, v in probe_angle.items()}
    else:
        angles = {"": _convert(where, "probe_angle", "number", probe_angle, False)}
    return (amplitude or "", amplitude_unit or "", phase or "", phase_unit or "", scale, angles)


@_front_door({"path": _Arg("path", "an order-tracked table (docs/data-format.md)"), **_TABLE_ARGS},
             returns="dict: rpm (array, rising), time_s (array, where the table has a time_s column), orders [{probe, order, probe_angle_deg (None: not declared), vector_m (complex "
                     "array, 0-to-peak, the reading Re(v e^{jk theta})), amplitude_column, phase_column}], notes, conventions")
def read_order_table(path, amplitude=None, amplitude_unit=None, phase=None, phase_unit=None, scale=None, probe_angle=None):
    """An order-tracked table (1X amplitude and phase against speed) as complex vectors; the
    conventions the file does not declare are given here."""
    return _rubref._read_order_table(path, *_conventions("read_order_table", amplitude, amplitude_unit, phase, phase_unit, scale, probe_angle))


@_front_door({"paths": _Arg("paths", "record files, or one order-tracked table"), "clearance": _RECORDS_CLEARANCE,
              "mass": _Arg("number", "rotor mass (None: the records' m_kg, else the paper's)", unit="kg", optional=True),
              "max_effects": _Arg("count", row=("trace", "max_effects")), **_TABLE_ARGS,
              "revolutions_per_row": _Arg("number", "an order table's block: the revolutions each row was read over (None: fitted)", optional=True),
              "sweep_rate": _Arg("number", "an order table's run-up or coast-down rate (None: from its time_s column, else fitted)", unit="rpm/s", optional=True),
              "progress": _PROGRESS},
             returns="dict: report.json's (error_before, error_after (the orbit's NRMSE), verdict {claim, named, tentative, explained_share, unexplained, rival, ...}, effects [{name, params, ...}], errors, notes, warnings, ...)")
def loop(paths, clearance=None, mass=None, max_effects=_default("trace", "max_effects"), amplitude=None, amplitude_unit=None, phase=None,
         phase_unit=None, scale=None, probe_angle=None, revolutions_per_row=None, sweep_rate=None, progress=None):
    """The loop (docs/loop.md): fit the paper's model to the records, trace the residual to the
    effects it lacks, refit; errors before and after. On one order-tracked table
    (docs/real-data.md) the table's conventions apply instead of clearance, mass and max_effects.
    Progress (stage by stage) goes to the 'rubref' logger by default."""
    sink = _progress_sink(progress, True)
    if any(_rubref._is_order_table(p) for p in paths):
        if len(paths) != 1:
            raise InputError(f"loop: an order-tracked table is fitted alone: give one table, not {len(paths)} files")
        for name, value in (("clearance", clearance), ("mass", mass)):
            if value is not None:
                raise InputError(f"loop: '{name}' is for record files; an order-tracked table takes amplitude, phase, scale, probe_angle")
        return _rubref._loop_table(paths[0], *_conventions("loop", amplitude, amplitude_unit, phase, phase_unit, scale, probe_angle),
                                   revolutions_per_row or 0.0, sweep_rate or 0.0, sink)
    for name in (*_TABLE_ARGS, "revolutions_per_row", "sweep_rate"):
        if locals()[name] is not None:
            raise InputError(f"loop: '{name}' is an order-tracked table's convention; these are record files")
    return _rubref._loop(paths, clearance, mass, max_effects, sink)


@_front_door({"case": _Arg("path", "a golden case file (golden_dir() holds the installed ones)"),
              "candidate": _Arg("path", "the other code's orbit, a record file")},
             returns="dict: the case's verdict (pass), errors and diagnosis, as `rubref validate --json` gives for one case")
def validate(case, candidate):
    """Another code's output against a golden case."""
    return _rubref._validate(case, candidate)


@_front_door({"spec": _Arg("any", "a SPEC file's path, or the same object as a dict"), "out": _Arg("path", "the study folder"),
              "shard": _Arg("text", "'i/N': one shard of a job array"), "threads": _Arg("count", "threads: 0 = RUBREF_THREADS, else every core"),
              "progress": _PROGRESS},
             returns="dict: computed, already, complete, summary (summary.json's dict once the whole study is in, else None)")
def study(spec, out, shard="1/1", threads=0, progress=False):
    """A parameter study (docs/studies.md) into the folder ``out``, resumed if it holds the same
    study. The table is ``out/points.csv`` (a table: use numpy or pandas). No figures (``rubref
    study`` draws them). Progress (off by default) is the command line's meter."""
    if isinstance(spec, dict):
        text, source = _json.dumps(spec), "<dict>"
    elif isinstance(spec, (str, _os.PathLike)):
        try:
            with open(spec, encoding="utf-8") as f:
                text, source = f.read(), _os.fspath(spec)
        except OSError as e:
            raise InputError(f"study: cannot read the SPEC {_os.fspath(spec)}: {e.strerror}") from None
    else:
        raise InputError(f"study: 'spec' must be a SPEC file's path or a dict (got {_type_name(spec)})")
    return _rubref._study(text, source, out, shard, threads, _progress_sink(progress, False))


@_front_door({"dirs": _Arg("paths", "study folders holding shards"), "out": _Arg("path", "the merged folder (None: the first)", optional=True),
              "threads": _Arg("count", "threads: 0 = RUBREF_THREADS, else every core")},
             returns="the summary (summary.json as a dict)")
def study_merge(dirs, out=None, threads=0):
    """Assembles a study's shards from one or more folders into ``out``."""
    return _rubref._study_merge(dirs, out if out is not None else dirs[0], threads)


def golden_dir():
    """The folder of the golden cases (golden/*.csv): RUBREF_GOLDEN_DIR if set, else where this
    package's build or install put them (``<prefix>/share/rubref/golden``)."""
    from . import _paths
    d = _os.environ.get("RUBREF_GOLDEN_DIR") or _os.path.normpath(_os.path.join(_os.path.dirname(__file__), _paths.GOLDEN_DIR))
    if not _os.path.isdir(d):
        raise InputError(f"golden_dir: {d} does not exist (set RUBREF_GOLDEN_DIR to the golden/ folder)")
    return d
