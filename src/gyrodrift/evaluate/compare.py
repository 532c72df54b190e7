"""Run our method and the paper's baselines on the same log (``gyrodrift compare``).

What each method is, and what they share: docs/evaluation.md, section "Methods".
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.compensator.output import updated_column
from gyrodrift.conventions import REF_HEADING, TRUE_BIAS_Z, wrap_360
from gyrodrift.errors import ConfigError
from gyrodrift.estimators import ESTIMATORS, FixedParams, Poly3Calibration, fit_linear_drift, fit_poly3
from gyrodrift.evaluate.metrics import bias_error, error_stats, heading_error_stats
from gyrodrift.fusion import FusionState
from gyrodrift.fusion_offset import PACKAGE as FUSION_OFFSET_PACKAGE
from gyrodrift.fusion_offset import available as fusion_offset_available
from gyrodrift.fusion_offset import fusion_offset_drift
from gyrodrift.kernels.integrate import trapezoid

__all__ = ["METHODS", "DEFAULT_METHOD", "DEFAULT_METHODS", "CAUSAL", "is_causal", "is_method", "valid_methods",
           "method_label", "run_method", "run_methods", "calibration_from_log", "summary_table"]

METHODS = ("stkf", "kf", "stkf-s1", "lsm", "mlr", "smoothed", "poly3", "fusion-offset", "oracle")
#: The estimator ``compensate`` runs when none is chosen.
DEFAULT_METHOD = CompensatorConfig().estimator
#: The methods ``compare`` and ``report`` run when none are chosen: the default estimator first.
DEFAULT_METHODS = tuple(dict.fromkeys((DEFAULT_METHOD, *METHODS)))
CAUSAL = {"stkf": True, "kf": True, "stkf-s1": True, "lsm": True, "mlr": False, "smoothed": False, "poly3": True,
          "fusion-offset": True, "oracle": False}
_FILTERS = ("stkf", "kf", "stkf-s1", "lsm")
#: The filter whose accepted interval measurements ``mlr`` fits (whatever ``config.estimator``).
_MLR_MEASUREMENTS = "kf"


def _is_estimator_method(name: str) -> bool:
    """A registered estimator name that is not one of :data:`METHODS` (run as ``estimator=name``)."""
    return name in ESTIMATORS and name not in METHODS


def is_method(name: str) -> bool:
    """Whether ``name`` is a method :func:`run_method` runs (:data:`METHODS` or a registered estimator)."""
    return name in METHODS or _is_estimator_method(name)


def method_label(name: str) -> str:
    """The name a table or figure shows for a method: ``"adaptive (default)"`` for the default estimator."""
    return f"{name} (default)" if name == DEFAULT_METHOD else name


def valid_methods() -> str:
    """Every method name, comma-separated, for messages."""
    return ", ".join([*METHODS, *sorted(n for n in ESTIMATORS if _is_estimator_method(n))])


def is_causal(name: str) -> bool:
    """Whether a method is causal: :data:`CAUSAL`, else the registered estimator's ``causal``."""
    return CAUSAL[name] if name in CAUSAL else getattr(ESTIMATORS.get(name), "causal", True)


def calibration_from_log(log: pd.DataFrame) -> Poly3Calibration:
    """Fit the ``poly3`` baseline on a motionless heating run (input contract columns)."""
    return fit_poly3(log["temp"].to_numpy(float), log["gyro_z"].to_numpy(float))


def _known_drift(log: pd.DataFrame, config: CompensatorConfig, drift_dps: np.ndarray) -> pd.DataFrame:
    """The log compensated with a drift known for every row, deg/s, without a filter or gates (docs/evaluation.md)."""
    out = compensate(log, config, estimator=FixedParams())  # the columns and the anchor row
    t = out["t"].to_numpy()
    rate = log["gyro_z"].ffill().to_numpy(float) - drift_dps
    integral = trapezoid(t, rate, hold=np.r_[False, np.diff(t) > config.gate.max_gap_s])  # held across a gap, as the engine
    compass = out["compass_heading"].to_numpy()
    seen = np.flatnonzero(np.isfinite(compass))
    anchor = int(seen[0]) if seen.size else 0  # no compass: relative to the first row, as the engine
    out["rate_z"] = rate
    out["bias_z"] = drift_dps
    out["heading"] = wrap_360((compass[anchor] if seen.size else 0.0) + integral - integral[anchor])
    out[["a", "b", "c"]] = np.nan
    out["updated"] = 0
    out["gated"] = 0
    out["gate_reason"] = ""
    out["bias_sd"] = 0.0
    fused = FusionState(config.fusion_settings, config.gyro_noise_dps_rthz, config.gate.max_gap_s).rows(
        t, rate, compass, np.ones(t.size, dtype=bool), np.zeros(t.size))
    out["heading_fused"], out["heading_fused_sd"], out["heading_sd"] = fused
    return out


