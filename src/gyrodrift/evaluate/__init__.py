"""Evaluation: how well the compensation does, measured against a reference or the truth.

Nothing here is needed to compensate a log; everything here runs the compensation and
scores it. :mod:`~gyrodrift.evaluate.compare` runs the default estimator and the paper's
baselines on one log, :mod:`~gyrodrift.evaluate.metrics` scores an output table (the
statistics of the paper's Table 2, heading and bias errors) and
:mod:`~gyrodrift.evaluate.allan` gives the Allan deviation and its noise terms;
:mod:`~gyrodrift.evaluate.montecarlo` and :mod:`~gyrodrift.evaluate.heldout` run every
method over simulated families and generated scenarios, :mod:`~gyrodrift.evaluate.paper`
regenerates the paper's experiments, and :mod:`~gyrodrift.evaluate.plots` (on the canvas
of :mod:`~gyrodrift.evaluate.plotbase`), :mod:`~gyrodrift.evaluate.report` and
:mod:`~gyrodrift.evaluate.report_figures` draw the figures and the HTML report. Import
what you use from its module (``from gyrodrift.evaluate.compare import run_methods``).
"""
