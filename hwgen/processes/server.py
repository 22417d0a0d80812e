"""Imported first by the fork server (:data:`hwgen.processes.PRELOAD`), and only there: the server
ends without the interpreter's teardown. It ends when the process that started it has ended, its
forks gone before it, so tearing down what it imported (CadQuery, OCP, VTK) would only spend CPU
and hold the build's output pipe open meanwhile (the bench's table says how long)."""
from __future__ import annotations

import atexit
import os
import sys


def _in_fork_server() -> bool:
    """Whether this import runs in the fork server's start (multiprocessing.forkserver.main is
    on the stack): anywhere else, importing this module does nothing."""
    frame = sys._getframe(1)
    while frame is not None:
        code = frame.f_code
        if code.co_name == "main" and code.co_filename.endswith(os.path.join("multiprocessing", "forkserver.py")):
            return True
        frame = frame.f_back
    return False


if _in_fork_server():
    atexit.register(os._exit, 0)        # the first handler registered runs last
