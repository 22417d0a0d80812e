"""What every section of the parameter YAML's schema shares: the pydantic base that forbids unknown
keys, freezes the values and refuses YAML's booleans for numbers. Its own module so that a section
kept in a module of its own (:mod:`hwgen.params_experiment`) and :mod:`hwgen.params`, which gathers
the sections into a design, both build on it."""
from __future__ import annotations

from typing import get_args

from pydantic import BaseModel, ConfigDict, field_validator


def _has_bool(value) -> bool:
    if isinstance(value, bool):
        return True
    return isinstance(value, (list, tuple)) and any(_has_bool(v) for v in value)


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    @field_validator("*", mode="before")
    @classmethod
    def _no_bool_for_numbers(cls, value, info):
        """YAML reads true/false/yes/no/on/off as booleans, and pydantic would take them as 1 and 0."""
        if _has_bool(value) and bool not in (cls.model_fields[info.field_name].annotation,
                                             *get_args(cls.model_fields[info.field_name].annotation)):
            raise ValueError("true/false is not a number or a name (YAML reads yes, no, on, off, true and "
                             "false as booleans; quote a name that is one of them)")
        return value
