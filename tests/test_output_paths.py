"""No command writes onto what it reads, nor replaces a node that is not a file (issue 24, item 1).

Every output (``-o``, ``--save-profile``) is checked against every input (the log,
``--prior``, ``--profile``, ``--config``, ``--calibration``) by identity, through
symbolic and hard links, and against the other output; every output is checked before
any work, so a bad ``--save-profile`` leaves no ``-o`` behind. A FIFO or a character
device is written through, a symbolic link through to its file; neither is replaced.
"""

from __future__ import annotations

import os
import stat
import threading
from pathlib import Path

import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift._atomic import atomic_output, write_bytes_atomic
from gyrodrift.cli import main
from gyrodrift.errors import ConfigError


@pytest.fixture
def log(tmp_path) -> Path:
    path = tmp_path / "log.csv"
    synthetic_log(duration_s=120.0, fs_hz=10.0).to_csv(path, index=False)
    return path


@pytest.fixture
def profile(tmp_path, log) -> Path:
    path = tmp_path / "dev.json"
    assert main(["compensate", str(log), "-o", str(tmp_path / "first.csv"), "-q", "--save-profile", str(path)]) == 0
    return path


def refused(capsys, argv, *words) -> str:
    """Run ``argv``: exit 2 with one error line holding every word."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("gyrodrift: error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    for word in words:
        assert word in err, (word, err)
    return err


def test_same_file_sees_through_links(tmp_path, log):
    from gyrodrift._paths import same_file

    (tmp_path / "soft.csv").symlink_to(log)
    os.link(log, tmp_path / "hard.csv")
    assert same_file(log, tmp_path / "soft.csv") and same_file(log, tmp_path / "hard.csv")
    assert same_file(log, tmp_path / "." / "log.csv")
    assert not same_file(log, tmp_path / "other.csv")


@pytest.mark.parametrize("target", ["input", "soft", "hard"])
def test_save_profile_onto_the_input_log_is_refused(tmp_path, log, capsys, target):
    before = log.read_bytes()
    if target == "soft":
        (tmp_path / "p.json").symlink_to(log)
    elif target == "hard":
        os.link(log, tmp_path / "p.json")
    path = log if target == "input" else tmp_path / "p.json"
    refused(capsys, ["compensate", str(log), "-o", str(tmp_path / "o.csv"), "--save-profile", str(path)],
            "--save-profile is the input log", "never overwritten")
    assert log.read_bytes() == before and not (tmp_path / "o.csv").exists()


def test_save_profile_onto_the_prior_or_the_profile_is_refused(tmp_path, log, profile, capsys):
    before = profile.read_bytes()
    refused(capsys, ["compensate", str(log), "-o", str(tmp_path / "o.csv"), "--prior", str(profile),
                     "--save-profile", str(profile)], "--save-profile is --prior")
    refused(capsys, ["compensate", str(log), "-o", str(tmp_path / "o.csv"), "--profile", str(profile),
                     "--save-profile", str(profile)], "--save-profile is --profile")
    refused(capsys, ["compensate", str(log), "-o", str(profile), "--profile", str(profile)], "-o is --profile")
    assert profile.read_bytes() == before


def test_output_onto_the_config_is_refused(tmp_path, log, capsys):
    cfg = tmp_path / "s.toml"
    cfg.write_text("init_s = 20.0\n")
    refused(capsys, ["compensate", str(log), "-o", str(cfg), "--config", str(cfg)], "-o is --config")
    assert cfg.read_text() == "init_s = 20.0\n"


def test_profile_equal_to_the_output_is_refused(tmp_path, log, capsys):
    refused(capsys, ["compensate", str(log), "-o", str(tmp_path / "o.csv"), "--save-profile", str(tmp_path / "o.csv")],
            "-o and --save-profile name the same file")


def test_stream_save_profile_onto_its_input_is_refused(tmp_path, log, capsys):
    before = log.read_bytes()
    refused(capsys, ["stream", str(log), "-o", str(tmp_path / "s.csv"), "--save-profile", str(log)],
            "--save-profile is the input log")
    assert log.read_bytes() == before


@pytest.mark.parametrize("bad", ["missing/p.json", "folder"])
def test_a_bad_profile_path_leaves_no_output_behind(tmp_path, log, capsys, bad):
    (tmp_path / "folder").mkdir()
    out = tmp_path / "o.csv"
    refused(capsys, ["compensate", str(log), "-o", str(out), "--save-profile", str(tmp_path / bad)], "--save-profile")
    assert not out.exists()


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_profile_folder_leaves_no_output_behind(tmp_path, log, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    out = tmp_path / "o.csv"
    refused(capsys, ["compensate", str(log), "-o", str(out), "--save-profile", str(ro / "p.json")], "permission")
    assert not out.exists()


def test_output_through_a_symlink_replaces_its_file_not_the_link(tmp_path, log):
    target = tmp_path / "target.csv"
    target.write_text("old\n")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    assert main(["compensate", str(log), "-o", str(link), "-q"]) == 0
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert len(pd.read_csv(target)) == 1200


def test_a_dangling_symlink_gets_its_file(tmp_path):
    link = tmp_path / "link.json"
    link.symlink_to(tmp_path / "made.json")
    write_bytes_atomic(link, b"{}\n")
    assert link.is_symlink() and (tmp_path / "made.json").read_bytes() == b"{}\n"


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
@pytest.mark.parametrize("name", ["out.csv", "out.parquet", "pipe"])
def test_output_onto_a_fifo_writes_through_it(tmp_path, log, name):
    fifo = tmp_path / name
    os.mkfifo(fifo)
    got = bytearray()

    def read() -> None:
        with open(fifo, "rb") as fh:
            got.extend(fh.read())

    reader = threading.Thread(target=read, daemon=True)  # blocked for good if nothing writes into the FIFO
    reader.start()
    assert main(["compensate", str(log), "-o", str(fifo), "-q"]) == 0
    reader.join(timeout=60)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)  # still the FIFO, not a regular file
    assert not reader.is_alive()
    if name.endswith(".parquet"):
        (tmp_path / "copy.parquet").write_bytes(bytes(got))
        assert len(pd.read_parquet(tmp_path / "copy.parquet")) == 1200
    else:
        assert got.count(b"\n") == 1201


@pytest.mark.skipif(not os.path.exists("/dev/null"), reason="no /dev/null")
def test_output_onto_dev_null_leaves_the_device(tmp_path, log, capsys):
    mode = os.stat("/dev/null").st_mode
    assert main(["compensate", str(log), "-o", "/dev/null", "-q"]) == 0
    assert main(["stream", str(log), "-o", "/dev/null", "-q"]) == 0
    with atomic_output("/dev/null") as fh:
        fh.write(b"x")
    assert os.stat("/dev/null").st_mode == mode and stat.S_ISCHR(mode)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no sockets here")
def test_output_onto_a_socket_is_refused(tmp_path, log, capsys):
    import socket

    path = tmp_path / "s.csv"
    with socket.socket(socket.AF_UNIX) as sock:
        sock.bind(str(path))
        refused(capsys, ["compensate", str(log), "-o", str(path)], "a socket, not a file")
        with pytest.raises(ConfigError, match="a socket"):
            write_bytes_atomic(path, b"x")
    assert stat.S_ISSOCK(os.stat(path).st_mode)


def test_a_file_name_too_long_is_one_line(tmp_path, log, capsys):
    from gyrodrift._paths import NAME_MAX

    refused(capsys, ["compensate", str(log), "-o", str(tmp_path / ("x" * 252 + ".csv"))],
            f"longer than the {NAME_MAX}")


def test_a_path_deeper_than_path_max_is_one_line(tmp_path, log, capsys):
    deep = tmp_path.joinpath(*["d" * 200] * 25) / "o.csv"
    refused(capsys, ["compensate", str(log), "-o", str(deep)], "path of")
    refused(capsys, ["compensate", str(log), "-o", str(tmp_path / "o.csv"), "--save-profile", str(deep)],
            "--save-profile")
