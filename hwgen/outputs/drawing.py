"""exploded.svg: a hidden-line drawing of the exploded assembly, balloons and a parts table.

Hidden lines are removed against a depth buffer rather than by the CAD kernel (CadQuery's
projection of a whole assembly with gears is far too slow for a build): the exploded parts are drawn
once, flat, into an offscreen depth buffer; every sharp mesh edge and every silhouette edge
of the same view is sampled about once per pixel and kept where nothing lies in front of it.
The result is the line drawing of the PNG's view, to scale.
"""
from __future__ import annotations

from pathlib import Path
from html import escape as _escape

import numpy as np

from .scene import Posed
from .view import ISOMETRIC, Look, Renderer


def escape(text: str) -> str:
    """&, < and > as entities (quotes as they are): the SVG's text and attribute values."""
    return _escape(text, quote=False)

DEPTH_WIDTH_PX = 3200        # depth buffer width: ~0.2 mm per pixel for the prototype's exploded view
SAMPLE_PX = 0.8              # edges are tested every this many pixels
DEPTH_TOL_MM = 0.25          # a point this far behind the nearest surface still counts as on it
PAGE_WIDTH = 1200.0          # SVG user units across the drawing (the table and margins add to it)
LINE_WIDTH = 0.55
OUTLINE_WIDTH = 0.9
BALLOON_R = 13.0
BALLOON_GAP = 40.0           # balloons sit this far outside the drawing
PAGE_MARGIN = 30.0
ROW_H = 22.0
CHAR_W = 6.8                 # generous mean width of a 12-unit sans-serif character, for table columns
FONT = "DejaVu Sans, Arial, Helvetica, sans-serif"


def _projector(ren, W: int, H: int):
    """world (n, 3) -> display x, y (pixels from bottom-left) and depth 0..1."""
    cam = ren.GetActiveCamera()
    vm = cam.GetCompositeProjectionTransformMatrix(W / H, -1, 1)
    M = np.array([[vm.GetElement(i, j) for j in range(4)] for i in range(4)])

    def project(P: np.ndarray) -> np.ndarray:
        h = np.c_[P, np.ones(len(P))] @ M.T
        ndc = h[:, :3] / h[:, 3:4]
        return np.column_stack([(ndc[:, 0] + 1) / 2 * W, (ndc[:, 1] + 1) / 2 * H, (ndc[:, 2] + 1) / 2])
    near, far = cam.GetClippingRange()
    return project, DEPTH_TOL_MM / (far - near)


MAX3_ROWS = 256      # _max3 works through the depth buffer this many rows at a time, in place (copies of the
#                      whole 3200-pixel buffer were the renderer's largest allocations)


def _max3(z: np.ndarray) -> np.ndarray:
    """Largest depth in each pixel's 3x3 neighbourhood (edges lie on the border of their faces;
    beyond the image's border the border pixel counts again), written over ``z`` and returned."""
    rows = z.shape[0]
    above = None                # the row above the block, as it was
    for i0 in range(0, rows, MAX3_ROWS):
        i1 = min(i0 + MAX3_ROWS, rows)
        src = np.vstack([z[i0:i0 + 1] if above is None else above, z[i0:i1], z[min(i1, rows - 1)][None]])
        p = np.pad(src, ((0, 0), (1, 1)), mode="edge")
        above = src[-2:-1]
        block = z[i0:i1]
        for dy in (0, 1, 2):
            for dx in (0, 1, 2):
                np.maximum(block, p[dy:dy + i1 - i0, dx:dx + z.shape[1]], out=block)
    return z


