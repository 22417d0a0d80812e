"""`hwgen ARGS` for the tests: in this process (typer's runner), where a child process adds
nothing but its start (about a second of CPU for the interpreter and hwgen's imports, more for a
sweep's or a tune's libraries); as a real process where the process itself is what is tested
(the console script, a signal, a worker pool, a Dask cluster). Both give what `subprocess.run`
gives: the exit code, stdout and stderr."""
from __future__ import annotations

import os
import subprocess
import sys


def hwgen(*args: str, env: dict | None = None, timeout: float | None = None) -> subprocess.CompletedProcess:
    """The command run in this process; ``env``: the whole environment it sees (as a child's would
    be), the test's own again afterwards. ``timeout`` is pytest-timeout's here, as for any test."""
    from typer.testing import CliRunner

    from hwgen.cli import app
    changed = None if env is None else {**{k: None for k in os.environ if k not in env}, **env}
    r = CliRunner().invoke(app, list(args), env=changed)
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise r.exception
    return subprocess.CompletedProcess(["hwgen", *args], r.exit_code, r.stdout, r.stderr)


def hwgen_process(*args: str, timeout: float = 600, **kw) -> subprocess.CompletedProcess:
    """The command as a process of its own (``python -m hwgen.cli``)."""
    return subprocess.run([sys.executable, "-m", "hwgen.cli", *args], capture_output=True, text=True,
                          timeout=timeout, **kw)
