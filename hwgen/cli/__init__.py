"""The `hwgen` command line: build, check, render, plates, coupon, routing, stiffness, experiment, compare, sweep, tune, fix, schema.

Exit codes: 0 success, 1 design findings that fail, 2 bad input or usage, 3 a bug in hwgen.

Every command reports through one error path (:func:`_errors`): bad input, parameters that
make no part (including any failure of the CAD kernel), and an output folder that cannot be
written all print one line ``error: FILE: FIELD: what is wrong`` (a file with several faults: a
line naming it, then one line for each) and exit 2; anything else is
a bug and says so in one line (``HWGEN_DEBUG=1`` shows the traceback). Nothing the user wrote
is ever read as rich markup or emoji codes: the consoles have both switched off, and styled
words are :class:`rich.text.Text` spans.
"""
from __future__ import annotations

import atexit
import os
import signal
import sys

from . import design, experiment, search  # noqa: F401  (each registers its commands on the app)
from .common import (EXIT_BAD_INPUT, EXIT_BUG, EXIT_FINDINGS, EXIT_OK, _STOPPING, _errors,  # noqa: F401
                     _terminate, _write_side_file, app)
from .design import _built_before  # noqa: F401


_EXIT: dict[str, int] = {}          # the code the program exits with, once main() has one


def _end() -> None:
    """The last exit handler (main() registers it before anything else can): once the
    interpreter has joined its threads and run every other handler, the process ends with
    main()'s code without the interpreter's teardown, which only frees what the process holds
    (after a build: the checks' meshes, the report, the libraries' modules). Kept because what it
    saves is measured on paths a user waits for, a check that measures and the no-op rebuild
    (issue 35's closing note; the bench has no row for it)."""
    if "code" not in _EXIT or "coverage" in sys.modules:
        # not ended through main(), or measured by coverage.py, whose handler (registered at start,
        # so after this one) writes its data: the interpreter's own way
        return
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):
        return                          # a closed pipe: the interpreter says so as it would
    os._exit(_EXIT["code"])


def main() -> None:
    """The program: a command, then the process ends (see :func:`_end`)."""
    atexit.register(_end)
    # standalone mode: typer.Exit(code) exits with that code, usage errors exit 2
    signal.signal(signal.SIGTERM, _terminate)
    signal.signal(signal.SIGINT, _terminate)
    try:
        app()
    except SystemExit as e:
        _EXIT["code"] = e.code if isinstance(e.code, int) else int(e.code is not None)
        raise




if __name__ == "__main__":
    main()
