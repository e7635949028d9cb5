"""A fleet view as one self-contained HTML page: overview, RUL ranking, a figure per unit.

`render_html` draws a `view.FleetView`: the count of units by level and the units naming
each fault, the ranking table in the view's order (``<tr data-unit data-fault data-level>``)
and a ``<section id="unit-ID">`` per unit with the severity history of one entry (90 %
interval, truth when known, the WARN and ERROR severities) beside its RUL cone.  The entry is
`view.shown_fault`'s, the one the unit's headline names; when it has no RUL the section says
why (`view.no_rul_reason`).  Figures span the page's width; they are inline base64 PNGs and
the CSS and script are inline: the page fetches nothing, so it can be mailed or archived as
one file.  `write_report` writes it atomically.
"""

from __future__ import annotations

import base64
import html
import io
import math
import textwrap
from collections.abc import Sequence
from pathlib import Path
from urllib.parse import quote

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..atomic_file import write_text_atomic
from ..domain.faults import NAMES, Fault, fault
from ..errors import ConfigError
from .view import (
    LEVELS,
    FleetView,
    Percentiles,
    UnitView,
    WindowPoint,
    no_rul_reason,
    not_seen,
    shown_fault,
)

#: Figure size (inches) and resolution: 1,350 x 430 px, the content width of a 1,400 px page,
#: drawn at its own size there (CSS scales it to the width of other pages).
FIG_SIZE = (13.5, 4.3)
FIG_DPI = 100

_CSS = """
body{font-family:system-ui,sans-serif;margin:1.5em;color:#222}
table{border-collapse:collapse;font-size:0.9em}
th,td{border:1px solid #ccc;padding:0.25em 0.5em;text-align:left;vertical-align:top}
#ranking th{cursor:pointer;background:#f0f0f0}
td.num{text-align:right}
td a{white-space:nowrap}
.lvl-ERROR{background:#f8d0d0}.lvl-WARN{background:#fbeec0}
.lvl-OK{background:#d8f0d8}.lvl-UNKNOWN{background:#e4e4e4}
section{border-top:1px solid #bbb;margin-top:1.5em}
section img{display:block;width:100%;height:auto}
.no-rul{font-style:italic}
.meta{color:#666;font-size:0.85em}
"""

# Sorts the ranking by a clicked header (numbers by data-v, then text); marks the page ready.
_SCRIPT = """
(function () {
  "use strict";
  function key(td) {
    var v = td.hasAttribute("data-v") ? td.getAttribute("data-v") : td.textContent;
    var n = Number(v);
    return v !== "" && !isNaN(n) ? n : v.toLowerCase();
  }
  function cmp(x, y) {
    if (typeof x !== typeof y) { return typeof x === "number" ? -1 : 1; }
    return x < y ? -1 : (x > y ? 1 : 0);
  }
  function sortBy(table, th, col) {
    var body = table.tBodies[0];
    var rows = Array.prototype.slice.call(body.rows);
    var dir = th.getAttribute("data-dir") === "asc" ? -1 : 1;
    rows.sort(function (a, b) { return dir * cmp(key(a.cells[col]), key(b.cells[col])); });
    th.setAttribute("data-dir", dir === 1 ? "asc" : "desc");
    rows.forEach(function (r) { body.appendChild(r); });
  }
  document.addEventListener("DOMContentLoaded", function () {
    var table = document.getElementById("ranking");
    if (table) {
      Array.prototype.forEach.call(table.tHead.rows[0].cells, function (th, col) {
        th.addEventListener("click", function () { sortBy(table, th, col); });
      });
    }
    document.body.dataset.ready = "1";
  });
})();
"""

_COLUMNS = (
    "rank",
    "unit",
    "level",
    "fault",
    "RUL p5 (cycles)",
    "RUL p50 (cycles)",
    "RUL p95 (cycles)",
    "RUL p5 / p50 / p95 (h)",
    "last cycle",
    "windows diagnosed / counted",
    "commissioned",
    "headline",
)


def _esc(value: object) -> str:
    return html.escape(str(value), quote=True)


