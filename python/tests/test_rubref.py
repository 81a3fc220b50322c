"""The Python module against the physics and against the command line (ctest label `python`).

Run from ctest with PYTHONPATH at the build's python/ folder, RUBREF_GOLDEN_DIR at golden/ and
RUBREF_COMMAND at the rubref binary (python/CMakeLists.txt)."""

import json
import math
import os
import subprocess
import threading

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
    r = rubref.simulate(rpm=1200, clearance=1.0)
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
    with pytest.raises(rubref.InputError, match="unknown parameter 'k1'"):
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
    b = rubref.continuation(start=1500, end=3000, clearance=0.3e-3)
    folds = b["summary"]["folds"]
    assert len(folds) >= 1
    assert any(2700 < f["speed_rpm"] < 2900 for f in folds)
    assert isinstance(b["branch"]["speed_rpm"], np.ndarray)
    with pytest.raises(rubref.InputError, match="needs start and end"):
        rubref.continuation(parameter="mu")


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
    assert report["effects"] == []
    assert report["unexplained"] is False
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
    with pytest.raises(rubref.InputError, match="unknown setting 'mass'"):
        rubref.loop(tmp_path / "t.csv", amplitude="0-peak", phase="lead", mass=1.0)
    report = rubref.loop(tmp_path / "t.csv", amplitude="0-peak", phase="lead")
    assert report["kind"] == "order-tracked" and report["effects"] == [] and report["unexplained"] is False
    import math
    # 1e-6: a noise-free table, fitted to its own rounding.
    assert abs(report["modes"][0]["critical_speed_rpm"] - 160 * 30 / math.pi) < 1e-6 * 160 * 30 / math.pi
