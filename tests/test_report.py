"""The HTML report: self-contained page, summary table, figures, notes, CLI and a real browser."""

from __future__ import annotations

import argparse
import io
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")
pytest.importorskip("allantools")

from gyrodrift import __version__  # noqa: E402
from gyrodrift.cli.report import add_report_parser, report_command  # noqa: E402
from gyrodrift.evaluate import report  # noqa: E402
from gyrodrift.evaluate.compare import run_methods  # noqa: E402
from gyrodrift.errors import ConfigError  # noqa: E402
from gyrodrift.simulate import simulate  # noqa: E402

METHODS = ("stkf", "kf", "mlr", "oracle")
ALL_FIGURES = ("temperature", "rates", "bias", "params", "heading", "heading_error", "allan")  # and "calibration"


@pytest.fixture(scope="module")
def static_page():
    """A motionless log with both truth columns, all figures expected."""
    log = simulate("static-outages", duration_s=900, fs_hz=10, seed=1)
    outputs, skipped = run_methods(log, methods=METHODS + ("poly3",))
    page = report.build_report(log, outputs, skipped, title="static <test>", source="static-outages.csv")
    return page, outputs


@pytest.fixture(scope="module")
def vehicle_page_without_ref():
    """A moving log without ref_heading: no heading error and no Allan figure."""
    log = simulate("vehicle", duration_s=900, fs_hz=10, seed=1).drop(columns="ref_heading")
    outputs, skipped = run_methods(log, methods=METHODS)
    return report.build_report(log, outputs, skipped, title="vehicle", source="vehicle.csv")


def figure_sections(page: str) -> dict[str, str]:
    parts = re.findall(r'<section class="figure" id="fig-([a-z_]+)">(.*?)</section>', page, flags=re.S)
    return dict(parts)


def assert_self_contained(page: str) -> None:
    assert page.startswith("<!DOCTYPE html>")
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", page, flags=re.I)
    assert not re.search(r"<script", page, flags=re.I)
    assert not re.search(r"url\(\s*['\"]?(https?:)?//", page, flags=re.I)
    assert not re.search(r"@import", page, flags=re.I)
    for src in re.findall(r"""<img[^>]*\ssrc="([^"]*)\"""", page):
        assert src.startswith("data:image/png;base64,")


def test_page_is_self_contained(static_page, vehicle_page_without_ref):
    assert_self_contained(static_page[0])
    assert_self_contained(vehicle_page_without_ref)
    assert "Content-Security-Policy" in static_page[0]


def test_header_says_what_was_read(static_page):
    page = static_page[0]
    read = re.search(r'<section id="read">(.*?)</section>', page, flags=re.S).group(1)
    for text in ("static-outages.csv", "9001", "15 min 00 s", "10 Hz", "22.9", "58.0", "heading column",
                 "ref_heading, true_bias_z", "stkf", "mlr <span class=nc>(non-causal)</span>"):
        assert text in read
    assert "<b>poly3</b>: no calibration run (--calibration)" in read
    assert "static &lt;test&gt;" in page  # the title is escaped


def test_summary_table_has_a_row_per_method(static_page):
    page, outputs = static_page
    table = re.search(r'<table class="summary">(.*?)</table>', page, flags=re.S).group(1)
    header = re.findall(r"<th>(.*?)</th>", table)
    for col in ("bias error mean (deg/s)", "bias error RMS (deg/s)", "heading error max |·| (deg)",
                "filter updates", "gated: init", "gated: interference"):
        assert col in header
    rows = re.findall(r"<tr><td>(.*?)</td>", table)
    assert rows == ["raw gyro (no compensation)", "stkf", "kf", "mlr †", "oracle †"]
    stkf = re.search(r"<tr><td>stkf</td>(.*?)</tr>", table).group(1)
    cells = re.findall(r"<td>(.*?)</td>", stkf)
    updates = cells[header.index("filter updates") - 1]
    assert updates == str(int(outputs["stkf"]["updated"].sum()))
    oracle = re.findall(r"<td>(.*?)</td>", re.search(r"<tr><td>oracle †</td>(.*?)</tr>", table).group(1))
    assert float(oracle[header.index("bias error RMS (deg/s)") - 1]) == 0.0


