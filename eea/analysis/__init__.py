"""Analysis of finished EEA runs: plots and statistics of studies (:mod:`~eea.analysis.plot`),
comparisons of variants (:mod:`~eea.analysis.compare`), diagnoses of search and inference
failures (:mod:`~eea.analysis.diagnosis`) and lineage reports (:mod:`~eea.analysis.lineage_report`).

Layering (tests/eea/test_layering.py): nothing outside this package imports it, except the
command-line front ends (:mod:`eea.cli`, ``aquafish``) lazily, to run analysis commands; the
algorithm never depends on an analysis.
"""
