"""How well can a *causal* fit do what ``mlr`` does? A probe for the vehicle cell of issue 6.

Run from the repository root (about 40 s for 20 seeds of two families)::

    python benchmarks/probe_causal_mlr.py --families vehicle,static --seeds 20

``mlr`` (the paper's MLR, :func:`gyrodrift.evaluate.compare.run_method`) fits one a, b, c by weighted
least squares over *all* the accepted drift measurements of a run, then compensates every
row with them: it uses the future. Its causal counterpart, printed here as "mlr, so far",
fits the same model to the measurements accepted *before* each row, regularised by the prior
every Kalman estimator starts from (:class:`gyrodrift.estimators.kalman.KalmanConfig`,
without it the first fits of a flat temperature are singular), and compensates the rows up
to the next measurement with it; rows before the sixth measurement take ``adaptive``'s bias.
The measurements are ``adaptive``'s own (``out.attrs["measurements"]``), as ``mlr`` uses.

Printed per family: mean over the seeds of the bias RMS error (deg/s, against
``true_bias_z``) of ``adaptive``, ``mlr`` and "mlr, so far", and on how many seeds the
causal fit beats ``adaptive``. A gap between "mlr, so far" and ``mlr`` is the price of
causality on that run with that model and those measurements, which no causal estimator
built on them avoids by tuning.
"""

from __future__ import annotations

import argparse

import numpy as np

from gyrodrift.evaluate.compare import run_method
from gyrodrift.config import CompensatorConfig
from gyrodrift.estimators.kalman import KalmanConfig
from gyrodrift.estimators.lsq import fit_linear_drift
from gyrodrift.evaluate.montecarlo import draw_case, simulate_case

#: Rows before this many accepted measurements keep ``adaptive``'s bias.
MIN_MEASUREMENTS = 6


def causal_mlr_bias(out, log, prior: KalmanConfig) -> np.ndarray:
    """Bias (deg/s) of every row from the weighted least-squares a, b, c of the
    measurements accepted before it (``out``: an ``adaptive`` output table)."""
    meas = out.attrs["measurements"]
    t = out["t"].to_numpy()
    temp_c = log["temp"].to_numpy(dtype=float)
    temp_rate_cps = out["temp_rate"].to_numpy()
    m, r, t_meas = (meas[k].to_numpy() for k in ("m", "r", "t"))
    H = np.column_stack([meas["temp"], meas["temp_rate"], np.ones(len(meas))])
    bias = out["bias_z"].to_numpy().copy()
    for k in range(MIN_MEASUREMENTS, len(meas) + 1):
        a, b, c = fit_linear_drift(m[:k], H[:k], r[:k], prior=prior)
        lo = np.searchsorted(t, t_meas[k - 1], "right")
        hi = np.searchsorted(t, t_meas[k], "right") if k < len(meas) else t.size
        bias[lo:hi] = a * temp_c[lo:hi] + b * temp_rate_cps[lo:hi] + c
    return bias


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--families", default="vehicle,static")
    ap.add_argument("--seeds", type=int, default=20)
    args = ap.parse_args(argv)
    cfg = CompensatorConfig()
    prior = cfg.kalman

    def rms(bias, truth):
        return float(np.sqrt(np.mean(np.square(bias - truth))))

    print("| family | adaptive | mlr (whole run) | mlr, so far (causal) | causal fit beats adaptive |")
    print("|---|---|---|---|---|")
    for family in args.families.split(","):
        rows = []
        for seed in range(args.seeds):
            log, _ = simulate_case(draw_case(family, seed), calibration=False)
            truth = log["true_bias_z"].to_numpy()
            adaptive = run_method("adaptive", log, cfg)
            mlr = run_method("mlr", log, cfg)
            rows.append(
                (
                    rms(adaptive["bias_z"].to_numpy(), truth),
                    rms(mlr["bias_z"].to_numpy(), truth),
                    rms(causal_mlr_bias(adaptive, log, prior), truth),
                )
            )
        a = np.array(rows)
        mean = a.mean(axis=0)
        wins = int(np.sum(a[:, 2] < a[:, 0]))
        print(f"| {family} | {mean[0]:.4f} | {mean[1]:.4f} | {mean[2]:.4f} | {wins}/{args.seeds} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
