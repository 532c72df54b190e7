"""The x and y gyro axes: the same temperature drift model, aided by gravity when quasi-static.

The heading axis (``gyro_z``) is aided by the compass (:mod:`gyrodrift.compensator`). The
two level axes have no compass, but when the unit is quasi-static the accelerometer
measures the gravity direction, i.e. roll and pitch, and their change over an update
interval plays the part the compass heading change plays for z.

Model (Feng, Li, Zhang 2015, eqs. 1, 2 and 5, per axis)
-------------------------------------------------------
``gyro_i = true_rate_i + drift_i + noise`` (eq. 1) with
``drift_i = a_i*T + b_i*T' + c_i`` (eq. 2), ``i = x, y``, with the temperature ``T`` and
the ``T'`` of the z axis (the ``temp_rate`` output column, :mod:`gyrodrift.model`).
Every row: ``bias_i = a_i*T + b_i*T' + c_i`` with the parameters in force and
``rate_i = gyro_i - bias_i`` (eq. 5). Each axis has its own estimator from the
registry (``TriadConfig.estimator``, default ``stkf``, eq. 10, with the same
:class:`~gyrodrift.estimators.KalmanConfig`); one measurement per interval, no stacking.

Signs and angles (FRD body, NED world; :mod:`gyrodrift.conventions`)
--------------------------------------------------------------------
From the specific force ``f`` (level and still: ``f = (0, 0, -1 g)``):
roll ``φ = atan2(-f_y, -f_z)`` (positive: right side down) and pitch
``θ = asin(f_x/|f|)`` (positive: nose up). A positive ``gyro_x`` rolls right side down,
a positive ``gyro_y`` pitches nose up (right-hand rule about the FRD axes), so with
the Euler-angle kinematics

    φ' = p + tanθ (q sinφ + r cosφ),      θ' = q cosφ − r sinφ

(``p, q, r``: body rates about x, y, z; ``r`` is the compensated ``rate_z`` when
given, else 0). gyrodrift integrates these with the raw ``gyro_x``/``gyro_y`` as
``p, q`` and the per-row accelerometer angles in the coefficients.

Measurement (the analogue of eqs. 4 and 6)
------------------------------------------
Over the interval between two boundary rows A and B (``update_interval_s`` apart on
a grid from the first row), each end is the mean over the rows of the last
``edge_s`` seconds up to the boundary (1 s: accelerometer noise averages down).
With ``Ī`` the window mean of a trapezoid integral and ``ā`` the window mean of an
angle:

    M_φ = [Ī_φ'(B) − Ī_φ'(A) − (φ̄(B) − φ̄(A))] / Δt,   Δt = t̄(B) − t̄(A)

and the same for θ. The same linear window functional is applied to the gyro
integral and to the angle, so for a constant drift and any attitude the accelerometer
sees exactly, ``M`` is the drift exactly; the sign measures the drift (gyro minus
reference, as gyrodrift's eq. 6). The drifts enter as ``M_φ = d_x + k1 d_y`` and
``M_θ = k2 d_y`` with ``k1`` and ``k2`` the window-matched interval means of
``tanθ sinφ`` and ``cosφ``, so ``m_y = M_θ/k2`` and ``m_x = M_φ − k1 m_y``: exact for
constant drifts whatever the attitude does between the edges. H is the row of
window-matched means of ``[T, T', 1]`` (exact for the linear drift model with a
constant attitude; eq. 3 with one row). Measurement
variance per axis: ``R = N²/Δt + (σ_A² + σ_B²)/Δt²`` with ``N`` the gyro noise density
and ``σ`` the standard error of each edge's mean angle (accelerometer noise, at least
``acc_noise_g``, or the spread seen in the window if larger), propagated through
``k1``, ``k2``.

Gates (an interval is refused and the estimators hold, as the paper's outages)
------------------------------------------------------------------------------
``gap``: a time step above ``GateConfig.max_gap_s``, or an empty gyro_x, gyro_y or
temp cell (held from the previous row). ``accel``: an edge window with too few
valid accelerometer rows, a mean specific-force norm more than ``acc_norm_tol_g``
from 1 g, or a component spread above ``acc_spread_g`` (linear acceleration: the
accelerometer does not show the gravity direction). ``tilt``: the tilt from level
(angle between ``-f`` and body z) above ``max_tilt_deg`` at an edge (30°: the roll
angle becomes ill-conditioned towards pitch 90° and the small cross-coupling
``k1`` grows). ``turning``: a ``GateConfig.turn_window_s`` mean of the compensated
x, y (or z, when given: a turning vehicle accelerates sideways) rate above
``GateConfig.turn_rate_dps``. ``residual`` (per axis): the disagreement
``(m − h·x)Δt`` exceeds ``max(residual_deg, residual_k·sqrt(h P hᵀ + R)·Δt)``: a
sustained linear acceleration looks like a tilt; as for the compass, after
``GateConfig.relock_intervals`` consecutive residual refusals that agree (same sign,
spread below half their mean) the next is accepted (the drift moved).
Known limit: a constant linear acceleration over a whole interval and both edges
that stays inside these tolerances biases the measurement.

Bad inputs
----------
* Empty (NaN) gyro_x/gyro_y/temp/temp_rate cells hold the previous value and refuse
  the interval; before the first gyro value ``rate_x``/``rate_y`` are empty (NaN)
  while ``bias_x``/``bias_y`` are given.
* Accelerometer rows that are empty, or whose norm is outside 0.5–1.5 g (e.g. all
  zero), are not used; with no usable accelerometer at all every interval is refused,
  the parameters stay at the prior ``x0`` and ``rate_i = gyro_i − drift(x0)``.
* The accelerometer unit (g or m/s²) is taken from the first usable row
  (``acc_unit="auto"``: norm above 3 means m/s²) unless given.

Causality and chunks: a row depends only on earlier rows. :class:`TriadCompensator`
processes chunks of any size with results identical bit for bit to one chunk
(:func:`compensate_triad`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from gyrodrift.compensator.config import CompensatorConfig, build_estimator
from gyrodrift.conventions import ACC_COLS, GYRO_X, GYRO_Y, TEMP, T
from gyrodrift.errors import ConfigError, GyroDriftError
from gyrodrift.estimators import Observation
from gyrodrift.kernels.aiding import steady_disagreement

__all__ = [
    "TriadConfig",
    "TriadCompensator",
    "compensate_triad",
    "add_triad_columns",
    "has_triad_inputs",
    "TRIAD_COLUMNS",
    "TRIAD_REASONS",
    "tilt_angles",
]

#: Output columns, in order: compensated rates and removed drifts (deg/s), and 1 where the
#: latest x/y update interval was refused (for either axis) or none has ended yet.
TRIAD_COLUMNS = ("rate_x", "rate_y", "bias_x", "bias_y", "tilt_gated")

#: Reasons an x/y interval is refused (:attr:`TriadCompensator.reasons` counts them).
TRIAD_REASONS = ("gap", "accel", "tilt", "turning", "residual")

_G_MPS2 = 9.80665

#: :meth:`TriadCompensator.feed` works through long inputs in blocks of this many rows.
_BLOCK_ROWS = 1 << 15


@dataclass(frozen=True, kw_only=True)
class TriadConfig:
    """Settings of the x/y gravity aiding (the rest comes from :class:`CompensatorConfig`).

    Attributes
    ----------
    edge_s : float
        Length of the window averaged at each interval edge, s (at most half the
        update interval).
    acc_unit : {"auto", "g", "m/s2"}
        Unit of ``acc``; ``auto`` decides on the first usable row (norm > 3: m/s²).
    acc_norm_tol_g : float
        Largest accepted departure of an edge's mean specific-force norm from 1 g, g.
    acc_spread_g : float
        Largest accepted standard deviation of any accelerometer component in an edge
        window, g.
    acc_noise_g : float
        Per-sample standard deviation of the accelerometer, g (floor of R).
    max_tilt_deg : float
        Largest accepted tilt from level at an edge, deg.
    residual_deg : float
        Floor of the residual gate, deg per interval.
    residual_k : float
        Residual gate in standard deviations of the predicted disagreement.
    estimator : str
        Drift estimator of the x and y axes (:mod:`gyrodrift.estimators`; its settings
        come from :class:`CompensatorConfig`). Default ``stkf``: the fixes of the
        ``adaptive`` estimator concern compass aiding of the heading axis, and on the
        simulated triad runs (10 Hz, seeds 1 and 2) ``stkf`` had the lower x/y drift
        RMS: static 0.0121/0.0077 against 0.0126/0.0084 deg/s, vehicle equal.
    """

    edge_s: float = 1.0
    acc_unit: str = "auto"
    acc_norm_tol_g: float = 0.03
    acc_spread_g: float = 0.02
    acc_noise_g: float = 0.003
    max_tilt_deg: float = 30.0
    residual_deg: float = 0.5
    residual_k: float = 5.0
    estimator: str = "stkf"

    def __post_init__(self):
        for name in ("edge_s", "acc_norm_tol_g", "acc_spread_g", "acc_noise_g", "residual_deg", "residual_k"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ConfigError(f"triad setting {name} must be a positive number, got {v!r}")
        if not (isinstance(self.max_tilt_deg, (int, float)) and 0 < self.max_tilt_deg < 80):
            raise ConfigError(f"triad setting max_tilt_deg must be in (0, 80) deg, got {self.max_tilt_deg!r}")
        if self.acc_unit not in ("auto", "g", "m/s2"):
            raise ConfigError(f"triad setting acc_unit must be 'auto', 'g' or 'm/s2', got {self.acc_unit!r}")
        from gyrodrift.estimators import ESTIMATORS

        if self.estimator not in ESTIMATORS:
            raise ConfigError(f"triad setting estimator must be one of {', '.join(sorted(ESTIMATORS))}, "
                              f"got {self.estimator!r}")


def tilt_angles(acc_g):
    """Roll and pitch (deg) of FRD specific force rows ``(N, 3)`` (any unit).

    ``roll = atan2(-f_y, -f_z)``, ``pitch = asin(f_x/|f|)``.

    >>> r, p = tilt_angles(np.array([[0.0, 0.0, -1.0], [np.sin(np.radians(10.0)), 0.0, -np.cos(np.radians(10.0))]]))
    >>> [round(float(v), 9) + 0.0 for v in r], [round(float(v), 9) + 0.0 for v in p]
    ([0.0, 0.0], [0.0, 10.0])
    """
    f = np.asarray(acc_g, dtype=float)
    norm = np.sqrt(f[:, 0] ** 2 + f[:, 1] ** 2 + f[:, 2] ** 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        roll = np.degrees(np.arctan2(-f[:, 1], -f[:, 2]))
        pitch = np.degrees(np.arcsin(np.clip(f[:, 0] / norm, -1.0, 1.0)))
    return roll, pitch


def _hold(x: np.ndarray, last: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Forward-fill non-finite values from ``last``; return values, held mask, new last."""
    bad = ~np.isfinite(x)
    if bad.any():
        x = pd.Series(np.where(bad, np.nan, x)).ffill().fillna(last).to_numpy()
    return x, bad, float(x[-1])