def _anchor(unit_id: str) -> str:
    """The href of a unit's section (percent-encoded: browsers decode fragments to match)."""
    return "#unit-" + quote(unit_id, safe="")


def _num(v: float, digits: int) -> str:
    return f"{v:.{digits}f}" if math.isfinite(v) else "&infin;"


def _fitted(unit: UnitView) -> list[WindowPoint]:
    return [p for p in unit.history if p.k is not None]


def _fault_of(unit: UnitView) -> Fault | None:
    """The entry a unit's section names and plots: `view.shown_fault`'s."""
    name = shown_fault(unit)
    return None if name is None else fault(name)


def _sev(values: Sequence[float] | None, f: Fault) -> float:
    if values is None or f.index >= len(values):
        return math.nan
    return abs(values[f.index] - f.nominal)


def _sev_band(p: WindowPoint, f: Fault) -> tuple[float, float]:
    """Severity interval of k's interval: 0 at the bottom when it straddles the healthy value."""
    if p.k_low is None or p.k_high is None or f.index >= min(len(p.k_low), len(p.k_high)):
        return math.nan, math.nan
    lo, hi = p.k_low[f.index] - f.nominal, p.k_high[f.index] - f.nominal
    top = max(abs(lo), abs(hi))
    return (0.0 if lo <= 0.0 <= hi else min(abs(lo), abs(hi))), top


def _draw_severity(ax: Axes, unit: UnitView, f: Fault) -> None:
    fitted = _fitted(unit)
    cycles = np.array([p.cycle for p in fitted], dtype=float)
    band = np.array([_sev_band(p, f) for p in fitted], dtype=float).reshape(-1, 2)
    if np.isfinite(band).any():
        ax.fill_between(cycles, band[:, 0], band[:, 1], color="C0", alpha=0.2, label="90 %")
    sev = np.array([_sev(p.k, f) for p in fitted])
    counted = np.array([p.status == "counted" for p in fitted], dtype=bool)
    ax.plot(cycles, sev, "-", color="C0", lw=1)
    ax.plot(cycles[counted], sev[counted], "o", color="C0", ms=4, label="counted")
    if (~counted).any():
        ax.plot(
            cycles[~counted], sev[~counted], "o", mfc="none", color="C0", ms=4, label="left out"
        )
    truth = np.array([_sev(p.k_true, f) for p in fitted])
    if np.isfinite(truth).any():
        ax.plot(cycles, truth, "--", color="k", lw=1, label="truth")
    if f.warn > 0.0:
        ax.axhline(f.warn, color="orange", lw=1, label="WARN")
    if f.error > 0.0:
        ax.axhline(f.error, color="red", lw=1, label="ERROR")
    # both thresholds in view, so a low severity reads as far from them
    shown = np.concatenate([band[:, 1], sev, truth])
    top = float(np.max(shown[np.isfinite(shown)], initial=f.error))
    top = 1.15 * top if top > 0.0 else 1.0
    ax.set_ylim(-0.04 * top, top)  # below 0: a healthy unit's points are not cut in half
    ax.set_ylabel("severity")
    ax.set_title(f"{f.label} {f.title}: severity |k - {f.nominal:g}|", fontsize=11)
    ax.set_xlabel("cycle")
    ax.legend(fontsize=9, loc="best", ncol=3)


def _draw_rul(ax: Axes, unit: UnitView, f: Fault) -> None:
    points = [(p.cycle, p.rul[f.name]) for p in unit.history if f.name in p.rul]
    rul = np.array([(r.p5, r.p50, r.p95) for _, r in points], dtype=float).reshape(-1, 3)
    finite = rul[np.isfinite(rul)]
    ax.set_ylabel("RUL (cycles)")
    ax.set_xlabel("cycle")
    ax.set_title(f"{f.label} {f.title}: remaining useful life", fontsize=11)
    if finite.size == 0:
        why = no_rul_reason(unit, f.name) or (
            "never reached within what was sampled" if points else "no RUL"
        )
        note = textwrap.fill(why, 60)
        ax.text(0.5, 0.5, note, ha="center", va="center", transform=ax.transAxes, fontsize=10)
        ax.set_yticks([])
        return
    # inf: not reached within what was sampled; drawn at the top, and said so
    cap = 1.1 * float(finite.max()) + 1.0
    capped = np.where(np.isfinite(rul), rul, cap)
    cycles = np.array([c for c, _ in points], dtype=float)
    ax.fill_between(cycles, capped[:, 0], capped[:, 2], color="C1", alpha=0.25, label="p5..p95")
    ax.plot(cycles, capped[:, 1], "-o", color="C1", ms=3, lw=1, label="p50")
    if not np.isfinite(rul).all():
        ax.axhline(cap, color="grey", lw=0.5, ls=":", label="beyond sampled")
    ax.set_ylim(bottom=0.0)
    ax.legend(fontsize=9, loc="upper right", ncol=3)


