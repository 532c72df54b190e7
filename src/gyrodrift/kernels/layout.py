"""Layout of the arrays the kernels share: index names, codes, sizes.

The arrays of the paper's filters and their row loop (:mod:`gyrodrift.kernels.loop`), then
those of the x and y axes (:mod:`gyrodrift.kernels.tilt`); the default estimator's model keeps
its own (:mod:`gyrodrift.kernels.evidence`). What each array holds: ``docs/engine.md`` ("Arrays").
"""

from __future__ import annotations

__all__ = ["REASON_NAMES", "UNOBSERVABLE_NAMES"]  # and the index names; import the module

# --------------------------------------------------------------- reason codes

#: ``gate_reason`` values ("" = accepted; :mod:`gyrodrift.gating` says what each means) and
#: their codes, the indices into this tuple.
REASON_NAMES = ("", "init", "gap", "no_compass", "field", "turning", "interference")
R_NONE, R_INIT, R_GAP, R_NO_COMPASS, R_FIELD, R_TURNING, R_INTERFERENCE = range(len(REASON_NAMES))
#: No refusal seen yet in the current interval.
NO_STICKY = -1

#: ``unobservable`` values (the drift parameters not yet determined) and their codes: 1 for
#: ``a`` plus 2 for ``b``, the indices into this tuple.
UNOBSERVABLE_NAMES = ("", "a", "b", "a+b")
UNOBS_A, UNOBS_B = 1, 2
#: A parameter is not observable while its standard deviation is above this fraction of its prior one.
UNOBSERVABLE_SD_FRACTION = 0.5

#: Estimator modes: fixed fading (``stkf``, ``stkf-s1``, ``kf``), or a Python estimator
#: updated by the caller at interval ends (:data:`PENDING_UPDATE`).
MODE_FIXED, MODE_EXTERNAL = 0, 2
#: ``ist[I_PENDING]`` after an interval end in MODE_EXTERNAL: what the caller must do.
PENDING_NONE, PENDING_UPDATE, PENDING_HOLD = 0, 1, 2

# ---------------------------------------------------------------- float state

F_T, F_G, F_TEMP, F_TP, F_BIAS, F_RATE = 0, 1, 2, 3, 4, 5  # the previous row
F_IRAW, F_IT, F_ITP, F_IBIAS, F_IRATE = 6, 7, 8, 9, 10  # trapezoid integrals to it
F_K, F_TSTART, F_ANCHOR = 11, 12, 13  # interval number, start of interval 0, heading anchor
#: A snap: (t, heading, I_raw, I_T, I_Tp, I_bias) at a compass sample.
N_SNAP = 6
S_T, S_HEADING, S_IRAW, S_IT, S_ITP, S_IBIAS = 0, 1, 2, 3, 4, 5
F_S0 = 14  # snap at the start of the interval
F_S1 = 20  # the last compass snap
F_PA, F_PB, F_PC = 26, 27, 28  # a, b, c in force
F_COV = 29  # covariance of the a, b, c in force (3x3, row-major)
F_TP_T0, F_TP_SUM_T, F_TP_SUM_TEMP, F_TP_RATE = 38, 39, 40, 41  # T' tracker
F_FUSION = 42  # fused-heading state (FZ_* offsets)
F_LAST_T, F_LAST_G, F_LAST_TEMP = 51, 52, 53  # last input row (time check, held cells)
F_FIELD_NORM, F_FIELD_DIP = 54, 55  # reference field of the init window (NaN: none)
#: The fused heading's refused compass run: the innovation its consistency is counted from,
#: and since when (:func:`gyrodrift.kernels.fusion.step`).
F_FZ_NU0, F_FZ_CONS_T = 56, 57
#: The T' tracker's temperature resolution (smallest non-zero step between rows, 0: none yet)
#: and the previous row's temperature.
F_TP_RES, F_TP_PREV = 58, 59
N_FSTATE = 60

