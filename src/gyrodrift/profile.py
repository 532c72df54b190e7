"""Device profiles: what a run learned about one gyro, to warm-start the next run.

``gyrodrift compensate --save-profile dev.json`` stores the final drift parameters, their
covariance, the temperature range seen, sample count, date and software version;
``--profile dev.json`` starts the next run from them. The file is versioned JSON and
validated on load.

Warm start
----------
The saved parameters become the prior mean ``x0``; the saved covariance, with every
standard deviation doubled (the device may have changed since: power cycles, ageing,
a different mounting) and never above the default prior, becomes the prior covariance.
The correlation between a and c, which a flat-temperature run leaves strong, is kept.

Checks
------
A profile is read as UTF-8 bytes (:func:`gyrodrift.config.read_utf8`) and checked
field by field, on loading and before saving; anything else is a
:class:`~gyrodrift.errors.ConfigError` of one line naming the file and the field:

* exactly the fields :meth:`Profile.to_json` writes, each of its JSON type (``true``
  is not a number, ``"0.1"`` is not a number, ``1.5`` is not a count);
* parameters finite and physically plausible (:data:`PARAM_BOUNDS`): ``|a| <= 1``
  deg/s/degC, ``|b| <= 1000`` deg, ``|c| <= 50`` deg/s. MEMS data sheets give zero-rate
  offsets of a few deg/s and temperature coefficients of hundredths of a deg/s/degC;
  the bounds lie ten times and more above that, so that only corrupt or hand-edited
  values are refused (``a = 1`` is already 210 deg/s of drift across the accepted
  temperatures; ``b = 1000`` is 10 deg/s at a heating rate of 0.01 degC/s);
* the covariance symmetric (to 1e-6 of ``sqrt(P_ii P_jj)``) and positive definite
  (the smallest eigenvalue of its correlation matrix above 1e-12: no correlation of 1
  to within rounding), each standard deviation within the same bound as its parameter;
* the temperature range ordered and inside
  :data:`gyrodrift.conventions.TEMP_RANGE_C`; ``updates <= samples``; ``created`` an
  ISO 8601 date and time.

Using a profile
---------------
:func:`profile_notes` returns what the user should know when a profile is used: it was
saved by another estimator than the one in use, or the run's temperatures reach beyond
those it was learned at (by more than :data:`TEMP_MARGIN_C`), so that its drift model
is extrapolated. ``gyrodrift compensate --profile`` prints each note as a warning line
on stderr; :func:`compensate_warm` (the same from Python) adds them to the output's
``attrs["notes"]``.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from gyrodrift import __version__
from gyrodrift._atomic import write_bytes_atomic
from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.config import DRIFT_PARAM_BOUNDS, read_utf8
from gyrodrift.conventions import TEMP, TEMP_RANGE_C
from gyrodrift.errors import ConfigError
from gyrodrift.kernels.numeric import cap_covariance

__all__ = [
    "FORMAT", "VERSION", "PARAM_BOUNDS", "TEMP_MARGIN_C", "Profile", "profile_from_run", "save_profile",
    "load_profile", "profile_notes", "warm_config", "compensate_warm",
]

FORMAT = "gyrodrift-profile"
VERSION = 1
_WARM_SD_FACTOR = 2.0
#: Largest plausible magnitude of each drift parameter, and of its standard deviation
#: (module notes): a deg/s/degC, b deg, c deg/s, by their names in the file.
PARAM_BOUNDS = dict(zip(("a_dps_per_c", "b_deg", "c_dps"), DRIFT_PARAM_BOUNDS))
#: How far (degC) a run's temperatures may reach beyond a profile's range before
#: :func:`profile_notes` says so: readings of the same conditions differ by noise and
#: quantisation (a few tenths of a degree).
TEMP_MARGIN_C = 2.0
_FIELDS = ("format", "version", "software", "created", "estimator", "params", "cov", "temp_range_c", "samples",
           "updates")
_LONGEST_TEXT = 200  # characters of software, created and estimator
_SYMMETRY_RTOL = 1e-6
# smallest eigenvalue of the correlation matrix of a positive definite covariance: below,
# a correlation is 1 to within rounding
_MIN_CORR_EIGENVALUE = 1e-12
_INT64_MAX = 2**63 - 1


@dataclass(frozen=True)
class Profile:
    """What one run learned.

    Attributes
    ----------
    params : tuple of 3 floats
        a (deg/s/degC), b (deg/degC), c (deg/s) at the end of the run.
    cov : 3x3 tuple
        Their covariance.
    temp_range_c : (float, float)
        Lowest and highest temperature seen, degC.
    samples, updates : int
        Rows compensated and filter updates taken.
    estimator : str
    created : str
        ISO 8601 date and time (UTC).
    software : str
        ``gyrodrift X.Y.Z``.
    """

    params: tuple[float, float, float]
    cov: tuple[tuple[float, float, float], ...]
    temp_range_c: tuple[float, float]
    samples: int
    updates: int
    estimator: str
    created: str
    software: str

    def to_json(self) -> dict:
        return {
            "format": FORMAT,
            "version": VERSION,
            "software": self.software,
            "created": self.created,
            "estimator": self.estimator,
            "params": {"a_dps_per_c": self.params[0], "b_deg": self.params[1], "c_dps": self.params[2]},
            "cov": [list(row) for row in self.cov],
            "temp_range_c": list(self.temp_range_c),
            "samples": self.samples,
            "updates": self.updates,
        }


def profile_from_run(out) -> Profile:
    """The profile of a run: a :func:`gyrodrift.compensator.compensate` output table, or the
    :class:`gyrodrift.pipeline.RunStats` of :func:`gyrodrift.pipeline.compensate_file`.

    Raises
    ------
    ConfigError
        The run's drift model was in time, not temperature (a log whose temperature never
        changes; ``CompensatorConfig.temperature``): it does not carry over to another run.
    """
    if hasattr(out, "attrs"):
        regressor, source = out.attrs.get("drift_regressor", "temperature"), out.attrs.get("source", "the log")
    else:  # RunStats
        regressor, source = out.regressor, out.source
    if regressor == "clock":
        raise ConfigError(
            f"{source}: no profile saved: the log's "
            "temperature never changes, so its drift was modelled in time, which does not carry over to another "
            "run; a profile needs a log with the gyro temperature"
        )
    if hasattr(out, "final_params") and not hasattr(out, "attrs"):  # RunStats
        final_params, final_cov, estimator = out.final_params, out.final_cov, out.estimator
        temp_range, samples, updates = (out.temp_min_c, out.temp_max_c), out.rows, out.updates
    else:
        from gyrodrift.compensator.output import updated_column

        final_params, final_cov = out.attrs["final_params"], out.attrs["final_cov"]
        estimator = out.attrs.get("estimator", "")
        temp = out["temp"] if "temp" in out.columns else out["in_temp"]
        temp_range, samples, updates = (temp.min(), temp.max()), len(out), updated_column(out, "profile_from_run").sum()
    return Profile(
        params=tuple(float(v) for v in final_params),
        cov=tuple(tuple(float(v) for v in row) for row in final_cov),
        temp_range_c=(float(temp_range[0]), float(temp_range[1])),
        samples=int(samples),
        updates=int(updates),
        estimator=str(estimator),
        created=_dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat(),
        software=f"gyrodrift {__version__}",
    )


def save_profile(profile: Profile, path) -> None:
    """Write the profile as JSON, atomically, after the checks :func:`load_profile` makes.

    Parameters
    ----------
    profile : Profile
    path : str or os.PathLike

    Raises
    ------
    ConfigError
        The profile would not load (module notes: e.g. a parameter that is not finite,
        a covariance that is not positive definite, as from an estimator that learns
        nothing); nothing is written. One line naming the file and the field.
    """
    checked = _from_json(profile.to_json(), path, advice="the run did not learn a usable profile; nothing was saved")
    write_bytes_atomic(path, (json.dumps(checked.to_json(), indent=2) + "\n").encode("utf-8"))


class _Refused(Exception):
    """A profile field fails a check; the message names the field."""


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _is_count(v) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _show(v) -> str:
    """A JSON value for a message: short, one line."""
    if _is_count(v) and abs(int(v)) >= 10**40:
        return "a very long integer"
    try:
        text = json.dumps(v.item() if isinstance(v, np.generic) else v, ensure_ascii=False, allow_nan=True)
    except (TypeError, ValueError):
        text = type(v).__name__
    return text if len(text) <= 60 else text[:57] + "..."


def _text(data: dict, name: str, *, non_empty: bool = False) -> str:
    v = data[name]
    if not isinstance(v, str) or len(v) > _LONGEST_TEXT or (non_empty and not v):
        need = "a non-empty string" if non_empty else "a string"
        raise _Refused(f"{name} = {_show(v)} must be {need} of at most {_LONGEST_TEXT} characters")
    return v


def _count(data: dict, name: str) -> int:
    v = data[name]
    if not _is_count(v) or not 0 <= v <= _INT64_MAX:
        raise _Refused(f"{name} = {_show(v)} must be a whole number >= 0")
    return int(v)


def _numbers(v, n: int, name: str) -> list[float]:
    """``v`` as ``n`` finite floats (JSON array), else :class:`_Refused` naming ``name``."""
    if not isinstance(v, (list, tuple)) or len(v) != n or not all(_is_number(x) for x in v):
        raise _Refused(f"{name} = {_show(v)} must be a list of {n} numbers")
    try:
        out = [float(x) for x in v]
    except OverflowError:
        out = [math.inf]
    if not all(math.isfinite(x) for x in out):
        raise _Refused(f"{name} = {_show(v)} must hold finite numbers")
    return out


def _params(v) -> tuple[float, float, float]:
    if not isinstance(v, dict):
        raise _Refused(f"params = {_show(v)} must be an object with {', '.join(PARAM_BOUNDS)}")
    names = list(PARAM_BOUNDS)
    odd = sorted((k for k in v if k not in PARAM_BOUNDS), key=repr)
    if odd:
        raise _Refused(f"params has unknown field(s) {', '.join(map(repr, odd))}; known: {', '.join(names)}")
    missing = [k for k in names if k not in v]
    if missing:
        raise _Refused(f"params lacks {', '.join(missing)}")
    out = []
    for name, bound in PARAM_BOUNDS.items():
        x = v[name]
        if not _is_number(x):
            raise _Refused(f"params.{name} = {_show(x)} must be a number")
        try:
            x = float(x)
        except OverflowError:
            x = math.inf
        if not math.isfinite(x):
            raise _Refused(f"params.{name} = {_show(v[name])} must be a finite number")
        if abs(x) > bound:
            raise _Refused(f"params.{name} = {x:g} is outside the plausible range |{name}| <= {bound:g}")
        out.append(x)
    return tuple(out)


def _covariance(v) -> tuple[tuple[float, float, float], ...]:
    if not isinstance(v, (list, tuple)) or len(v) != 3:
        raise _Refused(f"cov = {_show(v)} must be a 3x3 matrix (a list of 3 lists of 3 numbers)")
    rows = [_numbers(row, 3, f"cov[{i}]") for i, row in enumerate(v)]
    cov = np.array(rows, dtype=float)
    not_pd = "cov is not positive definite (a variance is zero or negative, or a correlation is 1 or more)"
    var = np.diag(cov)
    if not np.all(var > 0):
        raise _Refused(not_pd)
    sd = np.sqrt(var)
    for (name, bound), s in zip(PARAM_BOUNDS.items(), sd):
        if s > bound:
            raise _Refused(f"cov gives {name} a standard deviation of {s:g}, above the plausible {bound:g}")
    if not np.all(np.abs(cov - cov.T) <= _SYMMETRY_RTOL * np.outer(sd, sd)):
        raise _Refused("cov is not symmetric")
    corr = 0.5 * (cov + cov.T) / np.outer(sd, sd)  # scale-free: variances of 1e-12 and 1e3 side by side
    if not np.linalg.eigvalsh(corr).min() > _MIN_CORR_EIGENVALUE:
        raise _Refused(not_pd)
    return tuple(map(tuple, rows))


def _temp_range(v) -> tuple[float, float]:
    lo, hi = _numbers(v, 2, "temp_range_c")
    t_min, t_max = TEMP_RANGE_C
    if not lo <= hi:
        raise _Refused(f"temp_range_c = [{lo:g}, {hi:g}] must be [lowest, highest]")
    if lo < t_min or hi > t_max:
        raise _Refused(f"temp_range_c = [{lo:g}, {hi:g}] is outside the plausible {t_min:g} to {t_max:g} degC")
    return lo, hi


def _from_json(data, path, advice: str) -> Profile:
    """The :class:`Profile` of parsed JSON after every check (module notes); a
    :class:`ConfigError` ``"{path}: not a valid gyrodrift device profile: ..."`` else."""
    try:
        if not isinstance(data, dict):
            raise _Refused(f"the file holds {_show(data)}, not a JSON object")
        if data.get("format") != FORMAT or not isinstance(data.get("format"), str):
            raise _Refused(f"'format' is not {FORMAT!r}")
        version = data.get("version")
        if not _is_count(version) or version != VERSION:
            raise _Refused(f"version {_show(version)} is not supported (this gyrodrift reads version {VERSION})")
        odd = sorted((k for k in data if k not in _FIELDS), key=repr)
        if odd:
            raise _Refused(f"unknown field(s) {', '.join(map(repr, odd))}")
        missing = [k for k in _FIELDS if k not in data]
        if missing:
            raise _Refused(f"missing field(s) {', '.join(missing)}")
        software, estimator = _text(data, "software"), _text(data, "estimator", non_empty=True)
        created = _text(data, "created")
        try:
            _dt.datetime.fromisoformat(created)
        except ValueError:
            raise _Refused(f"created = {_show(created)} is not an ISO 8601 date and time") from None
        params, cov, temp_range = _params(data["params"]), _covariance(data["cov"]), _temp_range(data["temp_range_c"])
        samples, updates = _count(data, "samples"), _count(data, "updates")
        if updates > samples:
            raise _Refused(f"updates = {updates} is more than samples = {samples}")
    except _Refused as why:
        raise _bad(path, str(why), advice) from None
    return Profile(params, cov, temp_range, samples, updates, estimator, created, software)


def _bad(path, what: str, advice: str = "correct it or save a new one with --save-profile") -> ConfigError:
    return ConfigError(f"{path}: not a valid gyrodrift device profile: {what}; {advice}")


def load_profile(path) -> Profile:
    """Read and check a device profile.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    Profile

    Raises
    ------
    ConfigError
        The file is missing, unreadable or not UTF-8, not JSON, or a field fails its
        check (module notes). One line naming the file and the field.
    """
    path = Path(path)
    text = read_utf8(path, "profile file")
    try:
        data = json.loads(text)
    except RecursionError:
        raise _bad(path, "cannot read it as JSON (arrays or objects nested too deeply)") from None
    except ValueError as err:  # JSONDecodeError, or an integer beyond Python's digit limit for text
        reason = "a number with too many digits" if "digits" in str(err) else " ".join(str(err).split())
        raise _bad(path, f"cannot read it as JSON ({reason})") from None
    return _from_json(data, path, advice="correct it or save a new one with --save-profile")


def profile_notes(profile: Profile, *, estimator: str | None = None, temp_range_c=None) -> list[str]:
    """What a user of ``profile`` should know (module notes); empty when nothing.

    Parameters
    ----------
    profile : Profile
    estimator : str, optional
        The estimator the profile warm-starts (``CompensatorConfig.estimator``).
    temp_range_c : (float, float), optional
        Lowest and highest temperature of the run, degC; non-finite ends (no
        temperature seen) are left out.

    Returns
    -------
    list of str
        One sentence each, without the file name.
    """
    notes = []
    if estimator is not None and estimator != profile.estimator:
        notes.append(
            f"saved by the {profile.estimator!r} estimator, used with {estimator!r}: its parameters and covariance "
            f"may not suit {estimator!r}; use the estimator that saved it, or save a profile with this one"
        )
    if temp_range_c is not None:
        lo, hi = (float(v) for v in temp_range_c)
        p_lo, p_hi = profile.temp_range_c
        below = math.isfinite(lo) and lo < p_lo - TEMP_MARGIN_C
        above = math.isfinite(hi) and hi > p_hi + TEMP_MARGIN_C
        if below or above:
            notes.append(
                f"learned at {p_lo:.1f} to {p_hi:.1f} degC, used at {lo:.1f} to {hi:.1f} degC: its drift model is "
                "extrapolated beyond the temperatures it was learned at; save a profile that covers them "
                "(--save-profile)"
            )
    return notes


def warm_config(profile: Profile, config: CompensatorConfig | None = None) -> CompensatorConfig:
    """Settings that start the Kalman estimators from a profile (module notes)."""
    config = config or CompensatorConfig()
    kal = config.kalman
    cap = np.square(np.array(kal.max_sd or kal.p0_sd, dtype=float))
    P = cap_covariance(_WARM_SD_FACTOR**2 * np.array(profile.cov, dtype=float), cap)
    P = P + np.diag(np.square(np.array(kal.q_sd, dtype=float)))  # keeps it positive definite
    warm = replace(kal, x0=tuple(profile.params), p0_cov=tuple(map(tuple, P.tolist())))
    return replace(config, kalman=warm)


def compensate_warm(log, profile: Profile, config: CompensatorConfig | None = None, *, name: str = "profile",
                    **options):
    """:func:`gyrodrift.compensate` started from ``profile``, with its notes.

    Parameters
    ----------
    log : pandas.DataFrame
        A log in the input contract (:func:`gyrodrift.io.read_log`).
    profile : Profile
        From :func:`load_profile`.
    config : CompensatorConfig, optional
        The settings to warm-start (:func:`warm_config`); default settings without it.
    name : str, default "profile"
        What to call the profile in the notes (its file, say).
    **options
        Passed to :func:`gyrodrift.compensate` (``source``, ``progress``, ``gyro_max_dps``).

    Returns
    -------
    pandas.DataFrame
        The output of :func:`gyrodrift.compensate`; ``attrs["notes"]`` ends with the notes
        of :func:`profile_notes` for this configuration's estimator and the log's
        temperatures, each as ``"<name>: <note>"``.
    """
    config = config or CompensatorConfig()
    temp_c = np.asarray(log[TEMP], dtype=float) if TEMP in log.columns else np.array([])
    seen = temp_c[np.isfinite(temp_c)]
    temp_range_c = (float(seen.min()), float(seen.max())) if seen.size else None
    out = compensate(log, warm_config(profile, config), **options)
    notes = profile_notes(profile, estimator=config.estimator, temp_range_c=temp_range_c)
    out.attrs["notes"] = list(out.attrs.get("notes", ())) + [f"{name}: {note}" for note in notes]
    return out
