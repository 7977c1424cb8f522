"""Bad use never crashes the process; reset, several instances, threads, memory, FMU states,
logging."""

import math
import os
import pathlib
import threading
import time

import pytest

from conftest import (DEBUG_INJECT_PANIC_VR, Fmu, OUTPUTS, fmu_path, run, status_of)

ERROR = 3


def test_wrong_guid_is_refused_with_a_message(version):
    f = Fmu(version)
    assert not f.instantiate(guid="{00000000-0000-0000-0000-000000000000}")
    assert "wrong" in f.messages() and "00000000-0000" in f.messages()
    f.fmu.freeLibrary()


def test_empty_instance_name_is_refused(version):
    f = Fmu(version)
    assert not f.instantiate(name="")
    assert "instance name is empty" in f.messages()
    f.fmu.freeLibrary()


def test_missing_resources_fail_initialisation_with_a_message(version, tmp_path):
    f = Fmu(version)
    missing = tmp_path / "no-such-dir"
    loc = missing.as_uri() if version == "fmi2" else str(missing) + os.sep
    assert f.instantiate(resources=loc)
    assert "unusable" in f.messages()
    f.fmu.setupExperiment(startTime=0) if version == "fmi2" else None
    if version == "fmi2":
        f.fmu.enterInitializationMode()
    else:
        f.fmu.enterInitializationMode(startTime=0)
    assert status_of(f.fmu.exitInitializationMode) == ERROR
    assert "default_mission.toml" in f.messages() and "not found" in f.messages()
    # the instance is in the error mode: stepping is refused, freeing works
    assert status_of(f.fmu.doStep, 0.0, 0.5) == ERROR
    f.unload()


def test_call_sequence_errors_and_bad_steps(version, short_mission):
    f = Fmu(version)
    assert f.instantiate()
    # doStep before initialisation
    assert status_of(f.fmu.doStep, 0.0, 0.5) == ERROR
    assert "not allowed in mode Instantiated" in f.messages()
    # outputs cannot be read before initialisation
    with pytest.raises(Exception):
        f.get("x_m")
    f.init(stop=20.0, strings={"mission_file": str(short_mission)})
    # wrong communication point, negative and zero step, NaN
    assert status_of(f.fmu.doStep, 1.0, 0.5) == ERROR
    assert "is not the current time" in f.messages()
    assert status_of(f.fmu.doStep, 0.0, -0.5) == ERROR
    assert status_of(f.fmu.doStep, 0.0, 0.0) == ERROR
    assert status_of(f.fmu.doStep, float("nan"), 0.5) == ERROR
    # stepping past the stop time
    assert status_of(f.fmu.doStep, 0.0, 25.0) == ERROR
    assert "passes the stop time" in f.messages()
    # a fixed parameter cannot be set after initialisation; an unknown value reference is refused
    with pytest.raises(Exception):
        f.set(altitude_m=900.0)
    assert "is fixed" in f.messages()
    with pytest.raises(Exception):
        f.fmu.getReal([123456]) if version == "fmi2" else f.fmu.getFloat64([123456])
    assert "unknown value reference 123456" in f.messages()
    # the instance still works after all these refusals
    f.step(0.5, t=0.0)
    assert f.get("energy_j") > 0
    f.unload()


def test_bad_parameter_is_named(version, short_mission):
    f = Fmu(version)
    assert f.instantiate()
    if version == "fmi2":
        f.fmu.setupExperiment(startTime=0)
    f.set(max_speed_mps=-3.0)
    f.set_string("mission_file", str(short_mission))
    if version == "fmi2":
        f.fmu.enterInitializationMode()
    else:
        f.fmu.enterInitializationMode(startTime=0)
    assert status_of(f.fmu.exitInitializationMode) == ERROR
    assert "max_speed_mps" in f.messages()
    # NaN parameters are refused at once
    f.fmu.reset()
    with pytest.raises(Exception):
        f.set(altitude_m=float("nan"))
    assert "altitude_m" in f.messages() and "finite" in f.messages()
    f.unload()


def test_injected_panic_is_caught(version, short_mission):
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=20.0, strings={"mission_file": str(short_mission)})
    f.step(0.5, t=0.0)
    f.set_int(DEBUG_INJECT_PANIC_VR, 1)
    assert status_of(f.fmu.doStep, 0.5, 0.5) == ERROR
    assert "panic" in f.messages() and "error mode" in f.messages()
    # error mode: no more steps, but reset brings it back
    assert status_of(f.fmu.doStep, 0.5, 0.5) == ERROR
    f.fmu.reset()
    f.init(stop=20.0, strings={"mission_file": str(short_mission)})
    f.step(0.5, t=0.0)
    assert f.get("energy_j") > 0
    # a panic inside a get call
    f.set_int(DEBUG_INJECT_PANIC_VR, 2)
    with pytest.raises(Exception):
        f.get("x_m")
    f.unload()