def visible_runs(segments: np.ndarray, project, zmax: np.ndarray, tol: float):
    """Visible pieces of world segments (k, 2, 3), in display pixels (m, 2, 2), and the visible samples."""
    if len(segments) == 0:
        return np.zeros((0, 2, 2)), np.zeros((0, 2))
    a = project(segments[:, 0])
    b = project(segments[:, 1])
    n = np.maximum(1, np.ceil(np.linalg.norm((b - a)[:, :2], axis=1) / SAMPLE_PX).astype(int))
    idx = np.repeat(np.arange(len(a)), n)
    k = np.arange(len(idx)) - np.repeat(np.cumsum(n) - n, n)     # each sample's index within its edge
    t = ((k + 0.5) / n[idx])[:, None]
    s = a[idx] + t * (b[idx] - a[idx])
    H, W = zmax.shape
    col = np.clip(s[:, 0].astype(int), 0, W - 1)
    row = np.clip(s[:, 1].astype(int), 0, H - 1)
    vis = s[:, 2] <= zmax[row, col] + tol
    # runs of consecutive visible pieces within one edge
    t0 = (k / n[idx])[:, None]
    t1 = ((k + 1) / n[idx])[:, None]
    p0 = a[idx, :2] + t0 * (b[idx, :2] - a[idx, :2])
    p1 = a[idx, :2] + t1 * (b[idx, :2] - a[idx, :2])
    start = vis & ~np.r_[False, vis[:-1] & (idx[1:] == idx[:-1])]
    end = vis & ~np.r_[vis[1:] & (idx[1:] == idx[:-1]), False]
    return np.stack([p0[start], p1[end]], axis=1), s[vis, :2]


def chain(segments: np.ndarray, decimals: int = 2) -> list[np.ndarray]:
    """Join segments that share end points (equal when rounded to ``decimals``) into polylines
    (fewer, shorter path commands): from each segment not yet used, forward from its second end,
    then back from its first, each time taking the first unused segment that meets the tip."""
    if len(segments) == 0:
        return []
    ends_xy = segments.reshape(-1, 2)
    # one integer per distinct rounded point (+ 0.0 makes -0.0 the same point as 0.0)
    _, inverse = np.unique(np.round(ends_xy, decimals) + 0.0, axis=0, return_inverse=True)
    key = inverse.ravel().tolist()
    ends: dict[int, list[int]] = {}
    for i, k in enumerate(key):
        ends.setdefault(k, []).append(i // 2)
    used = [False] * len(segments)
    lines = []
    for s in range(len(segments)):
        if used[s]:
            continue
        used[s] = True
        seq = [2 * s, 2 * s + 1]            # end points (rows of ends_xy) of the polyline, in order
        for forward in (True, False):
            while True:
                tip = key[seq[-1] if forward else seq[0]]
                nxt = next((o for o in ends.get(tip, ()) if not used[o]), None)
                if nxt is None:
                    break
                used[nxt] = True
                far = 2 * nxt + 1 if key[2 * nxt] == tip else 2 * nxt
                if forward:
                    seq.append(far)
                else:
                    seq.insert(0, far)
        lines.append(ends_xy[seq])
    return lines


def _path(lines: list[np.ndarray], to_page) -> str:
    out = []
    for ln in lines:
        q = to_page(ln)
        out.append("M" + " L".join(f"{x:.1f} {y:.1f}" for x, y in q.tolist()))
    return " ".join(out)


def _name_range(names: list[str]) -> str:
    return names[0] if len(names) == 1 else (", ".join(names) if len(names) <= 3 else f"{names[0]} … {names[-1]}")


def _anchor_member(members: dict[str, list[np.ndarray]], to_page, axis: np.ndarray) -> np.ndarray | None:
    """Visible points (page) of the family member a balloon points at: a well-visible one near
    the middle of the family along the drawing's axis."""
    pts = {name: to_page(np.vstack(v)) for name, v in members.items() if sum(len(x) for x in v)}
    if not pts:
        return None
    most = max(len(v) for v in pts.values())
    mid = np.median(np.vstack(list(pts.values())) @ axis)
    good = [v for v in pts.values() if len(v) >= 0.5 * most]
    return min(good, key=lambda v: abs(np.mean(v @ axis) - mid))


def write_exploded_svg(renderer: Renderer, posed: list[Posed], colours: dict, table: list[dict], path: Path,
                       title: str) -> dict:
    """Draw the exploded assembly as visible lines with one balloon per family and a parts table
    (``posed``: the parts rigidly posed as exploded.png shows them, seen along ISOMETRIC)."""
    view = ISOMETRIC
    ren, W, H = renderer.draw(posed, colours, view, None,
                              look=Look(aspect_range=(0.3, 2.0), margin=0.02, edges=False, shading=False,
                                        width=DEPTH_WIDTH_PX))
    zmax = _max3(renderer.depth(W, H, rows_up=True))     # bottom-up rows, as display coordinates
    project, tol = _projector(ren, W, H)
    renderer.release()                  # the scene is read: its memory goes before the lines are found
    scale = PAGE_WIDTH / W

    def to_page(p: np.ndarray) -> np.ndarray:
        return np.column_stack([PAGE_MARGIN + p[:, 0] * scale, PAGE_MARGIN + 40 + (H - p[:, 1]) * scale])

    groups, visible_pts, n_runs = _visible_lines(posed, project, zmax, tol, to_page)
    balloons, page_pts = _balloons(table, visible_pts, to_page)
    parts_table, (x1, y1) = _parts_table(table, page_pts)
    xmax, ymax = page_pts.max(axis=0)
    width = max(xmax, x1) + PAGE_MARGIN
    height = max(ymax, y1) + PAGE_MARGIN
    svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height:.0f}" '
           f'viewBox="0 0 {width:.1f} {height:.1f}" font-family="{FONT}">',
           f'<title>{escape(title)}</title>',
           '<rect width="100%" height="100%" fill="#fff"/>',
           f'<text x="{PAGE_MARGIN}" y="{PAGE_MARGIN + 10}" font-size="18" font-weight="bold">{escape(title)}</text>',
           f'<text x="{PAGE_MARGIN}" y="{PAGE_MARGIN + 30}" font-size="11" fill="#444">Hidden lines removed; parallel '
           f'projection, the view of exploded.png; balloons number the part families of the table.</text>',
           '<g class="drawing" fill="none" stroke="#000" stroke-linecap="round" stroke-linejoin="round">',
           *groups, "</g>",
           '<g class="balloons" stroke="#000">', *balloons, "</g>",
           *parts_table, "</svg>"]
    Path(path).write_text("\n".join(svg) + "\n", encoding="utf-8")
    return {"balloons": len(balloons), "rows": len(table), "runs": n_runs,
            "depth_px": [W, H], "bytes": Path(path).stat().st_size}


