"""Experiment A of the paper (§III.A, §IV.A): the 75 × 75 cross-mapping behind ``hila eval``.

Modules, one stage each:

- :mod:`~hila_lang.evaluation.dataset`  the seeded stand-in for the paper's 75 human trials, and
  the reader/writer of the ``--dataset FOLDER`` format (CSV path + CSV ICPs per trial)
- :mod:`~hila_lang.evaluation.grid`     one template mapped onto every task for N = 1..4 equal
  segments, scored with R (eq. 1) and MSD (eq. 2)
- :mod:`~hila_lang.evaluation.peers`    the same work done by a plain TPS warp and by DMPs
- :mod:`~hila_lang.evaluation.run`      the whole grid: locally, with joblib, or on Dask
- :mod:`~hila_lang.evaluation.paper`    the paper's Tables I–III (reference figures only)
- :mod:`~hila_lang.evaluation.tables`   Tables I–III in the paper's layout, ours beside the paper's
- :mod:`~hila_lang.evaluation.report`   CSV / JSON / heatmap PNG output

The original human trials of the paper are not public; :mod:`.dataset` generates a documented
stand-in with the same structure (5 set-ups × 15 paths, ICPs in image pixels).
"""
