"""`hwgen fix` (issue 43): from the failing checks' tried fixes (``fixes`` in report.json,
:class:`hwgen.checks.base.Fix`), the nearest design that passes every check.

``choose.py`` (which fix of each failing check a round applies: never one that changes a ``--keep``
path, never a relaxation ``--allow-relax`` does not name; fixes that set one path to two values are
a conflict), ``run.py`` (the rounds: apply, build and check again, keep what helped; a conflict
searched with the tune engine over the paths it names; fixed.yaml, summary.md, the fixed design
built). Stage: after ``tune``, whose public entry points it uses."""
