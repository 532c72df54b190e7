"""The default estimator's model: heading, drift and compass error, judged by evidence.

Six linear-Gaussian filters over ``x = [δ, a, b, c', d, r, e, a2, σ, d_q, ω]`` (δ = heading −
∫gyro; a, b, c' the drift of eq. 2 centred on ``T_ref``; d the compass's deviation at the present
heading and d_q its quadrature, the deviation's first harmonic, which a turn rotates; r the
drift's rate of departure from eq. 2; e a magnetic disturbance; a2 the drift's curvature in
temperature; σ the share of a turn the gyro's scale factor adds, ``rate = (gyro - drift) (1 -
σ)``; ω the platform's true rate over the epoch, which the gyro measures with the drift, 0 when
still), one per hypothesis (compass clean, disturbed by a wandering or by a steady error ×
platform still or moving), stepped once per epoch (:func:`epoch`: δ moves by minus the drift
integral, eq. 5; the compass measures δ, eqs. 4–6) and mixed as an
interacting multiple model in which each mode also carries its own state (:func:`_branches`,
:func:`combine`). The model and every term: ``docs/model.md``.

Arrays: ``mf`` floats (``MF_*``), ``mc`` settings (``MC_*``). All functions are pure numba on
these arrays, so batch, chunked and streaming runs give the same bits.
"""

from __future__ import annotations

import math

import numpy as np

from gyrodrift.kernels import jit
from gyrodrift.kernels.numeric import wrap180

__all__ = ["NM", "NX", "epoch", "combine", "bias_var", "init_state", "seed_heading", "seed_noise"]

#: Modes (rows of the filter bank) and states.
NM, NX = 6, 11
#: Branches of an epoch: two starting points of each mode (:func:`_branches`).
NB = 2 * NM
#: Predictors of a moving platform's true rate (random walks, slow to agile).
N_RATE = 4
#: Floats of an epoch's scratch (one array, carved by :func:`_take` in :func:`epoch`): the mode
#: changes; the branches' states and covariances; an alternative's covariance; four numbers per
#: branch, two per mode; nine vectors of states (the three measurement rows, an alternative's
#: state, the moving modes' state, four for the helpers); eight of the rate predictors; a moving
#: mode's redrawn rate (a state, its covariance, two helpers).
N_WORK = NM * NM + NB * NX * (1 + NX) + NX * NX + 4 * NB + 2 * NM + 9 * NX + 8 * (N_RATE + 1) + NX * (NX + 3)
CLEAN_STILL, CLEAN_MOVING, DIST_STILL, DIST_MOVING, STEADY_STILL, STEADY_MOVING = 0, 1, 2, 3, 4, 5
#: Prior share of a new disturbance that is steady (walks slowly) rather than wandering.
STEADY_SHARE = 0.5
X_DELTA, X_A, X_B, X_C, X_D, X_R, X_E, X_A2, X_S, X_DQ, X_W = 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10

# ------------------------------------------------------------------ float state
MF_X = 0                      # (NM, NX) states per mode
MF_P = MF_X + NM * NX         # (NM, NX, NX) covariances
MF_MU = MF_P + NM * NX * NX   # (NM,) mode probabilities
MF_W = MF_MU + NM             # rate predictors: (ω, P) each, slow to agile
MF_XC = MF_W + 2 * N_RATE     # (NX,) combined state
MF_PC = MF_XC + NX            # (NX, NX) combined covariance
MF_TREF = MF_PC + NX * NX     # reference temperature (degC)
MF_SIG_S2 = MF_TREF + 1       # per-sample gyro noise variance ((deg/s)^2), measured
MF_SIG_W2 = MF_SIG_S2 + 1     # compass white noise variance (deg^2), measured
MF_NORM_REF, MF_DIP_REF = MF_SIG_W2 + 1, MF_SIG_W2 + 2   # field reference (NaN: none yet)
MF_H_S = MF_DIP_REF + 1       # the log's spacing: forgotten sum of its time steps (s; NaN before the first)
# epoch accumulators: duration is t_end - t0
MF_E_T0 = MF_H_S + 1          # epoch start time (s)
MF_E_G = MF_E_T0 + 1          # ∫gyro over the epoch (deg)
MF_E_TC = MF_E_G + 1          # ∫(T - T_ref) dt (degC s)
MF_E_TP = MF_E_TC + 1         # ∫T' dt (degC)
MF_E_H2 = MF_E_TP + 1         # Σ h² of the steps (s²)
MF_E_H4 = MF_E_H2 + 1         # Σ h⁴ (s⁴)
MF_E_NC = MF_E_H4 + 1         # compass samples
MF_E_SD = MF_E_NC + 1         # Σ (D_j - D_ref), D = compass - ∫gyro (deg)
MF_E_STC = MF_E_SD + 1        # Σ ∫(T - T_ref) to each compass sample
MF_E_STP = MF_E_STC + 1       # Σ ∫T' to each compass sample
MF_E_ST = MF_E_STP + 1        # Σ (t_j - t0)
MF_E_SG = MF_E_ST + 1         # Σ ∫gyro to each compass sample
MF_E_DREF = MF_E_SG + 1       # D_ref of the epoch
MF_E_DG2 = MF_E_DREF + 1      # Σ (Δgyro)² of successive rows
MF_E_NDG = MF_E_DG2 + 1       # their count
MF_E_NORM = MF_E_NDG + 1      # Σ field strength of the compass samples
MF_E_DIP = MF_E_NORM + 1      # Σ dip
MF_E_NF = MF_E_DIP + 1        # field samples
MF_E_DD2 = MF_E_NF + 1        # Σ (ΔD)² of successive compass samples
MF_E_NDD = MF_E_DD2 + 1       # their count
MF_E_T_START = MF_E_NDD + 1   # temperature at the epoch start (degC)
MF_E_GAP = MF_E_T_START + 1   # 1: the epoch is a time gap (no gyro data in it)
MF_E_G0, MF_E_S1, MF_E_S2, MF_E_NG = MF_E_GAP + 1, MF_E_GAP + 2, MF_E_GAP + 3, MF_E_GAP + 4  # gyro samples:
#   the first, Σ and Σ² of the others minus it, and their number (the sample variance of the epoch)
MF_LAST_D, MF_LAST_D_T = MF_E_NG + 1, MF_E_NG + 2  # last compass D and its time
MF_PDIST, MF_PSTILL, MF_FIELD_DOM = MF_LAST_D_T + 1, MF_LAST_D_T + 2, MF_LAST_D_T + 3  # labels of the last epoch
MF_UPDATED = MF_FIELD_DOM + 1  # the last epoch used a measurement (1) or not
MF_NS_S, MF_NS_W = MF_UPDATED + 1, MF_UPDATED + 2  # the gyro noise: forgotten sums of ½(Δg)² and of steps
MF_NW_S, MF_NW_W = MF_UPDATED + 3, MF_UPDATED + 4  # the compass noise: the same of ½(ΔD)²
#: The compass error an epoch's mean keeps beyond white noise (deg²): value, forgotten sum and weight.
MF_RX, MF_RX_S, MF_RX_W = MF_NW_W + 1, MF_NW_W + 2, MF_NW_W + 3
#: Probability that the last epoch's drift jumped (the modes' weights where the jump was kept).
MF_JUMP = MF_RX_W + 1
#: The gyro noise's colour (a still epoch's von Neumann ratio over its white value): belief mean, variance.
MF_COLOUR, MF_COLOUR_V = MF_JUMP + 1, MF_JUMP + 2
#: The epoch's ∫(T - T_ref)² dt (degC² s) and its Σ to each compass sample (the curvature's regressors).
MF_E_TC2, MF_E_STC2 = MF_COLOUR_V + 1, MF_COLOUR_V + 2
#: The epoch's Σ h³ of the steps (s³), and the motion's agility believed after the last moving epoch:
#: the rate predictors' mean walk variance ((deg/s)²/s) and the weight of any rate.
MF_E_H3, MF_WQ2, MF_WANY = MF_E_STC2 + 1, MF_E_STC2 + 2, MF_E_STC2 + 3
#: The motion's character carried with ``motion_memory_s`` (docs/model.md, "Motion"): the weights of
#: the rate predictors and of any rate that explained the last moving epoch (N_RATE + 1), and the
#: belief that the motion is smooth (its gyro white about the epoch's mean).
MF_PW = MF_WANY + 1
MF_SMOOTH = MF_PW + N_RATE + 1
MF_PLABEL = MF_SMOOTH + 1      # P(a disturbance moves the compass by more than LABEL_DEG), last epoch
# the compass noise's correlation: the epoch's halves (Σ of D + bias·(t - t0) over all samples and
# the first half's, the first half's count), and the forgotten sums of the inflation κ and its weight
MF_E_SB, MF_E_SB1, MF_E_NC1 = MF_PLABEL + 1, MF_PLABEL + 2, MF_PLABEL + 3
MF_KAPPA, MF_K_S, MF_K_W = MF_E_NC1 + 1, MF_E_NC1 + 2, MF_E_NC1 + 3
MF_H_N = MF_K_W + 1           # the log's spacing: the forgotten count of its time steps (MF_H_S's weight)
MF_H_L = MF_H_N + 1           # the forgotten sum of the log of its time steps (weight MF_H_N)
MF_H_SEEN = MF_H_L + 1        # the log's first steps seen (up to N_FIRST_STEPS)
MF_H_FIRST = MF_H_SEEN + 1    # the log's first steps (s), N_FIRST_STEPS of them
#: The log's first steps kept, from which its spacing is first taken (``evloop.SPACING_MIN_STEPS``).
N_FIRST_STEPS = 20
# the compass's tilt error (docs/model.md, "The compass's tilt"): over the epoch's compass samples,
# Σ of the difference of their headings tilted by the accelerometer and by the gyro-aided gravity
# (deg), Σ of its square (deg²) and their count; the last epoch's mean difference (NaN: none), the
# forgotten sums of successive epochs' products and mean squares, and the inflation they give
MF_E_TD, MF_E_TV, MF_E_NT = MF_H_FIRST + N_FIRST_STEPS, MF_H_FIRST + N_FIRST_STEPS + 1, MF_H_FIRST + N_FIRST_STEPS + 2
MF_TD_LAST, MF_TK_S, MF_TK_W, MF_TILT_K = MF_E_NT + 1, MF_E_NT + 2, MF_E_NT + 3, MF_E_NT + 4
#: The clean field's scatter about the reference, measured: forgotten sums of the epochs' squared
#: strength ratio and dip departure (deg²) while the compass is clean, each epoch weighted by its
#: chance of being no outlier (:func:`_robust`), and the sums of those weights.
MF_FS_N, MF_FS_D, MF_FS_WN, MF_FS_WD = MF_TILT_K + 1, MF_TILT_K + 2, MF_TILT_K + 3, MF_TILT_K + 4
#: The share of the clean field's epochs that are outliers, measured: forgotten sums of their
#: chances of being one and of the epochs (:func:`_robust`).
MF_FO_S, MF_FO_W = MF_FS_WD + 1, MF_FS_WD + 2
N_MF = MF_FO_W + 1
#: The tilt error's correlation from one epoch to the next before it is measured, and its weight
#: (deg², the sums' units: that of TILT_PRIOR_EPOCHS epochs of a 2-deg difference): a tilt error
#: lasts as long as the acceleration or the attitude that causes it, seconds to tens of seconds.
TILT_RHO0 = 0.8
TILT_PRIOR_EPOCHS = 20.0
#: The largest correlation taken (an inflation of 39): the compass is never refused outright.
TILT_RHO_MAX = 0.95

