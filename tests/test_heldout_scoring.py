"""How ``gyrodrift.evaluate.heldout`` scores one compensated generator log (issue 21's tables)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from gyrodrift.evaluate.heldout import _score, tuning_score
from gyrodrift.simulate.generator import DISTURBED_DEG, TRUE_COMPASS_OFFSET, TRUE_RATE_Z


def _case(reasons, offsets, rates):
    n = len(reasons)
    ref = np.linspace(10.0, 20.0, n)
    log = pd.DataFrame({"t": np.arange(n, dtype=float), "heading": ref + np.asarray(offsets), "ref_heading": ref,
                        "true_bias_z": np.full(n, 0.1), TRUE_COMPASS_OFFSET: np.asarray(offsets, dtype=float),
                        TRUE_RATE_Z: np.asarray(rates, dtype=float)})
    out = pd.DataFrame({"heading": ref + 1.0, "bias_z": np.full(n, 0.2), "heading_fused": ref - 2.0,
                        "bias_sd": np.full(n, 0.04), "heading_fused_sd": np.full(n, 3.0),
                        "gate_reason": reasons, "compass_heading": log["heading"]})
    return log, out


def test_errors_coverage_and_labels_are_scored_against_the_truth():
    big = DISTURBED_DEG + 5.0
    # rows: 0 clean and unlabelled; 1 disturbed, labelled by the hypotheses; 2 disturbed, labelled
    # by the field; 3 disturbed, missed; 4 clean, labelled (a false alarm); 5 turning, labelled
    reasons = ["", "interference", "field", "", "interference", "turning"]
    offsets = [0.0, big, big, big, 0.0, 0.0]
    rates = [0.0, 0.0, 0.0, 0.0, 0.0, 10.0]
    row = _score(*_case(reasons, offsets, rates), own=True)
    assert row["heading_rms_deg"] == pytest.approx(1.0)
    assert row["bias_rms_dps"] == pytest.approx(0.1)
    assert row["fused_rms_deg"] == pytest.approx(2.0)
    assert row["bias_in_1sd"] == 0.0 and row["bias_in_2sd"] == 0.0  # 0.1 off, 2.5 sd
    assert row["fused_in_1sd"] == 1.0
    # `field` is the same verdict as `interference`: 2 of the 3 labelled are disturbed, 2 of 3 disturbed labelled
    assert row["interference_precision"] == pytest.approx(2.0 / 3.0)
    assert row["interference_recall"] == pytest.approx(2.0 / 3.0)
    assert row["turning_precision"] == 1.0 and row["turning_recall"] == 1.0


def test_labels_without_any_truth_or_verdict_are_undefined():
    row = _score(*_case(["", ""], [0.0, 0.0], [0.0, 0.0]), own=True)
    assert np.isnan(row["interference_precision"]) and np.isnan(row["interference_recall"])
    assert np.isnan(row["turning_precision"]) and np.isnan(row["turning_recall"])


def test_labels_are_pooled_over_a_class_s_cases():
    """Two cases: one with 3 rows labelled, 2 of 4 true rows hit; one with 1 false label and no
    truth (precision 0 alone, undefined recall). Pooled: 2 of 4 labelled, 2 of 4 true."""
    from gyrodrift.evaluate.heldout import COLUMNS, pooled_labels

    base = dict.fromkeys(COLUMNS, np.nan)
    rows = [{**base, "split": "held-out", "class": "vessel", "seed": 1, "method": "default", "status": "ok",
             "turning_said": 3, "turning_true": 4, "turning_hits": 2, "interference_said": 0,
             "interference_true": 0, "interference_hits": 0},
            {**base, "split": "held-out", "class": "vessel", "seed": 2, "method": "default", "status": "ok",
             "turning_said": 1, "turning_true": 0, "turning_hits": 0, "interference_said": 0,
             "interference_true": 0, "interference_hits": 0},
            {**base, "split": "held-out", "class": "vessel", "seed": 2, "method": "stkf", "status": "ok"}]
    out = pooled_labels(pd.DataFrame(rows, columns=list(COLUMNS))).iloc[0]
    assert out["turning_precision"] == pytest.approx(0.5) and out["turning_recall"] == pytest.approx(0.5)
    assert np.isnan(out["interference_precision"]) and np.isnan(out["interference_recall"])


def test_a_case_s_label_counts_are_its_rows():
    reasons = ["", "interference", "field", "", "interference", "turning"]
    big = DISTURBED_DEG + 5.0
    row = _score(*_case(reasons, [0.0, big, big, big, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 10.0]), own=True)
    assert (row["interference_said"], row["interference_true"], row["interference_hits"]) == (3, 3, 2)
    assert (row["turning_said"], row["turning_true"], row["turning_hits"]) == (1, 1, 1)


def test_the_tuning_score_sums_the_log_ratios_and_skips_a_class_without_a_baseline():
    acc = pd.DataFrame({"heading": [2.0, 1.0], "best_heading": [1.0, 1.0], "bias": [0.01, 0.02],
                        "best_bias": [0.02, np.nan], "fused": [1.0, 3.0], "ahrs": [1.0, 1.0]})
    assert tuning_score(acc) == pytest.approx(np.log(2.0) + np.log(0.5) + np.log(3.0))
