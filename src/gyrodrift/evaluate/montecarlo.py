"""Monte Carlo comparison of the drift estimators over every simulated scenario family.

The families, cases, scores and summary: docs/evaluation.md, section "Monte Carlo over
scenario families".
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass
from types import MappingProxyType
from typing import Callable, Iterable, Mapping, Sequence

import numpy as np
import pandas as pd

from gyrodrift.compensator import CompensatorConfig
from gyrodrift.errors import ConfigError
from gyrodrift.evaluate.compare import is_method, run_method, valid_methods
from gyrodrift.evaluate.metrics import bias_error, error_stats, heading_error_stats, markdown_table
from gyrodrift.fleet import check_workers, error_line, map_jobs
from gyrodrift.simulate import (
    DEFAULT_DURATION_S,
    CompassModel,
    DeviceModel,
    random_compass,
    random_device,
    simulate,
)
from gyrodrift.simulate.device import TriadModel

__all__ = [
    "Family",
    "FAMILIES",
    "ADVERSARIAL_FAMILIES",
    "DEFAULT_METHODS",
    "REFERENCE_METHOD",
    "COLUMNS",
    "Case",
    "draw_case",
    "simulate_case",
    "run_case",
    "run_monte_carlo",
    "summarise",
    "markdown",
]


@dataclass(frozen=True)
class Family:
    """A scenario family of the Monte Carlo."""

    scenario: str  # simulated scenario (gyrodrift.simulate.SCENARIOS)
    duration_s: float  # default log length, s (times duration_scale)
    description: str  # one line for tables and help
    duration_range_s: tuple[float, float] | None = None  # each case's length drawn from it, s, whatever the scale
    triad: bool = False  # the log also has gyro_x, gyro_y and the default TriadModel's accelerometer


def _family(name: str, description: str, **options) -> tuple[str, Family]:
    return name, Family(name, DEFAULT_DURATION_S[name], description, **options)


#: The scenario families, by name: the six of the paper's kind, then :data:`ADVERSARIAL_FAMILIES`.
FAMILIES: Mapping[str, Family] = MappingProxyType(dict([
    _family("static", "motionless, heated 23 -> 58 degC and cooled (3 h)"),
    _family("interference-wander", "static ramp with slowly wandering magnetic interference in four windows (3 h)"),
    _family("vehicle", "car loops with 90 deg turns, 26 -> 37 degC (40 min)"),
    _family("hysteresis", "strongly nonlinear device with thermal lag and backlash, 10 -> 70 -> 10 degC cycles (4 h)"),
    _family("cold-start", "warm-up from -20 to +60 degC (2 h)"),
    _family("soak", "12-h soak, slow yaw sway, temperature ramps, long compass outages during the ramps"),
    _family("bursty", "still and cooling, logged in 5-s records every ~300 s; half the cases without compass (2 h)"),
    _family("ramp-interference",
            "still, temperature falling ~0.8 degC/min, 10 min of ~30 deg wandering interference (90 min)"),
    _family("sway", "moored platform: yaw sway < 0.2 deg/s, 40-90 min compass outages, day/night temperature (12 h)"),
    _family("vehicle-rawmag", "the vehicle with raw magnetometer + accelerometer (tilted when braking, cornering) and "
            "x/y gyros, no heading (40 min)", triad=True),
    _family("vessel", "slow continuous turn 0.15-0.6 deg/s with wave yaw, warming (2 h)"),
    _family("no-temp", "bench unit warming up, turned every few minutes; temperature column constant 0 degC (1 h)"),
    _family("short", "hand-held: a few seconds still, one 90-720 deg rotation (20-40 s)",
            duration_range_s=(20.0, 40.0)),
]))

#: The adversarial families (:mod:`gyrodrift.simulate.adversarial`), in the order of :data:`FAMILIES`.
ADVERSARIAL_FAMILIES = ("bursty", "ramp-interference", "sway", "vehicle-rawmag", "vessel", "no-temp", "short")

#: Methods of the comparison by default: ours, the paper's, PX4's and x-io Fusion's, our smoother.
DEFAULT_METHODS = ("adaptive", "stkf", "kf", "mlr", "lsm", "poly3", "fusion-offset", "smoothed")

#: The method the others are counted against in :func:`summarise`.
REFERENCE_METHOD = "adaptive"

#: Columns of :func:`run_monte_carlo`, in order.
COLUMNS = (
    "family", "seed", "method", "scenario", "duration_s",
    "heading_rms_deg", "heading_max_deg", "bias_rms_dps", "status", "error",
)

#: Length of the separate calibration heating run of ``poly3``, s (not scaled).
CALIBRATION_S = DEFAULT_DURATION_S["calibration"]


# --------------------------------------------------------------------------- one case


@dataclass(frozen=True)
class Case:
    """One (family, seed) of the Monte Carlo: what is simulated, fully determined."""

    family: str
    seed: int
    scenario: str
    duration_s: float  # log length, s
    log_seed: int  # simulate() seeds of the log and of the calibration run
    calibration_seed: int
    device: DeviceModel  # the randomised gyro, shared by the log and the calibration run
    compass: CompassModel


def _family_key(family: str) -> int:
    """A stable integer of a family name (not :func:`hash`, which changes per process)."""
    return zlib.crc32(family.encode("utf-8"))


def _check_names(given, known, kind: tuple[str, str], choices: str) -> list[str]:
    """``given`` (a name or names) as a list of distinct names ``known`` accepts; ``kind`` is (one, several)."""
    names = [given] if isinstance(given, str) else list(given)
    unknown = [n for n in names if not known(n)]
    if unknown or not names:
        raise ConfigError(f"unknown {kind[len(unknown) > 1]} {', '.join(map(str, unknown)) or '(none given)'}; "
                          f"choose from: {choices}")
    if len(set(names)) != len(names):
        raise ConfigError(f"{kind[1]} must not repeat, got {', '.join(names)}")
    return names


def _check_families(families) -> list[str]:
    given = list(FAMILIES) if families is None else families
    return _check_names(given, FAMILIES.__contains__, ("family", "families"), ", ".join(FAMILIES))


def _check_seeds(seeds) -> list[int]:
    if isinstance(seeds, (int, np.integer)) and not isinstance(seeds, bool):
        if seeds < 1:
            raise ConfigError(f"seeds must be at least 1, got {seeds}")
        return list(range(int(seeds)))
    try:
        out = list(seeds)
    except TypeError:
        raise ConfigError(f"seeds must be a count or a list of non-negative integers, got {seeds!r}") from None
    bad = [s for s in out if isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s < 0]
    if bad or not out:
        raise ConfigError(f"seeds must be non-negative integers, got {out!r}")
    if len(set(out)) != len(out):
        raise ConfigError(f"seeds must not repeat, got {out!r}")
    return [int(s) for s in out]


def _check_methods(methods) -> list[str]:
    return _check_names(methods, is_method, ("method", "methods"), valid_methods())


def _positive(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ConfigError(f"{name} must be a positive number, got {value!r}")
    return float(value)


def draw_case(family: str, seed: int, *, duration_scale: float = 1.0) -> Case:
    """Draw the device, compass and simulation seeds of one case, from ``(crc32(family), seed)``.

    ``duration_scale`` is the log length as a multiple of the family's default.
    """
    (family,) = _check_families([family])
    (seed,) = _check_seeds([seed])
    scale = _positive("duration_scale", duration_scale)
    spec = FAMILIES[family]
    root = np.random.SeedSequence([_family_key(family), seed])
    device_ss, compass_ss = root.spawn(2)
    log_seed, calibration_seed = (int(x) for x in root.generate_state(2))
    duration = spec.duration_s * scale
    if spec.duration_range_s is not None:
        (length_ss,) = root.spawn(1)
        duration = float(np.random.default_rng(length_ss).uniform(*spec.duration_range_s))
    return Case(
        family=family,
        seed=seed,
        scenario=spec.scenario,
        duration_s=duration,
        log_seed=log_seed,
        calibration_seed=calibration_seed,
        device=random_device(np.random.default_rng(device_ss), scenario=spec.scenario),
        compass=random_compass(np.random.default_rng(compass_ss)),
    )


def simulate_case(case: Case, *, fs_hz: float = 10.0, calibration: bool = True):
    """``(log, calibration_log)`` of a case at ``fs_hz``; the calibration heating run only if asked (else None)."""
    log = simulate(
        case.scenario, seed=case.log_seed, duration_s=case.duration_s, fs_hz=fs_hz,
        device=case.device, compass=case.compass, triad=TriadModel() if FAMILIES[case.family].triad else None,
    )
    cal = None
    if calibration:
        cal = simulate(
            "calibration", seed=case.calibration_seed, duration_s=CALIBRATION_S, fs_hz=fs_hz,
            device=case.device, compass=case.compass,
        )
    return log, cal


def _row(family, seed, method, scenario, duration_s, **values) -> dict:
    return {**dict.fromkeys(COLUMNS, math.nan), "family": family, "seed": int(seed), "method": method,
            "scenario": scenario, "duration_s": float(duration_s), "status": "ok", "error": "", **values}


def _score(out: pd.DataFrame) -> dict:
    heading = heading_error_stats(out)
    return {
        "heading_rms_deg": heading["rms"],
        "heading_max_deg": heading["max_abs"],
        "bias_rms_dps": error_stats(bias_error(out))["rms"],
    }


def run_case(
    family: str,
    seed: int,
    methods: Sequence[str] = DEFAULT_METHODS,
    *,
    duration_scale: float = 1.0,
    config: CompensatorConfig | None = None,
    fs_hz: float = 10.0,
) -> list[dict]:
    """Simulate one case (:func:`draw_case`) and run every method on it; one row (:data:`COLUMNS`) per method.

    A failure is a row with ``status = "error"``, never raised.
    """
    methods = _check_methods(methods)
    case = draw_case(family, seed, duration_scale=duration_scale)
    config = config or CompensatorConfig()
    try:
        log, cal = simulate_case(case, fs_hz=fs_hz, calibration="poly3" in methods)
    except Exception as err:  # reported per case, never stops the whole Monte Carlo
        why = "simulation failed: " + error_line(err)
        return [_row(family, seed, m, case.scenario, case.duration_s, status="error", error=why) for m in methods]
    rows = []
    for name in methods:
        try:
            out = run_method(name, log, config, calibration=cal)
            rows.append(_row(family, seed, name, case.scenario, case.duration_s, **_score(out)))
        except Exception as err:  # one failing method must not hide the others
            rows.append(_row(family, seed, name, case.scenario, case.duration_s, status="error", error=error_line(err)))
    return rows


def _run_task(task: tuple) -> list[dict]:
    """Process-pool entry point (module level, so it pickles)."""
    family, seed, methods, duration_scale, config, fs_hz = task
    return run_case(family, seed, methods, duration_scale=duration_scale, config=config, fs_hz=fs_hz)


def _failed_task(task: tuple, err: BaseException) -> list[dict]:
    family, seed, methods, duration_scale, _, _ = task
    scenario = FAMILIES[family].scenario
    duration = draw_case(family, seed, duration_scale=duration_scale).duration_s
    why = "worker failed: " + error_line(err)
    return [_row(family, seed, m, scenario, duration, status="error", error=why) for m in methods]


# --------------------------------------------------------------------------- many cases


def run_monte_carlo(
    families: Iterable[str] | None = None,
    seeds: int | Iterable[int] = 20,
    methods: Sequence[str] = DEFAULT_METHODS,
    duration_scale: float = 1.0,
    config: CompensatorConfig | None = None,
    workers: int | None = None,
    progress: Callable | None = None,
    *,
    fs_hz: float = 10.0,
) -> pd.DataFrame:
    """Run every method on every (family, seed) case; one row per (family, seed, method).

    Parameters
    ----------
    families : iterable of str, optional
        Family names (default: all of :data:`FAMILIES`, in that order).
    seeds : int or iterable of int
        A count ``N`` (seeds ``0 .. N-1``) or the seeds themselves.
    methods : sequence of str
        Names of :data:`gyrodrift.evaluate.compare.METHODS` or registered estimators.
    duration_scale : float
        Every log's length as a multiple of its family's default.
    config : CompensatorConfig, optional
        Settings shared by every method and case.
    workers : int, optional
        Worker processes (default :func:`os.cpu_count`); the rows do not depend on it.
    progress : callable, optional
        ``progress(iterable, total)`` wraps the finished cases and yields them.
    fs_hz : float
        Gyro sample rate of the simulated logs, Hz.

    Returns
    -------
    DataFrame
        Columns :data:`COLUMNS`, in the order of families, seeds and methods; ``attrs`` holds the arguments.

    Raises
    ------
    ConfigError
        Unknown family or method, or an invalid count, scale or worker number.
    """
    fams = _check_families(families)
    seed_list = _check_seeds(seeds)
    names = _check_methods(methods)
    scale = _positive("duration_scale", duration_scale)
    fs = _positive("fs_hz", fs_hz)
    n_workers = check_workers(workers)
    config = config or CompensatorConfig()
    tasks = [(f, s, tuple(names), scale, config, fs) for f in fams for s in seed_list]
    results = map_jobs(_run_task, tasks, n_workers, progress, on_error=_failed_task)
    rows = [row for task_rows in results for row in task_rows]
    df = pd.DataFrame(rows, columns=list(COLUMNS))
    df.attrs = {"families": fams, "seeds": seed_list, "methods": names, "duration_scale": scale, "fs_hz": fs}
    return df


# --------------------------------------------------------------------------- summary


def summarise(df: pd.DataFrame, reference: str = REFERENCE_METHOD) -> pd.DataFrame:
    """Per family and method: mean and median of both RMS errors, and how often ``reference`` wins.

    One row per (family, method) of the rows of :func:`run_monte_carlo`, then an ``all`` family
    with several families (the columns: docs/evaluation.md, section "Monte Carlo over scenario families").
    """
    metrics = ["heading_rms_deg", "bias_rms_dps"]
    missing = [c for c in ("family", "seed", "method", *metrics, "status") if c not in df.columns]
    if missing:
        raise ConfigError(f"summarise needs the columns of run_monte_carlo; missing {', '.join(missing)}")
    base = df.assign(case=df["family"].astype(str) + ":" + df["seed"].astype(str))
    families = list(dict.fromkeys(base["family"]))
    methods = list(dict.fromkeys(base["method"]))
    groups = [(fam, base[base["family"] == fam]) for fam in families]
    if len(families) > 1:
        groups.append(("all", base))
    rows = []
    for fam, part in groups:
        ok = part[part["status"] == "ok"]
        ref = ok[ok["method"] == reference].set_index("case")[metrics]
        for m in methods:
            tried = part[part["method"] == m]
            if tried.empty:
                continue
            cur = ok[ok["method"] == m].set_index("case")[metrics]
            row = {
                "family": fam,
                "method": m,
                "n": int(len(cur)),
                "failed": int(len(tried) - len(cur)),
                "heading_rms_mean_deg": float(cur["heading_rms_deg"].mean()) if len(cur) else math.nan,
                "heading_rms_median_deg": float(cur["heading_rms_deg"].median()) if len(cur) else math.nan,
                "bias_rms_mean_dps": float(cur["bias_rms_dps"].mean()) if len(cur) else math.nan,
                "bias_rms_median_dps": float(cur["bias_rms_dps"].median()) if len(cur) else math.nan,
                "pairs": pd.NA,
                "wins": pd.NA,
                "better_mean": pd.NA,
            }
            if m != reference and len(ref):
                both = cur.join(ref.add_suffix("_ref"), how="inner")
                wins = (both["heading_rms_deg_ref"] < both["heading_rms_deg"]) & (
                    both["bias_rms_dps_ref"] < both["bias_rms_dps"]
                )
                row.update(pairs=int(len(both)), wins=int(wins.sum()))
                if len(cur):
                    row["better_mean"] = bool(
                        ref["heading_rms_deg"].mean() < row["heading_rms_mean_deg"]
                        and ref["bias_rms_dps"].mean() < row["bias_rms_mean_dps"]
                    )
            rows.append(row)
    out = pd.DataFrame(rows)
    for col in ("pairs", "wins"):
        out[col] = out[col].astype("Int64")
    out["better_mean"] = out["better_mean"].astype("boolean")
    out.attrs = {"reference": reference}
    return out


def markdown(summary: pd.DataFrame, *, tuned_on: str | None = None, floatfmt: str = ".4g") -> str:
    """:func:`summarise` as GitHub Markdown with a legend, no trailing newline.

    ``tuned_on`` names the family the settings were tuned on: it gets a table apart from the
    others'; ``floatfmt`` is the :func:`format` spec of the numbers.
    """
    reference = summary.attrs.get("reference", REFERENCE_METHOD)
    table = summary.copy()
    table["wins"] = [
        "" if pd.isna(w) else f"{int(w)}/{int(p)}" for w, p in zip(summary["wins"], summary["pairs"])
    ]
    table["better_mean"] = ["" if pd.isna(b) else ("yes" if b else "no") for b in summary["better_mean"]]
    table = table.drop(columns=["pairs"]).rename(
        columns={"wins": f"{reference} wins", "better_mean": f"{reference} better on mean"}
    )
    legend = (
        f"heading_rms: RMS of heading minus ref_heading (deg); bias_rms: RMS of estimated minus true drift "
        f"(deg/s), per case, then mean and median over the cases (n; failed = cases where the method raised). "
        f"'{reference} wins k/n': cases where {reference} has both a lower heading RMS and a lower bias RMS "
        f"than the method; 'better on mean': both means lower."
    )
    if tuned_on is None:
        return markdown_table(table, floatfmt, index=False) + "\n\n" + legend
    if tuned_on not in set(table["family"]):
        raise ConfigError(f"tuned_on={tuned_on!r} is not a family of the summary: {', '.join(dict.fromkeys(table['family']))}")
    tuned = table[table["family"] == tuned_on]
    held = table[(table["family"] != tuned_on) & (table["family"] != "all")]
    parts = [f"Settings tuned on `{tuned_on}`:", "", markdown_table(tuned, floatfmt, index=False)]
    if len(held):
        parts += ["", "Held-out families (settings frozen):", "", markdown_table(held, floatfmt, index=False)]
    return "\n".join(parts) + "\n\n" + legend
