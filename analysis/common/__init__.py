"""What every stage of ``analysis`` shares, at the bottom of it (light: ``analyze --help`` reads it).

- :mod:`analysis.common.choices` — the choices ``analyze`` offers, each defined once;
- :mod:`analysis.common.text` — how numbers and intervals are written;
- :mod:`analysis.common.plots` — the figures (matplotlib, no pyplot state);
- :mod:`analysis.common.method_cells` — the cells the method comparison breaks objects into;
- :mod:`analysis.common.viewpoint_floor` — the viewpoint floor's rule, colour and labels.
"""
