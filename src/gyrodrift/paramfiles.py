"""Parameter files the autopilots load: PX4 ``.params``, ArduPilot ``.param``, gyrodrift JSON.

:func:`write_calibration` writes calibrations (one per gyro) for PX4, ArduPilot or as JSON;
:func:`read_px4_params`, :func:`read_ardupilot_params` and :func:`read_calibration_json`
read them back; :func:`param_values` reads an autopilot's file into ``{name: value}``. The
autopilots' parameters, file formats and frames, with their sources: docs/autopilot-files.md.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import re
from pathlib import Path

import numpy as np

from gyrodrift._version import __version__
from gyrodrift._atomic import write_bytes_atomic
from gyrodrift._text import printable
from gyrodrift.calibrate import AXES, AXIS_COLUMNS, AxisFit, Calibration
from gyrodrift.config import read_utf8
from gyrodrift.errors import ConfigError
from gyrodrift.onboard import ARDUPILOT_SCALE, ARDUPILOT_TREF_C

__all__ = [
    "FORMATS", "px4_parameters", "ardupilot_parameters", "calibration_json", "write_calibration", "output_format",
    "param_values", "param_file_format", "read_px4_params", "read_ardupilot_params", "read_calibration_json",
    "read_prior",
]

_ORDER = 3
_RAD_PER_DEG = math.pi / 180.0
_PX4_INT32, _PX4_REAL32 = 6, 9  # MAVLink MAV_PARAM_TYPE of the id and of the floats
#: Output formats of :func:`write_calibration` and the file endings that name them
#: (``ardupilot-qgc``: ArduPilot's parameters in QGroundControl's file, named by ``fmt`` only).
FORMATS = {"px4": (".params",), "ardupilot": (".param", ".parm"), "ardupilot-qgc": (), "json": (".json",)}
_MAV_INT8 = 2  # MAV_PARAM_TYPE of INS_TCALn_ENABLE (AP_Int8)
_JSON_FORMAT, _JSON_VERSION = "gyrodrift-calibration", 1


# ---------------------------------------------------------------------------- frames and polynomials


def _rotation(body_to_board, cal: Calibration | None = None) -> np.ndarray:
    """The 3x3 rotation ``v_board = R @ v_body``, checked: ``body_to_board``, else the
    calibration's own (``cal.matrix.T``), else the identity."""
    if body_to_board is None:
        return np.eye(3) if cal is None else cal.matrix.T
    R = np.asarray(body_to_board, dtype=float)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) \
            or np.linalg.det(R) <= 0:
        raise ConfigError(f"body_to_board must be a 3x3 rotation matrix (orthonormal, determinant +1), got {R.tolist()}")
    return R


def _board_coeffs(cal: Calibration, R: np.ndarray) -> np.ndarray:
    """Coefficients (deg/s per degC**k) as a (k, board axis) array; axes not in ``cal`` count as 0."""
    body = np.zeros((_ORDER + 1, 3))
    for i, axis in enumerate(AXES):
        if axis in cal.axes:
            body[:, i] = cal.axes[axis].coeffs
    return body @ R.T


def _shift(coeffs: np.ndarray, delta: float) -> np.ndarray:
    """Coefficients about ``ref + delta`` of the polynomial with ``coeffs`` about ``ref`` (rows = powers)."""
    n = coeffs.shape[0]
    out = np.zeros_like(coeffs)
    for j in range(n):
        for k in range(j, n):
            out[j] += coeffs[k] * math.comb(k, j) * delta ** (k - j)
    return out


def _missing_note(cal: Calibration) -> list[str]:
    missing = [AXIS_COLUMNS[a] for a in AXES if a not in cal.axes]
    if not missing:
        return []
    return [f"{', '.join(missing)} not in the log: their coefficients are written as 0 (no compensation)"]


def _number(value: float) -> str:
    """Every digit of the double, without an exponent."""
    return np.format_float_positional(float(value), unique=True, trim="-")


# ---------------------------------------------------------------------------- writers


