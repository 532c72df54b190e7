"""Pure Kalman-filter kernels shared by every Kalman drift estimator.

Eq. (10) of Feng et al. (2015) with Φ = Γ = I: the strong tracking (fading-memory)
filter differs from the plain Kalman filter only in the prediction ``P- = s*P + Q``;
``s = 1`` is the plain filter. This is filterpy's ``alpha`` with ``s = alpha**2``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["predict", "correct", "cap_covariance"]


def predict(P: np.ndarray, Q: np.ndarray, fading: float = 1.0) -> np.ndarray:
    """Covariance prediction of eq. (10) with Φ = I: ``P- = s*P + Q``.

    The state prediction is the identity (parameters modelled as constant).

    Parameters
    ----------
    P : (n, n) ndarray
        Posterior covariance.
    Q : (n, n) ndarray
        Process noise covariance.
    fading : float
        Fading factor s >= 1 (s = 1: plain Kalman filter).
    """
    if not fading >= 1.0:
        raise ValueError(f"fading factor s must be >= 1, got {fading!r}")
    return fading * P + Q


def correct(x: np.ndarray, P: np.ndarray, y: np.ndarray, H: np.ndarray, R: np.ndarray):
    """Measurement update of eq. (10), in Joseph form.

    Parameters
    ----------
    x : (n,) ndarray
        Predicted state.
    P : (n, n) ndarray
        Predicted covariance.
    y : (m,) ndarray
        Measurement.
    H : (m, n) ndarray
        Measurement matrix.
    R : (m, m) ndarray
        Measurement noise covariance.

    Returns
    -------
    x_post : (n,) ndarray
    P_post : (n, n) ndarray
        ``(I - K H) P (I - K H)^T + K R K^T``, symmetrised.
    innovation : (m,) ndarray
        ``y - H x``.
    S : (m, m) ndarray
        Innovation covariance ``H P H^T + R``.
    """
    S = H @ P @ H.T + R
    K = np.linalg.solve(S, H @ P).T  # P H^T S^-1, as P and S are symmetric
    innovation = y - H @ x
    A = np.eye(x.size) - K @ H
    P_post = A @ P @ A.T + K @ R @ K.T
    return x + K @ innovation, 0.5 * (P_post + P_post.T), innovation, S


def cap_covariance(P: np.ndarray, max_var: np.ndarray) -> np.ndarray:
    """Limit P to at most ``diag(max_var)`` in every direction (``P <= P_max``).

    In coordinates where ``P_max`` is the identity, eigenvalues of P above 1 are
    clipped to 1; directions already known better than the cap keep their variance.
    (Clipping each variance on its own would not: with a and c strongly correlated
    it would inflate the variance of the well-known combination ``a*T + c``.)
    P stays symmetric positive definite.
    """
    scale = np.sqrt(max_var)
    M = P / np.outer(scale, scale)
    if np.trace(M) <= 1.0:  # P is PSD: no eigenvalue of M can exceed its trace
        return P
    lam, V = np.linalg.eigh(0.5 * (M + M.T))
    if lam[-1] <= 1.0:
        return P
    clipped = (V * np.minimum(lam, 1.0)) @ V.T * np.outer(scale, scale)
    return 0.5 * (clipped + clipped.T)