#: A row is labelled ``interference`` where a disturbance moves the compass by more than this
#: (deg) with probability 0.5 or more.
LABEL_DEG = 2.0
#: The von Neumann test of stillness needs this many gyro samples in an epoch.
VN_MIN_SAMPLES = 8.0
#: Probability that a moving epoch's gyro is white about its mean (a steady turn).
VN_MOTION = 0.5
#: The smallest mode probability: a numerical guard only, far below any weight that competes
#: (a higher floor keeps a refuted mode's own branch weighted enough to re-fit the data).
MU_MIN = 1e-150
#: A moving mode's chance of a redrawn rate below which its posterior is the walked rate's alone
#: (the second update is then skipped; its share of the moments would be below 1e-4).
ANY_MIN = 1e-4
#: Prior standard deviation of the noise colour about white (1), and its random walk per √s.
COLOUR_SD0, COLOUR_WALK = 0.25, 0.001
#: Bounds of the colour where it sets the long-run noise (an AR(1) sequence's).
COLOUR_MIN, COLOUR_MAX = 0.2, 1.5
#: Largest heading variance a time gap adds to a moving platform, deg² (a heading anywhere).
GAP_VAR_MAX = 90.0**2
#: Largest predicted variance of a clean compass innovation that measures MF_RX, deg².
RX_S_MAX = 25.0
#: Mean time a motion keeps its character, s: the rate filters' chance of handing over.
RATE_SWITCH_S = 10.0
#: Weight of the settings' noise values in the measured noise, in steps of data.
NOISE_PRIOR_STEPS = 20.0
#: A still epoch's halves differing by more than this many times their expected square (4 sd)
#: hold a disturbance's step, not the noise's correlation.
KAPPA_CLIP = 16.0

# ------------------------------------------------------------------ settings
(MC_EPOCH, MC_TAU_CLEAN, MC_TAU_DIST, MC_TAU_STILL, MC_TAU_MOVE,
 MC_Q_A, MC_Q_B, MC_Q_C, MC_Q_CT,
 MC_SIG_D, MC_TAU_D, MC_K_TURN,
 MC_SIG_R, MC_TAU_R,
 MC_SIG_STEP, MC_Q_E, MC_TAU_E,
 MC_SIG_ACC, MC_OMEGA_GAP, MC_Q_STILL,
 MC_GAP_FACTOR, MC_COMPASS_SD, MC_GYRO_NOISE, MC_SIG_NORM, MC_SIG_DIP,
 MC_NOISE_MEMORY, MC_P_CLEAN0, MC_P_STILL0, MC_DELTA_SD0,
 MC_RATE_ANY, MC_CLOCK, MC_L_DEV, MC_SIG_JUMP, MC_TAU_JUMP, MC_Q_E_STEADY, MC_SF_WALK,
 MC_T_R, MC_SIG_RT, MC_MOTION_MEMORY, MC_SF_MAX, MC_L_DIST) = range(41)
#: The rate predictors' random walks (deg/s/√s) and their prior shares of a moving epoch
#: (the rest: any rate within ``MC_RATE_ANY``), N_RATE each.
MC_Q_W = 41
MC_SHARE = MC_Q_W + N_RATE
N_MC = MC_SHARE + N_RATE

#: Log-likelihoods of a disturbed field: strength ratio within ±50 %, dip within ±30 deg.
LL_ANY_NORM = -math.log(1.0)
LL_ANY_DIP = -math.log(60.0)
_LOG_2PI = math.log(2.0 * math.pi)
#: Log-likelihood ratio (clean against disturbed) of the field below which a disturbance is
#: labelled ``field``: the field strength and dip alone make it 20 times likelier.
FIELD_SAYS_DISTURBED = -3.0
#: The smallest scatter of a clean field taken, as a share of the settings' (``field_norm_sd``,
#: ``field_dip_deg``): a log whose field has held still is not thereby exact.
FIELD_SD_FLOOR = 0.1
#: Share of a clean field's epochs whose strength or dip departs as a disturbed field's would (the
#: accelerometer's tilt error in the dip while the platform speeds up or brakes; a glitch): the
#: prior, worth ``NOISE_PRIOR_STEPS`` epochs, of the share measured, which is taken within
#: ``FIELD_OUTLIER_RANGE``.
FIELD_OUTLIER = 0.05
FIELD_OUTLIER_RANGE = (0.005, 0.5)


@jit(inline=True)
def _is_clean(j):
    return j == CLEAN_STILL or j == CLEAN_MOVING


@jit(inline=True)
def _is_still(j):
    return j == CLEAN_STILL or j == DIST_STILL or j == STEADY_STILL


@jit(inline=True)
def _is_steady(j):
    return j == STEADY_STILL or j == STEADY_MOVING


@jit(inline=True)
def _share(j):
    """Prior share of mode ``j`` within its compass class (clean: 1)."""
    return 1.0 if _is_clean(j) else (STEADY_SHARE if _is_steady(j) else 1.0 - STEADY_SHARE)