def px4_parameters(cal: Calibration, *, instance: int | None = None, device_id: int | None = None,
                   body_to_board=None) -> list:
    """PX4's gyro thermal-compensation parameters of ``cal`` (docs/autopilot-files.md, section "PX4").

    Parameters
    ----------
    cal : Calibration
    instance : int, optional
        Gyro slot ``i`` of ``TC_G{i}_*`` (0..3); default ``cal.instance``.
    device_id : int, optional
        ``TC_G{i}_ID``; default ``cal.device_id`` (0 when unknown: PX4 then applies nothing).
    body_to_board : 3x3 array_like, optional
        Rotation from body FRD to the sensor frame; default ``cal.matrix.T``.

    Returns
    -------
    list of (str, int or float, int)
        ``(name, value, MAVLink type)``: ``TC_G_ENABLE``, ``TC_G{i}_ID``, ``TMIN``, ``TMAX``,
        ``TREF`` (degC) and ``TC_G{i}_X{k}_{a}`` (rad/s per degC**k), in that order.
    """
    instance = cal.instance if instance is None else instance
    device_id = (cal.device_id or 0) if device_id is None else device_id
    if isinstance(instance, bool) or not isinstance(instance, int) or not 0 <= instance <= 3:
        raise ConfigError(f"PX4 gyro slot must be 0 to 3, got {instance!r}")
    if isinstance(device_id, bool) or not isinstance(device_id, int) or not -(2**31) <= device_id < 2**32:
        raise ConfigError(f"PX4 device id must be a 32-bit whole number, got {device_id!r}")
    board = _board_coeffs(cal, _rotation(body_to_board, cal)) * _RAD_PER_DEG
    g = f"TC_G{instance}_"
    params = [("TC_G_ENABLE", 1, _PX4_INT32), (g + "ID", device_id - 2**32 if device_id >= 2**31 else device_id,
                                                _PX4_INT32)]
    params += [(g + "TMIN", cal.temp_min_c, _PX4_REAL32), (g + "TMAX", cal.temp_max_c, _PX4_REAL32),
               (g + "TREF", cal.temp_ref_c, _PX4_REAL32)]
    params += [(f"{g}X{k}_{a}", float(board[k, a]), _PX4_REAL32) for k in range(_ORDER + 1) for a in range(3)]
    return params


def ardupilot_parameters(cal: Calibration, *, instance: int | None = None, body_to_board=None) -> list:
    """ArduPilot's gyro temperature-calibration parameters of ``cal`` (docs/autopilot-files.md,
    section "ArduPilot").

    Parameters
    ----------
    cal : Calibration
    instance : int, optional
        IMU index from 0 (``INS_TCAL{instance + 1}_*``); default ``cal.instance``.
    body_to_board : 3x3 array_like, optional
        Rotation from body FRD to the sensor frame; default ``cal.matrix.T``.

    Returns
    -------
    list of (str, float)
        ``INS_TCAL{n}_ENABLE`` = 1, ``TMIN``, ``TMAX`` (degC), then ``GYR{k}_{X,Y,Z}``: the
        coefficient of ``(T - 35)**k`` in rad/s per degC**k times 1e6, k = 1..3.
    """
    instance = cal.instance if instance is None else instance
    if isinstance(instance, bool) or not isinstance(instance, int) or not 0 <= instance <= 2:
        raise ConfigError(f"ArduPilot IMU index must be 0 to 2 (INS_TCAL1..3), got {instance!r}")
    board = _shift(_board_coeffs(cal, _rotation(body_to_board, cal)), ARDUPILOT_TREF_C - cal.temp_ref_c)
    stored = board * _RAD_PER_DEG * ARDUPILOT_SCALE
    p = f"INS_TCAL{instance + 1}_"
    params = [(p + "ENABLE", 1), (p + "TMIN", cal.temp_min_c), (p + "TMAX", cal.temp_max_c)]
    params += [(f"{p}GYR{k}_{'XYZ'[a]}", float(stored[k, a])) for k in range(1, _ORDER + 1) for a in range(3)]
    return params


