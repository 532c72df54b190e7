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
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.errors import ConfigError
from gyrodrift.kernels.numeric import cap_covariance

__all__ = ["FORMAT", "VERSION", "Profile", "profile_from_run", "save_profile", "load_profile", "warm_config"]

FORMAT = "gyrodrift-profile"
VERSION = 1
_WARM_SD_FACTOR = 2.0


@dataclass(frozen=True)
class Profile:
    """What one run learned.

    Attributes
    ----------
    params : tuple of 3 floats
        a (deg/s/degC), b (deg), c (deg/s) at the end of the run.
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
    :class:`gyrodrift.pipeline.RunStats` of :func:`gyrodrift.pipeline.compensate_file`."""
    if hasattr(out, "final_params") and not hasattr(out, "attrs"):  # RunStats
        final_params, final_cov, estimator = out.final_params, out.final_cov, out.estimator
        temp_range, samples, updates = (out.temp_min_c, out.temp_max_c), out.rows, out.updates
    else:
        final_params, final_cov = out.attrs["final_params"], out.attrs["final_cov"]
        estimator = out.attrs.get("estimator", "")
        temp = out["temp"] if "temp" in out.columns else out["in_temp"]
        temp_range, samples, updates = (temp.min(), temp.max()), len(out), out["update"].sum()
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
    """Write the profile as JSON, atomically."""
    write_bytes_atomic(path, (json.dumps(profile.to_json(), indent=2) + "\n").encode("utf-8"))


def _bad(path, what: str) -> ConfigError:
    return ConfigError(f"{path}: not a valid gyrodrift device profile: {what}; save one with --save-profile")


def load_profile(path) -> Profile:
    """Read and validate a profile; any problem is a :class:`ConfigError` naming the file."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(f"{path}: profile file not found") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise _bad(path, f"cannot read it as JSON ({err})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise _bad(path, f"'format' is not {FORMAT!r}")
    if data.get("version") != VERSION:
        raise _bad(path, f"version {data.get('version')!r} is not supported (this gyrodrift reads version {VERSION})")
    try:
        p = data["params"]
        params = (float(p["a_dps_per_c"]), float(p["b_deg"]), float(p["c_dps"]))
        cov = np.array(data["cov"], dtype=float)
        t_lo, t_hi = (float(v) for v in data["temp_range_c"])
        samples, updates = int(data["samples"]), int(data["updates"])
        estimator, created, software = str(data["estimator"]), str(data["created"]), str(data["software"])
    except (KeyError, TypeError, ValueError) as err:
        raise _bad(path, f"missing or malformed field ({err})") from None
    if not all(math.isfinite(v) for v in params):
        raise _bad(path, "params are not finite numbers")
    if cov.shape != (3, 3) or not np.all(np.isfinite(cov)) or not np.allclose(cov, cov.T):
        raise _bad(path, "cov is not a symmetric 3x3 matrix")
    if np.linalg.eigvalsh(cov).min() < 0:
        raise _bad(path, "cov is not positive semi-definite")
    return Profile(params, tuple(map(tuple, cov.tolist())), (t_lo, t_hi), samples, updates, estimator, created, software)


def warm_config(profile: Profile, config: CompensatorConfig | None = None) -> CompensatorConfig:
    """Settings that start the Kalman estimators from a profile (module notes)."""
    config = config or CompensatorConfig()
    kal = config.kalman
    cap = np.square(np.array(kal.max_sd or kal.p0_sd, dtype=float))
    P = cap_covariance(_WARM_SD_FACTOR**2 * np.array(profile.cov, dtype=float), cap)
    P = P + np.diag(np.square(np.array(kal.q_sd, dtype=float)))  # keeps it positive definite
    warm = replace(kal, x0=tuple(profile.params), p0_cov=tuple(map(tuple, P.tolist())))
    return replace(config, kalman=warm)
