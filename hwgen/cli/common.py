"""What every command shares: the consoles, the options, the one error path and the exit codes."""
from __future__ import annotations

import functools
import os
import sys
import threading
import warnings
from contextlib import contextmanager, nullcontext, suppress
from pathlib import Path

import typer
from rich.console import Console
from rich.text import Text

from ..errors import DesignError, InputError, clip, printable

EXIT_OK, EXIT_FINDINGS, EXIT_BAD_INPUT, EXIT_BUG = 0, 1, 2, 3
DEBUG_ENV = "HWGEN_DEBUG"          # "1": let an unexpected exception through with its traceback
MESSAGE_CHARS = 400                # the longest error message printed
FIELD_CHARS = 100
MAX_LISTED = 25                    # problems of one input listed (a file of 2 000 unknown keys: the first 25)

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Print files, checks and pictures for tendon-driven continuum robots.")


def _console(stderr: bool) -> Console:
    stream = sys.stderr if stderr else sys.stdout
    # piped output (CI logs, files) gets a page wide enough that tables do not wrap
    return Console(stderr=stderr, width=None if stream.isatty() else 160, markup=False, emoji=False,
                   highlight=False)


out = _console(False)
err = _console(True)


def say(label: str, style: str, message: str, console: Console | None = None) -> None:
    """One line: a styled label and a plain message (never parsed as markup)."""
    (console or err).print(Text.assemble((label, style), " ", printable(message)), soft_wrap=True)


def _mm(v: float) -> str:
    return f"{v + 0.0:.3f}"  # + 0.0 turns -0.0 into 0.0

PARAMS = typer.Argument(..., help="design parameter YAML", show_default=False)
OUT = typer.Option(Path("out"), "--out", help="output root; the design goes to OUT/<design>/")
CACHE_DIR = typer.Option(None, "--cache-dir", show_default=False,
                         help="the part cache (default $HWGEN_CACHE_DIR, else $XDG_CACHE_HOME/hwgen or ~/.cache/hwgen)")
NO_CACHE = typer.Option(False, "--no-cache", help="build every part afresh; read and keep nothing in the part cache")
SCHEDULER = typer.Option(None, "--scheduler", show_default=False,
                         help="tcp://HOST:PORT of a running Dask scheduler; 'inline' to run in this process without "
                              "Dask (default: a local Dask cluster, one worker process per core)")
WORKERS = typer.Option(None, "--workers", min=1, show_default=False,
                       help="worker processes of the local cluster (default: the number of cores)")
CACHE_SIZE = typer.Option(None, "--cache-size", show_default=False,
                          help="the most the cache may hold (2G, 500M); the least recently used entries go first "
                               "(default $HWGEN_CACHE_SIZE, else 2G)")


def _cache(cache_dir: Path | None, no_cache: bool):
    """The pipeline's ``cache_dir``: False for none, True for the default folder, else the folder."""
    return False if no_cache else (cache_dir if cache_dir is not None else True)


def _options(cache_size: str | None = None, jobs: int | None = None):
    """How the build is run (:class:`hwgen.options.BuildOptions`): ``--cache-size`` and ``--jobs``
    where given, the rest as the environment says (read here, at the edge, and nowhere deeper)."""
    from ..cache import parse_size
    from ..options import BuildOptions
    size = None
    if cache_size is not None:
        try:
            size = parse_size(cache_size)
        except ValueError:
            raise InputError("command line", "--cache-size", f"{clip(cache_size)} is not a size (2G, 500M, bytes)") \
                from None
    return BuildOptions.from_environment(cache_size=size, jobs=jobs)


def _file_label(file) -> str:
    """The file as the user named it; a very long path keeps its end, where the name is."""
    text = printable(str(file))
    return text if len(text) <= 200 else "…" + text[-199:]


def _bad_input(file, path: str, message: str) -> typer.Exit:
    field = clip(path, FIELD_CHARS) if path else "<document>"
    say("error:", "bold red", f"{_file_label(file)}: {field}: {clip(message, MESSAGE_CHARS)}")
    return typer.Exit(EXIT_BAD_INPUT)


def _refused(e: InputError, params) -> typer.Exit:
    """Every problem of bad input in one block, in the order a user fixes them: one line when there
    is one (``error: FILE: FIELD: what``), else a line naming the file and how many, then one line
    per problem (its file when it is another, such as a base), at most :data:`MAX_LISTED`; under a
    problem others follow from, one line naming them (they may go once it is fixed); then the hints."""
    roots = e.roots
    top = str(params) if params is not None else e.file
    if len(roots) == 1:
        _bad_input(e.file, e.path, e.message)
        _followers(roots[0], "  ")
    else:
        after = sum(len(f) for _, f in roots)
        say("error:", "bold red", f"{_file_label(top)}: {len(roots)} problems"
                                  + (f" (and {after} that follow from them)" if after else "") + ":")
        for root in roots[:MAX_LISTED]:
            p = root[0]
            field = clip(p.path, FIELD_CHARS) if p.path else "<document>"
            where = "" if p.file == top else f"{_file_label(p.file)}: "
            err.print(Text(f"  - {printable(where)}{field}: {clip(p.message, MESSAGE_CHARS)}"), soft_wrap=True)
            _followers(root, "    ")
        if len(roots) > MAX_LISTED:
            err.print(Text(f"  ... and {len(roots) - MAX_LISTED} more (fix these and run again)"), soft_wrap=True)
    for note in e.notes:
        say("  hint:", "yellow", clip(note, MESSAGE_CHARS))
    return typer.Exit(EXIT_BAD_INPUT)