def calibration_json(cal: Calibration) -> dict:
    """gyrodrift's own calibration document (the fields :func:`read_calibration_json` reads)."""
    def num(v):
        return float(v) if math.isfinite(v) else None

    return {
        "format": _JSON_FORMAT, "version": _JSON_VERSION, "software": f"gyrodrift {__version__}",
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"), "source": cal.source,
        "model": "drift(T) = sum_k coeffs[k] * (clip(T, temp_min_c, temp_max_c) - temp_ref_c)**k, k = 0..3; "
                 "gyro_corrected = gyro - drift",
        "units": {"coeffs": "deg/s per degC**k", "temperatures": "degC", "residual_rms_dps": "deg/s"},
        "frame": "body FRD: gyrodrift's gyro_x, gyro_y, gyro_z",
        "temp_ref_c": cal.temp_ref_c, "temp_min_c": cal.temp_min_c, "temp_max_c": cal.temp_max_c,
        "span_c": cal.span_c, "samples": cal.samples, "offset_known": cal.offset_known,
        "instance": cal.instance, "device_id": cal.device_id, "sensor_to_body": cal.matrix.tolist(),
        "sensor_frame": cal.rotation_text,
        "residual_rms_dps": num(cal.residual_rms_dps),
        "axes": {a: {"coeffs": list(f.coeffs), "residual_rms_dps": num(f.residual_rms_dps)} for a, f in cal.axes.items()},
    }


def output_format(path, fmt: str | None = None) -> str:
    """``fmt`` checked, or the format named by the ending of ``path`` (:data:`FORMATS`)."""
    if fmt is not None:
        if fmt not in FORMATS:
            raise ConfigError(f"unknown calibration format {fmt!r}; choose one of: {', '.join(FORMATS)}")
        return fmt
    name = Path(path).name.lower()
    for key, endings in FORMATS.items():
        if name.endswith(endings):
            return key
    raise ConfigError(f"{path}: cannot tell the calibration format from the file name; give --output-format "
                      f"({', '.join(FORMATS)}) or end it in .params (px4), .param (ardupilot) or .json")


#: Lines at the head of an ArduPilot file: how to load it, and what it does not set.
_ARDUPILOT_LOADING = (
    "load: ArduPilot hides INS_TCALn_* while INS_TCALn_ENABLE is 0, so load this file, refresh the parameters, "
    "load it again, then reboot",
    "INS_TCALn_TMIN/TMAX also clip the accelerometer coefficients INS_TCALn_ACC* on the vehicle (not written here)",
)


def _check_slots(cals, fmt: str) -> None:
    slots = [c.instance for c in cals]
    twice = sorted({s for s in slots if slots.count(s) > 1})
    if twice:
        name = "TC_G{}" if fmt == "px4" else "INS_TCAL{}"
        raise ConfigError(f"two calibrations for {name.format(twice[0] + (fmt != 'px4'))}; "
                          "give one calibration per gyro")


