"""Evaluation: is one demonstration worth anything?  Experiment A of the paper and beyond.

Modules, one stage each:

- :mod:`~hila_lang.evaluation.dataset`    the seeded stand-in for the paper's 75 human trials, and
  the reader/writer of the ``--dataset FOLDER`` format (CSV path + ICPs per trial)
- :mod:`~hila_lang.evaluation.lasa`       real human handwriting: the LASA data set
- :mod:`~hila_lang.evaluation.protocols`  what a method is told about a task: the constraint
  pairs of the held-out, leak-free positions, paper and time-fraction protocols
- :mod:`~hila_lang.evaluation.controls`   the controls OSILA is compared with on exactly its
  constraints: no template, rigid similarity, bare warp, DMP, DMP in the similarity's frame
- :mod:`~hila_lang.evaluation.baselines`  via-point methods from the literature: ProMP,
  Laplacian trajectory editing, a GP, each also with OSILA's re-timing
- :mod:`~hila_lang.evaluation.ablation`   OSILA without its route, re-timing, plan adjustment,
  or with one warp only
- :mod:`~hila_lang.evaluation.grid`       one template mapped onto its tasks for each N and
  method, scored with every metric of :data:`hila_lang.metrics.METRICS`
- :mod:`~hila_lang.evaluation.run`        the whole grid: locally, with joblib, or on Dask
- :mod:`~hila_lang.evaluation.stats`      means per method and N; tests over shapes (Wilcoxon,
  Holm, bootstrap CI of the median difference)
- :mod:`~hila_lang.evaluation.paper`      the paper's Tables I–III (reference figures only)
- :mod:`~hila_lang.evaluation.tables`     what is printed: summary, tests, Tables I–III
- :mod:`~hila_lang.evaluation.report`     CSV / JSON (results byte-identical per seed; timings
  apart) / heatmap PNG output

The original human trials of the paper are not public; :mod:`.dataset` generates a documented
stand-in with the same structure (5 set-ups × 15 paths, ICPs in image pixels).
"""
