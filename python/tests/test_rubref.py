"""The Python module against the physics and against the command line (ctest label `python`).

Run from ctest with PYTHONPATH at the build's python/ folder, RUBREF_GOLDEN_DIR at golden/ and
RUBREF_COMMAND at the rubref binary (python/CMakeLists.txt)."""

import json
import logging
import math
import os
import signal
import subprocess
import threading
import time
import warnings

import numpy as np
import pytest

import rubref

P = rubref.default_parameters()

# Contact-free runs settle for 200 revolutions at the paper's damping (~40 decay times); what is
# left of the transient and the stepper's error (rtol 1e-10) are far below this share of the orbit.
SETTLED_REL = 1e-6


def closed_form(rpm, t):
    """Eq. 1 without contact, steady state: x = Re(X e^{jwt}), y = Re(-j Y e^{jwt}) with
    X, Y = m e w^2 e^{j phi} / (k - m w^2 + j c w) per axis (ref/model/closed_form.hpp)."""
    w = rpm * 2 * math.pi / 60
    f = P["m_kg"] * P["e_m"] * w * w * np.exp(1j * P["unbalance_phase_rad"])
    X = f / complex(P["k_x_N_m"] - P["m_kg"] * w * w, P["c_x_kg_s"] * w)
    Y = f / complex(P["k_y_N_m"] - P["m_kg"] * w * w, P["c_y_kg_s"] * w)
    rot = np.exp(1j * w * t)
    return (X * rot).real, (-1j * Y * rot).real, abs(X), abs(Y)


def test_contact_free_run_is_the_closed_form():
    r = rubref.simulate(rpm=1200, clearance=5e-3)  # 5 mm: far beyond the ~0.1 mm orbit, below the unit-trap warning's 1 cm
    x, y, ax, ay = closed_form(1200, r["t"])
    assert len(r["t"]) == 20 * 128
    assert np.max(np.abs(r["x"] - x)) <= SETTLED_REL * ax
    assert np.max(np.abs(r["y"] - y)) <= SETTLED_REL * ay
    assert r["summary"]["regime"] == "no_contact"
    assert np.all(r["fn"] == 0.0)


def test_rub_reaches_the_stator_and_no_further_than_its_penetration():
    clearance = 0.2e-3
    r = rubref.simulate(rpm=1600, clearance=clearance)
    s = r["summary"]
    assert s["regime"] != "no_contact"
    assert s["max_normal_force_N"] > 0
    # Samples above the stator are inside it by at most the located peak penetration.
    assert np.max(r["y"]) - clearance <= s["max_penetration_m"] * (1 + 1e-9)
    assert np.all(r["fn"][r["y"] < clearance] == 0.0)


def test_same_numbers_as_the_command_line(tmp_path):
    out = tmp_path / "orbit.csv"
    subprocess.run([os.environ["RUBREF_COMMAND"], "simulate", "--rpm", "1550", "--clearance", "0.3e-3", "--revs", "4", "--out", str(out)],
                   check=True, capture_output=True)
    rec = rubref.read_record(out)
    r = rubref.simulate(rpm=1550, clearance=0.3e-3, revs=4)
    # The CLI writes the shortest decimal that reads back to the same double: equal to the bit.
    assert np.array_equal(rec["columns"]["x_m"], r["x"])
    assert np.array_equal(rec["columns"]["y_m"], r["y"])
    with open(tmp_path / "orbit.summary.json") as f:
        assert json.load(f)["max_radius_m"] == r["summary"]["max_radius_m"]


def test_bad_input_is_an_input_error_with_the_library_message():
    with pytest.raises(rubref.InputError, match=r"unknown keyword 'k1'; did you mean 'k1_N_m' \(the parameter file's key of --k1\)\?"):
        rubref.simulate(k1=1.0)
    with pytest.raises(ValueError, match="variant"):
        rubref.simulate(variant="identifed")
    with pytest.raises(rubref.InputError, match="clearance once"):
        rubref.simulate(clearance=1e-3, clearance_m=1e-3)
    with pytest.raises(rubref.InputError, match="must be a number"):
        rubref.simulate(mu="0.2")
    # A fixed step far beyond RK4's stability bound is refused before integrating.
    with pytest.raises(rubref.InputError, match="dt"):
        rubref.simulate(stepper="rk4", dt=1.0)
    # A setting is named as its keyword argument, never as a command-line flag, with its range
    # and the reason (the settings registry, docs/architecture.md).
    with pytest.raises(rubref.InputError, match=r"^'revs' must be a whole number >= 1 rev \(got 0\): "):
        rubref.simulate(revs=0)
    with pytest.raises(rubref.InputError, match=r"^'samples_per_rev' must be a whole number >= 4"):
        rubref.simulate(samples_per_rev=2)
    with pytest.raises(rubref.InputError, match=r"^'tolerance' must be finite and > 0 m"):
        rubref.orbit(tolerance=-1.0)