@jit(inline=True)
def _loggauss(nu, S):
    return -0.5 * (_LOG_2PI + math.log(S) + nu * nu / S)


@jit(inline=True)
def _dot(a, b):
    """``a · b`` of two short vectors, summed in index order (no BLAS call)."""
    acc = 0.0
    for k in range(a.size):
        acc += a[k] * b[k]
    return acc


@jit(inline=True)
def _no_rate(x, P):
    """A still platform's state: its true rate ω is 0, known exactly."""
    x[X_W] = 0.0
    for k in range(NX):
        P[X_W, k] = 0.0
        P[k, X_W] = 0.0


@jit(inline=True)
def _robust(ll_clean, ll_any, eps):
    """A clean field's log-likelihood of one part (strength or dip) over a disturbed one's
    (``ll_any``), its scatter's outliers (a tilt's error in the dip, a glitch) anywhere as a
    disturbed field's are, with probability ``eps``; and the probability that the epoch is no
    outlier (the weight it gets in the learned scatter and, less, in the outliers' share)."""
    a = math.log(1.0 - eps) + ll_clean
    b = math.log(eps) + ll_any
    top = max(a, b)
    tot = math.exp(a - top) + math.exp(b - top)
    return top + math.log(tot) - ll_any, math.exp(a - top) / tot


@jit(inline=True)
def _mix_in(x, P, xa, Pa, qa, da, db):
    """``x``, ``P`` ← the moments of the mixture of themselves (weight ``1 - qa``) and ``xa``,
    ``Pa`` (weight ``qa``), in place; δ and e as angles about ``x``'s. ``da``, ``db``: scratch (NX)."""
    for k in range(NX):
        d = wrap180(xa[k] - x[k]) if k == X_DELTA or k == X_E else xa[k] - x[k]
        da[k] = (1.0 - qa) * d  # xa less the mixture's mean
        db[k] = -qa * d         # x less the mixture's mean
    for k in range(NX):
        x[k] -= db[k]
    for r in range(NX):
        for c in range(NX):
            P[r, c] = (1.0 - qa) * (P[r, c] + db[r] * db[c]) + qa * (Pa[r, c] + da[r] * da[c])


@jit
def init_state(mf, mc, x0, P0, t_ref):
    """Start the bank: every mode at the prior ``x0`` (NX,), ``P0`` (NX, NX) (drift states centred
    on ``t_ref``), mode probabilities from the settings, the rate filters at rest."""
    mf[MF_TREF] = t_ref
    pc, ps = mc[MC_P_CLEAN0], mc[MC_P_STILL0]
    X = mf[MF_X:MF_X + NM * NX].reshape((NM, NX))
    P = mf[MF_P:MF_P + NM * NX * NX].reshape((NM, NX, NX))
    for j in range(NM):
        X[j, :] = x0
        P[j, :, :] = P0
        # e of the disturbed filters starts at the compass's error scale (docs/model.md, "The start")
        if not _is_clean(j):
            P[j, X_E, X_E] = mc[MC_SIG_D] ** 2
        if _is_still(j):
            _no_rate(X[j], P[j])
        mf[MF_MU + j] = (pc if _is_clean(j) else 1.0 - pc) * (ps if _is_still(j) else 1.0 - ps) * _share(j)
    shares = np.empty(N_RATE + 1)
    shares[N_RATE] = 1.0
    steady = mc[MC_MOTION_MEMORY] > 0.0
    for k in range(N_RATE):
        # at rest within 1 deg/s; predicting the gyro's own rate, the drift's prior too
        mf[MF_W + 2 * k] = x0[X_C] if steady else 0.0
        mf[MF_W + 2 * k + 1] = 1.0 + P0[X_C, X_C] if steady else 1.0
        shares[k] = mc[MC_SHARE + k]
        shares[N_RATE] -= shares[k]
    _set_agility(mf, mc, shares)
    mf[MF_SMOOTH] = VN_MOTION
    mf[MF_KAPPA] = 1.0
    mf[MF_TD_LAST] = math.nan
    mf[MF_TK_W] = TILT_PRIOR_EPOCHS * 4.0
    mf[MF_TK_S] = TILT_RHO0 * mf[MF_TK_W]
    mf[MF_TILT_K] = (1.0 + TILT_RHO0) / (1.0 - TILT_RHO0)
    combine(mf)


@jit(inline=True)
def _set_agility(mf, mc, w):
    """The motion's agility from the weights ``w`` (N_RATE + 1) of the rate predictors and of
    any rate: their mean walk variance ((deg/s)²/s) and the weight of any rate; ``w`` kept."""
    mf[MF_PW:MF_PW + N_RATE + 1] = w
    mf[MF_WQ2] = 0.0
    for k in range(N_RATE):
        mf[MF_WQ2] += w[k] * mc[MC_Q_W + k] ** 2
    mf[MF_WANY] = w[N_RATE]


@jit
def seed_heading(mf, delta):
    """The heading's prior mean from the first compass sample (``delta`` = its heading minus
    the gyro integral, deg), its variance unchanged: the model then depends on no constant
    rotation of the compass (a declination)."""
    X = mf[MF_X:MF_X + NM * NX].reshape((NM, NX))
    for j in range(NM):
        X[j, X_DELTA] = delta
    combine(mf)


@jit(inline=True)
def _moments(X, P, w, ref_delta, ref_e, clean, step_var, x, Pm, dx):
    """Add the moments of the bank ``X``, ``P`` with weights ``w`` to ``x``, ``Pm`` (zeros): δ
    and e averaged as angles about ``ref_delta`` and ``ref_e``; ``clean``: for a clean mode,
    without a disturbance e, and ``step_var`` added to e's variance for each clean mode mixed
    into a disturbed one. ``dx``: scratch (NX)."""
    for i in range(NM):
        for k in range(NX):
            v = X[i, k]
            # angles: a still mode's δ and e follow a turn unwrapped
            if k == X_DELTA:
                v = ref_delta + wrap180(v - ref_delta)
            elif k == X_E:
                v = 0.0 if clean else ref_e + wrap180(v - ref_e)  # a clean compass has no disturbance
            x[k] += w[i] * v
    for i in range(NM):
        if w[i] == 0.0:
            continue
        for k in range(NX):
            dx[k] = X[i, k] - x[k]
        dx[X_DELTA] = wrap180(X[i, X_DELTA] - x[X_DELTA])
        dx[X_E] = 0.0 if clean else wrap180(X[i, X_E] - x[X_E])
        for r in range(NX):
            for c in range(NX):
                if clean and (r == X_E or c == X_E):
                    continue
                Pm[r, c] += w[i] * (P[i, r, c] + dx[r] * dx[c])
        if _is_clean(i) and not clean:  # a disturbance begins: a step of unknown size
            Pm[X_E, X_E] += w[i] * step_var


@jit(inline=True)
def _likeliest_e(X, w, default):
    """The disturbance e of the disturbed mode of largest weight ``w`` (a clean mode's e is no
    angle to average about), or ``default`` when no disturbed mode has weight."""
    ref_e = default
    top = 0.0
    for i in range(NM):
        if not _is_clean(i) and w[i] > top:
            top = w[i]
            ref_e = X[i, X_E]
    return ref_e


@jit(inline=True)
def _set_labels(mf):
    """P(disturbed) and P(still) from the mode probabilities."""
    p_dist = p_still = 0.0
    for j in range(NM):
        if not _is_clean(j):
            p_dist += mf[MF_MU + j]
        if _is_still(j):
            p_still += mf[MF_MU + j]
    mf[MF_PDIST] = p_dist
    mf[MF_PSTILL] = p_still
    X = mf[MF_X:MF_X + NM * NX].reshape((NM, NX))
    P = mf[MF_P:MF_P + NM * NX * NX].reshape((NM, NX, NX))
    p_label = 0.0
    for j in range(NM):
        if not _is_clean(j):
            m, s2 = X[j, X_E], P[j, X_E, X_E]
            if s2 > 0.0:
                z = math.sqrt(2.0 * s2)
                p_label += mf[MF_MU + j] * 0.5 * (math.erfc((LABEL_DEG - m) / z) + math.erfc((LABEL_DEG + m) / z))
            elif abs(m) > LABEL_DEG:
                p_label += mf[MF_MU + j]
    mf[MF_PLABEL] = p_label