def test_one_image_per_figure_with_a_reading_note(static_page):
    page = static_page[0]
    sections = figure_sections(page)
    assert tuple(sections) == ("temperature", "calibration", *ALL_FIGURES[1:])
    assert "no thermal calibration fit: this log:" in sections.pop("calibration")  # a note: not a clean heating run
    for key, body in sections.items():
        assert body.count("<img ") == 1, key
        assert "How to read this:" in body
    assert page.count("<img ") == len(ALL_FIGURES)
    allan = sections["allan"]
    assert '<table class="terms">' in allan and "angle random walk N" in allan
    assert "True rate: 0 (motionless" in allan


def test_missing_columns_leave_figures_out_with_a_note(vehicle_page_without_ref):
    page = vehicle_page_without_ref
    sections = figure_sections(page)
    assert "no ref_heading: heading error not shown" in sections["heading_error"]
    assert "<img" not in sections["heading_error"]
    assert "no ref_heading" in sections["allan"] and "<img" not in sections["allan"]
    assert page.count("<img ") == len(ALL_FIGURES) - 2
    assert "heading error mean" not in page  # no heading columns in the summary
    assert "gated: turning" in page


def test_version_and_settings_are_listed(static_page):
    page = static_page[0]
    settings = re.search(r'<section id="settings">(.*?)</section>', page, flags=re.S).group(1)
    assert f"gyrodrift {__version__}" in settings
    for name in ("update_interval_s", "kalman.fading", "gate.turn_rate_dps", "temp_rate.window_s"):
        assert f"<code>{name}</code>" in settings


def test_report_without_any_method():
    log = simulate("static", duration_s=120, fs_hz=10, seed=3)
    page = report.build_report(log, {}, {"oracle": "no true_bias_z column"}, title="t", source="s.csv")
    assert_self_contained(page)
    assert page.count("<img ") == 1  # the temperature only
    assert "No method ran" in page


def test_missing_matplotlib_names_the_extra(monkeypatch, log_csv, tmp_path):
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    log = simulate("static", duration_s=120, fs_hz=10, seed=3)
    with pytest.raises(ConfigError, match=r"gyrodrift\[plot\]"):
        report.build_report(log, {}, title="t", source="s.csv")
    args = parse(["report", str(log_csv), "-o", str(tmp_path / "r.html")])
    with pytest.raises(ConfigError, match=r"gyrodrift\[plot\]"):
        args.func(args)


def test_missing_allantools_leaves_only_the_allan_figure_out(monkeypatch):
    monkeypatch.setitem(sys.modules, "allantools", None)
    log = simulate("static", duration_s=120, fs_hz=10, seed=3)
    outputs, skipped = run_methods(log, methods=("stkf",))
    page = report.build_report(log, outputs, skipped, title="t", source="s.csv")
    allan = figure_sections(page)["allan"]
    assert "<img" not in allan and "gyrodrift[allan]" in allan
    assert page.count("<img ") == len(ALL_FIGURES) - 1


# --------------------------------------------------------------------- progress


class FakeTerminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_is_silent_off_a_terminal():
    stream = io.StringIO()
    assert list(report._progress(range(5), 5, "work", stream=stream)) == [0, 1, 2, 3, 4]
    assert stream.getvalue() == ""


def test_progress_bar_on_a_terminal(monkeypatch):
    monkeypatch.setitem(sys.modules, "tqdm", None)  # the built-in bar
    stream = FakeTerminal()
    assert list(report._progress(iter("abc"), 3, "work", stream=stream)) == ["a", "b", "c"]
    text = stream.getvalue()
    assert "\rwork [" in text and "3/3" in text and "\n" not in text
    assert text.endswith("\r")  # the line is erased at the end


# -------------------------------------------------------------------------- CLI


def parse(argv):
    parser = argparse.ArgumentParser(prog="gyrodrift")
    sub = parser.add_subparsers(dest="command")
    add_report_parser(sub)
    return parser.parse_args(argv)


