"""One-off studies: measurements that chose a constant or a setting, or answered a question once.

Each runs as ``python -m bench.studies.<name>`` from the repository root; the docs page that
reports it names it (docs/models.md, docs/excitation.md, docs/recorded_loop.md,
docs/severity_bias.md, docs/prognostics.md).  They are not re-run to compare releases.
"""
