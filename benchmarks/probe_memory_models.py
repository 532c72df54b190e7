"""Could ``adaptive`` choose its own memory? An offline IMM probe (see docs/results.md).

Run from the repository root (about 2 minutes for 10 seeds of every family)::

    python benchmarks/probe_memory_models.py --families static,vehicle --seeds 0-9

For each Monte Carlo case (:func:`gyrodrift.evaluate.montecarlo.draw_case`, full length) it runs
``adaptive`` once and, over its accepted measurements (``out.attrs["measurements"]``), a
forward Kalman filter that reproduces ``adaptive`` on the families without long outages:
the moving reference temperature, the slope random walk, the normalised fading test and
the covariance cap, without the outage twin and the holds. Then:

* ``low noise``: the same filter with a tenth of the process-noise variance and no slope
  random walk (a long memory);
* ``IMM``: both filters in an interacting multiple-model bank, switching probability 0.1
  per update interval (mixed before each update, weighted by each filter's Gaussian
  likelihood of its innovation). Bank and switching were chosen on static seeds 10-19
  alone (mean heading proxy), then frozen.

Printed per family: mean over the seeds of the bias RMS error (deg/s, against
``true_bias_z``) and of a heading proxy, the RMS over rows of the running integral of the
bias error (deg; the drift part of the heading error), and the IMM's mean weight of the
low-noise filter. Soak has long outages the probe does not model: its rows compare badly.
"""

from __future__ import annotations

import argparse
import math
from collections import deque

import numpy as np

from gyrodrift.evaluate.compare import run_method
from gyrodrift.config import CompensatorConfig
from gyrodrift.kernels.numeric import cap_covariance
from gyrodrift.evaluate.montecarlo import FAMILIES, draw_case, simulate_case
from gyrodrift.smooth import _groups, _held

#: IMM switching probability per update interval (chosen on static seeds 10-19).
P_SWITCH = 0.1


class Filter:
    """A forward filter of ``adaptive``'s model over its measurement groups; ``q_scale``
    scales the process-noise variance, ``slope`` keeps the slope random walk or not."""

    def __init__(self, cfg: CompensatorConfig, q_scale: float = 1.0, slope: bool = True):
        ad = cfg.adaptive
        self.Q = q_scale * np.diag(np.square(np.asarray(ad.q_sd, dtype=float)))
        self.slope_var = ad.slope_q_per_rtc**2 if slope else 0.0
        self.P0, self.max_var, _ = cfg.kalman.matrices()
        self.x0 = np.asarray(cfg.kalman.x0, dtype=float)
        self.softening, self.lambda_max = ad.softening, ad.lambda_max
        self.nis: deque[float] = deque(maxlen=ad.innovation_window)
        self.z = self.P = None

    def start(self, T_ref: float) -> None:
        self.z = np.array([self.x0[0], self.x0[1], self.x0[2] + self.x0[0] * T_ref])
        self.P = self.P0.copy()

    def recentre(self, d: float) -> None:
        J = np.eye(3)
        J[2, 0] = d  # c' at the new reference temperature
        self.z, self.P = J @ self.z, J @ self.P @ J.T

    def update(self, n: float, d: float, H, m, R) -> float:
        """One update after ``n`` intervals and a reference move ``d``; the log likelihood."""
        Q = n * self.Q
        Q[0, 0] += self.slope_var * abs(d)
        g = m - H @ self.z
        M = H @ self.P @ H.T
        S0 = M + H @ Q @ H.T + R
        nis = float(g @ np.linalg.solve(S0, g))
        loglik = -0.5 * (nis + np.linalg.slogdet(S0)[1] + g.size * math.log(2 * math.pi))
        self.nis.append(nis / g.size)
        excess = sum(self.nis) / len(self.nis) - self.softening
        trM = float(np.trace(M))
        lam = min(max(1.0, 1.0 + excess * float(np.trace(S0)) / trM), self.lambda_max) if trM > 0 else 1.0
        Pp = cap_covariance(lam * self.P + Q, self.max_var)
        K = np.linalg.solve(H @ Pp @ H.T + R, H @ Pp).T
        A = np.eye(3) - K @ H
        self.z = self.z + K @ g
        P = A @ Pp @ A.T + K @ R @ K.T
        self.P = cap_covariance(0.5 * (P + P.T), self.max_var)
        return loglik


