"""Input and output of tables: read logs in the input contract, write results.

See :mod:`gyrodrift.io.tabular` for the formats, checks and error-message style.
"""

from __future__ import annotations

from gyrodrift.io.tabular import check_output_path, read_log, write_table

__all__ = ["read_log", "write_table", "check_output_path"]
