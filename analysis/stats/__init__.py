"""The statistics of votes and metrics, on columns (NumPy), with no table or report in them.

- :mod:`analysis.stats.stats` — grouped PLCC/SRCC/KRCC/ROC AUC/logistic PLCC and the
  undefined-statistic rule;
- :mod:`analysis.stats.bootstrap` — the seeded cluster bootstrap over tracks;
- :mod:`analysis.stats.signflip` — the paired sign-flip test over tracks;
- :mod:`analysis.stats.noninferiority` — the cheapest metric that is good enough;
- :mod:`analysis.stats.bradley_terry`, :mod:`analysis.stats.jod` — pairwise comparisons;
- :mod:`analysis.stats.ceiling` — the noise ceiling;
- :mod:`analysis.stats.horizon_fit`, :mod:`analysis.stats.horizon_views` — the trust
  horizon's thresholds from votes, overall and per view.
"""
