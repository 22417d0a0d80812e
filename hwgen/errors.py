"""The two kinds of bad input every stage can raise; the CLI reports both the same way (exit 2).

Messages may quote what the user wrote; :func:`echo` is how they do it: control characters
escaped, and cut to a few dozen characters, so a 50 MB value makes a one-line message.
"""
from __future__ import annotations

import difflib
import reprlib
from pathlib import Path
from typing import NamedTuple

ECHO_CHARS = 40          # the most of one user-given value a message quotes


class Problem(NamedTuple):
    """A rule a design breaks: the field path (or the paths of the fields the rule involves, the
    one to change first) and what is wrong. ``cause`` names what the problem is about when others
    may follow from it (``the slot``); ``follows``, the cause this one follows from: found with
    it, it is reported under it, as a consequence that may go once the cause is fixed."""

    paths: str | tuple[str, ...]
    message: str
    cause: str = ""
    follows: str = ""


class InputError(Exception):
    """Bad input: the file, the field path (``tendons[2].routing.table``) and what is wrong.

    One error may carry others found in the same reading (``more``: every problem of a file is
    reported at once) and ``notes`` (hints on values that are not errors themselves, such as a
    length that looks like metres); :attr:`problems` is the error and the others, in order: the
    order a user fixes them in (:meth:`of`). ``cause`` and ``follows``: as a :class:`Problem`'s."""

    def __init__(self, file: str | Path, path: str, message: str, cause: str = "", follows: str = ""):
        self.file, self.path, self.message = str(file), path, message
        self.cause, self.follows = cause, follows
        self.more: list[InputError] = []
        self.notes: list[str] = []
        super().__init__(f"{file}: {path or '<document>'}: {message}")

    @property
    def problems(self) -> list[InputError]:
        return [self, *self.more]

    @classmethod
    def of(cls, problems: list[InputError], notes: list[str] = ()) -> InputError:
        """One error carrying all of ``problems`` (at least one) and the ``notes``, in the order a
        user fixes them: each root, then the problems that follow from it (``follows`` names the
        ``cause`` of one found among them, which is a root itself: one level). A problem whose
        cause is not found is a root of its own."""
        causes: dict[str, InputError] = {}
        for p in problems:
            if p.cause:
                causes.setdefault(p.cause, p)
        following: dict[str, list[InputError]] = {}
        for p in problems:
            if p.follows in causes and not p.cause:
                following.setdefault(p.follows, []).append(p)
        ordered = []
        for p in problems:
            if p.follows in causes and not p.cause:
                continue                                    # listed under its cause
            p.follows = ""
            ordered += [p, *(following.pop(p.cause, []) if p.cause and causes[p.cause] is p else [])]
        first = ordered[0]
        first.more = ordered[1:]
        first.notes = list(notes)
        return first

    @property
    def roots(self) -> list[tuple[InputError, list[InputError]]]:
        """Each problem that follows from no other, with the problems that follow from it."""
        out: list[tuple[InputError, list[InputError]]] = []
        for p in self.problems:
            if p.follows and out:
                out[-1][1].append(p)
            else:
                out.append((p, []))
        return out

    def __str__(self) -> str:
        text = super().__str__()
        return text if not self.more else f"{text} (and: " + "; ".join(
            f"{e.file}: {e.path or '<document>'}: {e.message}" for e in self.more) + ")"


class DesignError(Exception):
    """Parameters that each pass their checks but together make no buildable part.

    ``path`` names the section of the YAML to change; the CLI reports it like bad input.
    """

    def __init__(self, path: str, message: str):
        self.path, self.message = path, message
        super().__init__(f"{path}: {message}")


def printable(text: str) -> str:
    """``text`` with every control character (newline, escape, ...) written as a Python escape."""
    return "".join(c if c.isprintable() or c == " " else repr(c)[1:-1] for c in str(text))


_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxtuple, _REPR.maxdict = 2, 4, 4, 4
_REPR.maxstring = _REPR.maxother = _REPR.maxlong = ECHO_CHARS


def clip(text: str, limit: int = ECHO_CHARS) -> str:
    """``text`` made printable and cut to ``limit`` characters (an ellipsis marks the cut)."""
    text = printable(text[: limit + 1] if len(text) > 4 * limit else text)
    return text if len(text) <= limit else text[: limit - 1] + "…"


def nearest(word: str, choices, cutoff: float = 0.6) -> str | None:
    """The choice ``word`` is most likely a slip of (difflib's ratio, case aside), or None: what a
    message offers as "did you mean"."""
    folded = {str(c).lower(): c for c in choices}
    close = difflib.get_close_matches(str(word).lower(), list(folded), n=1, cutoff=cutoff)
    return folded[close[0]] if close else None


def echo(value, limit: int = ECHO_CHARS) -> str:
    """A user-given value as a message quotes it: its repr, printable, at most ``limit`` characters
    (a huge list or string is never turned into text whole)."""
    return clip(_REPR.repr(value), limit)
