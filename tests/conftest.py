"""Shared fixtures: small synthetic logs with known drift, and the real recorded logs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def pytest_sessionstart(session):
    """Every kernel compiled, or loaded from numba's cache, before the first test: a command a
    test runs in a subprocess then never compiles, so its stderr holds only what the test
    expects (a compile says so there: :func:`gyrodrift.kernels.say_when_compiling`)."""
    import io

    from gyrodrift.kernels import warm

    if hasattr(warm.dispatcher("kernels.evloop.run"), "compile"):  # not with NUMBA_DISABLE_JIT=1
        warm.compile_group(warm.SIGNATURES, out=io.StringIO())


def synthetic_log(
    *,
    duration_s: float = 1800.0,
    fs_hz: float = 20.0,
    compass_hz: float = 5.0,
    temp_c=lambda t: 25.0 + 10.0 * np.sin(np.pi * t / 1800.0) ** 2,
    drift_dps=None,
    heading_deg=lambda t: np.full_like(t, 100.0),
    gyro_noise_dps: float = 0.0,
    compass_noise_deg: float = 0.0,
    seed: int = 0,
) -> pd.DataFrame:
    """A log in the input contract with truth columns.

    ``drift_dps(t, temp_c)`` gives the true drift (default 0.3 deg/s constant); the true
    rate is the exact derivative of ``heading_deg`` (numerical, central).
    """
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, 1.0 / fs_hz)
    temp = temp_c(t)
    drift = np.full_like(t, 0.3) if drift_dps is None else drift_dps(t, temp)
    true_heading = heading_deg(t)
    true_rate = np.gradient(true_heading, t)
    gyro = true_rate + drift + rng.normal(0.0, gyro_noise_dps, t.size) if gyro_noise_dps else true_rate + drift
    compass = np.mod(true_heading + (rng.normal(0.0, compass_noise_deg, t.size) if compass_noise_deg else 0.0), 360.0)
    step = int(round(fs_hz / compass_hz))
    every = np.zeros(t.size, dtype=bool)
    every[::step] = True
    compass[~every] = np.nan
    return pd.DataFrame(
        {
            "t": t,
            "gyro_z": gyro,
            "temp": temp,
            "heading": compass,
            "ref_heading": np.mod(true_heading, 360.0),
            "true_bias_z": drift,
        }
    )


@pytest.fixture
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real recorded logs not found at {SHARED_DATA} (shared/data beside the repo)")
    return SHARED_DATA