def _visible_lines(posed: list[Posed], project, zmax, tol, to_page):
    """Each part's visible feature and silhouette edges as SVG paths; the visible points per
    family and part (for the balloons) and how many runs were drawn."""
    groups, visible_pts, n_runs = [], {}, 0
    for ps in posed:
        p = ps.part
        body = []
        for pairs, width in ((p.feature_edges(), LINE_WIDTH), (ps.silhouette, OUTLINE_WIDTH)):
            runs, pts = visible_runs(ps.vertices[pairs], project, zmax, tol)
            n_runs += len(runs)
            if len(runs):
                body.append(f'<path class="{"edge" if width == LINE_WIDTH else "outline"}" '
                            f'stroke-width="{width}" d="{_path(chain(runs), to_page)}"/>')
            visible_pts.setdefault(p.role, {}).setdefault(p.name, []).append(pts)
        groups.append(f'<g class="part" data-part="{escape(p.name)}" data-family="{escape(p.role)}">'
                      + "".join(body) + "</g>")
    return groups, visible_pts, n_runs


def _balloons(table: list[dict], visible_pts: dict, to_page) -> tuple[list[str], np.ndarray]:
    """One balloon per family on the empty side of the drawing, its leader to a visible edge.
    Returns the SVG groups and every page point the drawing and balloons cover."""
    allv = np.vstack([np.vstack(v) for fam in visible_pts.values() for v in fam.values() if len(np.vstack(v))])
    page_pts = to_page(allv)
    centre = page_pts.mean(axis=0)
    _, _, vt = np.linalg.svd(page_pts - centre, full_matrices=False)
    axis = vt[0] if vt[0][0] >= 0 else -vt[0]
    normal = np.array([axis[1], -axis[0]])          # points up the page (y down) when the axis runs right
    if normal[1] > 0:
        normal = -normal
    reach = ((page_pts - centre) @ normal).max() + BALLOON_GAP
    anchors, placed = {}, []
    for row in table:
        pts = _anchor_member(visible_pts.get(row["role"], {}), to_page, axis)
        if pts is None:
            continue
        # the member's edge nearest the balloons, near its middle: a short leader that crosses nothing
        along_m = (pts - np.median(pts, axis=0)) @ axis
        anchor = pts[np.argmax((pts - centre) @ normal - 0.5 * np.abs(along_m))]
        anchors[row["item"]] = anchor
        placed.append([row, (anchor - centre) @ axis])
    placed.sort(key=lambda b: b[1])
    for i in range(1, len(placed)):                # keep balloons apart along the axis
        placed[i][1] = max(placed[i][1], placed[i - 1][1] + 2.6 * BALLOON_R)
    out = []
    for row, along in placed:
        c = centre + axis * along + normal * reach
        a = anchors[row["item"]]
        v = a - c
        edge = c + v / max(np.linalg.norm(v), 1e-9) * BALLOON_R
        out.append(
            f'<g class="balloon" data-item="{row["item"]}" data-family="{escape(row["role"])}">'
            f'<line x1="{edge[0]:.1f}" y1="{edge[1]:.1f}" x2="{a[0]:.1f}" y2="{a[1]:.1f}" stroke-width="0.6"/>'
            f'<circle cx="{a[0]:.1f}" cy="{a[1]:.1f}" r="1.8" fill="#000"/>'
            f'<circle cx="{c[0]:.1f}" cy="{c[1]:.1f}" r="{BALLOON_R}" fill="#fff" stroke-width="1"/>'
            f'<text x="{c[0]:.1f}" y="{c[1] + 5:.1f}" text-anchor="middle" font-size="14" stroke="none" '
            f'fill="#000">{row["item"]}</text></g>')
        page_pts = np.vstack([page_pts, c + BALLOON_R, c - BALLOON_R])
    return out, page_pts


