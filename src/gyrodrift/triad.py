"""The x and y gyro axes: the same temperature drift model, aided by gravity when quasi-static.

Each level axis gets eq. (2) and its own estimator; the change of roll and pitch the
accelerometer measures over an update interval plays the part of the compass heading
change. The equations run in :mod:`gyrodrift.kernels.tilt`; this module holds the settings,
the state and the table functions. Model, measurement, gates and settings:
``docs/heading_and_axes.md`` (the x and y gyro axes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gyrodrift._columns import read_only_floats
from gyrodrift.conventions import ACC_COLS, GYRO_X, GYRO_Y
from gyrodrift.errors import ConfigError, GyroDriftError
from gyrodrift.estimators.base import LinearDrift, Observation, make_estimator
from gyrodrift.estimators.kalman import compiled_arrays
from gyrodrift.kernels import layout as L
from gyrodrift.kernels import tilt
from gyrodrift.settings import check, setting

__all__ = [
    "TriadConfig", "TriadCompensator", "has_triad_inputs", "TRIAD_COLUMNS", "TRIAD_REASONS",
]

#: Output columns, in order: compensated rates and removed drifts (deg/s), and 1 where the
#: latest x/y update interval was refused (for either axis) or none has ended yet.
TRIAD_COLUMNS = ("rate_x", "rate_y", "bias_x", "bias_y", "tilt_gated")

#: Reasons an x/y interval is refused, in the order the gates are tried
#: (:attr:`TriadCompensator.reasons` counts them).
TRIAD_REASONS = L.TILT_REASON_NAMES


def _interval_estimators() -> tuple:
    """The estimators that learn from interval measurements (all but the heading axis's ``adaptive``)."""
    from gyrodrift.estimators import ESTIMATORS

    return tuple(sorted(n for n in ESTIMATORS if n != "adaptive"))


@dataclass(frozen=True, kw_only=True)
class TriadConfig:
    """Settings of the x/y gravity aiding (the rest is the heading axis's): ``docs/heading_and_axes.md``."""

    edge_s: float = setting(1.0, "s", gt=0.0)
    acc_unit: str = setting("auto", choices=("auto", "g", "m/s2"))
    acc_norm_tol_g: float = setting(0.03, "g", gt=0.0)
    acc_spread_g: float = setting(0.02, "g", gt=0.0)
    acc_noise_g: float = setting(0.003, "g", gt=0.0)
    max_tilt_deg: float = setting(30.0, "deg", gt=0.0, lt=80.0)
    residual_deg: float = setting(0.5, "deg", gt=0.0)
    residual_k: float = setting(5.0, gt=0.0)
    estimator: str = setting("stkf", choices=_interval_estimators)

    def __post_init__(self):
        check(self)


#: Messages of the kernel's statuses below 0.
_STATUS = {
    L.XS_BAD_TIME: "triad: time must be finite and strictly increasing",
    L.XS_NO_TEMP: "triad: the first row needs a temp value",
}


class TriadCompensator:
    """Resumable x/y drift compensator: :meth:`feed` chunks of rows in time order.

    Parameters
    ----------
    config : CompensatorConfig
        The heading axis's settings (interval, noise, gate, ``kalman``).
    triad : TriadConfig, optional
    estimators : (DriftEstimator, DriftEstimator), optional
        Fresh x and y estimators instead of two built from the settings; their drift must be
        eq. (2) (:class:`~gyrodrift.estimators.base.LinearDrift`).
    """

    def __init__(self, config, triad: TriadConfig | None = None, *, estimators=None):
        self.config = config
        self.triad = triad or TriadConfig()
        tc, gate = self.triad, self.config.gate
        if tc.edge_s > 0.5 * self.config.update_interval_s:
            raise ConfigError(
                f"triad edge_s ({tc.edge_s:g} s) must be at most half the update interval "
                f"({self.config.update_interval_s:g} s)"
            )
        if estimators is None:
            estimators = tuple(make_estimator(self.triad.estimator, config=self.config.kalman) for _ in "xy")
        for est in estimators:
            owner = next((k for k in type(est).__mro__ if "drift" in k.__dict__), None)
            if owner is not LinearDrift:
                raise ConfigError(f"x/y estimator {est.name!r}: its drift is not a*T + b*T' + c (eq. 2), which the "
                                  "x/y axes are compensated with")
        self.est_x, self.est_y = estimators
        self._xc = np.zeros(L.N_XC)
        self._xc[[L.XC_INTERVAL, L.XC_MAX_GAP, L.XC_TURN_RATE, L.XC_TURN_WIN, L.XC_GYRO_NOISE, L.XC_EDGE_S]] = (
            self.config.update_interval_s, gate.max_gap_s, gate.turn_rate_dps, gate.turn_window_s,
            self.config.gyro_noise_dps_rthz, tc.edge_s)
        self._xc[[L.XC_NORM_TOL, L.XC_SPREAD, L.XC_ACC_NOISE, L.XC_MAX_TILT, L.XC_RESID_DEG, L.XC_RESID_K]] = (
            tc.acc_norm_tol_g, tc.acc_spread_g, tc.acc_noise_g, tc.max_tilt_deg, tc.residual_deg, tc.residual_k)
        self._xk = np.zeros(L.N_XK, dtype=np.int64)
        self._xk[L.XK_RELOCK] = gate.relock_intervals
        self._xf = np.zeros(L.xf_size(gate.relock_intervals))
        self._xf[[L.XF_TLAST, L.XF_GX, L.XF_GY, L.XF_TEMP]] = (-math.inf, math.nan, math.nan, math.nan)
        self._xf[L.XF_SCALE] = {"g": 1.0, "m/s2": 1.0 / tilt.G_MPS2}.get(tc.acc_unit, math.nan)
        self._xi = np.zeros(L.N_XI, dtype=np.int64)
        self._xi[L.XI_GATED] = 1
        self._ring = np.zeros((64, L.N_XW))
        filters = []
        for axis, est in enumerate(estimators):
            arrays = compiled_arrays(est)
            if arrays is None:  # a Python estimator: updated in _settle
                self._xk[L.XK_EXTERNAL + axis] = 1
                arrays = (np.zeros(1), np.zeros(1, dtype=np.int64))
            filters += arrays
            self._in_force(axis)
        self._filters = tuple(filters)
        self._external = bool(self._xk[L.XK_EXTERNAL:].any())
        self._one: _OneRow | None = None

    # ------------------------------------------------------------------ public
    @property
    def params(self) -> tuple[np.ndarray, np.ndarray]:
        """[a, b, c] of x and of y now in force (deg/s/degC, deg, deg/s)."""
        return self.est_x.params, self.est_y.params

    @property
    def reasons(self) -> dict[str, int]:
        """Intervals refused per reason of :data:`TRIAD_REASONS` (the first reason counts; not the first interval)."""
        return dict(zip(TRIAD_REASONS, self._xi[L.XI_REASONS:L.XI_REASONS + len(TRIAD_REASONS)].tolist()))

    @property
    def updates(self) -> dict[str, int]:
        """Accepted updates per axis (``x``, ``y``)."""
        return {"x": int(self._xi[L.XI_UPDATES]), "y": int(self._xi[L.XI_UPDATES + 1])}

    def feed(self, t_s, gyro_x_dps, gyro_y_dps, temp_c, temp_rate_cps, acc, rate_z_dps=None) -> dict:
        """Compensate the next rows; return the columns of :data:`TRIAD_COLUMNS` for them.

        Parameters
        ----------
        t_s : (N,) array_like
            Time, s, strictly increasing (also across chunks).
        gyro_x_dps, gyro_y_dps : (N,) array_like
            Raw roll- and pitch-axis rates, deg/s (FRD; NaN = hold).
        temp_c, temp_rate_cps : (N,) array_like
            Temperature (degC; the first row needs one) and the compensator's ``temp_rate`` (NaN = hold).
        acc : (N, 3) array_like
            FRD specific force (g or m/s², ``acc_unit``).
        rate_z_dps : (N,) array_like, optional
            Compensated ``rate_z`` (the Euler cross-coupling and the turning gate); None: 0.

        Raises
        ------
        GyroDriftError
            A time not finite or not increasing, no first temperature, or columns of different
            lengths; no row is taken then.
        """
        t = read_only_floats(t_s)
        n = t.size
        cols = [read_only_floats(v) for v in (gyro_x_dps, gyro_y_dps, temp_c, temp_rate_cps)]
        rz = read_only_floats(np.zeros(n) if rate_z_dps is None else rate_z_dps)
        acc = read_only_floats(np.asarray(acc, dtype=float).reshape(-1, 3))
        if t.ndim != 1 or any(c.shape != (n,) for c in (*cols, rz)) or acc.shape != (n, 3):
            raise GyroDriftError("triad: every input needs one value per row (acc three)")
        out = np.empty((4, n))
        gated = np.empty(n, dtype=np.int8)
        if n:
            inputs = (t, *cols, acc, rz)
            self._resume(tilt.run(*inputs, 0, *self._state, out, gated), inputs, out, gated)
        return {"rate_x": out[0], "rate_y": out[1], "bias_x": out[2], "bias_y": out[3], "tilt_gated": gated}

    def feed_row(self, t: float, gx: float, gy: float, T: float, Tp: float, acc, rz: float = 0.0) -> tuple:
        """:meth:`feed` for one row of Python floats (``acc`` three); the values of :data:`TRIAD_COLUMNS`."""
        one = self._one
        if one is None:
            one = self._one = _OneRow(self._state)
        ax, ay, az = acc
        v = one.values
        v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8] = t, gx, gy, T, Tp, ax, ay, az, rz
        done = tilt.run(*one.args)
        if done != 1 or self._external:
            self._resume(done, one.inputs, one.out, one.gated)
        return (*one.flat.tolist(), one.gated.item())

    # ------------------------------------------------------------------ the kernel
    @property
    def _state(self) -> tuple:
        """The state and estimator arrays, in the order of :func:`gyrodrift.kernels.tilt.run`."""
        return (self._xf, self._xi, self._xc, self._xk, self._ring, *self._filters)

    def _resume(self, done: int, inputs: tuple, out: np.ndarray, gated: np.ndarray) -> None:
        """Act on what the row loop returned (``done``: the next row, or a status below 0), and run it
        again until every row of ``inputs`` is done."""
        n = inputs[0].size
        while True:
            if done < 0:
                raise GyroDriftError(_STATUS[done])
            if self._external:
                self._settle()
            if self._xi[L.XI_N] == self._ring.shape[0]:
                self._grow()
            if done >= n:
                return
            done = tilt.run(*inputs, done, *self._state, out, gated)

    def _settle(self) -> None:
        """The Python estimators' update or hold at an interval end (PENDING_* of the kernel)."""
        xi, xf = self._xi, self._xf
        for axis, est in enumerate((self.est_x, self.est_y)):
            pending = xi[L.XI_PENDING + axis]
            if pending == L.PENDING_NONE:
                continue
            xi[L.XI_PENDING + axis] = L.PENDING_NONE
            if pending == L.PENDING_UPDATE:
                m, h_T, h_Tp, r = xf[L.XF_MEAS + 4 * axis:L.XF_MEAS + 4 * axis + 4].tolist()
                est.update(Observation(t=float(xf[L.XF_T_MEAS]), y=np.array([m]), H=np.array([[h_T, h_Tp, 1.0]]),
                                       R=np.array([[r]]), n_new=1))
            else:
                est.hold()
            self._in_force(axis)

    def _in_force(self, axis: int) -> None:
        """An estimator's parameters and covariance into the kernel's state."""
        est = (self.est_x, self.est_y)[axis]
        self._xf[L.XF_PARAMS + 3 * axis:L.XF_PARAMS + 3 * axis + 3] = np.asarray(est.params, dtype=float)
        self._xf[L.XF_COV + 9 * axis:L.XF_COV + 9 * axis + 9] = np.asarray(est.cov, dtype=float).ravel()

    def _grow(self) -> None:
        """Twice the rows in the ring, oldest first."""
        head, n = int(self._xi[L.XI_HEAD]), int(self._xi[L.XI_N])
        ring = np.zeros((2 * self._ring.shape[0], L.N_XW))
        ring[:n] = self._ring[(head + np.arange(n)) % self._ring.shape[0]]
        self._ring = ring
        self._xi[L.XI_HEAD] = 0
        if self._one is not None:
            self._one.bind(self._state)


class _OneRow:
    """One-row inputs, outputs and kernel arguments of :meth:`TriadCompensator.feed_row`, kept between calls."""

    def __init__(self, state: tuple):
        self.values = np.zeros(9)
        v = self.values
        self.inputs = tuple(read_only_floats(c)
                            for c in (v[0:1], v[1:2], v[2:3], v[3:4], v[4:5], v[5:8].reshape(1, 3), v[8:9]))
        self.out = np.zeros((4, 1))
        self.flat = self.out.reshape(4)
        self.gated = np.zeros(1, dtype=np.int8)
        self.bind(state)

    def bind(self, state: tuple) -> None:
        """The kernel's arguments with these state arrays."""
        self.args = (*self.inputs, 0, *state, self.out, self.gated)


def has_triad_inputs(columns) -> bool:
    """Whether a log has what the x/y compensation needs: ``gyro_x, gyro_y`` and ``acc_x..z``."""
    return all(c in columns for c in (GYRO_X, GYRO_Y, *ACC_COLS))