@jit
def combine(mf):
    """The moment-matched mixture of the bank into MF_XC, MF_PC (δ and e averaged as angles)."""
    _combine(mf, np.empty(NX))


@jit(inline=True)
def _combine(mf, dx):
    """:func:`combine` with its scratch ``dx`` (NX)."""
    X = mf[MF_X:MF_X + NM * NX].reshape((NM, NX))
    P = mf[MF_P:MF_P + NM * NX * NX].reshape((NM, NX, NX))
    xc = mf[MF_XC:MF_XC + NX]
    Pc = mf[MF_PC:MF_PC + NX * NX].reshape((NX, NX))
    xc[:] = 0.0
    Pc[:, :] = 0.0
    # angles about the likeliest mode's δ and the likeliest disturbed mode's e (a refuted mode's
    # δ may be half a turn away, and the likely modes must not fall on both sides of its wrap)
    mu = mf[MF_MU:MF_MU + NM]
    _moments(X, P, mu, X[np.argmax(mu), X_DELTA], _likeliest_e(X, mu, 0.0), False, 0.0, xc, Pc, dx)


@jit(inline=True)
def bias_var(Pc, hT, hTp, hT2):
    """Variance of ``a hT + b hTp + c + a2 hT2`` under the covariance ``Pc`` (NX, NX)."""
    A, B, C, A2 = X_A, X_B, X_C, X_A2
    v = (Pc[A, A] * hT * hT + Pc[B, B] * hTp * hTp + Pc[C, C] + 2.0 * Pc[A, B] * hT * hTp
         + 2.0 * Pc[A, C] * hT + 2.0 * Pc[B, C] * hTp
         + hT2 * (Pc[A2, A2] * hT2 + 2.0 * (Pc[A, A2] * hT + Pc[B, A2] * hTp + Pc[C, A2])))
    return max(v, 0.0)


@jit(inline=True)
def _quad(P, H):
    """``H P Hᵀ`` for a row ``H`` (no temporary)."""
    acc = 0.0
    for r in range(NX):
        for c in range(NX):
            acc += H[r] * P[r, c] * H[c]
    return acc


@jit(inline=True)
def _update(x, P, H, z, R, wrap, only, keep, PH):
    """Scalar measurement ``z = H x + v``, var R: x, P in place; returns the log-likelihood
    (``wrap``: the innovation is an angle, wrapped to ±180). ``only`` >= 0: the measurement
    corrects that state alone (the others are considered, not corrected: a Schmidt update).
    Else ``keep`` >= 0: it corrects every state but that one (its gain 0; in the Joseph form
    only its own variance then differs from the optimal update's: it is kept). ``PH``:
    scratch (NX)."""
    S = R
    nu = z
    for r in range(NX):
        acc = 0.0
        for c in range(NX):
            acc += P[r, c] * H[c]
        PH[r] = acc
        S += H[r] * acc
        nu -= H[r] * x[r]
    if wrap:
        nu = wrap180(nu)
    if only >= 0:
        # Joseph form (I - K H) P (I - K H)^T + K R K^T with K nonzero in row ``only`` alone:
        # only that row and column of P change; PH is reused for the new row
        k = PH[only] / S
        x[only] += k * nu
        for c in range(NX):
            acc = P[only, c]
            for m in range(NX):
                acc -= k * H[m] * P[m, c]
            PH[c] = acc
        corner = k * k * R
        for m in range(NX):
            corner += PH[m] * ((1.0 if m == only else 0.0) - k * H[m])
        for c in range(NX):
            P[only, c] = PH[c]
            P[c, only] = PH[c]
        P[only, only] = corner
    else:
        kept = P[keep, keep] if keep >= 0 else 0.0
        for r in range(NX):
            if r != keep:
                x[r] += PH[r] / S * nu
        for r in range(NX):
            k = PH[r] / S
            for c in range(NX):
                P[r, c] -= k * PH[c]
        if keep >= 0:
            P[keep, keep] = kept
    for r in range(NX):  # symmetric, non-negative diagonal
        for c in range(r + 1, NX):
            m = 0.5 * (P[r, c] + P[c, r])
            P[r, c] = m
            P[c, r] = m
        if P[r, r] < 0.0:
            P[r, r] = 0.0
    return _loggauss(nu, S)


@jit(inline=True)
def _rows(P, f01, f02, f03, f05, f07, f08, g, pd, cr, sr, pr, pe):
    """``P`` ← F P in place, F the identity but for the δ row (f01, f02, f03, f05, f07, f08: its
    a, b, c', r, a2, σ entries), c' from r (g), the deviation's pair (d, d_q) turned by the
    angle whose cosine and sine are ``cr``, ``sr`` and decayed by ``pd``, and the decays of r, e
    (pr, pe)."""
    for k in range(NX):
        P[X_DELTA, k] += (f01 * P[X_A, k] + f02 * P[X_B, k] + f03 * P[X_C, k] + f05 * P[X_R, k] + f07 * P[X_A2, k]
                          + f08 * P[X_S, k])
        P[X_C, k] += g * P[X_R, k]
        d, q = P[X_D, k], P[X_DQ, k]
        P[X_D, k] = pd * (cr * d + sr * q)
        P[X_DQ, k] = pd * (cr * q - sr * d)
        P[X_R, k] *= pr
        P[X_E, k] *= pe


@jit(inline=True)
def _transition(P, f01, f02, f03, f05, f07, f08, g, pd, cr, sr, pr, pe):
    """``P`` ← F P Fᵀ in place, no temporary (F as :func:`_rows` has it): rows, then columns."""
    _rows(P, f01, f02, f03, f05, f07, f08, g, pd, cr, sr, pr, pe)
    Pt = P.T
    _rows(Pt, f01, f02, f03, f05, f07, f08, g, pd, cr, sr, pr, pe)


@jit
def _branches(mf, Pi, step_var, XB, PB, wb, w, dx):
    """The two starting points of each mode ``j`` over an epoch: row ``j`` of the banks ``XB``,
    ``PB`` the switched-in branch (the IMM mixture of the other modes, weighted by the chances
    of having come from each) and row ``NM + j`` the mode's own state carried on; ``wb`` their
    prior probabilities. Each is updated by the epoch's data before the two are merged, so a
    mode of small weight keeps its own history where the data prefer it (docs/model.md,
    "Hypotheses"). ``w`` (NM), ``dx`` (NX): scratch."""
    X = mf[MF_X:MF_X + NM * NX].reshape((NM, NX))
    P = mf[MF_P:MF_P + NM * NX * NX].reshape((NM, NX, NX))
    mu = mf[MF_MU:MF_MU + NM]
    for j in range(NM):
        c = 0.0
        for i in range(NM):
            w[i] = 0.0 if i == j else Pi[i, j] * mu[i]
            c += w[i]
        wb[j] = c
        wb[NM + j] = Pi[j, j] * mu[j]
        XB[NM + j, :] = X[j]
        PB[NM + j, :, :] = P[j]
        if c > 0.0:
            for i in range(NM):
                w[i] /= c
            XB[j, :] = 0.0
            PB[j, :, :] = 0.0
            # angles about the likeliest source's (mode j's own may be half a turn away)
            _moments(X, P, w, X[np.argmax(w), X_DELTA], _likeliest_e(X, w, X[j, X_E]), _is_clean(j), step_var,
                     XB[j], PB[j], dx)
            if _is_still(j):
                _no_rate(XB[j], PB[j])
        else:
            XB[j, :] = X[j]
            PB[j, :, :] = P[j]


@jit(inline=True)
def _motion_prior(mf, mc, dt, out):
    """The weights of the rate predictors and of any rate for the next ``dt`` s (N_RATE + 1,
    into ``out``) and the chance that a motion is smooth: the prior shares and ``VN_MOTION``,
    or with ``motion_memory_s`` the last moving epoch's, drawn afresh with the chance of a change
    over ``dt``."""
    rest = 1.0
    for k in range(N_RATE):
        out[k] = mc[MC_SHARE + k]
        rest -= mc[MC_SHARE + k]
    out[N_RATE] = rest
    tau = mc[MC_MOTION_MEMORY]
    if not tau > 0.0:
        return VN_MOTION
    keep = math.exp(-dt / tau)
    for k in range(N_RATE + 1):
        out[k] = keep * mf[MF_PW + k] + (1.0 - keep) * out[k]
    return VN_MOTION + (mf[MF_SMOOTH] - VN_MOTION) * keep