def _oracle(log: pd.DataFrame, config: CompensatorConfig) -> pd.DataFrame:
    """Compensation with the true drift (the limit set by sensor noise alone)."""
    if TRUE_BIAS_Z not in log.columns:
        raise ConfigError("the oracle needs a true_bias_z column (simulated logs have one)")
    return _known_drift(log, config, log[TRUE_BIAS_Z].to_numpy(float))


def run_method(
    name: str,
    log: pd.DataFrame,
    config: CompensatorConfig | None = None,
    *,
    calibration: Poly3Calibration | pd.DataFrame | None = None,
) -> pd.DataFrame:
    """Compensate ``log`` with one method; return the output table of :func:`compensate`.

    Parameters
    ----------
    name : str
        One of :data:`METHODS`, or another registered estimator name (e.g. ``adaptive``).
    log : DataFrame
        Input contract.
    config : CompensatorConfig, optional
        Shared settings; ``config.estimator`` is replaced.
    calibration : Poly3Calibration or DataFrame, optional
        For ``poly3``: a fitted calibration, or the heating-run log to fit it on.

    Raises
    ------
    ConfigError
        An unknown method, or one that cannot run (no truth, calibration or ``imufusion``).
    """
    config = config or CompensatorConfig()
    if name in _FILTERS or _is_estimator_method(name):
        return compensate(log, replace(config, estimator=name))
    if name == "mlr":
        # The paper's interval measurements (eq. 6), as its KF accepts them: the default
        # estimator weighs epochs in its own model and records none.
        first = compensate(log, replace(config, estimator=_MLR_MEASUREMENTS))
        meas = first.attrs["measurements"]
        H = np.column_stack([meas["temp"], meas["temp_rate"], np.ones(len(meas))])
        params = fit_linear_drift(meas["m"], H, meas["r"])
        out = compensate(log, config, estimator=FixedParams(params))
        out.attrs["measurements"] = meas
        return out
    if name == "smoothed":
        from gyrodrift.smooth import smooth_output

        return smooth_output(compensate(log, config), config)
    if name == "poly3":
        if calibration is None:
            raise ConfigError("poly3 needs a calibration run of the same device: give --calibration FILE")
        if isinstance(calibration, pd.DataFrame):
            calibration = calibration_from_log(calibration)
        return _known_drift(log, config, calibration.drift(log["temp"].ffill().to_numpy(float)))
    if name == "fusion-offset":
        return _known_drift(log, config, fusion_offset_drift(log))
    if name == "oracle":
        return _oracle(log, config)
    raise ConfigError(f"unknown method {name!r}; choose from: {valid_methods()}")


def run_methods(
    log: pd.DataFrame,
    methods=DEFAULT_METHODS,
    config: CompensatorConfig | None = None,
    *,
    calibration=None,
) -> tuple[dict[str, pd.DataFrame], dict[str, str]]:
    """Run several methods (default :data:`DEFAULT_METHODS`); return ``(outputs, skipped)``.

    ``outputs`` maps each method to its output table in the order given, ``skipped`` each
    method that cannot run on this log to the reason.
    """
    unknown = [m for m in methods if not is_method(m)]
    if unknown:
        raise ConfigError(f"unknown method(s) {', '.join(unknown)}; choose from: {valid_methods()}")
    if isinstance(calibration, pd.DataFrame):
        calibration = calibration_from_log(calibration)
    outputs, skipped = {}, {}
    for name in methods:
        if name == "oracle" and TRUE_BIAS_Z not in log.columns:
            skipped[name] = "no true_bias_z column"
            continue
        if name == "poly3" and calibration is None:
            skipped[name] = "no calibration run (--calibration)"
            continue
        if name == "fusion-offset" and not fusion_offset_available():
            skipped[name] = f"{FUSION_OFFSET_PACKAGE} not installed (pip install {FUSION_OFFSET_PACKAGE})"
            continue
        outputs[name] = run_method(name, log, config, calibration=calibration)
    return outputs, skipped


def summary_table(outputs: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """One row per method: the paper's Table-2 statistics and more (docs/evaluation.md, section "Methods")."""
    rows = {}
    for name, out in outputs.items():
        updates = int(updated_column(out, f"summary_table ({name})").sum())
        row = {"causal": is_causal(name), "updates": updates, "gated_pct": 100.0 * float(out["gated"].mean())}
        if name == "oracle":
            row.update(updates=np.nan, gated_pct=np.nan)
        if TRUE_BIAS_Z in out.columns:
            b = error_stats(bias_error(out))
            row.update(bias_mean=b["mean"], bias_var=b["variance"], bias_rms=b["rms"], bias_max_abs=b["max_abs"])
        if REF_HEADING in out.columns:
            h = heading_error_stats(out)
            row.update(
                heading_mean=h["mean"], heading_var=h["variance"], heading_rms=h["rms"],
                heading_min=h["min"], heading_max=h["max"],
            )
        rows[name] = row
    return pd.DataFrame.from_dict(rows, orient="index")
