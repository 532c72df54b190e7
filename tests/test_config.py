import pytest

from gyrodrift.cli import main
from gyrodrift.config import config_from_dict, load_config
from gyrodrift.errors import ConfigError


def test_toml_settings_reach_every_level(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(
        'init_s = 20.0\nestimator = "kf"\n[kalman]\nfading = 1.05\np0_sd = [0.1, 2.0, 3.0]\n'
        "[gate]\nturn_rate_dps = 4.5\n[temp_rate]\nwindow_s = 120.0\n"
    )
    cfg = load_config(path)
    assert cfg.init_s == 20.0 and cfg.estimator == "kf"
    assert cfg.kalman.fading == 1.05 and cfg.kalman.p0_sd == (0.1, 2.0, 3.0)
    assert cfg.gate.turn_rate_dps == 4.5 and cfg.temp_rate.window_s == 120.0
    assert cfg.update_interval_s == 10.0  # untouched default


def test_toml_fusion_and_adaptive_tables(tmp_path):
    """The fused-heading settings (B) of docs/results.md and the adaptive switches from TOML."""
    path = tmp_path / "b.toml"
    path.write_text(
        'estimator = "adaptive"\n[fusion]\nmagnetic_gates = true\nbias_corr_s = 30.0\nrelock_s = inf\n'
        "[adaptive]\nzaru = false\n"
    )
    cfg = load_config(path)
    assert cfg.fusion.magnetic_gates and cfg.fusion.bias_corr_s == 30.0 and cfg.fusion.relock_s == float("inf")
    assert cfg.estimator == "adaptive" and cfg.adaptive.zaru is False


@pytest.mark.parametrize(
    "values, match",
    [
        ({"fusion": {"nis_gate": 0}}, r"\[fusion\].*nis_gate"),
        ({"fadding": 1.1}, "unknown setting"),
        ({"kalman": {"fading": 0.5}}, r"\[kalman\].*fading"),
        ({"gate": {"turn_rate_dps": -1}}, r"\[gate\].*turn_rate_dps"),
        ({"temp_rate": {"bin_s": 0}}, r"\[temp_rate\].*bin_s"),
        ({"kalman": 3}, "must be a table"),
    ],
)
def test_bad_settings_name_the_setting(values, match):
    with pytest.raises(ConfigError, match=match):
        config_from_dict(values)


def test_bad_toml_file_names_the_file(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text("fading = = 2\n")
    with pytest.raises(ConfigError, match="bad.toml: not valid TOML"):
        load_config(path)
    assert main(["demo", "--config", str(path), "-o", str(tmp_path / "o.csv")]) == 2
    assert "bad.toml" in capsys.readouterr().err


def test_fused_heading_settings_suit_the_estimator():
    from dataclasses import replace

    from gyrodrift.compensator import CompensatorConfig
    from gyrodrift.fusion import FusionConfig

    assert CompensatorConfig().fusion is None
    assert CompensatorConfig().fusion_settings == FusionConfig()  # (B) for adaptive
    for name in ("stkf", "kf", "lsm"):
        assert CompensatorConfig(estimator=name).fusion_settings == FusionConfig.tolerant()  # (A)
        assert replace(CompensatorConfig(), estimator=name).fusion_settings == FusionConfig.tolerant()
    explicit = FusionConfig(nis_gate=4.0)
    assert CompensatorConfig(estimator="stkf", fusion=explicit).fusion_settings is explicit
    with pytest.raises(ConfigError, match="fusion must be a FusionConfig"):
        CompensatorConfig(fusion={"nis_gate": 4.0})


def test_toml_fusion_table_changes_the_settings_that_suit_the_estimator(tmp_path):
    from gyrodrift.fusion import FusionConfig

    path = tmp_path / "a.toml"
    path.write_text('estimator = "stkf"\n[fusion]\nnis_gate = 4.0\n')
    assert load_config(path).fusion_settings == FusionConfig.tolerant(nis_gate=4.0)
    path.write_text("[fusion]\nnis_gate = 4.0\n")
    assert load_config(path).fusion_settings == FusionConfig(nis_gate=4.0)
    path.write_text('estimator = "nope"\n[fusion]\nnis_gate = 4.0\n')
    with pytest.raises(ConfigError, match="nope"):
        load_config(path)


def test_cli_estimator_chooses_the_fused_settings_a_fusion_table_adjusts(tmp_path):
    from gyrodrift.cli import _config, build_parser
    from gyrodrift.fusion import FusionConfig

    path = tmp_path / "f.toml"
    path.write_text("[fusion]\nnis_gate = 4.0\n")
    args = build_parser().parse_args(["compensate", "in.csv", "-o", "out.csv", "--config", str(path), "--estimator", "stkf"])
    cfg = _config(args)
    assert cfg.estimator == "stkf" and cfg.fusion_settings == FusionConfig.tolerant(nis_gate=4.0)
    args = build_parser().parse_args(["compensate", "in.csv", "-o", "out.csv", "--config", str(path)])
    assert _config(args).fusion_settings == FusionConfig(nis_gate=4.0)
