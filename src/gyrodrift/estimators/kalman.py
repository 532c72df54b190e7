"""The strong tracking Kalman filter of Feng et al. (2015), its s = 1 twin, and the KF baseline:
settings and state arrays of the filters of :mod:`gyrodrift.kernels.kalman`, behind the
:class:`~gyrodrift.estimators.base.DriftEstimator` interface (``docs/engine.md``, "The Kalman filters").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from gyrodrift.errors import ConfigError
from gyrodrift.estimators.base import LinearDrift, Observation, register
from gyrodrift.kernels import kalman as kernel
from gyrodrift.kernels import layout as L
from gyrodrift.settings import check, check_covariance, setting

__all__ = ["KalmanConfig", "KernelFilter", "filter_arrays", "compiled_arrays", "KalmanDrift", "PlainKalmanDrift", "BiasKalman"]


#: Names of the elements of a drift-model triple, for messages.
_ABC = ("a", "b", "c")


@dataclass(frozen=True, kw_only=True)
class KalmanConfig:
    """Settings of the Kalman drift estimators.

    Attributes
    ----------
    fading : float
        Fading factor s >= 1 of eq. (10); memory about ``1/(1 - 1/s)`` updates (1.2: about 6).
        Ignored by ``kf``.
    x0 : tuple of 3 floats
        Prior mean of [a (deg/s/degC), b (deg/degC), c (deg/s)].
    p0_sd : tuple of 3 floats
        Prior standard deviations of [a, b, c] (same units); P0 = diag(p0_sd²).
    q_sd : tuple of 3 floats
        Process-noise standard deviations of [a, b, c] per update interval;
        Q = diag(q_sd²).
    max_sd : tuple of 3 floats, optional
        Cap on each standard deviation (``docs/engine.md``); default ``p0_sd``. A cap above
        :data:`~gyrodrift.estimators.base.DRIFT_PARAM_BOUNDS` is allowed (no cap, for reference);
        ``x0``, ``p0_sd``, ``q_sd`` and the standard deviations of ``p0_cov`` must lie within them.
    p0_cov : 3x3 nested tuple, optional
        A full prior covariance replacing ``diag(p0_sd²)`` (a warm start from a device
        profile keeps the strong a–c correlation); the cap stays ``max_sd``/``p0_sd``.
    """

    fading: float = setting(1.2, ge=1.0, flag="--fading", help="fading factor s >= 1 of the STKF")
    x0: tuple[float, float, float] = setting((0.0, 0.0, 0.0), drift=_ABC, measured=True)
    p0_sd: tuple[float, float, float] = setting((0.05, 5.0, 5.0), drift=_ABC, gt=0.0)
    q_sd: tuple[float, float, float] = setting((1e-4, 0.05, 1e-3), drift=_ABC, ge=0.0)
    max_sd: tuple[float, float, float] | None = setting(None, gt=0.0)
    p0_cov: tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]] | None = \
        setting(None, measured=True)

    def __post_init__(self):
        check(self)

    def _check_together(self):
        if self.p0_cov is not None:
            check_covariance("p0_cov", self.p0_cov)

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Initial covariance P0, the variance cap (diagonal) and Q of these settings."""
        if self.p0_cov is not None:
            P0 = np.array(self.p0_cov, dtype=float)
        else:
            P0 = np.diag(np.square(np.array(self.p0_sd, dtype=float)))
        max_var = np.square(np.array(self.max_sd or self.p0_sd, dtype=float))
        return P0, max_var, np.diag(np.square(np.array(self.q_sd, dtype=float)))


def filter_arrays(*, x0, P0, Q, max_var, active=(0, 1, 2), fading: float = 1.0):
    """The estimator arrays ``(ef, ei)`` of :mod:`gyrodrift.kernels.kalman` for a prior: the
    filter starts from ``x0`` (absolute [a, b, c]) and ``P0``, with process noise ``Q``, cap
    ``max_var``, fading factor ``fading`` and the ``active`` states."""
    ef = np.zeros(L.N_EF)
    ei = np.zeros(L.N_EI, dtype=np.int64)
    ef[L.EF_Z:L.EF_Z + 3] = x0
    ef[L.EF_P:L.EF_P + 9] = np.asarray(P0, dtype=float).ravel()
    ef[L.EF_Q:L.EF_Q + 9] = np.asarray(Q, dtype=float).ravel()
    ef[L.EF_MAX_VAR:L.EF_MAX_VAR + 3] = max_var
    ef[L.EF_FADING] = fading
    ei[L.EI_MODE] = L.MODE_FIXED
    ei[L.EI_N_ACTIVE] = len(active)
    ei[L.EI_ACTIVE:L.EI_ACTIVE + len(active)] = active
    return ef, ei