def _figure_png(unit: UnitView, f: Fault) -> str:
    """The unit's two panels as a base64 PNG."""
    fig = Figure(figsize=FIG_SIZE, dpi=FIG_DPI)
    FigureCanvasAgg(fig)
    # fixed margins: a layout engine measures every label and doubles the drawing time
    fig.subplots_adjust(left=0.05, right=0.99, bottom=0.12, top=0.92, wspace=0.12)
    left, right = fig.subplots(1, 2, sharex=True)
    _draw_severity(left, unit, f)
    _draw_rul(right, unit, f)
    for ax in (left, right):
        ax.tick_params(labelsize=9)
        ax.grid(True, lw=0.3)
    buf = io.BytesIO()
    # no Software chunk: it would carry matplotlib's URL into the page
    fig.savefig(buf, format="png", dpi=FIG_DPI, metadata={"Software": None})
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _unit_section(unit: UnitView) -> str:
    uid = _esc(unit.unit_id)
    head = (
        f'<section id="unit-{uid}"><h3>{uid} &mdash; {_esc(unit.level)}</h3>'
        f"<p>{_esc(unit.headline)}</p>"
        f'<p class="meta">run {_esc(unit.run_id)}; windows diagnosed {unit.windows}, '
        f"counted {unit.counted}, skipped "
        f"{sum(p.status == 'skipped' for p in unit.history)}</p>"
    )
    f = _fault_of(unit)
    if f is None:
        return head + "<p>No window of this unit was fitted yet: nothing to plot.</p></section>"
    which = (
        "the fault named"
        if unit.fault == f.name
        else "no fault named; the most severe entry, as the last window's verdict names it"
    )
    why = no_rul_reason(unit, f.name)
    no_rul = (
        f'<p class="no-rul" data-fault="{_esc(f.name)}">{_esc(f.name)}: {_esc(why)}</p>'
        if why
        else ""
    )
    png = _figure_png(unit, f)
    hidden = "".join(
        f'<p class="not-seen" data-fault="{_esc(name)}">{_esc(name)}: {_esc(why)}</p>'
        for name, why in not_seen(unit).items()
        if name != f.name
    )
    return (
        f'{head}<p class="shown" data-fault="{_esc(f.name)}">Plotted: {_esc(f.label)} '
        f"{_esc(f.name)} ({_esc(which)})</p>{no_rul}{hidden}"
        f'<img data-fault="{_esc(f.name)}" alt="{uid}: {_esc(f.title)} severity and RUL" '
        f'src="data:image/png;base64,{png}"></section>'
    )


def _rul_cells(rul: Percentiles | None, hours: Percentiles | None) -> str:
    if rul is None:
        cells = '<td class="num" data-v="">&ndash;</td>' * 3
    else:
        cells = "".join(
            f'<td class="num" data-v="{v if math.isfinite(v) else "Infinity"}">{_num(v, 0)}</td>'
            for v in (rul.p5, rul.p50, rul.p95)
        )
    if hours is None:
        return cells + '<td data-v="">&ndash;</td>'
    text = " / ".join(_num(v, 1) for v in (hours.p5, hours.p50, hours.p95))
    key = hours.p5 if math.isfinite(hours.p5) else "Infinity"
    return cells + f'<td class="num" data-v="{key}">{text}</td>'


