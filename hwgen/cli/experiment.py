"""The paper's push test: `hwgen experiment` (what a lab should measure, and how) and `hwgen compare`
(what its measurements say about its robot)."""
from __future__ import annotations

from contextlib import nullcontext
from pathlib import Path

import typer
from rich.table import Table
from rich.text import Text

from ..errors import printable
from .common import CACHE_DIR, NO_CACHE, OUT, PARAMS, _cache, _command, _load, err, out

QUIET = typer.Option(False, "--quiet", "-q", help="no spinner")
CORRELATED = 0.9           # fitted values this correlated are said to be told apart poorly


def _ratio_line(ep: dict | None) -> str | None:
    if not ep:
        return None
    band = (f"{ep['low']:.2f}–{ep['high']:.2f}× over {ep['corners']} corners of the ranges, {ep['width']:.2f}× wide"
            if ep["corners"] else "no band: the design gives no experiment.ranges")
    where = f" ({'inside' if ep['paper_inside'] else 'outside'} the band)" if ep["corners"] else ""
    return (f"endpoint ratio {ep['state']}/{ep['over']} at disk {ep['disk']}: {ep['nominal']:.2f}× ({band}); "
            f"the paper measured {ep['paper']:g}× on its prototype{where}")


@_command
def experiment(params: Path = PARAMS, out_dir: Path = OUT, quiet: bool = QUIET,
               cache_dir: Path = CACHE_DIR, no_cache: bool = NO_CACHE) -> None:
    """The paper's push test for this robot: what to set, what to push, and the β of eq. (4) a lab should measure, with its band.

    From the parameters (no CAD; the weights from a current build when OUT/<design>/ holds one): experiment/protocol.md, predicted.csv, experiment.json, template.csv and experiment.png in OUT/<design>/.
    """
    loaded = _load(params)
    from ..pipeline import experiment as run

    with err.status(Text(f"pushing {loaded.name}"), spinner="dots") if not quiet else nullcontext():
        res, folder = run(loaded, out_dir, cache_dir=_cache(cache_dir, no_cache))
    t = Table(title=f"{loaded.name}: β of eq. (4) as the bench would fit it, N/mm (the band's low–high)")
    rows = res["rows"]
    states = list(dict.fromkeys(r["state"] for r in rows))
    disks = list(dict.fromkeys(r["disk"] for r in rows))
    shown = [disks[0], disks[len(disks) // 2], disks[-1]] if len(disks) > 2 else disks
    t.add_column("state", justify="left")
    for d in shown:
        t.add_column(f"disk {d}", justify="right")
    by = {(r["state"], r["disk"]): r for r in rows}
    for s in states:
        t.add_row(s, *(f"{by[(s, d)]['beta_n_per_mm']:.4g} ({by[(s, d)]['beta_low_n_per_mm']:.3g}–"
                       f"{by[(s, d)]['beta_high_n_per_mm']:.3g})" for d in shown))
    out.print(t)
    line = _ratio_line(res["endpoint_ratio"])
    if line:
        out.print(Text(line))
    out.print(Text(f"model: {res['model']}"))
    for name in ("protocol.md", "predicted.csv", "experiment.json", "template.csv", "experiment.png"):
        out.print(f"  {printable(folder / 'experiment' / name)}")


@_command
def compare(params: Path = PARAMS,
            measured: Path = typer.Argument(..., help="the lab's samples: a CSV with template.csv's columns",
                                            show_default=False),
            out_dir: Path = OUT, quiet: bool = QUIET) -> None:
    """A lab's pushes against the prediction, and the values the paper does not give fitted to them.

    Fits eq. (4) per state and disk (its interval from the repetitions), sets each beside the prediction for the pushes made, with its band, then fits the ranged values (experiment.ranges) to the measured β: experiment/compare.json, compare.png and calibrated.yaml (the design with the fitted values) in OUT/<design>/.
    """
    loaded = _load(params)
    from ..pipeline import compare as run

    with err.status(Text(f"fitting {loaded.name} to {measured}"), spinner="dots") if not quiet else nullcontext():
        res, folder = run(loaded, measured, out_dir)
    t = Table(title=f"{loaded.name}: measured against predicted, β N/mm")
    for col in ("state", "disk", "measured (interval)", "predicted (band)", "within"):
        t.add_column(col, justify="left" if col == "state" else "right")
    for r in res["rows"]:
        t.add_row(r["state"], str(r["disk"]),
                  f"{r['measured_n_per_mm']:.4g} ({r['interval'][0]:.3g}–{r['interval'][1]:.3g})",
                  f"{r['predicted_n_per_mm']:.4g} ({r['low_n_per_mm']:.3g}–{r['high_n_per_mm']:.3g})",
                  "yes" if r["within"] else "NO")
    out.print(t)
    inside = sum(r["within"] for r in res["rows"])
    out.print(f"{inside} of {len(res['rows'])} measured β meet the predicted band")
    f = Table(title="fitted to the measured β (95 % interval)")
    for col in ("field", "design", "fitted", "interval"):
        f.add_column(col, justify="left" if col == "field" else "right")
    for name, v in res["fitted"].items():
        f.add_row(name, f"{v['design']:.4g}", f"{v['value']:.4g}", f"{v['low']:.4g}–{v['high']:.4g}")
    if res["fitted"]:
        out.print(f)
        corr = res["calibration"]["correlation"]
        pairs = sorted({tuple(sorted((a, b))) for a, row in corr.items() for b, v in row.items()
                        if abs(v) >= CORRELATED})
        for a, b in pairs:
            out.print(Text(f"note: {a} and {b} are correlated {corr[a][b]:+.2f} in the fit: the pushes tell what "
                           "they do together better than either alone; measure one of them to pin the other"))
    else:
        out.print(Text(res["calibration"].get("note", "nothing fitted")))
    for name in ("compare.json", "compare.png", "calibrated.yaml"):
        out.print(f"  {printable(folder / 'experiment' / name)}")
