"""A design document turned into the design a build makes, one way for every command.

``hwgen build`` reads a file, checks it against the schema, derives the tensioner's gear where the
file leaves it to hwgen (:mod:`hwgen.model.gear_choice`) and refuses what cannot be built
(:mod:`hwgen.model.feasibility`). A sweep's variant, a tune's trial and a tried fix start from a
document in memory instead of a file; they go through :func:`design_from` so that each is the
design a build of the same document would make (an FDM variant gets the gear an FDM build gets).
Which keys the document wrote is what the gear may not change: a file's layers
(:class:`hwgen.designfile.Layers`) say so for a file, a :class:`hwgen.designfile.Document` for a
document in memory.
"""
from __future__ import annotations

from pathlib import Path

from .. import designfile, params
from . import feasibility, gear_choice


def follow_process(design: params.Design, layers: designfile.Layers) -> tuple[params.Design, str]:
    """``design`` with the tensioner's gear keys its own file did not write (``layers``) derived for
    its process, and the sentence saying so ("" when the stated gear is kept and prints); where no
    gear of the schema's range prints with the process's wall, the stated gear is kept (it is built
    and fails its tip checks) and the sentence names the wall that works."""
    free = {k for k in gear_choice.GEAR_KEYS if layers.origin(("tensioner", k)) != 0}
    choice = gear_choice.follow_process(design.tensioner, design.process.min_wall, free)
    if not choice.values:
        return design, choice.note
    return design.model_copy(update={"tensioner": design.tensioner.model_copy(update=choice.values)}), choice.note


def buildable(design: params.Design, layers: designfile.Layers) -> tuple[params.Design, str]:
    """``design`` with its gear followed and checked for what cannot be built, as a build does:
    (the design, the note on its gear); raises :class:`hwgen.errors.InputError` naming each fault in
    the file that wrote it."""
    design, note = follow_process(design, layers)
    found = feasibility.problems(design)
    if found:
        raise params.refuse(found, layers)
    return design, note


def design_from(doc: dict, where: str | Path) -> tuple[params.Design, str]:
    """The design a build of document ``doc`` makes (``where``: what to name it by in a message):
    the schema, the gear derived where ``doc`` leaves it to hwgen (a
    :class:`hwgen.designfile.Document` names the keys a base wrote), the feasibility checks;
    (the design, the note on its gear). Raises :class:`hwgen.errors.InputError`."""
    layers = designfile.single(doc, where)
    return buildable(params.validate(doc, where, layers), layers)


def loaded_buildable(loaded: params.LoadedDesign) -> params.LoadedDesign:
    """A design read from its file (:func:`hwgen.params.read`) made buildable the same way, the
    note on its gear among its warnings."""
    design, note = buildable(loaded.design, loaded.layers)
    if not note:
        return loaded
    return loaded.model_copy(update={"design": design, "warnings": (*loaded.warnings, note)})