def write_calibration(cal, path, fmt: str | None = None, *, instance: int | None = None,
                      device_id: int | None = None, body_to_board=None, sysid: int = 1) -> list[str]:
    """Write one calibration, or one per gyro, to ``path`` atomically (docs/autopilot-files.md,
    section "Files").

    Parameters
    ----------
    cal : Calibration or sequence of Calibration
        One per gyro, each to its own slot (``cal.instance``); JSON takes one.
    path : str or os.PathLike
    fmt : {"px4", "ardupilot", "ardupilot-qgc", "json"}, optional
        Default by the file name (:func:`output_format`).
    instance, device_id, body_to_board : optional
        One calibration only: the slot (PX4 ``TC_G{instance}``, ArduPilot
        ``INS_TCAL{instance+1}``), PX4's ``TC_G{i}_ID`` and the body-to-sensor rotation, in
        place of the calibration's own.
    sysid : int
        ``px4`` and ``ardupilot-qgc``: the vehicle's system id, the first column of every line.

    Returns
    -------
    list of str
        Notes for the user, e.g. axes written as 0 or an unknown PX4 device id.
    """
    cals = [cal] if isinstance(cal, Calibration) else list(cal)
    if not cals:
        raise ConfigError("no calibration to write")
    overrides = {k: v for k, v in (("instance", instance), ("device_id", device_id), ("body_to_board", body_to_board))
                 if v is not None}
    if overrides and len(cals) > 1:
        raise ConfigError(f"{', '.join(overrides)} apply to one calibration, not {len(cals)}")
    fmt = output_format(path, fmt)
    if fmt == "json" and len(cals) > 1:
        raise ConfigError(f"{path}: a JSON file holds one calibration, not {len(cals)}; choose a gyro with "
                          "--instance or write a .params or .param file")
    if isinstance(sysid, bool) or not isinstance(sysid, int) or not 1 <= sysid <= 255:
        raise ConfigError(f"the system id (--sysid) must be 1 to 255, got {sysid!r}")
    _check_slots(cals, fmt)
    notes = [] if fmt == "json" else [n for c in cals for n in _missing_note(c)]
    header = [f"gyro thermal calibration by gyrodrift {__version__}"]
    for c in cals:
        header.append(f"gyro {c.instance}{f' (device id {c.device_id})' if c.device_id else ''} from {printable(c.source)}, "
                      f"sensor frame {c.rotation_text or 'the body frame (no board rotation)'}: residual RMS "
                      f"{c.residual_rms_dps:.4g} deg/s over {c.temp_min_c:.2f} to {c.temp_max_c:.2f} degC")
    if fmt == "px4":
        rows = [r for c in cals for r in px4_parameters(c, **overrides)]
        rows = [r for i, r in enumerate(rows) if r[0] != "TC_G_ENABLE" or i == 0]  # one TC_G_ENABLE
        lines = [*(f"# {h}" for h in header),
                 f"# for the vehicle with system id (MAV_SYS_ID) {sysid}: QGroundControl refuses the file for another "
                 "(gyrodrift calibrate --sysid)", *(f"# {n}" for n in notes), "#",
                 "# Vehicle-Id Component-Id Name Value Type"]
        lines += [f"{sysid}\t1\t{name}\t{value if kind == _PX4_INT32 else _number(value)}\t{kind}"
                  for name, value, kind in rows]
        for name, value, _ in rows:
            if name.endswith("_ID") and value == 0:
                notes.append(f"{name} is 0: PX4 applies a slot only to the gyro whose device id it holds; "
                             "pass --device-id (the gyro's CAL_GYRO*_ID) or set it before loading the file")
    elif fmt in ("ardupilot", "ardupilot-qgc"):
        rows = [r for c in cals for r in ardupilot_parameters(c, **{k: v for k, v in overrides.items()
                                                                    if k != "device_id"})]
        if any(c.temp_min_c < -70.0 or c.temp_max_c > 80.0 for c in cals):
            notes.append("ArduPilot documents INS_TCAL*_TMIN/TMAX for -70 to 80 degC only; a parameter editor "
                         "may refuse the range written")
        lines = [*(f"# {h}" for h in header), *(f"# {n}" for n in (*_ARDUPILOT_LOADING, *notes))]
        if fmt == "ardupilot":
            lines += [f"{name},{_number(value)}" for name, value in rows]
        else:
            lines += [f"# for the vehicle with system id (SYSID_THISMAV) {sysid} (gyrodrift calibrate --sysid)",
                      "# Vehicle-Id Component-Id Name Value Type"]
            lines += [f"{sysid}\t1\t{name}\t{_number(value)}\t{_MAV_INT8 if name.endswith('_ENABLE') else _PX4_REAL32}"
                      for name, value in rows]
    else:
        one = cals[0] if not overrides else _with(cals[0], overrides)
        lines = [json.dumps(calibration_json(one), indent=2, allow_nan=False)]
    write_bytes_atomic(path, ("\n".join(lines) + "\n").encode("utf-8"))
    return notes


def _with(cal: Calibration, overrides: dict) -> Calibration:
    """``cal`` with the keyword overrides of :func:`write_calibration` (JSON)."""
    from dataclasses import replace

    changes = {k: v for k, v in overrides.items() if k in ("instance", "device_id")}
    if "body_to_board" in overrides:
        changes["rotation"] = tuple(map(tuple, _rotation(overrides["body_to_board"]).T.tolist()))
    return replace(cal, **changes)