#: Fused-heading state, from F_FUSION.
FZ_PSI, FZ_P, FZ_TPREV, FZ_RPREV, FZ_STARTED, FZ_T0, FZ_ISD, FZ_SDPREV, FZ_REJ_T = range(9)
N_FZ = 9

# -------------------------------------------------------------- integer state

I_S0_OK, I_S1_OK, I_STICKY, I_AFTER_INT = 0, 1, 2, 3
I_STACK_N, I_REFUSED_N, I_LB_HEAD, I_LB_N, I_UNOBS, I_N_ACC = 4, 5, 6, 7, 8, 9
I_TP_BIN, I_TP_N, I_TP_HEAD, I_TP_LEN, I_TP_STARTED = 10, 11, 12, 13, 14
I_ROWS = 15  # rows taken so far (0: the next is the first of the log)
I_INIT_END = 16  # last row of the init window in this call (-1: none)
I_INIT_UPDATED = 17  # the init window gave a measurement
I_ANCHOR_ROW = 18  # first compass row of the init window
I_PENDING = 19  # PENDING_* for the caller (MODE_EXTERNAL)
N_ISTATE = 20

# ----------------------------------------------------------- float settings

C_INTERVAL, C_COMPASS_SD, C_GYRO_NOISE, C_TURN_RATE, C_TURN_WIN = 0, 1, 2, 3, 4
C_INTERF, C_MAX_AGE, C_PRIOR_A, C_PRIOR_B, C_MAX_GAP = 5, 6, 7, 8, 9
C_TP_BIN_S, C_FIELD_NORM_TOL, C_DIP_TOL, C_STILL_STD, C_STILL_HEADING = 10, 11, 12, 13, 14
C_FUSION_R, C_FUSION_N2, C_FUSION_TAU, C_FUSION_GATE, C_FUSION_RELOCK = 15, 16, 17, 18, 19
C_FUSION_CONSISTENT = 20  # refused compass samples consistent with the gyro this long re-anchor, s
N_CFG = 21

# --------------------------------------------------------- integer settings

K_RELOCK, K_MODE, K_DEPTH, K_TP_WINDOW_BINS, K_FUSE_INTERFERENCE = 0, 1, 2, 3, 4
K_TP_SHORT_BINS = 5  # T''s short window, bins (0: the window alone)
N_KCFG = 6

# ----------------------------------------------------------------- estimator

#: Floats: states [a, b, c] (3), covariance (3x3), process noise (3x3), the variance cap
#: (3), the fading factor s.
EF_Z, EF_P, EF_Q, EF_MAX_VAR, EF_FADING = 0, 3, 12, 21, 24
N_EF = 25
#: Integers: mode, number of active states, the active states (3).
EI_MODE, EI_N_ACTIVE, EI_ACTIVE = 0, 1, 2
N_EI = 5

#: Columns of a stacked or accepted measurement: m, mean T, mean T', 1, r (``stack``);
#: time, m, mean T, mean T', r (``acc``).
N_MEAS = 5

# ------------------------------------------------------------------ outputs

#: Float output columns, each ``cap`` long in ``out``.
O_BIAS, O_RATE, O_HEADING, O_A, O_B, O_C, O_BIAS_SD, O_FUSED, O_FUSED_SD, O_HEADING_SD, O_TEMP_RATE = range(11)
N_OUT = 11
#: int8 output columns in ``codes``: update, reason, unobservable, gap.
OC_UPDATE, OC_REASON, OC_UNOBS, OC_GAP = 0, 1, 2, 3
N_CODES = 4


# =================================================================== the x/y axes: xf, xi, xc, xk, ring

#: Reasons an x/y interval is refused, in the order the gates are tried; the codes are
#: the indices into this tuple (:data:`gyrodrift.triad.TRIAD_REASONS` is this tuple).
TILT_REASON_NAMES = ("gap", "accel", "tilt", "turning", "residual")
XG_GAP, XG_ACCEL, XG_TILT, XG_TURNING, XG_RESIDUAL = range(len(TILT_REASON_NAMES))
#: No refusal.
XG_NONE = -1

