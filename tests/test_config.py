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
    """The fused-heading settings (B) of docs/results.md and the default model's settings from TOML."""
    from gyrodrift.estimators import AdaptiveConfig

    path = tmp_path / "b.toml"
    path.write_text(
        'estimator = "adaptive"\n[fusion]\nmagnetic_gates = true\nbias_corr_s = 30.0\nrelock_s = inf\n'
        "[adaptive]\ndisturbed_s = 600\ndrift_jump_dps = 0.0\nturn_walks = [0.01, 0.1, 1, 10.0]\n"
    )
    cfg = load_config(path)
    assert cfg.fusion.magnetic_gates and cfg.fusion.bias_corr_s == 30.0 and cfg.fusion.relock_s == float("inf")
    assert cfg.estimator == "adaptive"
    assert cfg.adaptive.disturbed_s == 600.0 and isinstance(cfg.adaptive.disturbed_s, float)
    assert cfg.adaptive.drift_jump_dps == 0.0  # 0: the drift never jumps
    assert cfg.adaptive.turn_walks == (0.01, 0.1, 1.0, 10.0) and isinstance(cfg.adaptive.turn_walks, tuple)
    assert cfg.adaptive.clean_s == AdaptiveConfig().clean_s  # untouched default


@pytest.mark.parametrize(
    "text, match",
    [
        ("zaru = false\n", r"\[adaptive\]: unknown setting\(s\) zaru; known: .*turn_walks"),
        ("q_sd = [1e-4, 0.05, 60.0]\n", r"\[adaptive\]: unknown setting\(s\) q_sd"),
        ('clean_s = "long"\n', r"\[adaptive\]: clean_s = \"long\" is refused: give a number, e.g. clean_s = 3600.0"),
        ("turn_walks = [0.01, 0.1]\n", r"\[adaptive\]: .*turn_walks = .* must be a list of 4 numbers"),
        ('turn_shares = [0.3, "x", 0.2, 0.1]\n', r"\[adaptive\]: turn_shares = .* is refused: give a list of numbers"),
        ("p_still0 = 1.5\n", r"\[adaptive\]: .*p_still0 = 1.5 must be between 0 and 1"),
        ("drift_walk = 1e300\n", r"\[adaptive\]: drift_walk = 1e\+300 is outside the plausible range"),
        ("heading_sd0 = 1e300\n", r"\[adaptive\]: heading_sd0 = 1e\+300 is outside the plausible range"),
    ],
)
def test_toml_adaptive_table_is_checked_against_the_model_settings(tmp_path, text, match):
    path = tmp_path / "m.toml"
    path.write_text("[adaptive]\n" + text, encoding="utf-8")
    with pytest.raises(ConfigError, match=match) as info:
        load_config(path)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


@pytest.mark.parametrize(
    "values, match",
    [
        ({"fusion": {"nis_gate": 0}}, r"\[fusion\].*nis_gate"),
        ({"fadding": 1.1}, "unknown setting"),
        ({"kalman": {"fading": 0.5}}, r"\[kalman\].*fading"),
        ({"gate": {"turn_rate_dps": -1}}, r"\[gate\].*turn_rate_dps"),
        ({"temp_rate": {"bin_s": 0}}, r"\[temp_rate\].*bin_s"),
        ({"kalman": 3}, "must be a table"),
        ({"mag_calibration": "yes"}, r'mag_calibration = "yes" must be one of true, false, "auto"'),
    ],
)
def test_bad_settings_name_the_setting(values, match):
    with pytest.raises(ConfigError, match=match):
        config_from_dict(values)


@pytest.mark.parametrize("value", [True, False, "auto"])
def test_mag_calibration_takes_true_false_or_auto(value):
    assert config_from_dict({"mag_calibration": value}).mag_calibration == value


def test_bad_toml_file_names_the_file(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text("fading = = 2\n")
    with pytest.raises(ConfigError, match="bad.toml: not valid TOML"):
        load_config(path)
    assert main(["demo", "--config", str(path), "-o", str(tmp_path / "o.csv")]) == 2
    assert "bad.toml" in capsys.readouterr().err


def test_fused_heading_settings_are_the_tolerant_ones_unless_given():
    from dataclasses import replace

    from gyrodrift.compensator import CompensatorConfig
    from gyrodrift.fusion import FusionConfig

    assert CompensatorConfig().fusion is None
    assert FusionConfig.tolerant() != FusionConfig()  # (A) is not (B): the check below can fail
    assert CompensatorConfig().fusion_settings == FusionConfig.tolerant()  # (A), the default estimator too
    for name in ("adaptive", "stkf", "kf", "stkf-s1", "lsm", "mlr-causal"):  # whatever the estimator
        assert CompensatorConfig(estimator=name).fusion_settings == FusionConfig.tolerant(), name
        assert replace(CompensatorConfig(), estimator=name).fusion_settings == FusionConfig.tolerant(), name
    explicit = FusionConfig(nis_gate=4.0)
    assert CompensatorConfig(estimator="stkf", fusion=explicit).fusion_settings is explicit
    with pytest.raises(ConfigError, match="fusion = a table is refused: give a FusionConfig"):
        CompensatorConfig(fusion={"nis_gate": 4.0})


def test_toml_fusion_table_changes_the_tolerant_settings(tmp_path):
    from gyrodrift.compensator import CompensatorConfig
    from gyrodrift.fusion import FusionConfig

    path = tmp_path / "a.toml"
    path.write_text('estimator = "stkf"\n[fusion]\nnis_gate = 4.0\n')
    assert load_config(path).fusion_settings == FusionConfig.tolerant(nis_gate=4.0)
    path.write_text("[fusion]\nnis_gate = 4.0\n")
    assert load_config(path).fusion_settings == FusionConfig.tolerant(nis_gate=4.0)
    # a [fusion] table changes the settings in force: given ones are kept where it is silent
    base = CompensatorConfig(fusion=FusionConfig(bias_corr_s=30.0))
    assert config_from_dict({"fusion": {"nis_gate": 4.0}}, base=base).fusion == FusionConfig(bias_corr_s=30.0, nis_gate=4.0)
    path.write_text('estimator = "nope"\n[fusion]\nnis_gate = 4.0\n')
    with pytest.raises(ConfigError, match="nope"):
        load_config(path)


def test_cli_fusion_table_adjusts_the_fused_settings_whatever_the_estimator(tmp_path):
    from gyrodrift.cli.options import method_config as _config
    from gyrodrift.cli.commands import build_parser
    from gyrodrift.fusion import FusionConfig

    path = tmp_path / "f.toml"
    path.write_text("[fusion]\nnis_gate = 4.0\n")
    args = build_parser().parse_args(["compensate", "in.csv", "-o", "out.csv", "--config", str(path), "--estimator", "stkf"])
    cfg = _config(args)
    assert cfg.estimator == "stkf" and cfg.fusion_settings == FusionConfig.tolerant(nis_gate=4.0)
    args = build_parser().parse_args(["compensate", "in.csv", "-o", "out.csv", "--config", str(path)])
    cfg = _config(args)
    assert cfg.estimator == "adaptive" and cfg.fusion_settings == FusionConfig.tolerant(nis_gate=4.0)