# ---------------------------------------------------------------------------- readers


def _bad(path, what: str) -> ConfigError:
    return ConfigError(f"{path}: {what}")


def param_values(path, fmt: str) -> dict[str, float]:
    """``{name: value}`` of a parameter file: QGroundControl lines (``px4`` or ``ardupilot``), or
    ``NAME,VALUE`` / ``NAME VALUE`` / ``NAME=VALUE`` lines (``ardupilot``); ``#`` starts a comment."""
    what = {"px4": "PX4 parameter file", "ardupilot": "ArduPilot parameter file"}[fmt]
    text = read_utf8(path, what)
    values: dict[str, float] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        body = line.strip()
        if not body or body.startswith("#"):
            continue
        fields = body.split("\t") if "\t" in body and body.count("\t") == 4 else re.split(r"\s*[,=]\s*|\s+", body)
        if len(fields) == 5:  # QGroundControl's line, for either autopilot
            name, value = fields[2].strip(), fields[3].strip()
        elif fmt == "ardupilot" and len(fields) == 2:
            name, value = fields
        else:
            form = "'vehicle component NAME VALUE type' (tab-separated)" if fmt == "px4" else "'NAME,VALUE'"
            raise _bad(path, f"line {number}: expected {form}, got {body[:60]!r}; is it a {what}?")
        try:
            number_value = float(value)
        except ValueError:
            raise _bad(path, f"line {number}: the value of {name} is not a number ({value[:30]!r}); correct it") from None
        if not math.isfinite(number_value):
            raise _bad(path, f"line {number}: the value of {name} is not finite; correct it")
        values[name] = number_value
    return values


def _need(values: dict, names, path, advice: str) -> list[float]:
    missing = [n for n in names if n not in values]
    if missing:
        raise _bad(path, f"{', '.join(missing[:4])}{' ...' if len(missing) > 4 else ''} missing; {advice}")
    return [values[n] for n in names]


def _range(path, t_min: float, t_max: float, names: str) -> None:
    if not t_min < t_max:
        raise _bad(path, f"{names}: the calibrated range {t_min:g} to {t_max:g} degC is empty; correct it")


def _from_board(path, board: np.ndarray, temp_ref: float, t_min: float, t_max: float, body_to_board,
                offset_known: bool) -> Calibration:
    body = board @ _rotation(body_to_board) / _RAD_PER_DEG  # rows: powers; R orthonormal, so R^-1 = R^T
    axes = {a: AxisFit(tuple(float(c) for c in body[:, i])) for i, a in enumerate(AXES)}
    return Calibration(axes, temp_ref, t_min, t_max, 0, str(path), offset_known)


def _instances(values: dict, pattern: str) -> str:
    found = sorted({m.group(1) for n in values if (m := re.fullmatch(pattern, n))})
    return ", ".join(found) if found else "none"


def read_px4_params(path, *, instance: int = 0, body_to_board=None) -> Calibration:
    """Read PX4's gyro slot ``TC_G{instance}`` from a QGroundControl parameter file into a
    :class:`Calibration` (body FRD, deg/s); a malformed file or missing slot is a :class:`ConfigError`."""
    values = param_values(path, "px4")
    g = f"TC_G{instance}_"
    slots = _instances(values, r"TC_G(\d)_TREF")
    advice = f"the file has gyro slots: {slots}; choose one with --instance"
    t_ref, t_min, t_max = _need(values, [g + "TREF", g + "TMIN", g + "TMAX"], path, advice)
    _range(path, t_min, t_max, f"{g}TMIN/{g}TMAX")
    names = [f"{g}X{k}_{a}" for k in range(_ORDER + 1) for a in range(3)]
    board = np.array(_need(values, names, path, advice)).reshape(_ORDER + 1, 3)
    return _from_board(path, board, t_ref, t_min, t_max, body_to_board, True)