class KernelFilter(LinearDrift):
    """A drift filter whose state is the estimator arrays of :mod:`gyrodrift.kernels.kalman`.

    :attr:`kernel_arrays` are updated in place by :meth:`update` and :meth:`hold`, here or
    inside the compiled row loop (:class:`gyrodrift.compensator.ChunkEngine`), which reads
    and writes the same arrays.
    """

    causal: ClassVar[bool] = True

    def __init__(self, ef: np.ndarray, ei: np.ndarray):
        self._ef = ef
        self._ei = ei

    @property
    def kernel_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(ef, ei)``: the state, read and written in place by the kernels."""
        return self._ef, self._ei

    @property
    def params(self) -> np.ndarray:
        return kernel.params(self._ef, self._ei)

    @property
    def cov(self) -> np.ndarray:
        return kernel.cov(self._ef, self._ei)

    def update(self, obs: Observation) -> np.ndarray:
        kernel.update(self._ef, self._ei, np.ascontiguousarray(obs.y, dtype=float),
                      np.ascontiguousarray(obs.H, dtype=float), np.ascontiguousarray(obs.R, dtype=float))
        return self.params

    def hold(self) -> np.ndarray:
        kernel.hold(self._ef, self._ei, 1.0)
        return self.params


def compiled_arrays(estimator) -> tuple[np.ndarray, np.ndarray] | None:
    """The state arrays of an estimator that a compiled row loop updates itself (a
    :class:`KernelFilter` whose ``update`` and ``hold`` are the kernels'), or None: it is
    updated in Python at interval ends (a subclass overriding them keeps its own)."""
    cls = type(estimator)
    if not isinstance(estimator, KernelFilter) or cls.update is not KernelFilter.update or cls.hold is not KernelFilter.hold:
        return None
    return estimator.kernel_arrays


@register
class KalmanDrift(KernelFilter):
    """Strong tracking Kalman filter over [a, b, c] (``stkf``), eqs. (3)–(10).

    Examples
    --------
    >>> from gyrodrift.estimators.base import Observation
    >>> est = KalmanDrift(KalmanConfig(fading=1.0))
    >>> obs = Observation(t=10.0, y=np.array([0.5]), H=np.array([[0.0, 0.0, 1.0]]),
    ...                   R=np.array([[1e-6]]))
    >>> round(float(est.update(obs)[2]), 4)
    0.5
    """

    name: ClassVar[str] = "stkf"

    def __init__(self, config: KalmanConfig = KalmanConfig()):
        self.config = config
        P0, max_var, Q = config.matrices()
        super().__init__(*filter_arrays(x0=config.x0, P0=P0, Q=Q, max_var=max_var, fading=config.fading))

    @property
    def fading(self) -> float:
        return self.config.fading


@register
class PlainKalmanDrift(KalmanDrift):
    """The same filter with s = 1 (``stkf-s1``): a plain Kalman filter over [a, b, c]."""

    name: ClassVar[str] = "stkf-s1"

    def __init__(self, config: KalmanConfig = KalmanConfig()):
        super().__init__(replace(config, fading=1.0))


@register
class BiasKalman(KernelFilter):
    """The paper's KF baseline (``kf``): a plain Kalman filter on a constant bias c alone.

    The filter of :class:`KalmanDrift` with s = 1 and only c active; a and b stay 0 (Section 4).

    Parameters
    ----------
    config : KalmanConfig
        Prior of c (``x0[2]``, ``p0_sd[2]``, cap ``max_sd[2]``).
    bias_q_sd : float
        Random-walk standard deviation of the bias per update interval, deg/s (``docs/engine.md``).
    """

    name: ClassVar[str] = "kf"

    def __init__(self, config: KalmanConfig = KalmanConfig(), bias_q_sd: float = 0.02):
        if not (math.isfinite(bias_q_sd) and bias_q_sd >= 0):
            raise ConfigError(f"bias_q_sd must be >= 0 deg/s, got {bias_q_sd!r}")
        self.config = config
        P0 = np.zeros((3, 3))
        P0[2, 2] = config.p0_sd[2] ** 2
        Q = np.zeros((3, 3))
        Q[2, 2] = bias_q_sd**2
        max_var = np.array([1.0, 1.0, (config.max_sd or config.p0_sd)[2] ** 2])
        super().__init__(*filter_arrays(x0=(0.0, 0.0, config.x0[2]), P0=P0, Q=Q, max_var=max_var, active=(2,)))
