"""The tables of ``analyze``: its inputs read and checked, the item labels, and the result tables.

- :mod:`analysis.tables.inputs` — ratings.csv and metric tables; which columns are metrics;
- :mod:`analysis.tables.labels` — votes to per-item GVF, the join of metric tables;
- :mod:`analysis.tables.aggregate` — crowd-kit label models (``--aggregate``);
- :mod:`analysis.tables.summary` — the per-metric table;
- :mod:`analysis.tables.breakdowns` — per category, offset and encoder;
- :mod:`analysis.tables.axes` — per perturbation axis (6-DoF views);
- :mod:`analysis.tables.within_view` — within-view agreement and the view-only baseline;
- :mod:`analysis.tables.side_tables` — the NTA-IoU and sets tables joined onto the pairs;
- :mod:`analysis.tables.real_floor` — the viewpoint floor on real photographs (``floor.csv``).
"""
