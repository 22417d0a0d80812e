"""The two kinds of bad input every stage can raise; the CLI reports both the same way (exit 2)."""
from __future__ import annotations

from pathlib import Path


class InputError(Exception):
    """Bad input: the file, the field path (``tendons[2].routing.table``) and what is wrong."""

    def __init__(self, file: str | Path, path: str, message: str):
        self.file, self.path, self.message = str(file), path, message
        super().__init__(f"{file}: {path or '<document>'}: {message}")


class DesignError(Exception):
    """Parameters that each pass their checks but together make no buildable part.

    ``path`` names the section of the YAML to change; the CLI reports it like bad input.
    """

    def __init__(self, path: str, message: str):
        self.path, self.message = path, message
        super().__init__(f"{path}: {message}")
