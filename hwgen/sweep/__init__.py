"""`hwgen sweep`: many variants of one design, evaluated on Dask, with Parquet results.

spec (the sweep file, variants) → lengths (many variants at once, no CAD) → levels (a batch on a
worker) → build (the build level, CadQuery) → run (Dask, Parquet) → summary (table and plots).
"""
