"""Printed materials and their densities, from the table shipped with hwgen (data/materials.csv)."""
from __future__ import annotations

import csv
from dataclasses import dataclass
from functools import cache
from importlib import resources

from ..errors import nearest
from ..params import Process


@dataclass(frozen=True)
class Material:
    name: str
    technology: str          # "SLA" or "FDM"
    density_g_cm3: float
    reason: str
    modulus_gpa: float
    modulus_reason: str
    contact_modulus_gpa: float   # for contact stress: the high end (a stiffer flank concentrates the contact)
    poisson: float
    contact_reason: str


@cache
def table() -> dict[str, Material]:
    """Every material of data/materials.csv by name."""
    text = resources.files("hwgen").joinpath("data/materials.csv").read_text(encoding="utf-8")
    return {r["material"]: Material(name=r["material"], technology=r["technology"],
                                    density_g_cm3=float(r["density_g_cm3"]), reason=r["reason"],
                                    modulus_gpa=float(r["modulus_gpa"]), modulus_reason=r["modulus_reason"],
                                    contact_modulus_gpa=float(r["contact_modulus_gpa"]), poisson=float(r["poisson"]),
                                    contact_reason=r["contact_reason"])
            for r in csv.DictReader(text.splitlines())}


def material_problem(process: Process) -> str | None:
    """Why the process's material is not one hwgen knows for its technology, or None."""
    return name_problem(process.material, process.technology)


def name_problem(material: str, technology: str | None) -> str | None:
    """Why ``material`` is not one hwgen knows (for ``technology``, when it is given), or None: also
    asked of a file the schema refuses, so that its material is named in the same run."""
    known = table()
    m = known.get(material)
    if m is None:
        close = nearest(material, known)
        meant = f"did you mean {close}? " if close else ""
        return f"unknown material {material!r}; {meant}hwgen knows {', '.join(sorted(known))}"
    if technology is not None and m.technology != technology:
        return f"{m.name} is a {m.technology} material, process.technology is {technology}"
    return None


def printed_density(process: Process) -> tuple[float, str]:
    """The density of a printed part (g/cm³, fill included) and where it comes from."""
    if process.density_g_cm3 is not None:
        rho, why = process.density_g_cm3, "process.density_g_cm3"
    else:
        m = table()[process.material]
        rho, why = m.density_g_cm3, f"{m.name}: {m.reason}"
    if process.fill_fraction < 1:
        why += f"; × fill fraction {process.fill_fraction:g}"
    return rho * process.fill_fraction, why


def printed_modulus(process: Process) -> tuple[float, str]:
    """The modulus of a printed part's material (GPa, solid; fill scales it) and where it comes from."""
    m = table()[process.material]
    e, why = m.modulus_gpa, f"{m.name}: {m.modulus_reason}"
    if process.fill_fraction < 1:
        e *= process.fill_fraction
        why += f"; × fill fraction {process.fill_fraction:g}"
    return e, why


def contact_elasticity(process: Process) -> tuple[float, float, str]:
    """(modulus MPa, Poisson's ratio, where they come from) of the printed material, for the
    Hertz contact of two printed gears (solid material: a gear's flanks are printed solid)."""
    m = table()[process.material]
    return 1000.0 * m.contact_modulus_gpa, m.poisson, f"{m.name}: {m.contact_reason}"