def _followers(root: tuple[InputError, list[InputError]], indent: str) -> None:
    """The line under a problem naming those that follow from it: how many, and their fields."""
    cause, followers = root
    if not followers:
        return
    n = len(followers)
    count: dict[str, int] = {}
    for p in followers:
        count[p.path or "<document>"] = count.get(p.path or "<document>", 0) + 1
    fields = ", ".join(f"{f} ×{k}" if k > 1 else f for f, k in count.items())
    many = n > 1
    err.print(Text(f"{indent}and {n} problem{'s' if many else ''} that follow{'' if many else 's'} from "
                   f"{cause.cause} (fix it first: {'they' if many else 'it'} may go with it): "
                   f"{clip(fields, MESSAGE_CHARS)}"), soft_wrap=True)


@contextmanager
def _errors(params: Path | None):
    """The one error path of every command (see the module's docstring)."""
    try:
        try:
            with warnings.catch_warnings():
                if not sys.warnoptions:               # numpy and library warnings are not for the user,
                    warnings.simplefilter("ignore")   # unless Python is told to show them (-W, PYTHONWARNINGS)
                yield
        except (typer.Exit, typer.Abort):
            raise
        except Exception:
            if _STOPPING.is_set():
                # the signal landed in code that made another error of it (an extension module's
                # import says "initialization failed"): the stop, not that error, is the news
                raise KeyboardInterrupt from None
            raise
    except (typer.Exit, typer.Abort):
        raise
    except InputError as e:
        raise _refused(e, params) from None
    except DesignError as e:
        raise _bad_input(params if params is not None else "", e.path, e.message) from None
    except KeyboardInterrupt:
        say("interrupted:", "yellow", "the outputs are as they were before this command")
        raise typer.Exit(130) from None
    except BrokenPipeError:
        # the reader of our output went away (| head): stop quietly, as a SIGPIPE would
        with suppress(OSError, ValueError):     # no stdout left to point anywhere
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        raise typer.Exit(141) from None
    except Exception as e:
        if os.environ.get(DEBUG_ENV) == "1":
            raise
        what = "ran out of memory" if isinstance(e, MemoryError) else f"{type(e).__name__}: {e}"
        say("error:", "bold red", f"internal error in hwgen ({clip(what, 200)}); this is a bug, please report it "
                                  f"with the parameter file ({DEBUG_ENV}=1 shows the traceback)")
        raise typer.Exit(EXIT_BUG) from None


def _command(fn):
    """A command whose every failure goes through :func:`_errors`."""
    @functools.wraps(fn)
    def run(*args, **kwargs):
        with _errors(kwargs.get("params")):
            return fn(*args, **kwargs)
    return app.command()(run)


def _load(path: Path):
    from ..pipeline import load
    loaded = load(path)
    for w in loaded.warnings:
        say("warning:", "yellow", w)
    return loaded


def _write_side_file(path: Path, option: str, write) -> None:
    """--report and --junit: a file that cannot be written is bad input naming the option."""
    try:
        write()
    except OSError as e:
        below_a_file = any(p.exists() and not p.is_dir() for p in Path(path).parents)
        why = "it lies below a file, not a folder" if below_a_file else e.strerror or str(e)
        raise InputError(path, option, f"cannot write it ({why})") from None


def _on_outputs(doing: str, quiet: bool, run):
    """Run a step on a design's outputs (it builds them first when they are missing or stale):
    a spinner while it works, and a word when it rebuilt. ``run()`` returns (result, folder,
    why it rebuilt or None)."""
    with err.status(Text(doing), spinner="dots") if not quiet else nullcontext():
        result, folder, rebuilt = run()
    if rebuilt:
        err.print(f"built {printable(folder)} first ({rebuilt})")
    return result, folder


def _check_scheduler(scheduler: str | None) -> None:
    """--scheduler of sweep and tune: a Dask scheduler's address, 'inline', or none (a local cluster)."""
    if scheduler is not None and scheduler != "inline" and not scheduler.startswith(("tcp://", "tls://")):
        raise InputError(scheduler, "--scheduler", "give tcp://HOST:PORT of a Dask scheduler, or 'inline'")


_STOPPING = threading.Event()       # set by SIGTERM or SIGINT: whatever error follows is the stop


def _terminate(signum, frame):
    """SIGTERM (and Ctrl-C) end a command: the temporary folder of a build is removed on the way out."""
    _STOPPING.set()
    raise KeyboardInterrupt


