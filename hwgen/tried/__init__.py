"""Fixes, tried (issue 43): each failing check's change applied to the design (the user's file as
its bases merged it, a dotted path and a value) and that check evaluated again with the model that
failed it, at the plan level: the tension sweep's statics, the tendon states' statics, the
as-built statistic. What a fix does to the stiffening, and what it breaks, is recorded beside it.

Stage: after ``checks`` (whose functions it calls again on changed plans), before ``outputs``; it
reads the schema (``params``) to apply a change as the user would, which the checks never do.
``trial.py`` (the design changed, planned and evaluated, each remembered), ``tension.py`` (the
tension checks' fixes), ``run.py`` (every failing check's fixes, their interactions, the prose)."""
