"""analysis stage of the NVRQ toolkit: ``analyze RATINGS.csv`` (docs/FORMATS.md §6).

Modules, in data-flow order:

- :mod:`analysis.inputs` — read and check ratings.csv and metric tables; which columns are
  metrics, attributes and proxies (the written rule).
- :mod:`annotate.screening` (one stage down, shared with the live admin page) — per-rater
  numbers and the screening rule (``analyze``'s default).
- :mod:`analysis.labels` — votes to per-item GVF; join of metric tables.
- :mod:`analysis.stats` — columnar (grouped) PLCC/SRCC/KRCC/ROC AUC/logistic PLCC and the
  undefined-statistic rule; :mod:`analysis.bootstrap` — cluster bootstrap over tracks;
  :mod:`analysis.aggregate` — crowd-kit label models; :mod:`analysis.ceiling` — the noise
  ceiling (GVF and Krippendorff's alpha come from :mod:`annotate.results`).
- :mod:`analysis.summary` — the per-metric table; :mod:`analysis.breakdowns` — per
  category, offset and encoder.
- :mod:`analysis.plots`, :mod:`analysis.report` (+ ``templates/``) — figures and the report
  directory; :mod:`analysis.pipeline` — everything as one function; :mod:`analysis.cli`.
"""