def test_batch_equals_single_runs_on_any_thread_count():
    speeds = np.array([1300.0, 1500.0, 1600.0, 1700.0])
    one = rubref.simulate_batch(speeds, clearance=0.3e-3, settle_revs=60, revs=4, threads=1)
    two = rubref.simulate_batch(speeds, clearance=0.3e-3, settle_revs=60, revs=4, threads=2)
    for key in one:
        assert np.array_equal(np.asarray(one[key]), np.asarray(two[key])), key
    single = rubref.simulate(rpm=1600, clearance=0.3e-3, settle_revs=60, revs=4)["summary"]
    assert one["max_radius_m"][2] == single["max_radius_m"]
    assert one["regime"][0] == "no_contact" and one["regime"][2] != "no_contact"
    # Parameters as arrays: one clearance per row.
    cl = rubref.simulate_batch(1600, clearance_m=[0.2e-3, 0.4e-3], settle_revs=60, revs=4)
    assert cl["max_y_m"].shape == (2,)
    with pytest.raises(rubref.InputError, match="values"):
        rubref.simulate_batch([1500, 1600], clearance=[0.2e-3, 0.3e-3, 0.4e-3])


def test_threads_run_concurrently_without_the_gil():
    results = [None, None]

    def run(i):
        results[i] = rubref.simulate(rpm=1600, clearance=0.3e-3, settle_revs=40, revs=2)["summary"]["max_radius_m"]

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results[0] == results[1] is not None


def test_orbit_is_a_stable_fixed_point_of_the_revolution_map():
    o = rubref.orbit(rpm=1600, clearance=0.3e-3)
    s = o["summary"]
    assert s["method"] == "shooting" and s["converged"] and s["stable"]
    assert s["shooting_residual_m"] <= 1e-12
    assert all(m["modulus"] < 1 for m in s["floquet_multipliers"])
    assert len(o["t"]) == 128


def test_continuation_finds_the_jump_fold():
    # The identified law at 0.3 mm: the rubbing branch folds back near 2795 rpm (docs/reproduce.md).
    b = rubref.continuation(from_=1500, to=3000, clearance=0.3e-3)
    folds = b["summary"]["folds"]
    assert len(folds) >= 1
    assert any(2700 < f["speed_rpm"] < 2900 for f in folds)
    assert isinstance(b["branch"]["speed_rpm"], np.ndarray)
    with pytest.raises(rubref.InputError, match="needs from_ and to"):
        rubref.continuation(parameter="mu")
    # One name per quantity: the command line's --from/--to, not another pair.
    with pytest.raises(rubref.InputError, match="range is from_ and to"):
        rubref.continuation(start=1500, end=3000)


def test_records_round_trip_to_the_bit(tmp_path):
    t = np.linspace(0, 0.1, 101)
    cols = {"t_s": t, "x_m": 1e-4 * np.sin(100 * t) / 3, "y_m": 1e-4 * np.cos(100 * t) / 7, "speed_rpm": np.full_like(t, 1600.0)}
    rubref.write_record(tmp_path / "r.csv", cols, {"clearance_m": 0.3e-3, "description": "made in python"})
    back = rubref.read_record(tmp_path / "r.csv")
    for k, v in cols.items():
        assert np.array_equal(back["columns"][k], v), k
    assert float(back["metadata"]["clearance_m"]) == 0.3e-3
    # A record without the required columns is refused and nothing is written.
    with pytest.raises(rubref.InputError):
        rubref.write_record(tmp_path / "bad.csv", {"t_s": t, "x_m": t})
    assert not (tmp_path / "bad.csv").exists()


