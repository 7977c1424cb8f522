"""A plan releases the GIL (other Python threads run meanwhile) and Ctrl-C interrupts it."""

import _thread
import signal
import threading

import pytest

import cellsar


def long_mission():
    # 0.1 s slots: 3000 slots, several seconds of planning in a debug build
    return cellsar.Mission.default(30.0, slot_s=0.1)


def test_plan_in_a_thread_while_the_main_thread_runs():
    mission = cellsar.Mission.default(30.0)
    result = {}
    worker = threading.Thread(target=lambda: result.update(plan=cellsar.plan(mission, resolution="paper")))
    ticks = 0
    worker.start()
    while worker.is_alive():
        ticks += 1  # pure Python: runs only while the plan does not hold the GIL
    worker.join()
    assert result["plan"].feasible
    assert ticks > 1000


def test_ctrl_c_interrupts_a_plan():
    mission = long_mission()
    calls = []

    def interrupt_on_first_iteration(record):
        calls.append(record)
        if len(calls) == 1:
            _thread.interrupt_main()  # as Ctrl-C: SIGINT's handler runs in the main thread

    # Python's own SIGINT handler, as an interactive session has it: a test run started with
    # SIGINT ignored (`nohup ... &`) starts Python without one, and interrupt_main() then does
    # nothing
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            cellsar.plan(mission, scheme="paper", progress=interrupt_on_first_iteration)
    finally:
        signal.signal(signal.SIGINT, previous)
    # the plan stopped at the first check after the signal (within one cone program of
    # 3000 slots), not after the tens of iterations a whole run takes
    assert 1 <= len(calls) <= 3


def test_plans_from_several_threads_run_side_by_side_and_match():
    # planning threads are kept between plans; several callers at once each get their own,
    # and every plan equals the one planned alone
    missions = [cellsar.Mission.default(30.0), cellsar.Mission.default(30.0, uav_mass_kg=3.0)]
    alone = [cellsar.plan(m, resolution="paper").summary["energy_j"] for m in missions]
    results = [None] * (2 * len(missions))

    def run(k):
        results[k] = cellsar.plan(missions[k % len(missions)], resolution="paper").summary["energy_j"]

    threads = [threading.Thread(target=run, args=(k,)) for k in range(len(results))]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=600)
    assert not any(t.is_alive() for t in threads)
    for k, energy_j in enumerate(results):
        assert energy_j == pytest.approx(alone[k % len(missions)], rel=1e-12)
    # and the kept threads serve the next plan as before
    assert cellsar.plan(missions[0], resolution="paper").summary["energy_j"] == pytest.approx(alone[0], rel=1e-12)
