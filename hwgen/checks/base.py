"""The one record every check produces, whatever it measures."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, Literal

Severity = Literal["error", "warning", "info"]


@dataclass(frozen=True)
class Check:
    """One finding. ``passed`` False with severity "error" fails the design (exit code 1)."""

    id: str                       # stable, dotted: "eyelet.wall.edge", "gear.self_locking"
    severity: Severity
    passed: bool
    message: str                  # a sentence a person can act on, naming the place
    measured: float | None = None
    limit: float | None = None
    where: dict[str, Any] = field(default_factory=dict)   # part, station, tendon, channel, ...

    def to_json(self) -> dict:
        return asdict(self)