def test_rig_then_identify_recovers_the_law(tmp_path):
    rec = rubref.rig(noise=0.2e-6, seed=7)
    assert rec["truth"]["effects"] == [] or rec["truth"]["effects"] == {}
    rubref.write_record(tmp_path / "rig.csv", rec["columns"], rec["metadata"])
    ident = rubref.identify(tmp_path / "rig.csv", bootstrap=0)
    k1 = {e["term"]: e["value"] for e in ident["estimates"]}
    # The rig's truth is the paper's identified law; 0.2 um of probe noise leaves k1 within 5 %.
    assert k1["z1"] == pytest.approx(P["k1_N_m"], rel=0.05)


def test_validate_passes_a_golden_case_against_itself():
    case = os.path.join(os.environ["RUBREF_GOLDEN_DIR"], "identified_0.3mm_1600rpm.csv")
    r = rubref.validate(case, case)
    assert r["pass"] is True


def test_version():
    assert rubref.__version__.count(".") == 2


def test_loop_on_records_without_an_effect_claims_none(tmp_path):
    # The rig's truth is the paper's model: the loop must fit it and claim no effect.
    rec = rubref.rig(noise=0.5e-6, seed=3)
    rubref.write_record(tmp_path / "rig.csv", rec["columns"], rec["metadata"])
    report = rubref.loop(tmp_path / "rig.csv")
    assert report["verdict"]["claim"] == "none" and report["verdict"]["named"] == [] and report["effects"] == []
    assert report["verdict"]["unexplained"] is False
    assert report["error_after"] <= report["error_before"]


def test_study_in_shards_equals_one_run_and_names_its_keys(tmp_path):
    spec = {"study": "regime_map", "grid": [{"name": "clearance_m", "values": [2e-4, 3e-4]},
                                            {"name": "speed_rpm", "from": 1300, "to": 2100, "step": 200}]}
    whole = rubref.study(spec, tmp_path / "whole", threads=1)
    assert whole["complete"] and whole["computed"] == 10
    assert whole["summary"]["status"] == {"ok": 10}
    for i in (1, 2):
        part = rubref.study(spec, tmp_path / "shared", shard=f"{i}/2", threads=2)
        assert part["summary"] is None
    merged = rubref.study_merge(tmp_path / "shared")
    assert merged == whole["summary"]
    for f in ("points.csv", "summary.json", "folds.csv"):
        assert (tmp_path / "whole" / f).read_bytes() == (tmp_path / "shared" / f).read_bytes()
    again = rubref.study(spec, tmp_path / "whole")  # complete: nothing computed again
    assert again["computed"] == 0 and again["already"] == 10
    with pytest.raises(rubref.InputError, match="key 'grid\\[1\\].step'"):
        rubref.study({"study": "grid", "grid": [{"name": "mu", "values": [0.2]}, {"name": "speed_rpm", "from": 1, "to": 2, "step": -1}]},
                     tmp_path / "bad")
    assert not (tmp_path / "bad").exists()


def _write_table(path):
    # tests/closed_form_table.py: an isotropic rotor's closed-form 1X, micrometres 0-peak, lead.
    import importlib.util
    import pathlib
    spec = importlib.util.spec_from_file_location("closed_form_table", pathlib.Path(__file__).resolve().parents[2] / "tests" / "closed_form_table.py")
    table = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(table)
    table.write(path, "um-0peak-lead")


def test_order_table_reads_as_complex_vectors_and_loops(tmp_path):
    _write_table(tmp_path / "t.csv")
    t = rubref.read_order_table(tmp_path / "t.csv", amplitude="0-peak", phase="lead")
    assert t["rpm"].shape == (120,) and t["orders"][0]["vector_m"].dtype == complex
    assert t["orders"][0]["probe_angle_deg"] is None
    with pytest.raises(rubref.InputError, match="the phase convention is not declared: give it \\('phase' lead"):
        rubref.read_order_table(tmp_path / "t.csv", amplitude="0-peak")
    with pytest.raises(rubref.InputError, match="'mass' is for record files"):
        rubref.loop(tmp_path / "t.csv", amplitude="0-peak", phase="lead", mass=1.0)
    report = rubref.loop(tmp_path / "t.csv", amplitude="0-peak", phase="lead")
    assert report["kind"] == "order-tracked" and report["verdict"]["named"] == [] and report["verdict"]["unexplained"] is False
    import math
    # 1e-6: a noise-free table, fitted to its own rounding.
    assert abs(report["modes"][0]["critical_speed_rpm"] - 160 * 30 / math.pi) < 1e-6 * 160 * 30 / math.pi
    # A negative sweep rate is refused before any work (its direction is the table's).
    with pytest.raises(rubref.InputError, match="'sweep_rate' must be a positive rate in rpm/s"):
        rubref.loop(tmp_path / "t.csv", amplitude="0-peak", phase="lead", sweep_rate=-5.0)
    # A time_s column follows its rows into rising speed.
    (tmp_path / "timed.csv").write_text("rpm,time_s,amp_1x_um,phase_1x_deg\n2000,2.0,1,0\n1000,4.0,2,10\n")
    timed = rubref.read_order_table(tmp_path / "timed.csv", amplitude="0-peak", phase="lead")
    assert list(timed["time_s"]) == [4.0, 2.0]