def _row(rank: int, unit: UnitView) -> str:
    uid, name = _esc(unit.unit_id), _esc(unit.fault or "")
    level = _esc(unit.level)
    css = f"lvl-{unit.level}" if unit.level in LEVELS else ""
    last = "" if unit.last_cycle is None else str(unit.last_cycle)
    return (
        f'<tr data-unit="{uid}" data-fault="{name}" data-level="{level}">'
        f'<td class="num">{rank}</td><td><a href="{_esc(_anchor(unit.unit_id))}">{uid}</a></td>'
        f'<td class="{css}" data-v="{LEVELS.index(unit.level) if css else len(LEVELS)}">'
        f"{level}</td><td>{name or '&ndash;'}</td>"
        f"{_rul_cells(unit.rul_cycles, unit.rul_hours)}"
        f'<td class="num" data-v="{last}">{last or "&ndash;"}</td>'
        f'<td class="num" data-v="{unit.windows}">{unit.windows} / {unit.counted}</td>'
        f"<td>{'yes' if unit.commissioned else 'no'}</td><td>{_esc(unit.headline)}</td></tr>"
    )


def _ranking(view: FleetView) -> str:
    if not view.units:
        return "<h2>RUL ranking</h2><p>The store holds no units: nothing to rank.</p>"
    head = "".join(f"<th>{_esc(c)}</th>" for c in _COLUMNS)
    rows = "".join(_row(i, u) for i, u in enumerate(view.units, start=1))
    return (
        "<h2>RUL ranking</h2><p>Most at risk first (level, then RUL p5, then p50); "
        "click a header to sort.</p>"
        f'<table id="ranking"><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>'
    )


def _overview(view: FleetView) -> str:
    counts = "".join(
        f'<tr><td class="lvl-{lv}">{lv}</td><td class="num" data-level="{lv}">'
        f"{sum(u.level == lv for u in view.units)}</td></tr>"
        for lv in LEVELS
    )
    named = [u.fault for u in view.units if u.fault]
    order = [n for n in NAMES if n in named] + sorted({n for n in named if n not in NAMES})
    faults = "".join(
        f'<tr data-fault="{_esc(n)}"><td>{_esc(n)}</td><td>'
        + ", ".join(
            f'<a href="{_esc(_anchor(u.unit_id))}">{_esc(u.unit_id)}</a>'
            for u in view.units
            if u.fault == n
        )
        + "</td></tr>"
        for n in order
    )
    by_fault = (
        f'<table id="faults"><tr><th>fault</th><th>units naming it</th></tr>{faults}</table>'
        if faults
        else "<p>No unit names a fault.</p>"
    )
    return (
        f"<h2>Fleet overview</h2><p>{len(view.units)} units.</p>"
        f'<table id="levels"><tr><th>level</th><th>units</th></tr>{counts}</table>'
        f"<h3>Faults named</h3>{by_fault}"
    )


def render_html(view: FleetView, *, title: str = "ema_phm fleet report") -> str:
    """The fleet `view` as one self-contained HTML page (nothing fetched when it opens).

    Units appear in the view's order (`FleetView.ranked` gives the risk order).  Every
    text taken from the data is HTML-escaped.
    """
    t = _esc(title)
    sections = "".join(_unit_section(u) for u in view.units)
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{t}</title><style>{_CSS}</style><script>{_SCRIPT}</script></head>"
        f"<body><h1>{t}</h1>"
        f'<p class="meta">store {_esc(view.store)}; schema {view.schema_version}; '
        f"read {_esc(view.created)}</p>"
        f"{_overview(view)}{_ranking(view)}<h2>Units</h2>"
        f"{sections or '<p>No units.</p>'}</body></html>\n"
    )


def write_report(view: FleetView, path: str | Path) -> Path:
    """Render `view` and write it to `path` whole or not at all; return the path.

    The folder is created.  ConfigError naming the file when it cannot be written (the old
    file, if any, is left intact).
    """
    path = Path(path)
    text = render_html(view)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return write_text_atomic(path, text)
    except OSError as exc:
        raise ConfigError(f"cannot write report {path}: {exc.strerror or exc}") from None