def test_null_instance_is_an_error_not_a_crash(version):
    f = Fmu(version)
    if version == "fmi2":
        assert status_of(f.fmu.fmi2DoStep, None, 0.0, 0.5, 1) == ERROR
        assert status_of(f.fmu.fmi2Terminate, None) == ERROR
    else:
        assert status_of(f.fmu.fmi3Terminate, None) == ERROR
    f.fmu.freeLibrary()


def test_reset_then_rerun_is_identical(version, short_mission):
    f = Fmu(version)
    assert f.instantiate()
    results = []
    for _ in range(2):
        f.init(stop=20.0, strings={"mission_file": str(short_mission)})
        rows = []
        for k in range(12):
            f.step(0.75, t=k * 0.75)
            rows.append(f.outputs())
        results.append(rows)
        f.fmu.terminate()
        f.fmu.reset()
    assert results[0] == results[1]
    f.unload()


def test_two_instances_and_threads_match_separate_runs(version, short_mission):
    reference = run(version, short_mission, stop=20.0, step=0.5)
    # two instances of one loaded library, stepped alternately
    a, b = Fmu(version, name="a"), Fmu(version, name="b")  # dlopen: one library, two instances
    assert a.instantiate() and b.instantiate()
    a.init(stop=20.0, strings={"mission_file": str(short_mission)})
    b.init(stop=20.0, params={"blade_power_w": 3.4},
           strings={"mission_file": str(short_mission)})
    rows_a, rows_b = [(0.0, a.outputs())], [(0.0, b.outputs())]
    for k in range(40):
        a.step(0.5, t=k * 0.5)
        b.step(0.5, t=k * 0.5)
        rows_a.append(((k + 1) * 0.5, a.outputs()))
        rows_b.append(((k + 1) * 0.5, b.outputs()))
    assert rows_a == reference and rows_b == reference
    a.free()
    b.free()
    a.fmu.freeLibrary()
    # four threads, each with its own instance (ctypes releases the GIL during calls)
    results = [None] * 4
    errors = []

    def worker(i):
        try:
            results[i] = run(version, short_mission, stop=20.0, step=0.5, name=f"thread{i}")
        except Exception as e:  # pragma: no cover - reported below
            errors.append(e)

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert not errors, errors
    assert all(r == reference for r in results)


def _rss_kib():
    for line in pathlib.Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError("no VmRSS")


def _threads():
    return len(os.listdir("/proc/self/task"))


def test_200_instantiate_free_cycles_do_not_grow_memory(version, tiny_mission):
    f = Fmu(version)

    def cycle():
        assert f.instantiate()
        f.init(stop=2.0, strings={"mission_file": str(tiny_mission)})
        for k in range(4):
            f.step(0.5, t=k * 0.5)
        s = f.fmu.getFMUstate() if version == "fmi2" else f.fmu.getFMUState()
        f.fmu.freeFMUstate(s) if version == "fmi2" else f.fmu.freeFMUState(s)
        f.free()

    threads = _threads()
    for _ in range(20):
        cycle()
    before = _rss_kib()
    for _ in range(200):
        cycle()
    grown = _rss_kib() - before
    assert grown < 4096, f"RSS grew by {grown} KiB over 200 cycles"
    assert _threads() <= threads, "threads outlived FreeInstance"
    f.fmu.freeLibrary()