# --- The command line's checks, from the same library code --------------------------------------

def _one_line(excinfo):
    text = str(excinfo.value)
    assert "\n" not in text, text
    return text


def test_mistyped_keywords_get_the_librarys_did_you_mean(small_rig_records):
    with pytest.raises(rubref.InputError, match=r"^simulate: unknown keyword 'setle_revs'; did you mean 'settle_revs'\?$") as e:
        rubref.simulate(setle_revs=10)
    _one_line(e)
    # No spelling is near, but the registry says what 'speed' is: the shaft speed in rpm.
    with pytest.raises(rubref.InputError, match=r"unknown keyword 'speed'; did you mean 'rpm' \(shaft speed"):
        rubref.orbit(speed=1600)
    with pytest.raises(rubref.InputError, match=r"unknown keyword 'bootstarp'; did you mean 'bootstrap'\?"):
        rubref.identify("x.csv", bootstarp=0)
    # A value naming a parameter gets the library's check too, before any work.
    with pytest.raises(rubref.InputError, match=r"re-identification: unknown parameter 'delta' \(k1, k3, c2, mu, e, clearance\)"):
        rubref.identify(small_rig_records, reidentify=True, reid_fit=["k1", "delta"])
    with pytest.raises(rubref.InputError, match=r"unknown keyword 'max_efects'; did you mean 'max_effects'\?"):
        rubref.loop("x.csv", max_efects=2)
    # A parameter file's key, mistyped, among the model parameters.
    with pytest.raises(rubref.InputError, match=r"did you mean 'k1_N_m'\?"):
        rubref.simulate(k1_N_n=1.0)


def test_wrong_types_are_one_line_input_errors_naming_the_argument():
    cases = [
        (lambda: rubref.simulate(rpm="1600"), r"^simulate: 'rpm' must be a number \(got str '1600'\)$"),
        (lambda: rubref.simulate(revs=2.5), r"^simulate: 'revs' must be a whole number \(got float 2.5\)$"),
        (lambda: rubref.simulate(variant=3), r"^simulate: 'variant' must be a str \(got int 3\)$"),
        (lambda: rubref.simulate(mu=True), r"^simulate: 'mu' must be a number \(got bool True\)$"),
        (lambda: rubref.rig(keyphasor="no"), r"^rig: 'keyphasor' must be a bool \(got str 'no'\)$"),
        (lambda: rubref.rig(speeds=[[1500, 1600]]), r"^rig: 'speeds' must be a 1-D array of numbers"),
        (lambda: rubref.identify(3), r"^identify: 'paths' must be a path or list of paths \(got int 3\)$"),
        (lambda: rubref.simulate(1600), r"^simulate: 'variant' must be a str \(got int 1600\)$"),  # positional: the first is the variant
        (lambda: rubref.read_record(), r"^read_record: missing a required argument: 'path'$"),
    ]
    for call, message in cases:
        with pytest.raises(rubref.InputError, match=message) as e:
            call()
        _one_line(e)
    # numpy scalars are numbers, and a whole float is a count.
    assert rubref.simulate(rpm=np.float64(1600), revs=np.int64(2), settle_revs=2.0)["t"].shape == (2 * 128,)


def test_a_length_that_looks_like_millimetres_warns_as_on_the_command_line():
    with pytest.warns(UserWarning, match=r"^clearance_m = 0.3 m is larger than any rotor kit's; if millimetres were meant, 0.3 mm is 0.0003 m$"):
        rubref.simulate(clearance=0.3, settle_revs=2, revs=2)
    with pytest.warns(UserWarning, match="e_m = 0.05 m is larger than any rotor kit's"):
        rubref.rig(e_m=0.05, speeds=[1200], settle_revs=2, revs=2)
    with pytest.warns(UserWarning, match="clearance_m = 0.2 m") as record:
        rubref.simulate_batch([1500, 1600], clearance=0.2, settle_revs=2, revs=2)
    assert len(record) == 1  # said once for the batch, not once per run
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rubref.simulate(clearance=0.3e-3, settle_revs=2, revs=2)  # metres: no warning