#: Per-row arrays of the open interval, in the order kept by the buffer.
_FIELDS = ("t", "Iphi", "Ith", "IT", "ITp", "Ik1", "Ik2", "Igx", "Igy", "Irz", "fx", "fy", "fz", "ok")
_F = slice(10, 13)
_OK = 13


class TriadCompensator:
    """Resumable x/y drift compensator: :meth:`feed` chunks of rows in time order.

    Parameters
    ----------
    config : CompensatorConfig, optional
        ``update_interval_s``, ``gyro_noise_dps_rthz``, ``gate`` (``max_gap_s``,
        ``turn_rate_dps``, ``turn_window_s``, ``relock_intervals``) and the estimator
        (``kalman``, ``adaptive``) as for the z axis; the estimator's name is
        ``triad.estimator``.
    triad : TriadConfig, optional
    estimators : (DriftEstimator, DriftEstimator), optional
        Fresh estimators for x and y instead of two built from ``config``.

    Examples
    --------
    A still, level unit whose x gyro reads 0.1 deg/s and y gyro -0.2 deg/s:

    >>> tc = TriadCompensator()
    >>> t = np.arange(0.0, 300.0, 0.1)
    >>> acc = np.tile([0.0, 0.0, -1.0], (t.size, 1))
    >>> out = tc.feed(t, np.full(t.size, 0.1), np.full(t.size, -0.2), np.full(t.size, 25.0), np.zeros(t.size), acc)
    >>> round(float(out["bias_x"][-1]), 4), round(float(out["bias_y"][-1]), 4)
    (0.1, -0.2)
    """

    def __init__(self, config=None, triad: TriadConfig | None = None, *, estimators=None):
        self.config = config or CompensatorConfig()
        self.triad = triad or TriadConfig()
        if self.triad.edge_s > 0.5 * self.config.update_interval_s:
            raise ConfigError(
                f"triad edge_s ({self.triad.edge_s:g} s) must be at most half the update interval "
                f"({self.config.update_interval_s:g} s)"
            )
        if estimators is None:
            axis_config = replace(self.config, estimator=self.triad.estimator)
            estimators = (build_estimator(axis_config), build_estimator(axis_config))
        self.est_x, self.est_y = estimators
        self._scale: float | None = {"g": 1.0, "m/s2": 1.0 / _G_MPS2}.get(self.triad.acc_unit)
        self._t0: float | None = None
        self._k = 0.0
        self._t_last = -math.inf
        self._prev: np.ndarray | None = None  # integrands of the last row
        self._I = np.zeros(9)  # their integrals
        self._held = {"gx": math.nan, "gy": math.nan, "T": math.nan, "Tp": 0.0}
        self._buf: list[dict[str, np.ndarray]] = []
        self._bad = False  # a gap or held cell in the open interval
        self._edge: dict | None = None  # window means at the start of the open interval
        self._gated = 1
        self._started = False
        #: Rates of the residual refusals in a row, per axis, and how many are held (lock-out recovery).
        self._relock = {axis: np.zeros(max(self.config.gate.relock_intervals, 1)) for axis in ("x", "y")}
        self._refusals = {"x": 0, "y": 0}
        #: Number of intervals refused for each reason of :data:`TRIAD_REASONS` (an
        #: interval refused for two reasons counts under the first).
        self.reasons = dict.fromkeys(TRIAD_REASONS, 0)
        #: Accepted updates per axis.
        self.updates = {"x": 0, "y": 0}

    # ------------------------------------------------------------------ public
    @property
    def params(self) -> tuple[np.ndarray, np.ndarray]:
        """[a, b, c] of x and of y now in force (deg/s/degC, deg, deg/s)."""
        return self.est_x.params, self.est_y.params

    def feed(self, t_s, gyro_x_dps, gyro_y_dps, temp_c, temp_rate_cps, acc, rate_z_dps=None) -> dict:
        """Compensate the next rows; return the columns of :data:`TRIAD_COLUMNS` for them.

        Parameters
        ----------
        t_s : (N,) array_like
            Time, s, strictly increasing (also across chunks).
        gyro_x_dps, gyro_y_dps : (N,) array_like
            Raw roll- and pitch-axis rates, deg/s (FRD; NaN = hold).
        temp_c : (N,) array_like
            Gyro temperature, degC (NaN = hold; the first row needs a value).
        temp_rate_cps : (N,) array_like
            T', degC/s: the compensator's ``temp_rate`` column (NaN = hold).
        acc : (N, 3) array_like
            FRD specific force ``acc_x, acc_y, acc_z`` (g or m/s², see ``acc_unit``).
        rate_z_dps : (N,) array_like, optional
            Compensated heading-axis rate, deg/s (the ``rate_z`` column): the Euler
            cross-coupling and the turning gate. None: taken as 0.

        Returns
        -------
        dict of (N,) ndarray
            ``rate_x, rate_y, bias_x, bias_y`` (deg/s, float) and ``tilt_gated`` (int8).
        """
        t = np.asarray(t_s, dtype=float)
        n = t.size
        cols = [np.asarray(v, dtype=float) for v in (gyro_x_dps, gyro_y_dps, temp_c, temp_rate_cps)]
        acc = np.asarray(acc, dtype=float).reshape(n, 3)
        rz = np.zeros(n) if rate_z_dps is None else np.asarray(rate_z_dps, dtype=float)
        if n == 1:  # the streaming compensator's case: the same arithmetic on Python floats
            out = self.feed_row(float(t[0]), *(float(c[0]) for c in cols), acc[0], float(rz[0]))
            return {c: np.array([v], dtype=np.int8 if c == "tilt_gated" else float) for c, v in zip(TRIAD_COLUMNS, out)}
        if n <= _BLOCK_ROWS:
            return self._feed(t, *cols, acc, rz)
        # blocks of cache size: the result does not depend on them, the speed does
        parts = [
            self._feed(t[i : i + _BLOCK_ROWS], *(c[i : i + _BLOCK_ROWS] for c in cols), acc[i : i + _BLOCK_ROWS],
                       rz[i : i + _BLOCK_ROWS])
            for i in range(0, n, _BLOCK_ROWS)
        ]
        return {c: np.concatenate([p[c] for p in parts]) for c in TRIAD_COLUMNS}

    def _feed(self, t, gyro_x_dps, gyro_y_dps, temp_c, temp_rate_cps, acc, rz) -> dict:
        n = t.size
        if n == 0:
            return {c: np.empty(0, dtype=np.int8 if c == "tilt_gated" else float) for c in TRIAD_COLUMNS}
        rz = np.where(np.isfinite(rz), rz, 0.0)
        if not np.all(np.isfinite(t)) or not (t[0] > self._t_last and np.all(np.diff(t) > 0)):
            raise GyroDriftError("triad: time must be finite and strictly increasing")
        if self._t0 is None:
            if not math.isfinite(float(np.asarray(temp_c, dtype=float)[0])):
                raise GyroDriftError("triad: the first row needs a temp value")
            self._t0 = float(t[0])
            self._k = 0.0
        h = self._held
        gx, bad_gx, h["gx"] = _hold(np.asarray(gyro_x_dps, dtype=float), h["gx"])
        gy, bad_gy, h["gy"] = _hold(np.asarray(gyro_y_dps, dtype=float), h["gy"])
        T, bad_T, h["T"] = _hold(np.asarray(temp_c, dtype=float), h["T"])
        Tp, _, h["Tp"] = _hold(np.asarray(temp_rate_cps, dtype=float), h["Tp"])
        gx0 = np.where(np.isfinite(gx), gx, 0.0)  # before the first value: integrate 0 (refused)
        gy0 = np.where(np.isfinite(gy), gy, 0.0)
        dt = t - np.r_[t[0] if self._prev is None else self._t_last, t[:-1]]
        bad = bad_gx | bad_gy | bad_T | (dt > self.config.gate.max_gap_s) | ~np.isfinite(gx) | ~np.isfinite(gy)

        # accelerometer: unit, validity, angles, Euler coefficients
        if self._scale is None:
            norm_raw = np.sqrt(np.sum(acc**2, axis=1))
            first = np.flatnonzero(np.isfinite(norm_raw) & (norm_raw > 0.05))
            if first.size:
                self._scale = 1.0 / _G_MPS2 if norm_raw[first[0]] > 3.0 else 1.0
        f = acc * (self._scale if self._scale is not None else math.nan)
        norm = np.sqrt(f[:, 0] ** 2 + f[:, 1] ** 2 + f[:, 2] ** 2)
        ok = np.isfinite(norm) & (norm > 0.5) & (norm < 1.5)
        f = np.where(ok[:, None], f, np.array([0.0, 0.0, -1.0]))  # unusable rows: taken as level
        yz = np.sqrt(f[:, 1] ** 2 + f[:, 2] ** 2)
        sphi, cphi, tth = -f[:, 1] / yz, -f[:, 2] / yz, f[:, 0] / yz  # sin φ, cos φ, tan θ
        k1 = tth * sphi
        u_phi = gx0 + tth * (gy0 * sphi + rz * cphi)
        u_th = gy0 * cphi - rz * sphi

        # trapezoid integrals continued from the last chunk (sequential sums: chunk-invariant)
        u = np.stack([u_phi, u_th, T, Tp, k1, cphi, gx0, gy0, rz])
        prev = self._prev if self._prev is not None else u[:, 0]
        inc = 0.5 * (u + np.concatenate([prev[:, None], u[:, :-1]], axis=1)) * dt
        inc[:, 0] += self._I
        I = np.cumsum(inc, axis=1)
        self._I, self._prev, self._t_last = I[:, -1].copy(), u[:, -1].copy(), float(t[-1])
        rows = np.empty((n, len(_FIELDS)))
        rows[:, 0] = t
        rows[:, 1:10] = I.T
        rows[:, _F] = f
        rows[:, _OK] = ok

        out_bias_x, out_bias_y = np.empty(n), np.empty(n)
        out_gated = np.empty(n, dtype=np.int8)
        k = np.floor((t - self._t0) / self.config.update_interval_s)
        boundary = np.flatnonzero(k > np.r_[self._k, k[:-1]])
        self._k = float(k[-1])
        ends = [(int(b), True) for b in boundary]
        if not ends or ends[-1][0] != n - 1:
            ends.append((n - 1, False))
        s = 0
        for b, closes in ends:
            seg = slice(s, b + 1)
            out_bias_x[seg] = self.est_x.drift(T[seg], Tp[seg])
            out_bias_y[seg] = self.est_y.drift(T[seg], Tp[seg])
            out_gated[seg] = self._gated
            self._buf.append(rows[seg])
            self._bad = self._bad or bool(bad[seg].any())
            if closes:  # the boundary row keeps the old parameters and shows the decision
                self._close()
                out_gated[b] = self._gated
                self._buf = [rows[b : b + 1]]
                self._bad = False
            s = b + 1
        return {
            "rate_x": gx - out_bias_x,
            "rate_y": gy - out_bias_y,
            "bias_x": out_bias_x,
            "bias_y": out_bias_y,
            "tilt_gated": out_gated,
        }

    def feed_row(self, t: float, gx: float, gy: float, T: float, Tp: float, acc, rz: float = 0.0) -> tuple:
        """:meth:`feed` for one row, on Python floats (the streaming compensator's case): the
        same operations in the same order as for a chunk, so the same bits, without numpy's
        per-call cost. Arguments as for :meth:`feed`, one value each (``acc`` three); returns
        the values of :data:`TRIAD_COLUMNS` for the row, as floats and an int."""
        rz = rz if math.isfinite(rz) else 0.0
        if not (math.isfinite(t) and t > self._t_last):
            raise GyroDriftError("triad: time must be finite and strictly increasing")
        if self._t0 is None:
            if not math.isfinite(T):
                raise GyroDriftError("triad: the first row needs a temp value")
            self._t0 = t
            self._k = 0.0
        h = self._held
        bad_gx, bad_gy, bad_T = not math.isfinite(gx), not math.isfinite(gy), not math.isfinite(T)
        gx = h["gx"] if bad_gx else gx
        gy = h["gy"] if bad_gy else gy
        T = h["T"] if bad_T else T
        Tp = h["Tp"] if not math.isfinite(Tp) else Tp
        h["gx"], h["gy"], h["T"], h["Tp"] = gx, gy, T, Tp
        gx_ok, gy_ok = math.isfinite(gx), math.isfinite(gy)
        gx0 = gx if gx_ok else 0.0
        gy0 = gy if gy_ok else 0.0
        dt = t - (t if self._prev is None else self._t_last)
        bad = bad_gx or bad_gy or bad_T or dt > self.config.gate.max_gap_s or not gx_ok or not gy_ok

        ax, ay, az = (float(v) for v in acc)
        if self._scale is None:
            norm_raw = math.sqrt(ax * ax + ay * ay + az * az)
            if math.isfinite(norm_raw) and norm_raw > 0.05:
                self._scale = 1.0 / _G_MPS2 if norm_raw > 3.0 else 1.0
        scale = self._scale if self._scale is not None else math.nan
        f0, f1, f2 = ax * scale, ay * scale, az * scale
        norm = math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
        ok = math.isfinite(norm) and 0.5 < norm < 1.5
        if not ok:
            f0, f1, f2 = 0.0, 0.0, -1.0
        yz = math.sqrt(f1 * f1 + f2 * f2)
        sphi, cphi, tth = -f1 / yz, -f2 / yz, f0 / yz
        k1 = tth * sphi
        u = (gx0 + tth * (gy0 * sphi + rz * cphi), gy0 * cphi - rz * sphi, T, Tp, k1, cphi, gx0, gy0, rz)
        prev = u if self._prev is None else self._prev.tolist()
        I = [0.5 * (ui + pi) * dt + Ii for ui, pi, Ii in zip(u, prev, self._I.tolist())]
        self._I, self._prev, self._t_last = np.array(I), np.array(u), t
        row = np.array([[t, *I, f0, f1, f2, float(ok)]])

        k = math.floor((t - self._t0) / self.config.update_interval_s)
        closes = k > self._k
        self._k = float(k)
        bias_x, bias_y = self.est_x.drift(T, Tp), self.est_y.drift(T, Tp)
        gated = self._gated
        self._buf.append(row)
        self._bad = self._bad or bad
        if closes:  # the boundary row keeps the old parameters and shows the decision
            self._close()
            gated = self._gated
            self._buf = [row]
            self._bad = False
        return float(gx - bias_x), float(gy - bias_y), float(bias_x), float(bias_y), int(gated)

    # ------------------------------------------------------------------ intervals
    def _window(self, buf: np.ndarray) -> dict | None:
        """Means over the last ``edge_s`` of the buffer rows (ending at its last row); None if unusable."""
        t = buf[:, 0]
        first = int(np.searchsorted(t, t[-1] - self.triad.edge_s, "right"))
        win = buf[first:]
        n = win.shape[0]
        okw = win[:, _OK] > 0
        n_ok = int(okw.sum())
        if n < 3 or n_ok < max(3, 0.8 * n) or t[-1] - t[first] < 0.5 * self.triad.edge_s:
            return None
        if n_ok < n:
            win = win[okw]
        m = win.mean(axis=0)
        f = win[:, _F]
        roll, pitch = tilt_angles(f)
        fm = m[_F]
        norm = float(np.sqrt(fm @ fm))
        return {
            **{name: float(m[i]) for i, name in enumerate(_FIELDS[:7])},
            "roll": float(np.mean(roll)),
            "pitch": float(np.mean(pitch)),
            "norm": norm,
            "tilt": math.degrees(math.acos(max(-1.0, min(1.0, -float(fm[2]) / norm)))),
            "spread": float(np.max(f.std(axis=0))),
            "n": n_ok,
        }

    def _refusal(self, start: dict | None, end: dict | None, r: dict[str, np.ndarray]) -> str | None:
        tc, gate = self.triad, self.config.gate
        if self._bad:
            return "gap"
        if start is None or end is None:
            return "accel"
        for e in (start, end):
            if abs(e["norm"] - 1.0) > tc.acc_norm_tol_g or e["spread"] > tc.acc_spread_g:
                return "accel"
        if max(start["tilt"], end["tilt"]) > tc.max_tilt_deg:
            return "tilt"
        # turning: window means of the compensated rates
        t = r["t"]
        j = np.searchsorted(t, t - gate.turn_window_s, "left")
        span = t - t[j]
        use = span >= 0.5 * gate.turn_window_s
        if use.any():
            span, j, i = span[use], j[use], np.flatnonzero(use)
            dT, dTp = r["IT"][i] - r["IT"][j], r["ITp"][i] - r["ITp"][j]
            for est, key in ((self.est_x, "Igx"), (self.est_y, "Igy")):
                a, b, c = (float(v) for v in est.params)
                mean = (r[key][i] - r[key][j] - a * dT - b * dTp - c * span) / span
                if np.max(np.abs(mean)) > gate.turn_rate_dps:
                    return "turning"
            if np.max(np.abs((r["Irz"][i] - r["Irz"][j]) / span)) > gate.turn_rate_dps:
                return "turning"
        return None

    def _close(self) -> None:
        """Decide the interval that ends at the buffer's last row; update or hold."""
        buf = np.concatenate(self._buf) if len(self._buf) > 1 else self._buf[0]
        r = {name: buf[:, i] for i, name in enumerate(_FIELDS)}
        start, end = self._edge, self._window(buf)
        self._edge = end
        first, self._started = not self._started, True
        reason = self._refusal(start, end, r)
        if reason is not None:
            if not first:  # the first interval has no start edge: nothing to count
                self.reasons[reason] += 1
            self.est_x.hold()
            self.est_y.hold()
            self._gated = 1
            self._refusals = {"x": 0, "y": 0}
            return
        dt = end["t"] - start["t"]
        M_phi = (end["Iphi"] - start["Iphi"] - (end["roll"] - start["roll"])) / dt
        M_th = (end["Ith"] - start["Ith"] - (end["pitch"] - start["pitch"])) / dt
        k1 = (end["Ik1"] - start["Ik1"]) / dt  # window-matched means of tanθ sinφ and cos φ
        k2 = (end["Ik2"] - start["Ik2"]) / dt
        m_y = M_th / k2
        m_x = M_phi - k1 * m_y
        h = np.array([(end["IT"] - start["IT"]) / dt, (end["ITp"] - start["ITp"]) / dt, 1.0])
        var_edge = sum(
            math.degrees(max(self.triad.acc_noise_g, e["spread"])) ** 2 / e["n"] for e in (start, end)
        )
        r_angle = self.config.gyro_noise_dps_rthz**2 / dt + var_edge / dt**2
        r_y = r_angle / k2**2
        r_x = r_angle + k1**2 * r_y
        t_end = float(r["t"][-1])
        refused = False
        for axis, est, m, var in (("x", self.est_x, m_x, r_x), ("y", self.est_y, m_y, r_y)):
            if self._residual_ok(axis, est, m, h, var, dt):
                est.update(Observation(t=t_end, y=np.array([m]), H=h[None, :], R=np.array([[var]]), n_new=1))
                self.updates[axis] += 1
            else:
                est.hold()
                refused = True
        if refused:
            self.reasons["residual"] += 1
        self._gated = int(refused)

    def _residual_ok(self, axis: str, est, m: float, h: np.ndarray, var: float, dt: float) -> bool:
        """The residual gate with lock-out recovery (module notes)."""
        resid = (m - float(h @ est.params)) * dt
        s = float(h @ est.cov @ h) + var
        limit = max(self.triad.residual_deg, self.triad.residual_k * math.sqrt(max(s, 0.0)) * dt)
        if abs(resid) <= limit:
            self._refusals[axis] = 0
            return True
        accept, self._refusals[axis] = steady_disagreement(resid / dt, self._relock[axis], self._refusals[axis],
                                                           self.config.gate.relock_intervals)
        if accept:
            self._refusals[axis] = 0
        return bool(accept)