@pytest.fixture(scope="module")
def log_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("in") / "log.csv"
    simulate("static-outages", duration_s=600, fs_hz=10, seed=4).to_csv(path, index=False)
    return path


def test_report_command_writes_atomically(log_csv, tmp_path, monkeypatch, capsys):
    out = tmp_path / "report.html"
    out.write_text("old")
    replaced = []
    real_replace = os.replace

    def spy(src, dst):
        replaced.append((Path(src), Path(dst)))
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", spy)
    args = parse(["report", str(log_csv), "-o", str(out), "--methods", "stkf,kf,poly3"])
    assert args.func is report_command
    assert args.func(args) == 0
    (src, dst), = replaced
    assert dst == out and src.parent == out.parent and src.name.startswith(".report.html.")
    assert os.listdir(tmp_path) == ["report.html"]
    page = out.read_text(encoding="utf-8")
    assert_self_contained(page)
    assert "gyrodrift report: log.csv" in page and "<b>poly3</b>" in page
    assert "wrote" in capsys.readouterr().out


def test_report_command_refuses_its_input_as_output(log_csv):
    before = log_csv.read_bytes()
    args = parse(["report", str(log_csv), "-o", str(log_csv)])
    with pytest.raises(ConfigError, match="input"):
        args.func(args)
    assert log_csv.read_bytes() == before


def test_report_command_errors(log_csv, tmp_path):
    args = parse(["report", str(log_csv), "-o", str(tmp_path / "missing" / "r.html")])
    with pytest.raises(ConfigError, match="missing"):
        args.func(args)
    args = parse(["report", str(log_csv), "-o", str(tmp_path / "r.html"), "--methods", "stkf,nope"])
    with pytest.raises(ConfigError, match="nope"):
        args.func(args)
    args = parse(["report", str(log_csv), "-o", str(tmp_path / "r.html"), "--methods", "oracle", "--map", "x"])
    with pytest.raises(ConfigError, match="--map"):
        args.func(args)
    assert not (tmp_path / "r.html").exists()


def test_write_report_names_a_missing_folder(tmp_path):
    with pytest.raises(ConfigError, match="nowhere"):
        report.write_report(tmp_path / "nowhere" / "r.html", "<html></html>")


# ---------------------------------------------------------------- real browser


def find_chromium() -> str | None:
    if os.access("/usr/bin/chromium", os.X_OK):
        return "/usr/bin/chromium"
    return shutil.which("chromium") or shutil.which("chromium-browser")


def test_report_renders_in_chromium_without_console_errors(static_page, tmp_path):
    chromium = find_chromium()
    if chromium is None:
        pytest.skip("no Chromium: install the Debian package 'chromium' to run the browser test")
    page_path = tmp_path / "report.html"
    report.write_report(page_path, static_page[0])
    shot = tmp_path / "report.png"
    cmd = [
        chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        f"--user-data-dir={tmp_path / 'profile'}", "--enable-logging=stderr", "--v=0",
        f"--screenshot={shot}", "--window-size=1280,4000", page_path.as_uri(),
    ]
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        pytest.fail("Chromium did not finish within 120 s")
    assert res.returncode == 0, res.stderr[-2000:]
    assert shot.is_file() and shot.stat().st_size > 20_000
    import matplotlib.image

    pixels = matplotlib.image.imread(str(shot))[..., :3]
    assert pixels.shape[:2] == (4000, 1280)
    assert pixels.std() > 0.05  # not blank: text, tables and figures drawn
    dark = (pixels.mean(axis=2) < 0.5).mean(axis=1)
    assert (dark > 0).sum() > 1000  # content on many rows, not one line of text
    page_errors = [
        line for line in res.stderr.splitlines()
        if re.search(r"CONSOLE[(:]|Uncaught", line)
    ]
    assert not page_errors, "\n".join(page_errors)


# ------------------------------------------------------------------ the default estimator first


