"""Would a quadratic temperature term help ``adaptive``? A causal probe (see docs/results.md).

Run from the repository root (about 30 s for 5 seeds of two families)::

    python benchmarks/probe_quadratic_term.py --families vehicle,static --seeds 5

For each Monte Carlo case (:func:`gyrodrift.montecarlo.draw_case`, full length) it runs
``adaptive`` once, takes its accepted drift measurements (``out.attrs["measurements"]``)
and runs over them a forward (causal) Kalman filter with ``adaptive``'s drift model, the
temperature centred on a reference that follows each measurement (as
:mod:`gyrodrift.smooth` does, without the fading and the cap), with and without a state
``a2`` for ``a2 (T - T_ref)^2``. Each row is compensated with the parameters of the last
measurement before it. Printed: the mean over the cases of the bias RMS error (deg/s,
against ``true_bias_z``) for ``adaptive`` itself, ``mlr`` (one a, b, c over the whole run,
non-causal) and each filter variant, for the process noise of ``c'`` (``qc``, deg/s per
interval) and the slope random walk in temperature (``sq``) given. This reuses the
measurements, so it asks only what the model order changes, not what the gates would do.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from gyrodrift.compare import run_method
from gyrodrift.config import CompensatorConfig
from gyrodrift.montecarlo import draw_case, simulate_case
from gyrodrift.smooth import _groups, _held, _process_noise


def forward(meas, cfg: CompensatorConfig, quad: bool, a2_q_sd: float):
    """Forward filter over the measurement groups: times (s), states, reference temperatures (degC).

    States ``[a2,] a, b, c'`` with ``drift = c' + a (T - T_ref) [+ a2 (T - T_ref)^2] + b T'``.
    """
    groups = _groups(meas)
    Q3, q_T = _process_noise(cfg)
    n = 4 if quad else 3
    ia = n - 3  # index of a
    Q = np.zeros((n, n))
    Q[ia:, ia:] = Q3
    P = np.zeros((n, n))
    P[ia:, ia:] = cfg.kalman.matrices()[0]
    if quad:
        Q[0, 0] = a2_q_sd**2
        P[0, 0] = 1e-3**2  # deg/s/degC^2
    a0, b0, c0 = (float(v) for v in cfg.kalman.x0)
    z, t_prev, t_ref = None, None, None
    ts, zs, refs = [], [], []
    for t_k, T_k, m, temp, temp_rate, r in groups:
        if z is None:
            z = np.zeros(n)
            z[ia:] = a0, b0, c0 + a0 * T_k
        else:
            d = T_k - t_ref
            J = np.eye(n)
            J[ia + 2, ia] = d  # c' at the new reference
            if quad:
                J[ia + 2, 0] = d * d
                J[ia, 0] = 2.0 * d  # the slope at the new reference
            Qk = (t_k - t_prev) / cfg.update_interval_s * Q
            Qk[ia, ia] += q_T**2 * abs(d)
            z, P = J @ z, J @ P @ J.T + Qk
        t_prev, t_ref = t_k, T_k
        dT = temp - T_k
        H = np.column_stack(([dT**2] if quad else []) + [dT, temp_rate, np.ones(m.size)])
        R = np.diag(r)
        K = np.linalg.solve(H @ P @ H.T + R, H @ P).T
        A = np.eye(n) - K @ H
        z = z + K @ (m - H @ z)
        P = A @ P @ A.T + K @ R @ K.T
        P = 0.5 * (P + P.T)
        ts.append(t_k)
        zs.append(z.copy())
        refs.append(t_ref)
    return np.array(ts), np.array(zs), np.array(refs)


def causal_bias(out, cfg: CompensatorConfig, quad: bool, a2_q_sd: float = 1e-5) -> np.ndarray:
    """Drift per row (deg/s) from the last measurement before the row; ``adaptive``'s before the first."""
    tk, Z, refs = forward(out.attrs["measurements"], cfg, quad, a2_q_sd)
    t = out["t"].to_numpy(float)
    T = _held(out["temp"].to_numpy(float))
    Tp = out["temp_rate"].to_numpy(float)
    k = np.searchsorted(tk, t, side="left") - 1
    bias = out["bias_z"].to_numpy(float).copy()
    ok = k >= 0
    z, d = Z[k[ok]], T[ok] - refs[k[ok]]
    ia = 1 if quad else 0
    bias[ok] = z[:, ia + 2] + z[:, ia] * d + z[:, ia + 1] * Tp[ok] + (z[:, 0] * d * d if quad else 0.0)
    return bias


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--families", default="vehicle,static", help="Monte Carlo families, comma-separated")
    p.add_argument("--seeds", type=int, default=5, help="seeds 0..N-1 per family (default 5)")
    args = p.parse_args(argv)
    base = CompensatorConfig()
    variants = [(qc, sq) for qc in (5e-3, 1e-3, 3e-4) for sq in (base.adaptive.slope_q_per_rtc, 0.0)]
    for fam in args.families.split(","):
        res: dict[str, list[float]] = {}
        for seed in range(args.seeds):
            log, _ = simulate_case(draw_case(fam, seed), calibration=False)
            truth = log["true_bias_z"].to_numpy(float)

            def rms(bias):
                return float(np.sqrt(np.nanmean((bias - truth) ** 2)))

            out = run_method("adaptive", log, base)
            res.setdefault("adaptive", []).append(rms(out["bias_z"].to_numpy(float)))
            res.setdefault("mlr (non-causal)", []).append(rms(run_method("mlr", log, base)["bias_z"].to_numpy(float)))
            for qc, sq in variants:
                cfg = replace(base, adaptive=replace(base.adaptive, q_sd=(*base.adaptive.q_sd[:2], qc),
                                                     slope_q_per_rtc=sq))
                for quad in (False, True):
                    label = f"{'quadratic' if quad else 'linear'} qc={qc:g} sq={sq:g}"
                    res.setdefault(label, []).append(rms(causal_bias(out, cfg, quad)))
        print(f"{fam}: mean bias RMS error over {args.seeds} seeds, deg/s")
        for label, values in res.items():
            print(f"  {label:32s} {np.mean(values):.4f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