def run_bank(groups, filters, interval_s: float):
    """States after each measurement group (times, combined states, reference temperatures,
    weights): an IMM over ``filters`` (one filter: that filter alone)."""
    k = len(filters)
    mu = np.full(k, 1.0 / k)
    ts, states, refs, weights = [], [], [], []
    t_prev = t_ref = None
    for t_k, T_k, m, temp, temp_rate, r in groups:
        if t_prev is None:
            for f in filters:
                f.start(T_k)
            n, d, prior = 1.0, 0.0, mu
        else:
            n, d = (t_k - t_prev) / interval_s, T_k - t_ref
            for f in filters:
                f.recentre(d)
            prior = mu
            if k > 1:  # IMM mixing
                p = 1.0 - (1.0 - P_SWITCH) ** max(n, 1.0)
                Pi = np.full((k, k), p / (k - 1))
                np.fill_diagonal(Pi, 1.0 - p)
                prior = Pi.T @ mu
                mix = Pi * mu[:, None] / prior[None, :]
                zs, Ps = [f.z for f in filters], [f.P for f in filters]
                for j, f in enumerate(filters):
                    zj = sum(mix[i, j] * zs[i] for i in range(k))
                    Pj = sum(mix[i, j] * (Ps[i] + np.outer(zs[i] - zj, zs[i] - zj)) for i in range(k))
                    f.z, f.P = zj, 0.5 * (Pj + Pj.T)
        H = np.column_stack([temp - T_k, temp_rate, np.ones(m.size)])
        loglik = np.array([f.update(n, d, H, m, np.diag(r)) for f in filters])
        w = np.log(np.maximum(prior, 1e-300)) + loglik
        mu = np.exp(w - w.max())
        mu /= mu.sum()
        t_prev, t_ref = t_k, T_k
        ts.append(t_k)
        states.append(sum(mu[j] * filters[j].z for j in range(k)))
        refs.append(T_k)
        weights.append(mu.copy())
    return np.array(ts), np.array(states), np.array(refs), np.array(weights)


def row_bias(out, ts, states, refs) -> np.ndarray:
    """Bias of every row from the state of the last group before it (``adaptive``'s before the first)."""
    t = out["t"].to_numpy(float)
    T = _held(out["temp"].to_numpy(float))
    Tp = out["temp_rate"].to_numpy(float)
    bias = out["bias_z"].to_numpy(float).copy()
    k = np.searchsorted(ts, t, side="left") - 1
    ok = k >= 0
    z, d = states[k[ok]], T[ok] - refs[k[ok]]
    bias[ok] = z[:, 2] + z[:, 0] * d + z[:, 1] * Tp[ok]
    return bias


def scores(t, bias, truth) -> tuple[float, float]:
    """Bias RMS error (deg/s) and the RMS of its running integral (deg)."""
    e = bias - truth
    integral = np.cumsum(e * np.diff(t, prepend=t[0]))
    return float(np.sqrt(np.mean(e**2))), float(np.sqrt(np.mean(integral**2)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--families", default=",".join(FAMILIES))
    ap.add_argument("--seeds", default="0-9", help="first-last (default 0-9)")
    args = ap.parse_args(argv)
    first, last = (int(v) for v in args.seeds.split("-"))
    cfg = CompensatorConfig()
    variants = {
        "reproduction of the default": lambda: [Filter(cfg)],
        "low noise (x0.1 variance, no slope walk)": lambda: [Filter(cfg, 0.1, slope=False)],
        f"IMM of the two, switching {P_SWITCH}": lambda: [Filter(cfg), Filter(cfg, 0.1, slope=False)],
    }
    print("| family | adaptive | " + " | ".join(variants) + " | IMM weight of low noise |")
    print("|---" * (len(variants) + 3) + "|")
    for family in args.families.split(","):
        res = {name: [] for name in ["adaptive", *variants]}
        low_weight = []
        for seed in range(first, last + 1):
            log, _ = simulate_case(draw_case(family, seed), calibration=False)
            out = run_method("adaptive", log, cfg)
            t, truth = out["t"].to_numpy(float), log["true_bias_z"].to_numpy(float)
            res["adaptive"].append(scores(t, out["bias_z"].to_numpy(float), truth))
            groups = _groups(out.attrs["measurements"])
            for name, make in variants.items():
                ts, states, refs, weights = run_bank(groups, make(), cfg.update_interval_s)
                res[name].append(scores(t, row_bias(out, ts, states, refs), truth))
                if weights.shape[1] > 1:
                    low_weight.append(weights[:, 1].mean())
        cells = [f"{np.mean([r[0] for r in v]):.4f} / {np.mean([r[1] for r in v]):.2f}" for v in res.values()]
        print(f"| {family} | " + " | ".join(cells) + f" | {np.mean(low_weight):.2f} |", flush=True)
    print("cells: bias RMS (deg/s) / heading proxy (deg), means over the seeds")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
