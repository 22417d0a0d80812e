"""The files of `hwgen experiment` and `hwgen compare`, from their JSON (:mod:`hwgen.model.experiment`,
:mod:`hwgen.model.calibration`): protocol.md (the paper's procedure for this robot), predicted.csv,
template.csv (what a lab fills in), experiment.png in the manner of the paper's Fig. 8 with the
band; compare.png (measured against predicted)."""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..model import protocol
from ..model.calibration import COLUMNS as MEASURED_COLUMNS
from .plots import pyplot, save

PREDICTED_COLUMNS = ("state", "disk", "s_mm", "push_mm", "beta_n_per_mm", "beta_low_n_per_mm", "beta_high_n_per_mm")


def write_predicted(result: dict, path: Path) -> None:
    """predicted.csv: a row per state and disk."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(PREDICTED_COLUMNS)
        for r in result["rows"]:
            w.writerow([r["state"], r["disk"], f"{r['s_mm']:.2f}", f"{r['push_mm']:.2f}"]
                       + [f"{r[c]:.6g}" for c in PREDICTED_COLUMNS[4:]])


def write_template(result: dict, path: Path) -> None:
    """template.csv: the columns a lab fills, a line per state, disk and repetition in the order they
    are pushed (each to be replaced by that push's samples, one line per sample)."""
    reps = result["settings"]["repetitions"]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(MEASURED_COLUMNS)
        for r in result["rows"]:
            for k in range(1, reps + 1):
                w.writerow([r["state"], r["disk"], k, "", ""])


def _turns(t: dict) -> str:
    if t["worm_turns"] is None:
        return f"by {t['take_in_mm']:.1f} mm of line ({t['take_in_low_mm']:.1f}–{t['take_in_high_mm']:.1f})"
    return (f"{t['worm_turns']:.2f} turns ({t['worm_turns_low']:.2f}–{t['worm_turns_high']:.2f} over the band's "
            f"springs; {t['take_in_mm']:.2f} mm of line)")


def _channel(tendons: list[dict]) -> str:
    """What to do with one channel's worm: one worm pulls every tendon of the channel."""
    given = any(t["from"] == "pretension_n" for t in tendons)
    same = len({(round(t["set_n"], 2), round(t["take_in_mm"], 2)) for t in tendons}) == 1
    if same and not given:
        names = ", ".join(t["tendon"] for t in tendons)
        each = " each" if len(tendons) > 1 else ""
        return f"turn its worm {_turns(tendons[0])}: {names} to {tendons[0]['set_n']:.2f} N{each}"
    return "; ".join(f"{protocol.set_words(t['tendon'], t['set_n'], t['from'])}: {_turns(t)}" for t in tendons)


def _state_lines(state: dict, rows: list[dict]) -> list[str]:
    out = [f"### {state['state']}", ""]
    if not state["channels"]:
        out += ["No tendon is tensioned: slacken every worm until its line hangs loose (the strip alone, "
                "the paper's N).", ""]
    else:
        out += ["1. Slacken every worm until its line hangs loose; then, for each channel in turn, wind its "
                "worm until the line is just taut (no sag between the disks, no tension on a hand-held gauge) "
                "and turn it on as below."]
        for n, c in enumerate(state["channels"], start=2):
            roll = ("on edge, the strip's height vertical (roll 90°), so that the weight bends only its stiff "
                    "direction" if c["on_edge"] else f"rolled to {c['roll_deg']:g}°" if c["roll_deg"] is not None
                    else "weightless")
            out.append(f"{n}. Channel {c['channel']}, the robot {roll}: {_channel(c['tendons'])}; the worm holds it.")
        locked = protocol.locked_words({t["tendon"]: t["locked_n"] for c in state["channels"] for t in c["tendons"]})
        out += [f"{len(state['channels']) + 2}. Roll the robot to {state['push_roll_deg']:g}° for the pushes. "
                f"Locked, the tendons then carry {locked}." if state["push_roll_deg"] is not None else
                f"{len(state['channels']) + 2}. Locked, the tendons carry {locked}."]
        out += [f"   - {n}" for n in state["notes"]]
        out.append("")
    out += ["| disk | s mm | push mm | peak force N (band's top) | β N/mm predicted (band) | slack in the push |",
            "|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        out.append(f"| {r['disk']} | {r['s_mm']:.1f} | {r['push_mm']:.2f} | {r['peak_force_n']:.2f} "
                   f"({r['peak_force_high_n']:.2f}) | {r['beta_n_per_mm']:.4g} ({r['beta_low_n_per_mm']:.4g}–"
                   f"{r['beta_high_n_per_mm']:.4g}) | {', '.join(r['slackened']) or '–'} |")
    return out + [""]


def write_protocol(result: dict, path: Path) -> None:
    """protocol.md: the paper's procedure (Sect. III-B, III-C) for this robot, step by step."""
    s = result["settings"]
    ep = result["endpoint_ratio"]
    lines = [f"# {result['design']}: the push test, step by step", "",
             "The paper's experiment (Sect. III-B's tensioning, Sect. III-C's pushes) for this robot, with what "
             "hwgen predicts each push measures (`predicted.csv`, `experiment.json`, `experiment.png`). Record "
             "every push in `template.csv`'s columns and run `hwgen compare` on it.", "",
             "## The bench", "",
             f"- The robot horizontal, clamped at its base disk, {s['orientation']} "
             f"(the strip's flexible direction vertical{', C1 up' if s['orientation'] == 'gravity -z' else ''}).",
             f"- The load cell ({s['load_cell_range_n']:g} N range) on the arm, pushing the centre of each disk "
             f"toward {s['push_toward']} at {s['displacement_rate_mm_s']:g} mm/s, out by the push below and back "
             f"to where it started, {s['repetitions']} times at each disk, disks {s['disks'][0]} to "
             f"{s['disks'][-1]} in that order (disk 1 is the clamped base, as the paper counts).",
             f"- Record the arm's displacement along the push and the force at {s['sample_rate_hz']:g} samples "
             f"a second; eq. (4) is fitted to {s['fit_window_samples']} samples either side of each peak "
             f"({s['window_mm']:.1f} mm of travel).",
             f"- Each push is as long as keeps the force within {100 * s['load_fraction']:.0f} % of the load "
             f"cell's range for the stiffest robot of the band, at most {s['max_push_mm']:g} mm.", ""]
    if result["ranges"]:
        lines += ["The band spans: " + "; ".join(f"`{r['field']}` {r['low']:g}–{r['high']:g} (nominal "
                                                  f"{r['nominal']:g})" for r in result["ranges"])
                  + " (each with its reason in the design's YAML).", ""]
    if ep:
        band = (f"{ep['low']:.2f}–{ep['high']:.2f}× over the band's corners; the paper measured {ep['paper']:g}× on "
                f"its prototype, {'inside' if ep['paper_inside'] else 'outside'} the band" if ep["corners"] else
                f"no band: no experiment.ranges; the paper measured {ep['paper']:g}× on its prototype")
        lines += [f"Predicted endpoint ratio {ep['state']}/{ep['over']} at disk {ep['disk']}: {ep['nominal']:.2f}× "
                  f"({band}).", ""]
    lines += ["## The states, in order", "",
              "Each state is tensioned from the robot untensioned: tensions as `hwgen stiffness` computes them (the "
              "paper's protocol); worm turns counted from the line just taut, from the line's spring (EA over its "
              "free length, with the tie-off's give), the drum and the gear ratio, with the band's springs in "
              "brackets.", ""]
    for st in result["states"]:
        lines += _state_lines(st, [r for r in result["rows"] if r["state"] == st["state"]])
    lines += ["## What is assumed", "", *[f"- {a}" for a in result["assumptions"]], "", f"Model: {result['model']}.",
              ""]
    Path(path).write_text("\n".join(lines))


def plot_experiment(result: dict, path: Path, measured: dict | None = None) -> None:
    """experiment.png (and compare.png, with ``measured``): :func:`experiment_figure` written."""
    save(pyplot(), experiment_figure(result, measured), path)


def experiment_figure(result: dict, measured: dict | None = None):
    """Bars grouped by disk, a colour per state (the paper's Fig. 8), each up to the predicted β
    with the band as an error bar; with ``measured`` (compare.json), the measured β and its
    interval as black markers."""
    plt = pyplot()
    from matplotlib.patches import Patch
    rows = result["rows"]
    states = list(dict.fromkeys(r["state"] for r in rows))
    disks = list(dict.fromkeys(r["disk"] for r in rows))
    n = len(states)
    width = 0.8 / max(n, 1)
    fig, ax = plt.subplots(figsize=(11, 4.6))
    cmap = plt.get_cmap("viridis")
    colours = [cmap(j / max(n - 1, 1)) for j in range(n)]
    where = {(r["state"], r["disk"]): disks.index(r["disk"]) + (states.index(r["state"]) - (n - 1) / 2) * width
             for r in rows}
    at = np.array([where[(r["state"], r["disk"])] for r in rows])
    beta = np.array([r["beta_n_per_mm"] for r in rows])
    lo = np.array([r["beta_low_n_per_mm"] for r in rows])
    hi = np.array([r["beta_high_n_per_mm"] for r in rows])
    ax.bar(at, beta, width, color=[colours[states.index(r["state"])] for r in rows])
    ax.errorbar(at, beta, yerr=[beta - lo, hi - beta], fmt="none", ecolor="0.25", elinewidth=0.8, capsize=1.5)
    if measured:
        m = [r for r in measured["rows"] if (r["state"], r["disk"]) in where]
        mx = np.array([where[(r["state"], r["disk"])] for r in m])
        mb = np.array([r["measured_n_per_mm"] for r in m])
        ax.errorbar(mx, mb, yerr=[mb - np.array([r["interval"][0] for r in m]),
                                  np.array([r["interval"][1] for r in m]) - mb],
                    fmt="o", color="k", ms=3, elinewidth=0.8, label="measured (interval)")
    ax.set_yscale("log")
    ax.set_xticks(range(len(disks)), [str(d) for d in disks])
    ax.set_xlabel("tendon support disk pushed (1 = base, clamped)")
    ax.set_ylabel("β of eq. (4), N/mm")
    s = result["settings"]
    title = (f"β as the bench would fit it: pushed toward {s['push_toward']} ({s['orientation']}), bars nominal, "
             "whiskers the band")
    ep = result.get("endpoint_ratio")
    if ep:
        title += (f"\n{ep['state']}/{ep['over']} at disk {ep['disk']}: {ep['nominal']:.2f}× "
                  f"({ep['low']:.2f}–{ep['high']:.2f}×); paper {ep['paper']:g}×")
    ax.set_title(title, fontsize=9)
    handles = [Patch(color=colours[j], label=st) for j, st in enumerate(states)]
    if measured:
        handles.append(ax.get_legend_handles_labels()[0][-1])
    ax.legend(handles=handles, ncol=min(len(handles), 10), fontsize=7, loc="upper right")
    ax.grid(axis="y", which="both", alpha=0.3)
    fig.tight_layout()
    return fig