def test_state_rollback_and_serialisation_resume_identically(version, short_mission):
    uninterrupted = run(version, short_mission, stop=20.0, step=0.5)
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=20.0, strings={"mission_file": str(short_mission)})
    for k in range(10):
        f.step(0.5, t=k * 0.5)
    get, set_, free = ((f.fmu.getFMUstate, f.fmu.setFMUstate, f.fmu.freeFMUstate)
                       if version == "fmi2" else
                       (f.fmu.getFMUState, f.fmu.setFMUState, f.fmu.freeFMUState))
    state = get()
    blob = f.fmu.serializeFMUstate(state) if version == "fmi2" else f.fmu.serializeFMUState(state)
    # wander off with odd steps, then roll back and resume
    f.step(1.3, t=5.0)
    f.step(2.9, t=6.3)
    set_(state)
    free(state)
    rows = []
    for k in range(10, 40):
        f.step(0.5, t=k * 0.5)
        rows.append(((k + 1) * 0.5, f.outputs()))
    assert rows == uninterrupted[11:]
    f.free()
    # a fresh instance resumes from the serialised state without initialisation
    g = Fmu(version, name="resumed")
    assert g.instantiate()
    if version == "fmi2":
        s = g.fmu.deSerializeFMUstate(blob)
        g.fmu.setFMUstate(s)
        g.fmu.freeFMUstate(s)
    else:
        s = g.fmu.deserializeFMUState(blob)
        g.fmu.setFMUState(s)
        g.fmu.freeFMUState(s)
    rows = []
    for k in range(10, 40):
        g.step(0.5, t=k * 0.5)
        rows.append(((k + 1) * 0.5, g.outputs()))
    assert rows == uninterrupted[11:]
    # a corrupted blob is refused
    bad = bytearray(blob)
    bad[0] ^= 0xFF
    with pytest.raises(Exception):
        g.fmu.deSerializeFMUstate(bytes(bad)) if version == "fmi2" else g.fmu.deserializeFMUState(bytes(bad))
    assert "rejected" in g.messages()
    g.free()
    f.fmu.freeLibrary()


def test_debug_logging_keeps_percent_and_non_ascii(version, tmp_path, short_mission):
    name = "Überflug 100 % – Größe ≤ 20 m"
    text = short_mission.read_text(encoding="utf-8").replace(
        'name = "short test mission"', f'name = "{name}"')
    mission = tmp_path / "mission-ü.toml"
    mission.write_text(text, encoding="utf-8")
    f = Fmu(version)
    assert f.instantiate(debug=True)
    f.init(stop=20.0, strings={"mission_file": str(mission)})
    f.step(0.5, t=0.0)
    msgs = f.messages()
    assert name in msgs, msgs
    assert "mission-ü.toml" in msgs
    assert any(c == "logEvents" for c, _, _ in f.logs)
    assert any(c == "logCalls" and m == ("fmi2DoStep" if version == "fmi2" else "fmi3DoStep")
               for c, _, m in f.logs)
    # switching categories off silences them; unknown categories are refused
    if version == "fmi2":
        with pytest.raises(Exception):
            f.fmu.setDebugLogging(True, ["logNoSuchThing"])
        assert "unknown log category `logNoSuchThing`" in f.messages()
        f.fmu.setDebugLogging(False, ["logCalls", "logEvents"])
    else:
        f.fmu.fmi3SetDebugLogging(f.fmu.component, False, 0, None)
    n = len(f.logs)
    f.step(0.5, t=0.5)
    assert len(f.logs) == n
    f.unload()


def test_fmpy_simulate_with_debug_logging(version, tmp_path, short_mission):
    from fmpy import simulate_fmu
    seen = []
    if version == "fmi2":
        def logger(env, instance, status, category, message):
            seen.append(message.decode("utf-8"))
    else:
        def logger(env, status, category, message):
            seen.append(message.decode("utf-8"))
    simulate_fmu(str(fmu_path(version)), stop_time=2.0, output_interval=0.5,
                 start_values={"mission_file": str(short_mission)}, debug_logging=True,
                 logger=logger)
    assert any("short test mission" in m for m in seen), seen


def _init_mode(f):
    if f.version == "fmi2":
        f.fmu.setupExperiment(startTime=0)
        f.fmu.enterInitializationMode()
    else:
        f.fmu.enterInitializationMode(startTime=0)


def test_refused_multi_value_set_changes_nothing(version, short_mission):
    """A set call with one bad value is refused as a whole (altitude_m was already set before)."""
    f = Fmu(version)
    assert f.instantiate()
    set_real = f.fmu.setReal if version == "fmi2" else f.fmu.setFloat64
    vrs = [f.vr("altitude_m"), f.vr("bandwidth_hz")]
    assert status_of(set_real, vrs, [1100.0, float("nan")]) == ERROR
    assert "bandwidth_hz" in f.messages()
    # an unknown value reference after a good one
    assert status_of(set_real, [f.vr("altitude_m"), 123456], [1100.0, 1.0]) == ERROR
    set_string = f.fmu.setString
    assert status_of(set_string, [f.vr("mission_file"), f.vr("altitude_m")],
                     [str(short_mission), "x"]) == ERROR
    set_int = f.fmu.setInteger if version == "fmi2" else f.fmu.setInt32
    assert status_of(set_int, [DEBUG_INJECT_PANIC_VR, f.vr("replan_count")], [1, 0]) == ERROR
    _init_mode(f)
    assert f.get("altitude_m") == 1000.0
    assert f.get("mission_file") in ("default_mission.toml", b"default_mission.toml")
    f.set_string("mission_file", str(short_mission))
    f.fmu.exitInitializationMode()
    assert status_of(f.fmu.doStep, 0.0, 0.5) == 0  # the panic hook was not set either
    f.unload()