def compensate_triad(
    t_s, gyro_x_dps, gyro_y_dps, temp_c, temp_rate_cps, acc, rate_z_dps=None, config=None,
    triad: TriadConfig | None = None, *, estimators=None,
) -> pd.DataFrame:
    """Compensate whole x/y columns at once; see :class:`TriadCompensator` (same arguments).

    Returns
    -------
    DataFrame
        The columns of :data:`TRIAD_COLUMNS`; ``attrs["params_x"]``, ``attrs["params_y"]``
        (final [a, b, c]) and ``attrs["triad_reasons"]`` (refused intervals by reason).
    """
    tc = TriadCompensator(config, triad, estimators=estimators)
    out = pd.DataFrame(tc.feed(t_s, gyro_x_dps, gyro_y_dps, temp_c, temp_rate_cps, acc, rate_z_dps))
    out.attrs["params_x"], out.attrs["params_y"] = tc.params
    out.attrs["triad_reasons"] = dict(tc.reasons)
    return out


def has_triad_inputs(columns) -> bool:
    """Whether a log has what the x/y compensation needs: ``gyro_x, gyro_y`` and ``acc_x..z``."""
    return all(c in columns for c in (GYRO_X, GYRO_Y, *ACC_COLS))


def triad_inputs(out: pd.DataFrame, log: pd.DataFrame) -> tuple:
    """Arguments of :meth:`TriadCompensator.feed` from input rows and their z output rows."""
    return (
        log[T].to_numpy(float),
        log[GYRO_X].to_numpy(float),
        log[GYRO_Y].to_numpy(float),
        log[TEMP].to_numpy(float),
        out["temp_rate"].to_numpy(float),
        log[list(ACC_COLS)].to_numpy(float),
        out["rate_z"].to_numpy(float),
    )


def add_triad_columns(out: pd.DataFrame, log: pd.DataFrame, config=None, tc: TriadCompensator | None = None):
    """Append :data:`TRIAD_COLUMNS` to the z output ``out`` of the rows of ``log`` (in place).

    ``tc`` continues a run chunk by chunk (:func:`gyrodrift.pipeline.compensate_file`);
    None compensates these rows as a whole log. The x/y estimators are built from
    ``config`` (their name from :attr:`TriadConfig.estimator`), also when the z axis was
    given an estimator instance. Returns ``out``.
    """
    tc = tc or TriadCompensator(config)
    for name, col in tc.feed(*triad_inputs(out, log)).items():
        out[name] = col
    return out
