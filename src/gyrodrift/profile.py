"""Device profiles: what a run learned about one gyro, to warm-start the next run.

``gyrodrift compensate --save-profile dev.json`` stores the final drift parameters and
their covariance with the run's facts; ``--profile dev.json`` starts the next run from them.
The file, the warm start, the checks and the notes: docs/settings-and-profiles.md, section
"Device profiles".
"""

from __future__ import annotations

import datetime as _dt
import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from gyrodrift._version import __version__
from gyrodrift._atomic import write_bytes_atomic
from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.config import parse_problem, read_utf8
from gyrodrift.conventions import TEMP, TEMP_RANGE_C
from gyrodrift.errors import ConfigError
from gyrodrift.kernels.numeric import cap_covariance
from gyrodrift.settings import DRIFT_PARAM_BOUNDS, SettingError, check, check_covariance, setting, show

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
_NAMES = tuple(PARAM_BOUNDS)
_INT64_MAX = 2**63 - 1


@dataclass(frozen=True)
class Profile:
    """What one run learned (docs/settings-and-profiles.md, section "Device profiles")."""

    #: a (deg/s/degC), b (deg/degC), c (deg/s) at the end of the run, and their covariance
    params: tuple[float, float, float] = setting(drift=_NAMES, measured=True)
    cov: tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]] = \
        setting(measured=True)
    #: lowest and highest temperature seen, degC
    temp_range_c: tuple[float, float] = setting(unit="degC", ge=TEMP_RANGE_C[0], le=TEMP_RANGE_C[1], measured=True)
    samples: int = setting(ge=0, whole_max=_INT64_MAX)  #: rows compensated
    updates: int = setting(ge=0, whole_max=_INT64_MAX)  #: filter updates taken
    estimator: str = setting(longest=200)
    created: str = setting(longest=200)  #: ISO 8601 date and time (UTC)
    software: str = setting(longest=200)  #: "gyrodrift X.Y.Z"

    def _check_together(self) -> None:
        """The checks that involve more than one value (:func:`check` runs them)."""
        check_covariance("cov", self.cov, _NAMES)
        lo, hi = self.temp_range_c
        if not lo <= hi:
            raise SettingError(f"temp_range_c = [{lo:g}, {hi:g}] must be [lowest, highest]")
        if self.updates > self.samples:
            raise SettingError(f"updates = {self.updates} is more than samples = {self.samples}")
        if not self.estimator:
            raise SettingError('estimator = "" must name the estimator')
        try:
            _dt.datetime.fromisoformat(self.created)
        except ValueError:
            raise SettingError(f"created = {show(self.created)} is not an ISO 8601 date and time") from None

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
    :class:`gyrodrift.pipeline.RunStats` of :func:`gyrodrift.pipeline.compensate_file`; a
    :class:`ConfigError` when its drift model was in time, not temperature."""
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
    """Write the profile to ``path`` as JSON, atomically, after the checks :func:`load_profile`
    makes; one that would not load is a one-line :class:`ConfigError` and nothing is written."""
    checked = _from_json(profile.to_json(), path, advice="the run did not learn a usable profile; nothing was saved")
    write_bytes_atomic(path, (json.dumps(checked.to_json(), indent=2) + "\n").encode("utf-8"))


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _is_count(v) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _check_keys(data: dict, known, unknown: str, missing: str) -> None:
    """Raise :class:`SettingError` for keys of ``data`` not ``known`` (the ``unknown`` wording,
    keys quoted) or ``known`` keys it lacks (the ``missing`` wording)."""
    odd = sorted((k for k in data if k not in known), key=repr)
    if odd:
        raise SettingError(unknown.format(", ".join(map(repr, odd))))
    absent = [k for k in known if k not in data]
    if absent:
        raise SettingError(missing.format(", ".join(absent)))


def _from_json(data, path, advice: str) -> Profile:
    """The :class:`Profile` of parsed JSON after every check, or a :class:`ConfigError`."""
    try:
        if not isinstance(data, dict):
            raise SettingError(f"the file holds {show(data)}, not a JSON object")
        if data.get("format") != FORMAT or not isinstance(data.get("format"), str):
            raise SettingError(f"'format' is not {FORMAT!r}")
        version = data.get("version")
        if not _is_count(version) or version != VERSION:
            raise SettingError(f"version {show(version)} is not supported (this gyrodrift reads version {VERSION})")
        _check_keys(data, _FIELDS, "unknown field(s) {}", "missing field(s) {}")
        params = data["params"]
        if not isinstance(params, dict):
            raise SettingError(f"params = {show(params)} must be an object with {', '.join(_NAMES)}")
        _check_keys(params, _NAMES, f"params has unknown field(s) {{}}; known: {', '.join(_NAMES)}", "params lacks {}")
        for name in _NAMES:  # each named, as in the file (the validator names the element of a triple)
            if not _is_number(params[name]) or not math.isfinite(params[name]):
                raise SettingError(f"params.{name} = {show(params[name])} must be a finite number")
        profile = Profile(tuple(params[k] for k in _NAMES), *(data[k] for k in _FIELDS[6:]), data["estimator"],
                          data["created"], data["software"])
        check(profile)  # the validator of every setting (gyrodrift.settings): types, bounds, _check_together
    except SettingError as why:
        raise _bad(path, why.text, advice) from None
    return profile


def _bad(path, what: str, advice: str = "correct it or save a new one with --save-profile") -> ConfigError:
    return ConfigError(f"{path}: not a valid gyrodrift device profile: {what}; {advice}")


def load_profile(path) -> Profile:
    """Read and check a device profile; a missing, unreadable, non-UTF-8 or non-JSON file, or a
    field that fails its check, is a one-line :class:`ConfigError` naming the file and the field."""
    path = Path(path)
    text = read_utf8(path, "profile file")
    try:
        data = json.loads(text)
    except RecursionError:
        raise _bad(path, "cannot read it as JSON (arrays or objects nested too deeply)") from None
    except ValueError as err:  # JSONDecodeError, or an integer beyond Python's digit limit for text
        raise _bad(path, f"cannot read it as JSON ({parse_problem(err)})") from None
    return _from_json(data, path, advice="correct it or save a new one with --save-profile")


def profile_notes(profile: Profile, *, estimator: str | None = None, temp_range_c=None) -> list[str]:
    """What a user of ``profile`` should know, one sentence each without the file name.

    ``estimator`` is the estimator it warm-starts; ``temp_range_c`` the run's lowest and
    highest temperature, degC (non-finite ends left out).
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
    """Settings that start the Kalman estimators from ``profile`` (docs/settings-and-profiles.md)."""
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

    ``config`` is warm-started (:func:`warm_config`; default settings without it), ``name``
    calls the profile in the notes, ``options`` go to :func:`gyrodrift.compensate`. The
    output's ``attrs["notes"]`` ends with those of :func:`profile_notes`, as ``"<name>: <note>"``.
    """
    config = config or CompensatorConfig()
    temp_c = np.asarray(log[TEMP], dtype=float) if TEMP in log.columns else np.array([])
    seen = temp_c[np.isfinite(temp_c)]
    temp_range_c = (float(seen.min()), float(seen.max())) if seen.size else None
    out = compensate(log, warm_config(profile, config), **options)
    notes = profile_notes(profile, estimator=config.estimator, temp_range_c=temp_range_c)
    out.attrs["notes"] = list(out.attrs.get("notes", ())) + [f"{name}: {note}" for note in notes]
    return out