@jit(inline=True)
def _normalise(v):
    """``v`` divided by its sum (summed in index order), in place."""
    tot = 0.0
    for i in range(v.size):
        tot += v[i]
    for i in range(v.size):
        v[i] /= tot


@jit(inline=True)
def _take(work, at, n):
    """The ``n`` floats of ``work`` from ``at``, and the offset after them."""
    return work[at:at + n], at + n


@jit(inline=True)
def _switch(dt, tau):
    return 1.0 - math.exp(-dt / tau) if tau > 0.0 else 0.0


@jit
def _measure(x, P, j, mf, mc, gap, dt, dG, arw, Hg, l_white, l_any, n_c, D, Rc, h_still, Hs, Hm, field_ll, PH, lk,
             shares, sw):
    """Mode ``j``'s update by the epoch's data (x, P in place): the gyro (a drift measurement
    when still; the true rate ω plus the drift when moving, ω having walked as one of the rate
    models has it or been redrawn, any rate: the two posteriors moment-matched), its serial
    structure, the compass (with the disturbance e in a disturbed mode) and the field. Returns
    the log-likelihood, the compass innovation's excess over its predicted variance (NaN: none,
    or the heading not known to a few degrees), and the compass innovation and its variance
    (NaN: no compass). ``shares``: the rate models' weights for the
    epoch (:func:`_motion_prior`). ``PH`` (NX), ``lk`` (N_RATE + 1), ``sw`` (NX (NX + 3)): scratch."""
    ll = 0.0
    still = _is_still(j)
    # the compass's error while turning: none when still; else with the rate this mode's drift leaves
    turn = 0.0 if still else mc[MC_K_TURN] * (dG - _dot(Hg, x) + x[X_W] * dt) / dt
    if not gap:
        if still:
            ll += _update(x, P, Hg, dG, arw, False, -1, -1, PH)
        else:
            # the gyro measures the true rate ω plus the drift; ω walks as one of the rate models
            # has it (or is any rate), weighed by how well each predicts the epoch's gyro
            nu = dG - _dot(Hg, x)
            base = _quad(P, Hg) + arw
            for k in range(N_RATE):
                lk[k] = math.log(shares[k]) + _loggauss(nu, base + mc[MC_Q_W + k] ** 2 * dt * dt * dt)
            lk[N_RATE] = math.log(shares[N_RATE]) + _loggauss(nu, base + (mc[MC_RATE_ANY] * dt) ** 2)
            m = np.max(lk)
            tot = 0.0
            for k in range(N_RATE + 1):
                tot += math.exp(lk[k] - m)
            ll += m + math.log(tot)
            # the posterior is a mixture of two: ω walked (the rate models' variances, weighted as
            # they explained the epoch) or ω was redrawn (any rate), moment-matched
            p_any = math.exp(lk[N_RATE] - m) / tot
            q_w = 0.0
            for k in range(N_RATE):
                q_w += math.exp(lk[k] - m) / tot * mc[MC_Q_W + k] ** 2 * dt
            if p_any > ANY_MIN:
                xa = sw[:NX]
                Pa = sw[NX:NX * (NX + 1)].reshape((NX, NX))
                xa[:] = x
                Pa[:, :] = P
                _no_rate(xa, Pa)
                Pa[X_W, X_W] = mc[MC_RATE_ANY] ** 2
                _update(xa, Pa, Hg, dG, arw, False, -1, -1, PH)
            P[X_W, X_W] += q_w / max(1.0 - p_any, 1e-300)
            _update(x, P, Hg, dG, arw, False, -1, -1, PH)
            if p_any > ANY_MIN:
                _mix_in(x, P, xa, Pa, p_any, sw[NX * (NX + 1):NX * (NX + 2)], sw[NX * (NX + 2):])
        ll += l_white if still else l_any
    elif not still:  # across a time gap the rate walks as the motion believed has it
        P[X_W, X_W] += mf[MF_WQ2] * dt + mf[MF_WANY] * mc[MC_RATE_ANY] ** 2
    excess = nu = S = math.nan
    if n_c > 0.0:
        # a wandering disturbance's compass corrects e alone, unless the heading is known worse
        # than a step is large; a steady one's corrects every state
        only = -1 if _is_clean(j) or _is_steady(j) or P[X_DELTA, X_DELTA] > mc[MC_SIG_STEP] ** 2 else X_E
        H = Hs if still else Hm
        z = D - h_still if still else D
        nu = wrap180(z - _dot(H, x))
        S = _quad(P, H) + Rc + turn * turn
        s_pred = S - mf[MF_RX]
        if s_pred < RX_S_MAX:  # the excess says something of the compass once the heading is known
            excess = nu * nu - s_pred
        # the scale factor is learned from a clean compass alone: a disturbance that changes
        # as the platform turns (or a steady one with a heading-dependent deviation) must not
        # teach it (σ considered, not corrected)
        ll += _update(x, P, H, z, Rc + turn * turn, True, only, -1 if _is_clean(j) else X_S, PH)
        if _is_clean(j):
            ll += field_ll
    return ll, excess, nu, S


@jit(inline=True)
def long_run(mf, half_msd):
    """The gyro's long-run noise variance per sample from ``half_msd``, half the mean square of
    its successive differences: for the learned colour c = 1 - ρ (an AR(1) noise) that times
    (1 + ρ) / (1 - ρ)²."""
    colour = min(max(mf[MF_COLOUR], COLOUR_MIN), COLOUR_MAX)
    return half_msd * (2.0 - colour) / (colour * colour)


@jit(inline=True)
def r_walk(mc, phi_r, dtemp):
    """The variance r (the drift's departure rate) gains over an epoch of ``dtemp`` degC in
    which it decays by ``phi_r``: its stationary variance times the share renewed by the
    temperature's change (``1 - exp(-2 |ΔT| / T_r)``), plus a smaller part renewed with time
    (``1 - phi_r²``). On the clock (no temperature) time stands for the temperature and the
    whole of it renews with time."""
    renew_t = 1.0 - phi_r * phi_r
    if mc[MC_CLOCK] == 1.0:
        return mc[MC_SIG_R] ** 2 * renew_t
    return mc[MC_SIG_R] ** 2 * (1.0 - math.exp(-2.0 * dtemp / mc[MC_T_R])) + mc[MC_SIG_RT] ** 2 * renew_t


