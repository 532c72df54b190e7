"""OutputBuffers: compensate_arrays writing into memory kept between calls."""

import numpy as np
import pandas as pd
import pytest

from gyrodrift import OutputBuffers
from gyrodrift.compensator import CompensatorConfig, compensate_arrays
from gyrodrift.errors import GyroDriftError
from test_compensate import complex_log


def run(log: pd.DataFrame, cfg: CompensatorConfig, **kw) -> pd.DataFrame:
    return compensate_arrays(log["t"], log["gyro_z"], log["temp"], log["heading"], config=cfg, **kw)


def quiet_log() -> pd.DataFrame:
    """A log that refuses and updates on other rows than :func:`complex_log`: no turns, no
    interference; run with a longer init window, whose rows the kernel leaves to the zeroed
    codes, so codes left over from a call on the other log would show."""
    log = complex_log().iloc[:9000].copy()
    log["heading"] = np.where(np.isfinite(log["heading"]), 100.0, np.nan)
    log["gyro_z"] = 0.02 * log["temp"] - 0.3
    return log


@pytest.mark.parametrize("estimator", ["adaptive", "stkf"])
def test_buffers_give_the_same_table(estimator):
    log = complex_log()
    cfg = CompensatorConfig(estimator=estimator)
    fresh = run(log, cfg)
    buffers = OutputBuffers(len(log) + 100)  # larger than the log: the first rows are used
    pd.testing.assert_frame_equal(run(log, cfg, buffers=buffers), fresh)
    assert fresh["updated"].sum() > 10 and fresh["gated"].sum() > 100  # the codes matter here


def test_a_second_call_overwrites_the_first_and_starts_from_clean_codes():
    cfg, cfg_long_init = CompensatorConfig(), CompensatorConfig(init_s=120.0)
    busy, quiet = complex_log(), quiet_log()
    expected_quiet = run(quiet, cfg_long_init)
    expected_busy = run(busy, cfg)
    assert expected_busy.loc[expected_busy["t"] < 100.0, "updated"].sum() > 3  # inside the second call's init
    buffers = OutputBuffers(len(busy))
    first = run(busy, cfg, buffers=buffers)
    pd.testing.assert_frame_equal(first, expected_busy)
    second = run(quiet, cfg_long_init, buffers=buffers)
    pd.testing.assert_frame_equal(second, expected_quiet)
    # the first table views the same memory: its first rows are now the second call's
    np.testing.assert_array_equal(first["bias_z"].to_numpy()[: len(quiet)], second["bias_z"].to_numpy())
    assert not np.array_equal(first["bias_z"].to_numpy()[: len(quiet)], expected_busy["bias_z"].to_numpy()[: len(quiet)])


def test_too_small_buffers_say_how_large_they_must_be():
    log = complex_log()
    with pytest.raises(GyroDriftError, match=rf"has {len(log)} rows but the OutputBuffers were made for 100"):
        run(log, CompensatorConfig(), buffers=OutputBuffers(100))
    with pytest.raises(GyroDriftError, match="at least one row"):
        OutputBuffers(0)