def read_ardupilot_params(path, *, instance: int = 0, body_to_board=None) -> Calibration:
    """Read ArduPilot's ``INS_TCAL{instance+1}`` from a ``.param`` file into a :class:`Calibration`
    (body FRD, deg/s, known up to a constant); errors as :func:`read_px4_params`."""
    values = param_values(path, "ardupilot")
    p = f"INS_TCAL{instance + 1}_"
    imus = _instances(values, r"INS_TCAL(\d)_TMIN")
    advice = f"the file has IMUs: {imus}; choose one with --instance (IMU - 1)"
    t_min, t_max = _need(values, [p + "TMIN", p + "TMAX"], path, advice)
    _range(path, t_min, t_max, f"{p}TMIN/{p}TMAX")
    names = [f"{p}GYR{k}_{'XYZ'[a]}" for k in range(1, _ORDER + 1) for a in range(3)]
    board = np.zeros((_ORDER + 1, 3))
    board[1:] = np.array(_need(values, names, path, advice)).reshape(_ORDER, 3) / ARDUPILOT_SCALE
    return _from_board(path, board, ARDUPILOT_TREF_C, t_min, t_max, body_to_board, False)


def read_calibration_json(path) -> Calibration:
    """Read a calibration written by :func:`write_calibration` as ``json``."""
    try:
        data = json.loads(read_utf8(path, "calibration file"))
    except ValueError as err:
        raise _bad(path, f"cannot read it as JSON ({' '.join(str(err).split())}); write it again") from None
    if not isinstance(data, dict) or data.get("format") != _JSON_FORMAT or data.get("version") != _JSON_VERSION:
        raise _bad(path, f"not a {_JSON_FORMAT} version {_JSON_VERSION} file; write it with gyrodrift calibrate")
    try:
        axes = {}
        for a, f in data["axes"].items():
            coeffs = tuple(float(c) for c in f["coeffs"])
            if a not in AXES or len(coeffs) != _ORDER + 1 or not all(map(math.isfinite, coeffs)):
                raise ValueError(f"axis {a!r}")
            res = f.get("residual_rms_dps")
            axes[a] = AxisFit(coeffs, math.nan if res is None else float(res))
        temps = [float(data[k]) for k in ("temp_ref_c", "temp_min_c", "temp_max_c")]
        device = data.get("device_id")
        cal = Calibration(axes, *temps, int(data.get("samples", 0)), str(path), bool(data.get("offset_known", True)),
                          int(data.get("instance", 0)), None if device is None else int(device))
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        raise _bad(path, f"a field is missing or malformed ({err}); write it again with gyrodrift calibrate") from None
    if "z" not in axes or not all(map(math.isfinite, temps)):
        raise _bad(path, "no z axis or a non-finite temperature; write it again with gyrodrift calibrate")
    _range(path, cal.temp_min_c, cal.temp_max_c, "temp_min_c/temp_max_c")
    return cal


def param_file_format(path) -> str:
    """``"json"``, ``"px4"`` or ``"ardupilot"``: a parameter file told apart by its content
    (a JSON object; ``TC_G`` or ``INS_TCAL`` names)."""
    text = read_utf8(path, "parameter file")
    if text.lstrip().startswith("{"):
        return "json"
    if re.search(r"(^|\s)TC_G(\d_|_ENABLE)", text, re.MULTILINE):
        return "px4"
    if re.search(r"(^|\s)INS_TCAL\d_", text, re.MULTILINE):
        return "ardupilot"
    raise _bad(path, "no TC_G* (PX4) or INS_TCAL* (ArduPilot) parameters found; give the file the autopilot's "
                     "thermal calibration was saved in, or one written by gyrodrift calibrate")


def read_prior(path, *, instance: int = 0) -> Calibration:
    """Read a calibration from a PX4 ``.params``, ArduPilot ``.param`` or gyrodrift JSON
    file (:func:`param_file_format`)."""
    reader = {"json": lambda p: read_calibration_json(p), "px4": lambda p: read_px4_params(p, instance=instance),
              "ardupilot": lambda p: read_ardupilot_params(p, instance=instance)}
    return reader[param_file_format(path)](path)