@jit
def epoch(mf, mc, t_end, temp_end):
    """Close the epoch ending at ``t_end`` (temperature ``temp_end``): predict, weigh the
    modes by the epoch's gyro and compass data, update, combine. The epoch's sums are in
    ``mf`` (``MF_E_*``); the caller resets them."""
    dt = t_end - mf[MF_E_T0]
    if not dt > 0.0:
        return
    gap = mf[MF_E_GAP] == 1.0
    dG, dTc, dTp, dTc2 = mf[MF_E_G], mf[MF_E_TC], mf[MF_E_TP], mf[MF_E_TC2]
    # the temperature change over the epoch: from T' (no quantisation flips), or T itself for the clock
    dtemp = abs(temp_end - mf[MF_E_T_START]) if mc[MC_CLOCK] == 1.0 else abs(dTp)
    # Markov chain of mode changes over dt
    pcd, pdc = _switch(dt, mc[MC_TAU_CLEAN]), _switch(dt, mc[MC_TAU_DIST])
    psm, pms = _switch(dt, mc[MC_TAU_STILL]), _switch(dt, mc[MC_TAU_MOVE])
    work = np.empty(N_WORK)
    Pi, at = _take(work, 0, NM * NM)
    Pi = Pi.reshape((NM, NM))
    X, at = _take(work, at, NB * NX)
    X = X.reshape((NB, NX))
    P, at = _take(work, at, NB * NX * NX)
    P = P.reshape((NB, NX, NX))
    Pb, at = _take(work, at, NX * NX)
    Pb = Pb.reshape((NX, NX))
    v, at = _take(work, at, 4 * NB)  # the branches' weights, likelihoods, excesses, jumps
    v = v.reshape((4, NB))
    wb, ll, excess, jumped = v[0], v[1], v[2], v[3]
    v, at = _take(work, at, 2 * NM)
    v = v.reshape((2, NM))
    lm, wmix = v[0], v[1]
    v, at = _take(work, at, 9 * NX)
    v = v.reshape((9, NX))
    Hg, Hs, Hm, xb, xm, PH, dx, da, db = v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]
    v, at = _take(work, at, 8 * (N_RATE + 1))
    v = v.reshape((8, N_RATE + 1))
    lk, lw, ws, Ps, pw, wk, tmp, pred = v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]
    sw, at = _take(work, at, NX * (NX + 3))  # a moving mode's rate redrawn (:func:`_measure`)
    for i in range(NM):
        for j in range(NM):
            ci, cj = _is_clean(i), _is_clean(j)
            si, sj = _is_still(i), _is_still(j)
            if ci:
                pc = 1.0 - pcd if cj else pcd * _share(j)
            elif cj:
                pc = pdc
            else:  # a disturbance goes on, and changes kind about as often as it ends
                pc = (1.0 - pdc) * (1.0 - pdc if _is_steady(i) == _is_steady(j) else pdc)
            ps = (1.0 - psm if sj else psm) if si else (pms if sj else 1.0 - pms)
            Pi[i, j] = pc * ps
    _branches(mf, Pi, mc[MC_SIG_STEP] ** 2, X, P, wb, wmix, dx)
    # process noise of the drift, shared by every mode
    phi_r = math.exp(-dt / mc[MC_TAU_R])
    gain_r = mc[MC_TAU_R] * (1.0 - phi_r)  # the drift's change per unit of its rate over dt
    q_r = r_walk(mc, phi_r, dtemp)
    q_a = mc[MC_Q_A] ** 2 * dtemp
    q_b = mc[MC_Q_B] ** 2 * dt
    q_c = mc[MC_Q_C] ** 2 * dt + mc[MC_Q_CT] ** 2 * dtemp
    q_s = mc[MC_SF_WALK] ** 2 * dtemp  # the scale factor walks with the temperature
    sig_s2 = long_run(mf, mf[MF_SIG_S2])
    arw = sig_s2 * mf[MF_E_H2]  # variance of the gyro integral's white noise over the epoch
    # the trapezoid's error within each step under the motion believed: the rate's walk over the
    # step (h³/12 each), or for any rate an angular acceleration (h⁴/12 each)
    moving_q = arw + (mf[MF_WQ2] * mf[MF_E_H3] + mf[MF_WANY] * mc[MC_SIG_ACC] ** 2 * mf[MF_E_H4]) / 12.0
    if gap:  # the heading of a moving platform across a gap: the gap's own uncertainty too
        moving_q = min(moving_q + (mc[MC_OMEGA_GAP] * dt) ** 2 + mc[MC_SIG_ACC] ** 2 * dt**4 / 12.0, GAP_VAR_MAX)
    for r in range(NB):
        j = r % NM
        x = X[r]
        Pj = P[r]
        still = _is_still(j)
        drift_int = x[X_A] * dTc + x[X_B] * dTp + x[X_C] * dt + 0.5 * x[X_R] * dt * dt + x[X_A2] * dTc2
        # the turn the gyro saw beyond its drift: the scale factor's share σ of it is no turn
        seen = dG - drift_int
        if still:  # the heading holds: δ moves with the gyro integral
            x[X_DELTA] -= dG
        else:  # δ moves by minus the drift integral (eq. 5) and the scale factor's part of the turn
            x[X_DELTA] -= drift_int + x[X_S] * seen
        # the deviation d is a harmonic of the heading: (d, d_q) turn with the heading this mode
        # turned (none when still); it and e decorrelate in time and with the heading turned
        turn_rad = 0.0 if still or gap else math.radians(seen * (1.0 - x[X_S]))
        turned = abs(math.degrees(turn_rad))
        cr, sr = math.cos(turn_rad), math.sin(turn_rad)
        phi_d = math.exp(-dt / mc[MC_TAU_D] - turned / mc[MC_L_DEV])
        # a steady disturbance is fixed in the world: it does not change as the platform turns
        te = 0.0 if _is_steady(j) else turned / mc[MC_L_DIST]
        phi_e = math.exp(-dt / mc[MC_TAU_E] - te)
        q_d = mc[MC_SIG_D] ** 2 * (1.0 - phi_d * phi_d)
        walk_e = mc[MC_Q_E_STEADY] if _is_steady(j) else mc[MC_Q_E]
        q_e = walk_e**2 * dt + mc[MC_SIG_STEP] ** 2 * (1.0 - math.exp(-2.0 * te))
        x[X_C] += x[X_R] * gain_r
        x[X_R] *= phi_r
        # the compass's errors are angles: they decay towards 0 from within ±180 deg
        d = wrap180(x[X_D])
        x[X_D] = phi_d * (cr * d + sr * x[X_DQ])
        x[X_DQ] = phi_d * (cr * x[X_DQ] - sr * d)
        x[X_E] = wrap180(x[X_E]) * phi_e
        if still:
            _transition(Pj, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, gain_r, phi_d, 1.0, 0.0, phi_r, phi_e)
        else:
            _transition(Pj, -dTc, -dTp, -dt, -0.5 * dt * dt, -dTc2, -seen, gain_r, phi_d, cr, sr, phi_r, phi_e)
        Pj[X_DELTA, X_DELTA] += mc[MC_Q_STILL] ** 2 * dt if still else moving_q
        Pj[X_S, X_S] += q_s
        Pj[X_A, X_A] += q_a
        Pj[X_B, X_B] += q_b
        Pj[X_C, X_C] += q_c
        Pj[X_D, X_D] += q_d
        Pj[X_DQ, X_DQ] += q_d
        Pj[X_R, X_R] += q_r
        if not _is_clean(j):
            Pj[X_E, X_E] += q_e
    # the epoch's data, shared by every mode: the gyro's integral and its serial structure
    Hg[:] = 0.0  # the drift's integral over the epoch (c' and its rate at the epoch end)
    Hg[X_A] = dTc
    Hg[X_A2] = dTc2
    Hg[X_B] = dTp
    Hg[X_C] = dt
    Hg[X_R] = -0.5 * dt * dt
    Hg[X_W] = dt  # the true rate (0 in a still mode)
    l_white = l_any = 0.0
    ng = mf[MF_E_NG]
    u = var_u = math.nan
    smooth = _motion_prior(mf, mc, dt, pred)  # the motion's character for this epoch
    l_rough = math.nan
    if not gap and ng >= VN_MIN_SAMPLES:
        # the von Neumann ratio over its white value (mean 2, variance 4 (n - 2) / ((n - 1)(n + 1))):
        # near the believed colour when still (docs/model.md, "Stillness")
        ss = mf[MF_E_S2] - mf[MF_E_S1] ** 2 / ng
        if ss > 0.0:
            mean0 = 2.0
            var0 = 4.0 * (ng - 2.0) / ((ng - 1.0) * (ng + 1.0))
            u = mf[MF_E_DG2] / ss / mean0
            var_u = var0 / (mean0 * mean0)
            spread = var_u + mf[MF_COLOUR_V]
            l_white = _loggauss(u - mf[MF_COLOUR], spread)
            rough = mf[MF_COLOUR] + 3.0 * math.sqrt(spread)  # a structured ratio: anywhere up to this
            l_any = math.log(smooth * math.exp(min(l_white, 50.0)) + (1.0 - smooth) / rough)
            l_rough = -math.log(rough)
    # the compass: the mean of D = compass - ∫gyro over the epoch's samples
    n_c = mf[MF_E_NC]
    D = Rc = h_still = 0.0
    field_ll = ratio = ddip = 0.0
    w_n = w_d = 1.0
    has_f = False
    Hs[:] = 0.0
    Hm[:] = 0.0
    if n_c > 0.0:
        D = mf[MF_E_DREF] + mf[MF_E_SD] / n_c
        h_still = dG - mf[MF_E_SG] / n_c  # ∫gyro from the mean sample to the epoch end
        Hs[X_DELTA] = 1.0
        Hs[X_D] = 1.0
        Hs[X_E] = 1.0
        Hm[:] = Hs
        Hm[X_A] = dTc - mf[MF_E_STC] / n_c
        Hm[X_A2] = dTc2 - mf[MF_E_STC2] / n_c
        Hm[X_B] = dTp - mf[MF_E_STP] / n_c
        Hm[X_C] = dt - mf[MF_E_ST] / n_c
        Hm[X_S] = h_still  # the scale factor's share of the turn from the mean sample to the end
        if mf[MF_E_NF] > 0.0 and math.isfinite(mf[MF_NORM_REF]):
            has_f = True
            ratio = mf[MF_E_NORM] / mf[MF_E_NF] / mf[MF_NORM_REF] - 1.0
            ddip = mf[MF_E_DIP] / mf[MF_E_NF] - mf[MF_DIP_REF]
            var_n = max(mf[MF_FS_N] / mf[MF_FS_WN], (FIELD_SD_FLOOR * mc[MC_SIG_NORM]) ** 2)
            var_d = max(mf[MF_FS_D] / mf[MF_FS_WD], (FIELD_SD_FLOOR * mc[MC_SIG_DIP]) ** 2)
            eps = min(max(mf[MF_FO_S] / mf[MF_FO_W], FIELD_OUTLIER_RANGE[0]), FIELD_OUTLIER_RANGE[1])
            ll_n, w_n = _robust(_loggauss(ratio, var_n), LL_ANY_NORM, eps)
            ll_d, w_d = _robust(_loggauss(ddip, var_d), LL_ANY_DIP, eps)
            field_ll = ll_n + ll_d
        # the noise, correlated; the epoch-level error; the tilt's error as the samples' two tilts
        # disagree, as one error over the epoch that persists from epoch to epoch
        Rc = mf[MF_KAPPA] * mf[MF_SIG_W2] / n_c + mf[MF_RX] + mf[MF_TILT_K] * mf[MF_E_TV] / max(mf[MF_E_NT], 1.0)
    p_jump = _switch(dt, mc[MC_TAU_JUMP])
    p_step = _switch(dt, mc[MC_TAU_DIST])  # a disturbance steps again about as often as it ends
    jump_var = mc[MC_SIG_JUMP] ** 2
    excess[:] = 0.0
    jumped[:] = 0.0
    for r in range(NB):
        j = r % NM
        if wb[r] == 0.0:
            ll[r], excess[r] = -math.inf, math.nan
            continue
        # the alternative a mode weighs beside its own prediction: a jump of the drift (the still,
        # clean mode; docs/model.md, "Drift jumps") or a new step of a disturbance while it lasts
        # (the disturbed modes; "Disturbance steps"); its likelihood the sum, its state the likelier one's
        k, var, p = -1, 0.0, 0.0
        if j == CLEAN_STILL and p_jump > 0.0 and jump_var > 0.0:
            k, var, p = X_C, jump_var, p_jump
        elif not _is_clean(j) and n_c > 0.0 and p_step > 0.0:
            k, var, p = X_E, mc[MC_SIG_STEP] ** 2, p_step
        if k < 0:
            ll[r], excess[r], _, _ = _measure(X[r], P[r], j, mf, mc, gap, dt, dG, arw, Hg, l_white, l_any, n_c, D, Rc,
                                              h_still, Hs, Hm, field_ll, PH, lk, pred, sw)
            continue
        xb[:] = X[r]
        Pb[:, :] = P[r]
        Pb[k, k] += var
        lla, exa, nu, S = _measure(X[r], P[r], j, mf, mc, gap, dt, dG, arw, Hg, l_white, l_any, n_c, D, Rc, h_still, Hs,
                                   Hm, field_ll, PH, lk, pred, sw)
        if k == X_E:  # e is in the compass alone: the step changes its innovation's variance only
            llb = lla - _loggauss(nu, S) + _loggauss(nu, S + var)
        else:
            llb, exb, _, _ = _measure(xb, Pb, j, mf, mc, gap, dt, dG, arw, Hg, l_white, l_any, n_c, D, Rc, h_still, Hs,
                                      Hm, field_ll, PH, lk, pred, sw)
        la, lb = math.log(1.0 - p) + lla, math.log(p) + llb
        top = max(la, lb)
        ll[r] = top + math.log(math.exp(la - top) + math.exp(lb - top))
        excess[r] = exa
        # the likelier of the two is kept (merged, the rare alternative's variance would be
        # process noise every epoch)
        if lb > la:
            if k == X_E:
                _, exb, _, _ = _measure(xb, Pb, j, mf, mc, gap, dt, dG, arw, Hg, l_white, l_any, n_c, D, Rc, h_still,
                                        Hs, Hm, field_ll, PH, lk, pred, sw)
            X[r, :] = xb
            P[r, :, :] = Pb
            excess[r] = exb
            if k == X_C:
                jumped[r] = 1.0
    # each mode: its two branches merged, weighted by prior and likelihood; mode probabilities
    Xm = mf[MF_X:MF_X + NM * NX].reshape((NM, NX))
    Pm = mf[MF_P:MF_P + NM * NX * NX].reshape((NM, NX, NX))
    top = -math.inf
    for j in range(NM):
        la = math.log(max(wb[j], 1e-300)) + ll[j]
        lb = math.log(max(wb[NM + j], 1e-300)) + ll[NM + j]
        t2 = max(la, lb)
        qa, qb = math.exp(la - t2), math.exp(lb - t2)
        lm[j] = t2 + math.log(qa + qb)
        qa, qb = qa / (qa + qb), qb / (qa + qb)
        Xm[j, :] = X[NM + j]  # the own branch, the switched-in one mixed in (angles about the own's)
        Pm[j, :, :] = P[NM + j]
        _mix_in(Xm[j], Pm[j], X[j], P[j], qa, da, db)
        # a gyro's scale factor is within its datasheet's tolerance: a compass whose error the
        # model does not know (a deviation beyond d's) must not carry σ past it
        Xm[j, X_S] = min(max(Xm[j, X_S], -mc[MC_SF_MAX]), mc[MC_SF_MAX])
        ea, eb = excess[j], excess[NM + j]
        excess[j] = ea if not math.isfinite(eb) else (eb if not math.isfinite(ea) else qa * ea + qb * eb)
        jumped[j] = qa * jumped[j] + qb * jumped[NM + j]
        top = max(top, lm[j])
    tot = 0.0
    for j in range(NM):
        lm[j] = math.exp(lm[j] - top)
        tot += lm[j]
    for j in range(NM):
        mf[MF_MU + j] = max(lm[j] / tot, MU_MIN)
    _combine(mf, dx)
    mu = mf[MF_MU:MF_MU + NM]
    p_clean = mu[CLEAN_STILL] + mu[CLEAN_MOVING]
    ex = (mu[CLEAN_STILL] * excess[CLEAN_STILL] + mu[CLEAN_MOVING] * excess[CLEAN_MOVING]) / p_clean
    if n_c > 0.0 and p_clean > 0.9 and math.isfinite(ex):  # the clean innovations' excess
        keep = math.exp(-dt / mc[MC_NOISE_MEMORY])
        mf[MF_RX_S] = keep * mf[MF_RX_S] + ex
        mf[MF_RX_W] = keep * mf[MF_RX_W] + 1.0
        mf[MF_RX] = max(mf[MF_RX_S] / mf[MF_RX_W], 0.0)
    if has_f and p_clean > 0.9:  # the clean field's scatter
        keep = math.exp(-dt / mc[MC_NOISE_MEMORY])
        mf[MF_FS_N] = keep * mf[MF_FS_N] + w_n * ratio * ratio
        mf[MF_FS_D] = keep * mf[MF_FS_D] + w_d * ddip * ddip
        mf[MF_FS_WN] = keep * mf[MF_FS_WN] + w_n
        mf[MF_FS_WD] = keep * mf[MF_FS_WD] + w_d
        mf[MF_FO_S] = keep * mf[MF_FO_S] + 1.0 - 0.5 * (w_n + w_d)
        mf[MF_FO_W] = keep * mf[MF_FO_W] + 1.0
    _set_labels(mf)
    mf[MF_JUMP] = _dot(mu, jumped[:NM])
    mf[MF_COLOUR_V] += COLOUR_WALK**2 * dt
    if math.isfinite(u) and mf[MF_PSTILL] > 0.0:
        # the colour learned from the epoch as far as it is still: variance var_u / P(still)
        k = mf[MF_COLOUR_V] / (mf[MF_COLOUR_V] + var_u / mf[MF_PSTILL])
        mf[MF_COLOUR] += k * (u - mf[MF_COLOUR])
        mf[MF_COLOUR_V] *= 1.0 - k
    mf[MF_FIELD_DOM] = 1.0 if field_ll < FIELD_SAYS_DISTURBED else 0.0
    mf[MF_UPDATED] = 1.0 if (n_c > 0.0 and mf[MF_PDIST] < 0.5) or (not gap and mf[MF_PSTILL] >= 0.5) else 0.0
    # the smoothness learned from the epoch as far as it is moving (with motion_memory_s)
    if mc[MC_MOTION_MEMORY] > 0.0 and math.isfinite(l_rough):
        sw = smooth * math.exp(min(l_white, 50.0))
        post = sw / (sw + (1.0 - smooth) * math.exp(l_rough))
        mf[MF_SMOOTH] = smooth + (1.0 - mf[MF_PSTILL]) * (post - smooth)
    else:
        mf[MF_SMOOTH] = smooth
    # the rate filters, which weigh the motion's agility (the trapezoid's error, a gap), follow
    # the compensated mean rate, or with motion_memory_s the gyro's own, and interact
    # (docs/model.md, "Motion")
    Pc = mf[MF_PC:MF_PC + NX * NX].reshape((NX, NX))
    r = Rr = 0.0
    if not gap and mc[MC_MOTION_MEMORY] > 0.0:
        r = dG / dt
        Rr = arw / (dt * dt)
    elif not gap:
        # the rate a moving platform had: the gyro less the moving hypotheses' drift
        xm[:] = 0.0
        p_moving = 0.0
        for j in range(NM):
            if not _is_still(j):
                for k in range(NX):
                    xm[k] += mu[j] * Xm[j, k]
                p_moving += mu[j]
        for k in range(NX):
            xm[k] /= p_moving
        r = (dG - (xm[X_A] * dTc + xm[X_B] * dTp + xm[X_C] * dt + xm[X_A2] * dTc2)) / dt
        Rr = (arw + bias_var(Pc, dTc, dTp, dTc2) * dt * dt) / (dt * dt)
    if not gap:
        for k in range(N_RATE):
            w = mf[MF_W + 2 * k]
            Pp = mf[MF_W + 2 * k + 1] + mc[MC_Q_W + k] ** 2 * dt
            lw[k] = math.log(pred[k]) + _loggauss(r - w, Pp + Rr)
            K = Pp / (Pp + Rr)
            ws[k] = w + K * (r - w)
            Ps[k] = (1.0 - K) * Pp
        lw[N_RATE] = math.log(pred[N_RATE]) + _loggauss(r, mc[MC_RATE_ANY] ** 2 + Rr)
        ws[N_RATE] = r
        Ps[N_RATE] = Rr
        top = np.max(lw)
        for i in range(N_RATE + 1):
            pw[i] = math.exp(lw[i] - top)
        _normalise(pw)
        _set_agility(mf, mc, pw)
        switch = _switch(dt, RATE_SWITCH_S)
        for k in range(N_RATE):
            for i in range(N_RATE + 1):
                wk[i] = pw[i] * ((1.0 - switch) if i == k else switch / N_RATE)
            _normalise(wk)
            m = _dot(wk, ws)
            mf[MF_W + 2 * k] = m
            for i in range(N_RATE + 1):
                tmp[i] = Ps[i] + (ws[i] - m) ** 2
            mf[MF_W + 2 * k + 1] = _dot(wk, tmp)
    else:
        for k in range(N_RATE):
            mf[MF_W + 2 * k + 1] += mc[MC_Q_W + k] ** 2 * dt
        mf[MF_PW:MF_PW + N_RATE + 1] = pred
    # the measured noise (gyro while still, compass always), sums forgotten over ``noise_memory_s``
    keep = math.exp(-dt / mc[MC_NOISE_MEMORY])
    if mf[MF_E_NDG] >= 1.0 and mf[MF_PSTILL] >= 0.5:
        mf[MF_NS_S] = keep * mf[MF_NS_S] + 0.5 * mf[MF_E_DG2]
        mf[MF_NS_W] = keep * mf[MF_NS_W] + mf[MF_E_NDG]
        mf[MF_SIG_S2] = mf[MF_NS_S] / mf[MF_NS_W]
    if mf[MF_E_NDD] >= 1.0:  # the sensor's white noise, disturbed or not (steps clipped by the loop)
        mf[MF_NW_S] = keep * mf[MF_NW_S] + 0.5 * mf[MF_E_DD2]
        mf[MF_NW_W] = keep * mf[MF_NW_W] + mf[MF_E_NDD]
        mf[MF_SIG_W2] = max(mf[MF_NW_S] / mf[MF_NW_W], 0.01 * mc[MC_COMPASS_SD] ** 2)
    # how much the noise's correlation inflates an epoch mean's variance (κ, 1 for white noise),
    # from the two halves of a still epoch: their means differ by the noise alone
    n1 = mf[MF_E_NC1]
    n2 = mf[MF_E_NC] - n1
    if n1 >= 1.0 and n2 >= 1.0 and mf[MF_PSTILL] >= 0.5:
        diff = (mf[MF_E_SB] - mf[MF_E_SB1]) / n2 - mf[MF_E_SB1] / n1
        z2 = diff * diff / (mf[MF_SIG_W2] * (1.0 / n1 + 1.0 / n2))
        mf[MF_K_S] = keep * mf[MF_K_S] + min(z2, KAPPA_CLIP * mf[MF_KAPPA])  # a step within is no noise
        mf[MF_K_W] = keep * mf[MF_K_W] + 1.0
        mf[MF_KAPPA] = max(mf[MF_K_S] / mf[MF_K_W], 1.0)
    # the tilt error's persistence: the correlation ρ of successive epochs' mean differences, and
    # the long-run variance of a first-order autoregressive error, (1 + ρ) / (1 - ρ) times its own
    if mf[MF_E_NT] > 0.0 and not gap:
        m = mf[MF_E_TD] / mf[MF_E_NT]
        last = mf[MF_TD_LAST]
        if math.isfinite(last):
            mf[MF_TK_S] = keep * mf[MF_TK_S] + m * last
            mf[MF_TK_W] = keep * mf[MF_TK_W] + 0.5 * (m * m + last * last)
            rho = min(max(mf[MF_TK_S] / mf[MF_TK_W], 0.0), TILT_RHO_MAX)
            mf[MF_TILT_K] = (1.0 + rho) / (1.0 - rho)
        mf[MF_TD_LAST] = m
    else:
        mf[MF_TD_LAST] = math.nan


