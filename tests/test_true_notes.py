"""Notes that are true (issue 23, item 7): a note that is wrong teaches users to ignore notes.

The gyro-unit check must not fire on a still, drifting unit whose compass swings in
magnetic interference; a compass that repeats a value by chance is no table of held
values; and gyrodrift's own demo, a still drifting unit, gets no note at all.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from gyrodrift.gyro_units import GyroUnitCheck
from gyrodrift.io import read_log
from gyrodrift.simulate import simulate


def test_the_demo_prints_no_note(tmp_path):
    from test_cli import run_module

    res = run_module("demo", "-o", str(tmp_path / "demo.csv"))
    assert res.returncode == 0, res.stderr
    assert "note:" not in res.stdout and res.stderr == "", res.stdout + res.stderr


@pytest.mark.parametrize("seed", range(4))
def test_the_unit_check_is_silent_on_still_drifting_units(seed):
    """Still units with interference windows (the demo's scenario, other seeds): the compass
    swings while the gyro reads its drift; no unit error may be claimed."""
    log = simulate("static-outages", seed=seed, duration_s=3600.0, fs_hz=10.0)
    check = GyroUnitCheck("still.csv", "deg/s")
    check.add(log["t"].to_numpy(), log["gyro_z"].to_numpy(), log["heading"].to_numpy())
    assert check.note() is None, check.note()


def test_the_unit_check_is_silent_when_a_small_drift_meets_compass_swings():
    """A good gyro (0.02 deg/s drift) beside a compass stepping +-20 deg in interference:
    compass/gyro ratios of about 100, of both signs."""
    t = np.arange(0.0, 3600.0, 0.1)
    heading = np.full(t.size, 100.0)
    for k, start in enumerate(range(200, 3400, 400)):
        heading[(t >= start) & (t < start + 60)] += 20.0 if k % 3 else -25.0
    check = GyroUnitCheck("good.csv", "deg/s")
    check.add(t, np.full(t.size, 0.02), heading)
    assert len(check._ratios) >= 6 and check.note() is None


def test_the_unit_check_still_sees_a_unit_error_among_interference():
    """rad/s read as deg/s on a turning vehicle, with two interference swings mixed in."""
    t = np.arange(0.0, 600.0, 0.1)
    true = 90.0 * np.sin(2 * np.pi * t / 120.0)
    heading = 100.0 + true
    heading[(t > 100) & (t < 120)] += 30.0
    check = GyroUnitCheck("rad.csv", "deg/s")
    check.add(t, np.radians(np.gradient(true, t)), heading)
    assert "times less than the compass" in (check.note() or "")


def test_a_quantised_compass_repeating_by_chance_keeps_its_samples(tmp_path):
    rng = np.random.default_rng(4)
    n = 20000
    log = pd.DataFrame({"t": np.arange(n) * 0.1, "gyro_z": 0.1, "temp": 30.0,
                        "heading": np.round(120.0 + rng.normal(0.0, 0.5, n), 3)})
    repeats = int((log["heading"].diff() == 0).sum())
    assert repeats > 0  # some samples equal the one before, by chance
    log.to_csv(tmp_path / "q.csv", index=False)
    read = read_log(tmp_path / "q.csv")
    assert read["heading"].notna().sum() == n and not read.attrs.get("notes")


def test_the_unit_check_ends_on_times_coarser_than_its_window():
    """Times so large that a window's length is below their resolution (4e17 s: steps of 64 s
    that 10 s does not move): every window still ends at a later sample."""
    import threading

    n = 50
    check = GyroUnitCheck("far.csv", "deg/s")
    worker = threading.Thread(target=check.add, args=(4e17 + 64.0 * np.arange(n), np.ones(n),
                                                      np.mod(20.0 * np.arange(n), 360.0)), daemon=True)
    worker.start()
    worker.join(20.0)
    assert not worker.is_alive()
    assert len(check._ratios) == n - 1


def test_the_unit_check_measures_known_turns_and_any_chunking_gives_the_same():
    """A gyro at a constant 3 deg/s beside a compass turning 6 deg/s (wrapping through 360):
    every closed 10-s window measures a ratio of 2 exactly (the trapezoid is exact on a constant
    rate), whatever the chunks, an empty gyro cell holding the value before it."""
    t = np.arange(0.0, 200.0, 0.1)
    gyro = np.full(t.size, 3.0)
    gyro[[5, 6, 700]] = np.nan  # held at 3 deg/s
    heading = np.full(t.size, np.nan)
    heading[::5] = np.mod(40.0 + 6.0 * t[::5], 360.0)
    whole = GyroUnitCheck("k.csv", "deg/s")
    whole.add(t, gyro, heading)
    assert len(whole._ratios) == 19 and np.allclose(whole._ratios, 2.0, rtol=1e-9, atol=0.0)
    for cuts in ([1, 2, 999], [37, 1500], list(range(1, t.size, 97))):
        chunked = GyroUnitCheck("k.csv", "deg/s")
        for part in np.split(np.arange(t.size), cuts):
            chunked.add(t[part], gyro[part], heading[part])
        assert np.allclose(chunked._ratios, whole._ratios, rtol=1e-12, atol=0.0)
