"""`hwgen tune`: design by search over a base design's parameters, on the sweep's workers.

spec (the tune file: base, free parameters, goal) → results (what can be maximised or bounded,
the one reader of the statics' results) → run (Optuna asks, the sweep's levels evaluate on Dask,
Optuna is told; the journal makes it resumable) → report (trials.parquet, best.yaml, summary.md,
convergence.png) → best (all of it, then the best built whole and checked).
"""
