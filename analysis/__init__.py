"""analysis stage of the NVRQ toolkit: ``analyze RATINGS.csv`` (docs/FORMATS.md §6).

Its stages, from the command down (docs/ARCHITECTURE.md, "Inside ``analysis``"; a package
imports only the ones below it):

- :mod:`analysis.cli` — the ``analyze`` command;
- :mod:`analysis.report` — the report folders: pages (+ ``templates/``), the leaderboard,
  pairwise and trust-horizon sections, the off-path metrics;
- the analyses, one entrance each: :mod:`analysis.pipeline` (ratings, everything as one
  function), :mod:`analysis.all_pairs` (every pair, no votes), :mod:`analysis.pairwise`
  (pairwise votes), :mod:`analysis.methods` (the method leaderboard), :mod:`analysis.horizon`
  (the trust horizon); their options in :mod:`analysis.options`;
- :mod:`analysis.tables` — input tables, item labels and the result tables (summary,
  breakdowns, axes, within-view, the real-photograph floor); the rater screening comes from
  :mod:`annotate.screening` (one stage down, shared with the live admin page);
- :mod:`analysis.stats` — correlations, the cluster bootstrap, sign-flip tests,
  non-inferiority, Bradley-Terry, JOD, the noise ceiling, the trust horizon's fits;
- :mod:`analysis.common` — the choices ``analyze`` offers, number formats, figures, the cells
  of the method comparison and the viewpoint floor's labels.
"""
