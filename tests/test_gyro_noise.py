"""The gyro's white noise measured from the log's still runs (kernels.aiding.gyro_noise)."""

import numpy as np
import pytest

from conftest import synthetic_log
from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.kernels import aiding
from gyrodrift.kernels import layout as L


def test_white_noise_density_is_recovered_from_steps():
    rng = np.random.default_rng(0)
    fs_hz, density = 50.0, 0.07
    fs = np.zeros(L.N_FSTATE)
    for _ in range(40):  # 40 runs of 2 s with an offset and a slow ramp: neither is noise
        n = 100
        t = np.arange(n) / fs_hz
        g = 0.3 + 0.05 * t + rng.normal(0.0, density * np.sqrt(fs_hz), n)
        aiding.note_still_noise(float(np.sum(np.diff(g) ** 2)), n, t[-1] - t[0], fs)
    assert np.sqrt(fs[L.F_NOISE_SUM] / fs[L.F_NOISE_W]) == pytest.approx(density, rel=0.05)
    cfg = np.zeros(L.N_CFG)
    cfg[L.C_GYRO_NOISE] = 0.04
    assert aiding.gyro_noise(cfg, fs) == pytest.approx(density, rel=0.05)
    cfg[L.C_GYRO_NOISE] = 0.2  # a setting above the measured noise stays
    assert aiding.gyro_noise(cfg, fs) == 0.2


def test_too_few_steps_keep_the_setting():
    fs = np.zeros(L.N_FSTATE)
    aiding.note_still_noise(1.0, 50, 1.0, fs)
    cfg = np.zeros(L.N_CFG)
    cfg[L.C_GYRO_NOISE] = 0.04
    assert aiding.gyro_noise(cfg, fs) == 0.04


@pytest.mark.parametrize("density, expected", [(0.12, 0.12), (0.01, 0.04)])
def test_zero_rate_variance_uses_the_measured_noise_when_larger(density, expected):
    """A still unit: its zero-rate measurements' variance is N²/Δt with the gyro's own N when
    it is noisier than the 0.04 deg/s/√Hz setting, and the setting when it is quieter."""
    fs_hz = 20.0
    log = synthetic_log(duration_s=900.0, fs_hz=fs_hz, seed=1, compass_noise_deg=0.2)
    rng = np.random.default_rng(2)
    log["gyro_z"] += rng.normal(0.0, density * np.sqrt(fs_hz), len(log))
    out = compensate(log, CompensatorConfig())
    meas = out.attrs["measurements"]
    late = meas[meas["t"] > 300.0]
    zaru = late["r"] < 2.0 * expected**2 / 10.0  # the zero-rate ones (a compass difference has more)
    assert zaru.sum() > 20
    n_used = np.sqrt(late["r"][zaru] * 10.0)
    assert np.median(n_used) == pytest.approx(expected, rel=0.1)
