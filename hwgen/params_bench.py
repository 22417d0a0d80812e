"""The ``base_frame:`` and ``rig:`` sections of the parameter YAML: the paper's bench as printable
hardware (issue 46). The base frame turns the robot about its own axis (Fig. 3 ①-⑧, the protocol of
Sect. III-B); the rig holds the load cell on the arm's flange and pushes a disk's rim (Sect. IV-C).
Both are left out unless ``enabled``. A value left out (None) is derived from the robot by the
model (:mod:`hwgen.model.bench_frame`): the worm pair from the tensioner's, the push from the
experiment's load cell."""
from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from .params_base import _Model

Number = Annotated[float, Field(allow_inf_nan=False)]
Mm = Annotated[float, Field(gt=0, le=1000, allow_inf_nan=False)]


class BaseFrame(_Model):
    """The rotating base frame: the base mount bolted to a cradle on a shaft along the robot's axis,
    between a front and a back upright, turned through a GT2 belt by a self-locking worm."""

    enabled: bool = Field(False, description="build the base frame (false: leave it out)")
    module: Number | None = Field(None, ge=0.3, le=3.0, description="worm's axial module, mm (default: the "
                                                                     "tensioner's, so the pair is one already proven)")
    worm_starts: int | None = Field(None, ge=1, le=4, description="thread starts (default: the tensioner's)")
    wheel_teeth: int | None = Field(None, ge=6, le=120,
                                    description="teeth of the worm wheel (default: the tensioner's, more if the "
                                                "robot's torque about the shaft needs them)")
    worm_pitch_diameter: Number | None = Field(None, gt=0, le=40, description="d1, mm (default: the tensioner's)")
    face_width: Number | None = Field(None, gt=0, le=30, description="wheel face width, mm (default: the tensioner's)")
    friction_coefficient: Number | None = Field(None, gt=0, le=1,
                                                description="μ of the worm on the wheel (default: the tensioner's)")
    bearing: Literal["608", "625"] = Field("608", description="the ball bearings the shafts turn in "
                                                              "(hwgen/data/bench_parts.csv)")
    pulley_teeth: Literal[20, 36, 40] = Field(20, description="teeth of the two GT2 pulleys (1:1), a stock size of "
                                                             "hwgen/data/bench_parts.csv")
    mounting: Literal["breadboard", "table_edge"] = Field(
        "breadboard", description="breadboard: the frame's base screws to an M6 25 mm grid; table_edge: two G-clamps "
                                  "hold it at a table's edge and the robot overhangs")
    clearance_mm: Mm = Field(5.0, description="least gap between the turning robot (with its mount and cradle) and "
                                              "the fixed frame at every angle, mm")
    mark_step_deg: Annotated[float, Field(ge=1, le=45, allow_inf_nan=False)] = Field(
        15.0, description="angle marks on the cradle's flange every this many degrees")
    push_n: Number | None = Field(None, gt=0, le=1000,
                                  description="the push at the tip the shaft and bearings are sized for, N "
                                              "(default: experiment.load_cell_range_n)")
    safety_factor: Number = Field(2.0, ge=1, le=10, description="required factor on the gear teeth, the bearings' "
                                                               "static load and the clamp's grip")
    max_tip_shift_mm: Mm = Field(0.5, description="largest shift of the robot's tip the shaft's bending may add "
                                                   "under the robot's weight and the push, mm")


class LoadCell(_Model):
    """A beam load cell: a bar fixed by two screws at one end, loaded by two at the other."""

    name: str = Field("LSP-5", min_length=1, max_length=64, description="the cell's maker's name")
    length: Mm = Field(25.4, description="the bar's length, mm")
    width: Mm = Field(12.7, description="the bar's width across the load, mm")
    height: Mm = Field(6.35, description="the bar's depth along the load, mm")
    screw: Literal["M2", "M3", "M4"] = Field("M3", description="the screws through its end holes")
    screw_spacing: Mm = Field(5.1, description="between the two holes of one end, along the bar, mm")
    end_hole_inset: Mm = Field(3.2, description="from the bar's end to its nearer hole, mm")
    range_n: Number | None = Field(None, gt=0, le=10_000,
                                   description="its range, N (default: experiment.load_cell_range_n)")


class Rig(_Model):
    """The stiffness rig of Sect. IV-C: a bracket for the load cell on the arm's flange (or a linear
    stage), a push block on the cell's free end, and a support under the base frame."""

    enabled: bool = Field(False, description="build the rig (false: leave it out)")
    flange: Literal["ISO9409-1-50-4-M6", "stage_M6_25mm"] = Field(
        "ISO9409-1-50-4-M6", description="what the bracket bolts to: a robot flange (the UR5e's) or a linear "
                                         "stage's M6 25 mm carriage")
    load_cell: LoadCell = Field(default_factory=LoadCell, description="the beam load cell")
    reach_mm: Mm = Field(60.0, description="from the flange's face to the load cell's axis, mm")
    push_gap_mm: Number = Field(1.0, ge=0, le=50,
                                description="the push block stands this far above the disk's rim before a push, mm")
    support_height_mm: Mm = Field(40.0, description="the support's height under the base frame, mm")