def test_write_record_never_replaces_a_file_rubref_did_not_write(tmp_path):
    t = np.linspace(0, 0.01, 11)
    cols = {"t_s": t, "x_m": 0 * t, "y_m": 0 * t, "speed_rpm": 1600 + 0 * t}
    mine = tmp_path / "notes.csv"
    mine.write_text("my own notes\n")
    with pytest.raises(rubref.InputError, match="notes.csv: exists and was not written by rubref; refusing to replace it") as e:
        rubref.write_record(mine, cols)
    _one_line(e)
    assert mine.read_text() == "my own notes\n"
    rubref.write_record(mine, cols, force=True)  # the command line's --force
    rubref.write_record(mine, cols, {"description": "again"})  # rubref's own file is replaced
    assert rubref.read_record(mine)["metadata"]["description"] == "again"


def test_orbit_takes_the_command_lines_integration_settings():
    loose = rubref.orbit(rpm=1600, clearance=0.3e-3, rtol=1e-8, atol=1e-12)["summary"]
    fixed = rubref.orbit(rpm=1600, clearance=0.3e-3, stepper="rk4", dt=2e-5)["summary"]
    tight = rubref.orbit(rpm=1600, clearance=0.3e-3)["summary"]
    assert loose["converged"] and fixed["converged"]
    # The same stable orbit: rk4 at 2e-5 s (~1900 steps a revolution) and rtol 1e-8 agree with
    # the default to well under a micrometre (the orbit is ~0.6 mm).
    assert abs(fixed["max_radius_m"] - tight["max_radius_m"]) < 1e-6
    assert abs(loose["max_radius_m"] - tight["max_radius_m"]) < 1e-6
    with pytest.raises(rubref.InputError, match="stepper"):
        rubref.orbit(stepper="rk5")


def test_docstrings_carry_units_defaults_and_ranges_from_the_registry():
    doc = rubref.simulate.__doc__
    assert "rpm (number): shaft speed [rpm]; default 1600.0" in doc
    assert "settle_revs (whole number): revolutions from rest discarded before recording [rev]; default 200" in doc
    assert "clearance (number): radial clearance" in doc and "(None: the library's)" in doc
    assert "Returns: dict: t (s)" in doc
    assert "from_ (number): start of the parameter's range" in rubref.continuation.__doc__
    for f in (rubref.simulate, rubref.simulate_batch, rubref.orbit, rubref.continuation, rubref.rig, rubref.identify, rubref.loop,
              rubref.read_order_table, rubref.validate, rubref.study, rubref.study_merge, rubref.read_record, rubref.write_record):
        assert "Arguments:" in f.__doc__, f.__name__


def test_golden_dir_holds_the_cases():
    assert os.path.isfile(os.path.join(rubref.golden_dir(), "identified_0.3mm_1600rpm.csv"))


# --- Ctrl-C and progress -------------------------------------------------------------------------

# A poll every 50 ms plus one integration step or one parallel task's check: well inside a second
# (the bound), with room for a loaded CI machine.
INTERRUPT_LATENCY_S = 1.0


def _interrupt(after_s):
    """Sends SIGINT to this (the main) thread after `after_s`, as a terminal's Ctrl-C would; the
    time it was sent is appended to the returned list."""
    sent = []
    main = threading.main_thread().ident

    def fire():
        sent.append(time.monotonic())
        signal.pthread_kill(main, signal.SIGINT)

    timer = threading.Timer(after_s, fire)
    timer.start()
    return timer, sent


def _assert_interrupted(call, after_s=1.0):
    timer, sent = _interrupt(after_s)
    try:
        with pytest.raises(KeyboardInterrupt):
            call()
        latency = time.monotonic() - sent[0]
    finally:
        timer.cancel()
    assert latency < INTERRUPT_LATENCY_S, latency
    return latency