def test_report_runs_the_default_estimator_first_and_names_it(log_csv, tmp_path):
    from gyrodrift.evaluate.compare import DEFAULT_METHODS

    assert parse(["report", str(log_csv), "-o", "r.html"]).methods == ",".join(DEFAULT_METHODS)
    assert DEFAULT_METHODS[0] == "adaptive"
    out = tmp_path / "r.html"
    args = parse(["report", str(log_csv), "-o", str(out), "--methods", "adaptive,stkf", "-q"])
    assert args.func(args) == 0
    page = out.read_text(encoding="utf-8")
    table = re.search(r'<table class="summary">(.*?)</table>', page, flags=re.S).group(1)
    rows = re.findall(r"<tr><td>(.*?)</td>", table)
    assert rows == ["raw gyro (no compensation)", "adaptive (default)", "stkf"]
    figures = figure_sections(page)
    for key in ("rates", "params", "heading"):
        assert "(adaptive (default))</h2>" in figures[key]
    assert "<td>adaptive (default) rate_z</td>" in figures["allan"]  # the noise-term table names the curve


def test_figure_legends_name_the_default_estimator():
    from gyrodrift.evaluate import plots

    log = simulate("vehicle", duration_s=300, fs_hz=10, seed=1)
    outputs, _ = run_methods(log, methods=("adaptive", "mlr"))
    legend = [t.get_text() for t in plots.fig_bias(outputs).axes[0].get_legend().get_texts()]
    assert "adaptive (default) bias_z" in legend and "mlr bias_z" in legend
    legend = [t.get_text() for t in plots.fig_heading_error(outputs).axes[0].get_legend().get_texts()]
    assert legend == ["adaptive (default)", "mlr (non-causal)"]


# ------------------------------------------------------------------ thermal calibration fit


def test_a_heating_run_gets_the_calibration_fit_and_a_flat_log_says_why_not():
    heating = simulate("calibration", duration_s=1200, fs_hz=10, seed=2)
    outputs, skipped = run_methods(heating, methods=("stkf",))
    page = report.build_report(heating, outputs, skipped, title="heat", source="heat.csv")
    section = figure_sections(page)["calibration"]
    assert section.count("<img ") == 1 and "How to read this:" in section
    assert "calibrated gyro z from this log" in section and "span" in section
    flat = heating.assign(temp=25.0)
    outputs, skipped = run_methods(flat, methods=("stkf",))
    section = figure_sections(report.build_report(flat, outputs, skipped, title="flat", source="flat.csv"))["calibration"]
    assert "<img" not in section
    assert "no thermal calibration fit: this log: the temperature spans only 0.00 degC" in section


def test_calibration_figure_draws_data_fit_and_residual_per_axis():
    from gyrodrift.evaluate import plots
    from gyrodrift.calibrate import fit_calibration

    log = simulate("calibration", duration_s=1200, fs_hz=10, seed=2)
    log = log.drop(columns=["gyro_y"], errors="ignore").assign(gyro_x=0.01 * (log["temp"] - 20.0))  # exactly linear
    cal = fit_calibration(log)
    fig = plots.fig_calibration(log, cal)
    top_x, top_z, bottom_x, bottom_z = fig.axes  # rows: fit, residual; columns: the axes of the calibration
    assert list(cal.axes) == ["x", "z"] and top_x.get_title() == "gyro_x"
    assert [t.get_text() for t in top_x.get_legend().get_texts()] == ["samples", "mean per 0.25 degC", "fitted cubic"]
    assert f"span {cal.span_c:.1f} degC" in fig.get_suptitle()
    assert bottom_x.get_title().startswith("residual RMS")
    fit_line = top_x.get_lines()[2]
    assert fit_line.get_xdata()[0] == cal.temp_min_c and fit_line.get_xdata()[-1] == cal.temp_max_c


def test_allan_of_a_jittery_time_base_is_on_an_even_one():
    log = simulate("static", duration_s=300, fs_hz=10, seed=3)
    log["t"] += np.random.default_rng(0).uniform(-0.02, 0.02, len(log))  # ±20 % of the sample interval
    outputs, skipped = run_methods(log, methods=("stkf",))
    allan = figure_sections(report.build_report(log, outputs, skipped, title="t", source="s.csv"))["allan"]
    assert "<img " in allan and "resampled to an even time base (the time stamps jitter)" in allan