def _parts_table(table: list[dict], page_pts: np.ndarray) -> tuple[list[str], tuple[float, float]]:
    """The parts table: in the empty lower-right corner if it fits, else below the drawing.
    Returns the SVG and the table's lower-right corner."""
    body = [[str(row["item"]), row["label"], str(row["qty"]), row["kind"], row["material"],
             _name_range(row["parts"])] for row in table]
    heads = ["Item", "Part family", "Qty", "Kind", "Material", "Parts"]
    cols = [(h, CHAR_W * max(len(c) for c in [h] + [b[i] for b in body]) + 12) for i, h in enumerate(heads)]
    tw = sum(w for _, w in cols)
    th = ROW_H * (len(table) + 1)
    xmax, ymax = page_pts.max(axis=0)
    x0, y0 = xmax - tw, ymax - th
    if ((page_pts[:, 0] > x0 - 10) & (page_pts[:, 1] > y0 - 10)).any():
        y0 = ymax + 30
    t = [f'<g class="parts-table" transform="translate({x0:.1f},{y0:.1f})" font-size="12" stroke="none" '
         f'fill="#000">',
         f'<rect x="0" y="0" width="{tw}" height="{th}" fill="none" stroke="#000" stroke-width="0.8"/>']
    x = 0.0
    for name, w in cols:
        t.append(f'<text x="{x + 5:.1f}" y="{ROW_H - 7:.1f}" font-weight="bold">{name}</text>')
        x += w
    for i, (row, cells) in enumerate(zip(table, body), start=1):
        y = ROW_H * i
        t.append(f'<g class="bom-row" data-item="{row["item"]}" data-family="{escape(row["role"])}">'
                 f'<line x1="0" y1="{y:.1f}" x2="{tw}" y2="{y:.1f}" stroke="#000" stroke-width="0.4"/>')
        x = 0.0
        for (_, w), cell in zip(cols, cells):
            t.append(f'<text x="{x + 5:.1f}" y="{y + ROW_H - 7:.1f}">{escape(cell)}</text>')
            x += w
        t.append("</g>")
    x = 0.0
    for _, w in cols[:-1]:
        x += w
        t.append(f'<line x1="{x}" y1="0" x2="{x}" y2="{th}" stroke="#000" stroke-width="0.4"/>')
    t.append("</g>")
    return t, (x0 + tw, y0 + th)