#: Status returned by :func:`gyrodrift.kernels.tilt.run` below 0: a time that is not
#: finite or does not increase; no temperature on the first row.
XS_BAD_TIME, XS_NO_TEMP = -1, -2

#: Columns of a row of ``ring``: time, the trapezoid integrals (N_XU), the specific force, usable.
XW_T, XW_IPHI, XW_ITH, XW_IT, XW_ITP, XW_IK1, XW_IK2, XW_IGX, XW_IGY, XW_IRZ = range(10)
XW_F0, XW_F1, XW_F2, XW_OK = 10, 11, 12, 13
N_XW = 14
#: Number of integrated quantities (XW_IPHI..XW_IRZ, in that order).
N_XU = 9

#: Means over an edge window: time, the integrals XW_IPHI..XW_IK2, roll, pitch, |f|, tilt, spread, rows.
XE_T, XE_IPHI, XE_ITH, XE_IT, XE_ITP, XE_IK1, XE_IK2 = range(7)
XE_ROLL, XE_PITCH, XE_NORM, XE_TILT, XE_SPREAD, XE_N = 7, 8, 9, 10, 11, 12
N_XE = 13

#: Float state (``docs/engine.md``, "Arrays").
XF_T0, XF_K, XF_TLAST, XF_SCALE = 0, 1, 2, 3  # first time, interval number, last time, g per input unit
XF_I = 4  # the integrals (N_XU)
XF_U = XF_I + N_XU  # the last row's integrands (N_XU)
XF_GX, XF_GY, XF_TEMP, XF_TP = XF_U + N_XU, XF_U + N_XU + 1, XF_U + N_XU + 2, XF_U + N_XU + 3  # held values
XF_PARAMS = XF_TP + 1  # (2, 3): [a, b, c] in force per axis
XF_COV = XF_PARAMS + 6  # (2, 9): their covariance, row-major
XF_EDGE = XF_COV + 18  # the open interval's start edge (N_XE)
XF_MEAS = XF_EDGE + N_XE  # (2, 4): [m, h_T, h_T', r] of an interval just accepted
XF_T_MEAS = XF_MEAS + 8  # its time
XF_RELOCK = XF_T_MEAS + 1  # (2, max(relock, 1)): rates of the residual refusals in a row


def xf_size(relock_intervals: int) -> int:
    """Length of ``xf`` for ``relock_intervals`` (:attr:`gyrodrift.gating.GateConfig.relock_intervals`)."""
    return XF_RELOCK + 2 * max(relock_intervals, 1)


#: Integer state (``docs/engine.md``, "Arrays").
XI_STARTED, XI_BAD, XI_TURNING, XI_EDGE_OK, XI_GATED, XI_DECIDED = 0, 1, 2, 3, 4, 5  # flags (0/1)
XI_HEAD, XI_N, XI_TURN_J = 6, 7, 8  # the ring's head, rows and turning-window start
XI_REFUSALS, XI_UPDATES, XI_PENDING = 9, 11, 13  # each (2,): residual refusals in a row, updates, PENDING_*
XI_REASONS = 15  # refusals by reason
N_XI = XI_REASONS + len(TILT_REASON_NAMES)

#: Float settings, in the units of :class:`gyrodrift.triad.TriadConfig` and ``CompensatorConfig``.
XC_INTERVAL, XC_MAX_GAP, XC_TURN_RATE, XC_TURN_WIN, XC_GYRO_NOISE, XC_EDGE_S = range(6)
XC_NORM_TOL, XC_SPREAD, XC_ACC_NOISE, XC_MAX_TILT, XC_RESID_DEG, XC_RESID_K = range(6, 12)
N_XC = 12
#: Integer settings: relock intervals, then per axis 1 when the caller runs its estimator (PENDING_*).
XK_RELOCK, XK_EXTERNAL = 0, 1  # XK_EXTERNAL: (2,)
N_XK = 3