def test_ctrl_c_stops_a_long_batch_within_a_second():
    # 400 runs of 40020 revolutions: over a minute uninterrupted on the 2-core build machine (with
    # 400 settling revolutions the batch ended in 0.8 s there, before the Ctrl-C at 1 s). Settling
    # stores nothing, so the work grows and the memory does not.
    _assert_interrupted(lambda: rubref.simulate_batch(np.linspace(1200, 2000, 400), clearance=0.3e-3, settle_revs=40000, revs=20, threads=2))
    # The module is usable at once, and the next call is not cancelled by the last one's stop.
    assert rubref.simulate(rpm=1600, settle_revs=2, revs=2)["t"].shape == (256,)


@pytest.fixture(scope="module")
def small_rig_records(tmp_path_factory):
    d = tmp_path_factory.mktemp("rig")
    rec = rubref.rig(speeds=[1200, 1300, 1600, 1650], revs=4, settle_revs=40, seed=5)
    rubref.write_record(d / "rig.csv", rec["columns"], rec["metadata"])
    return d / "rig.csv"


def test_ctrl_c_stops_the_loop_within_a_second_and_progress_reaches_the_logger(small_rig_records, caplog):
    caplog.set_level(logging.INFO, logger="rubref")
    _assert_interrupted(lambda: rubref.loop(small_rig_records), after_s=1.5)
    lines = [r.getMessage() for r in caplog.records if r.name == "rubref"]
    assert any("every coordinate together" in line for line in lines), lines  # the before-fit's start, as the CLI prints it


def test_ctrl_c_leaves_a_study_resumable_with_nothing_partial(tmp_path):
    # 7200 points: several seconds on two threads, so the interrupt meets it midway.
    spec = {"study": "regime_map", "grid": [{"name": "clearance_m", "values": [2e-4, 2.5e-4, 3e-4, 3.5e-4]},
                                            {"name": "speed_rpm", "from": 1200, "to": 2999, "step": 1}]}
    _assert_interrupted(lambda: rubref.study(spec, tmp_path / "s", threads=2), after_s=1.0)
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == ["s"], left  # no staging file or folder beside it
    assert not [p for p in (tmp_path / "s").rglob("*") if ".tmp-" in p.name]
    done = rubref.study(spec, tmp_path / "s", threads=2)
    assert done["complete"] and done["computed"] + done["already"] == 7200 and done["already"] > 0


def test_progress_goes_to_a_callable_and_is_off_by_default_in_a_batch(caplog):
    caplog.set_level(logging.INFO, logger="rubref")
    lines = []
    rubref.simulate_batch(np.linspace(1200, 1600, 40), settle_revs=4, revs=2, progress=lines.append)
    assert lines[-1] == "simulate_batch: 40 of 40 runs" and len(lines) == 20
    rubref.simulate_batch(np.linspace(1200, 1600, 40), settle_revs=4, revs=2)
    assert not [r for r in caplog.records if r.name == "rubref"]
    rubref.simulate_batch(np.linspace(1200, 1600, 4), settle_revs=4, revs=2, progress=True)
    assert [r.getMessage() for r in caplog.records if r.name == "rubref"][-1] == "simulate_batch: 4 of 4 runs"

    # A callable that raises stops the call with its own exception.
    def fail(line):
        raise RuntimeError("stop here: " + line)

    with pytest.raises(RuntimeError, match="stop here: simulate_batch"):
        rubref.simulate_batch(np.linspace(1200, 1600, 40), settle_revs=4, revs=2, progress=fail)


def test_records_in_millimetres_and_bad_headers_are_refused_with_a_hint(small_rig_records, tmp_path):
    # The same intake as `rubref identify` and `rubref loop` (ref/identification/dwells.cpp).
    rec = rubref.read_record(small_rig_records)
    cols = dict(rec["columns"])
    cols["x_m"], cols["y_m"] = cols["x_m"] * 1e3, cols["y_m"] * 1e3
    rubref.write_record(tmp_path / "mm.csv", cols, rec["metadata"])
    for call in (rubref.identify, rubref.loop):
        with pytest.raises(rubref.InputError, match=r"mm.csv:\d+: [xy]_m reaches .* m, .*if the file holds millimetres, divide x_m and y_m by 1000") as e:
            call(tmp_path / "mm.csv")
        _one_line(e)
    (tmp_path / "h.csv").write_text("time,x,y,rpm\n0,0,0,1600\n1,0,0,1600\n")
    with pytest.raises(rubref.InputError, match="time,x,y,rpm") as e:
        rubref.read_record(tmp_path / "h.csv")
    _one_line(e)
