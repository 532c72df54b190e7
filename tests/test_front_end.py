"""One front end for every entry point (issue 22, item 1): the batch ``compensate``, the
chunked file path and the streaming ``Compensator`` give the same rows for every front-end
setting."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift import Compensator, CompensatorConfig, compensate


def _pushed(log: pd.DataFrame, cfg: CompensatorConfig) -> pd.DataFrame:
    """The rows of a :class:`Compensator` fed ``log`` row by row (held init window)."""
    comp = Compensator(cfg, provisional=False)
    rows = []
    for r in log.itertuples(index=False):
        rows += comp.push(r.t, r.gyro_z, r.temp, heading_deg=r.heading)
    rows += comp.flush()
    return pd.DataFrame([dataclasses.asdict(r) for r in rows])


@pytest.mark.parametrize("estimator", ["adaptive", "stkf"])
def test_declination_is_added_to_the_streamed_compass_after_the_init_window(estimator):
    log = synthetic_log(duration_s=120.0, fs_hz=10.0, heading_deg=lambda t: np.full_like(t, 90.0))
    cfg = CompensatorConfig(declination_deg=7.0, estimator=estimator)
    batch, stream = compensate(log, cfg), _pushed(log, cfg)
    assert np.nanmax(np.abs(batch["compass_heading"] - 97.0)) < 1e-9
    np.testing.assert_array_equal(stream["compass_heading"], batch["compass_heading"])
    np.testing.assert_array_equal(stream["heading_fused"], batch["heading_fused"])
    assert (stream["gate_reason"] == batch["gate_reason"]).all()
