"""The ``experiment:`` section of the parameter YAML: the paper's push test (Sect. III-C) as a lab
runs it, and the ranges of the values the paper does not give that its prediction spans
(`hwgen experiment`, `hwgen compare`). Defaults are the paper's where it gives them."""
from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, field_validator

from .params_base import _Model

Number = Annotated[float, Field(allow_inf_nan=False)]


class Ranges(_Model):
    """The band of the prediction: each value the paper does not give, as [low, high] (the design's
    own value is its nominal); a value not given is not varied."""

    axial_stiffness_n: tuple[Annotated[Number, Field(gt=1, le=1e7)], Annotated[Number, Field(gt=1, le=1e7)]] | None \
        = Field(None, description="tendon_material.axial_stiffness_n: the line's EA, [low, high] N")
    tie_off_compliance_mm_per_n: tuple[Annotated[Number, Field(ge=0, le=10)], Annotated[Number, Field(ge=0, le=10)]] \
        | None = Field(None, description="tendon_material.tie_off_compliance_mm_per_n: the give of a tendon's knot, "
                                         "drum and drive, [low, high] mm/N")
    eyelet_friction: tuple[Annotated[Number, Field(ge=0, le=2)], Annotated[Number, Field(ge=0, le=2)]] | None = Field(
        None, description="tendon_material.eyelet_friction: μ of the line in an eyelet, [low, high]")
    modulus_gpa: tuple[Annotated[Number, Field(gt=1, le=400)], Annotated[Number, Field(gt=1, le=400)]] | None = Field(
        None, description="backbone.modulus_gpa: the strip's E in bending, [low, high] GPa")

    @field_validator("*", mode="after")
    @classmethod
    def _ordered(cls, value, info):
        if value is not None and value[0] > value[1]:
            raise ValueError(f"the low end {value[0]:g} is above the high end {value[1]:g}: give [low, high]")
        return value


class Experiment(_Model):
    """The push test: where and how the robot is pushed, what the load cell reads, how the samples
    are fitted (the paper's eq. (4)), and the ranges its prediction spans."""

    orientation: Literal["gravity -z", "gravity +z", "weightless"] = Field(
        "gravity -z", description="how the robot lies while it is tensioned and pushed: horizontal with its flexible "
                                  "direction along gravity (-z: C1's base eyelet up, as Sect. III-B tensions it; +z: "
                                  "turned over), or weightless")
    push_toward: Literal["+z", "-z"] = Field(
        "-z", description="the direction the arm pushes the disks, along the strip's flexible direction")
    first_disk: int = Field(3, ge=2, le=200, description="the first disk pushed, counted from 1 at the clamped base "
                                                         "as the paper does (Sect. IV-C: 3; 2: all); the pushes go "
                                                         "on to the tip disk")
    load_cell_range_n: Number = Field(5.0, gt=0, le=10_000, description="the load cell's range, N (Sect. III-C: 5)")
    load_fraction: Number = Field(0.8, gt=0, le=1, description="the share of the load cell's range the largest "
                                                               "predicted force of a push may reach")
    max_push_mm: Number = Field(20.0, gt=0, le=1000, description="the longest push, mm")
    displacement_rate_mm_s: Number = Field(1.0, gt=0, le=1000, description="the arm's speed, mm/s")
    sample_rate_hz: Number = Field(30.0, gt=0, le=1e6, description="samples per second (Sect. III-C: 30)")
    fit_window_samples: int = Field(400, ge=2, le=10_000_000,
                                    description="samples either side of each peak eq. (4) is fitted to (Sect. "
                                                "III-C: 400)")
    repetitions: int = Field(3, ge=1, le=100, description="pushes at each disk (Sect. III-C: 3)")
    ranges: Ranges = Field(default_factory=Ranges, description="what the prediction's band spans")
