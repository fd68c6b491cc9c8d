"""The report folders of ``analyze`` (``--out REPORT_DIR``): what the analyses computed, as files.

- :mod:`analysis.report.report` — the report of ratings or of every pair (``report.html``,
  ``report.md`` from ``templates/``, the CSVs and figures) and the folder rules every report
  shares;
- :mod:`analysis.report.pairwise_report` — the report of a pairwise study;
- :mod:`analysis.report.methods_report` — the leaderboard section;
- :mod:`analysis.report.horizon_report` — the trust horizon's files and section;
- :mod:`analysis.report.off_path` — the "Off-path metrics" section.
"""