@jit
def seed_noise(mf, mc, sig_s2):
    """The gyro's per-sample noise variance from the settings (``sig_s2``, (deg/s)², at the
    log's first step) and the compass's, each worth ``NOISE_PRIOR_STEPS`` steps of data."""
    mf[MF_SIG_S2] = sig_s2
    mf[MF_NS_S] = NOISE_PRIOR_STEPS * sig_s2
    mf[MF_NS_W] = NOISE_PRIOR_STEPS
    mf[MF_SIG_W2] = mc[MC_COMPASS_SD] ** 2
    mf[MF_NW_S] = NOISE_PRIOR_STEPS * mf[MF_SIG_W2]
    mf[MF_NW_W] = NOISE_PRIOR_STEPS
    mf[MF_KAPPA] = 1.0
    mf[MF_K_S] = NOISE_PRIOR_STEPS
    mf[MF_K_W] = NOISE_PRIOR_STEPS
    mf[MF_RX] = 0.0
    mf[MF_RX_S] = 0.0
    mf[MF_RX_W] = NOISE_PRIOR_STEPS
    mf[MF_FS_N] = NOISE_PRIOR_STEPS * mc[MC_SIG_NORM] ** 2
    mf[MF_FS_D] = NOISE_PRIOR_STEPS * mc[MC_SIG_DIP] ** 2
    mf[MF_FS_WN] = NOISE_PRIOR_STEPS
    mf[MF_FS_WD] = NOISE_PRIOR_STEPS
    mf[MF_FO_S] = NOISE_PRIOR_STEPS * FIELD_OUTLIER
    mf[MF_FO_W] = NOISE_PRIOR_STEPS
    mf[MF_COLOUR] = 1.0
    mf[MF_COLOUR_V] = COLOUR_SD0**2