def test_bad_landmark_inputs_are_refused_and_named(version, short_mission):
    """An infinite landmark input is refused at the set; one NaN and one finite coordinate are
    refused at the doStep, which is not taken (both were silently "no move" before)."""
    f = Fmu(version)
    assert f.instantiate()
    f.init(stop=20.0, strings={"mission_file": str(short_mission)})
    with pytest.raises(Exception):
        f.set(landmark_x_in_m=float("inf"))
    assert "landmark_x_in_m" in f.messages() and "inf" in f.messages()
    assert math.isnan(f.get("landmark_x_in_m"))
    f.set(landmark_x_in_m=40.0)  # landmark_y_in_m stays NaN
    n = len(f.logs)
    assert f.step_status(0.5) == ERROR
    text = "\n".join(m for _, _, m in f.logs[n:])
    assert "landmark_x_in_m" in text and "landmark_y_in_m" in text and "NaN" in text, text
    assert f.time == 0.0
    f.set(landmark_x_in_m=float("nan"))
    assert f.step_status(0.5, t=0.0) == 0
    assert f.get("replan_count") == 0
    f.unload()


def test_bad_mover_parameters_are_refused_and_named(version):
    """A negative hold_s meant "forever" silently; now it is refused, as are infinite inputs."""
    m = Fmu(version, "LandmarkMover", name="mover")
    assert m.instantiate()
    with pytest.raises(Exception):
        m.set(hold_s=-1.0)
    assert "hold_s" in m.messages() and ">= 0" in m.messages()
    with pytest.raises(Exception):
        m.set(landmark_x_m=float("-inf"))
    assert "landmark_x_m" in m.messages()
    m.init(stop=20.0, params={"move_at_s": 1.0})
    assert m.get("hold_s") == 0.0
    m.set(landmark_x_m=1.0, landmark_y_m=float("nan"))
    assert m.step_status(0.5) == ERROR
    assert "landmark_y_m" in m.messages()
    m.unload()


def test_too_many_slots_are_refused_at_once(version, short_mission):
    """slot_s = 1e-4 on a 20 s mission (200 000 slots) kept ExitInitializationMode busy for
    minutes; the FMU refuses it at once, naming both parameters."""
    f = Fmu(version)
    assert f.instantiate()
    if version == "fmi2":
        f.fmu.setupExperiment(startTime=0)
    f.set(slot_s=1e-4)
    f.set_string("mission_file", str(short_mission))
    if version == "fmi2":
        f.fmu.enterInitializationMode()
    else:
        f.fmu.enterInitializationMode(startTime=0)
    t0 = time.monotonic()
    assert status_of(f.fmu.exitInitializationMode) == ERROR
    assert time.monotonic() - t0 < 5.0
    msg = f.messages()
    assert "slot_s" in msg and "horizon_s" in msg and "200000 slots" in msg, msg
    assert "0.0001" in msg
    f.unload()


def test_huge_and_tiny_numbers_are_short_in_messages(version):
    """-1e308 was written with 309 digits and 1e-12 as 0.000000000001."""
    f = Fmu(version)
    assert f.instantiate()
    if version == "fmi2":
        assert status_of(f.fmu.setupExperiment, startTime=0.0, stopTime=-1e308) == ERROR
    else:
        assert status_of(f.fmu.enterInitializationMode, startTime=0.0, stopTime=-1e308) == ERROR
    assert "stop time -1e308 must be finite" in f.messages(), f.messages()
    with pytest.raises(Exception):
        f.set(altitude_m=float("inf"))
    assert "`altitude_m` = inf" in f.messages()
    f.init(stop=300.0)
    assert status_of(f.fmu.doStep, 0.0, -1e-12) == ERROR
    assert "communication step size must be > 0, got -1e-12" in f.messages()
    assert max(len(m) for _, _, m in f.logs) < 400
    f.unload()
