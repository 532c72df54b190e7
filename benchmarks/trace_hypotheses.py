"""Trace the default model's hypotheses epoch by epoch on one generated case or one log (a
diagnosis aid: the kind of trace docs/results.md quotes).

    python benchmarks/trace_hypotheses.py multicopter 1000000 --from 300 --to 330
    python benchmarks/trace_hypotheses.py path/to/log.csv --from 30 --to 60 --every 5
    python benchmarks/trace_hypotheses.py vessel 3 --to 600 --every 30 --set steady_walk=0.03

Runs with numba's compilation off (``NUMBA_DISABLE_JIT=1``, set here before gyrodrift is
imported), so the kernels' Python functions can be wrapped: about a minute for 1,000 s of a
100-Hz log. Only the rows up to ``--to`` are compensated. For each printed epoch (every
``--every`` s of epoch ends between ``--from`` and ``--to``): per hypothesis (0 clean still,
1 clean moving, 2 disturbed still, 3 disturbed moving, 4 steady still, 5 steady moving) its
probability after the epoch, the epoch's log-likelihood, the compass innovation and its
variance (deg, deg²), the heading variance before the update (deg²), its mean drift over the
epoch (deg/s), the compass's slow error d and the disturbance e (deg); for a hypothesis that
also weighs an alternative (a drift jump, a disturbance step), those of its last update. A generated case adds
the truth at the epoch end: rate, drift, compass offset.
"""

from __future__ import annotations

import argparse
import ast
import os
import warnings

os.environ["NUMBA_DISABLE_JIT"] = "1"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("source", help="a generator class (then SEED) or a log file")
    p.add_argument("seed", nargs="?", type=int)
    p.add_argument("--from", dest="t0", type=float, default=0.0, help="first epoch end to print, s")
    p.add_argument("--to", dest="t1", type=float, required=True, help="last epoch end to print, s")
    p.add_argument("--every", type=float, default=1.0, help="print an epoch at most this often, s")
    p.add_argument("--modes", default="0,1,2,3,4,5", help="hypotheses to print, comma-separated")
    p.add_argument("--set", dest="settings", action="append", default=[], metavar="NAME=VALUE",
                   help="an AdaptiveConfig setting (a tuple as NAME=v1,v2,...); repeatable")
    p.add_argument("--temperature", choices=("auto", "measured", "clock"), default="auto",
                   help="what the drift model's T is (CompensatorConfig.temperature)")
    args = p.parse_args(argv)
    warnings.simplefilter("ignore")

    import numpy as np

    from gyrodrift.compensator import CompensatorConfig, compensate
    from gyrodrift.estimators import AdaptiveConfig
    from gyrodrift.kernels import evidence as ev

    settings = {k: ast.literal_eval(v) for k, v in (s.split("=", 1) for s in args.settings)}
    config = CompensatorConfig(adaptive=AdaptiveConfig(**settings), temperature=args.temperature)

    truth = args.seed is not None  # a generated case carries its truth columns
    if truth:
        from gyrodrift.simulate.generator import generate

        log = generate(args.source, args.seed).log
    else:
        from gyrodrift.io import read_log

        log = read_log(args.source)
    modes = [int(m) for m in args.modes.split(",")]
    calls = []
    measure, epoch = ev._measure, ev.epoch

    def traced_measure(x, P, j, mf, *rest):
        pdd = P[ev.X_DELTA, ev.X_DELTA]
        out = measure(x, P, j, mf, *rest)
        calls.append((j, out[0], out[2], out[3], pdd, x[ev.X_D], x[ev.X_E]))
        return out

    state = {"next": args.t0}

    def traced_epoch(mf, mc, t_end, temp_end):
        calls.clear()
        dt = t_end - mf[ev.MF_E_T0]
        sums = mf[ev.MF_E_TC], mf[ev.MF_E_TP], mf[ev.MF_E_TC2]
        epoch(mf, mc, t_end, temp_end)
        if not (args.t0 <= t_end <= args.t1 and t_end >= state["next"] and dt > 0):
            return
        state["next"] = t_end + args.every
        X = mf[ev.MF_X:ev.MF_X + ev.NM * ev.NX].reshape(ev.NM, ev.NX)
        mu = mf[ev.MF_MU:ev.MF_MU + ev.NM]
        line = f"t {t_end:8.1f}"
        if truth:
            i = min(int(np.searchsorted(log["t"].to_numpy(), t_end)), len(log) - 1)
            line += (f" | truth rate {log['true_rate_z'].iloc[i]:+.3f} drift {log['true_bias_z'].iloc[i]:+.3f}"
                     f" offset {log['true_compass_offset'].iloc[i]:+.1f}")
        print(line)
        last = {}
        for j, ll, nu, S, pdd, d, e in calls:  # a mode's last update (its alternative's, if it weighs one)
            last[j] = (ll, nu, S, pdd, d, e)
        for j in modes:
            x = X[j]
            # the drift integral as the epoch measures it (c' and its rate r at the epoch end), per s
            drift = (x[ev.X_A] * sums[0] + x[ev.X_B] * sums[1] + x[ev.X_C] * dt - 0.5 * x[ev.X_R] * dt * dt
                     + x[ev.X_A2] * sums[2]) / dt
            ll, nu, S, pdd, d, e = last.get(j, (np.nan,) * 6)
            print(f"   {j} P {mu[j]:9.3e} ll {ll:+8.2f} nu {nu:+7.2f} S {S:8.2f} Pdd {pdd:8.2f} drift {drift:+.4f}"
                  f" d {d:+6.2f} e {e:+7.2f}")

    ev._measure = traced_measure
    ev.epoch = traced_epoch
    compensate(log[log["t"] <= args.t1 + 1.0], config)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
