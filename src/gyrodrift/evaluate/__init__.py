"""Evaluation: how well the compensation does, measured against a reference or the truth.

Nothing here is needed to compensate a log. The modules: docs/evaluation.md, section "Modules".
Import what you use from its module (``from gyrodrift.evaluate.compare import run_methods``).
"""
