"""The adaptive drift compensator: per sample (:class:`Compensator`) or per log (:func:`compensate`).

Both, and the chunked file path, drive one front end (:class:`~gyrodrift.compensator.intake.Intake`)
and one engine (:class:`ChunkEngine`; :class:`~gyrodrift.compensator.model_engine.ModelEngine`
for the default estimator) on the equations of :mod:`gyrodrift.kernels`, so all three give the
same numbers. The paper's method as the engine runs it (Feng, Li, Zhang 2015, eqs. 2–6), the
modules here and the engines' design: ``docs/engine.md``; the default model: ``docs/model.md``.
"""

from gyrodrift.compensator.batch import compensate, compensate_arrays
from gyrodrift.compensator.config import CompensatorConfig, build_estimator, clock_config, uses_clock
from gyrodrift.compensator.engine import ChunkEngine
from gyrodrift.compensator.memory import OutputBuffers
from gyrodrift.compensator.output import (
    MEASUREMENT_COLUMNS,
    UNOBSERVABLE,
    CompensatedSample,
    append_input_columns,
    check_input_columns,
    output_frame,
)
from gyrodrift.compensator.streaming import Compensator

__all__ = [
    "CompensatorConfig", "build_estimator", "CompensatedSample", "Compensator", "compensate", "compensate_arrays",
    "OutputBuffers", "ChunkEngine", "MEASUREMENT_COLUMNS", "UNOBSERVABLE", "output_frame", "check_input_columns",
    "append_input_columns", "uses_clock", "clock_config",
]
