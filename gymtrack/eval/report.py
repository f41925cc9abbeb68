"""Tables, claims and the written report of a benchmark run (paper Tables 3, 5, 6 and Fig. 6).

Kept for compatibility: the aggregation (pooling rows into Tables 3, 5, 6, ratios and claims)
is :mod:`gymtrack.eval.aggregate`, the rendering (report.md, CSV, JSON, plots) is
:mod:`gymtrack.eval.render`, the thresholds are :mod:`gymtrack.eval.config`.
"""

from .aggregate import (ABLATION, METHODS, N_CAMS, ROW_FIELDS, Claim, averaged, claims, ok_rows, pooled, present, ratios,
                        speed, summed, table3, table5, table6)
from .config import DEFAULT_CONFIG, BenchmarkConfig
from .render import fmt, markdown_table, plot_target_trajectories, report_markdown, table3_markdown, write_csv, write_report

__all__ = [
    "ABLATION", "METHODS", "N_CAMS", "ROW_FIELDS", "Claim", "averaged", "claims", "ok_rows", "pooled", "present", "ratios",
    "speed", "summed", "table3", "table5", "table6", "DEFAULT_CONFIG", "BenchmarkConfig", "fmt", "markdown_table",
    "plot_target_trajectories", "report_markdown", "table3_markdown", "write_csv", "write_report",
]
