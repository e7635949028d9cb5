"""fleet.report: the HTML page of a fleet view, in Python and in a headless Chromium."""

from __future__ import annotations

import dataclasses
import html
import math
import os
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from browser import console_messages, load

from ema_phm.diagnosis import health
from ema_phm.domain.faults import NAMES, NOMINAL, fault, k_with
from ema_phm.errors import ConfigError
from ema_phm.fleet import report, summary, view
from ema_phm.fleet.view import FleetView, Percentiles, UnitView, WindowPoint
from ema_phm.monitor.tracker import PrognosticTracker

WEIRD_ID = "<b>&x"


def _k(**levels: float) -> tuple[float, ...]:
    return tuple(float(v) for v in k_with(**levels))


def _degrading(unit_id: str = "u-friction", n: int = 6) -> UnitView:
    """Friction growing 0.10 -> 0.10 + 0.06 (n-1), with intervals, truth and RUL."""
    history = []
    for i in range(n):
        s = 0.10 + 0.06 * i
        p5, p50, p95 = (max(v, 0.0) for v in (40.0 - 6 * i, 60.0 - 8 * i, 90.0 - 9 * i))
        rul = Percentiles(p5, p50, math.inf if i < 2 else p95)
        history.append(
            WindowPoint(
                cycle=100 * (i + 1),
                status="counted" if i != 2 else "not_counted",
                reason="" if i != 2 else "outlier",
                level="ERROR" if s >= 0.4 else ("WARN" if s >= 0.15 else "OK"),
                k=_k(friction=s),
                k_low=_k(friction=s - 0.03),
                k_high=_k(friction=s + 0.03),
                k_true=_k(friction=s - 0.01),
                rul={"friction": rul} if i >= 1 else {},
            )
        )
    last = history[-1].rul["friction"]
    return UnitView(
        unit_id=unit_id,
        run_id="run-1",
        level="ERROR",
        fault="friction",
        headline="friction at 0.40: ERROR",
        rul_cycles=last,
        rul_hours=Percentiles(last.p5 / 10, last.p50 / 10, last.p95 / 10),
        last_cycle=history[-1].cycle,
        windows=n,
        counted=n - 1,
        commissioned=True,
        history=tuple(history),
    )


def _backlash_warn() -> UnitView:
    history = tuple(
        WindowPoint(cycle=50 * (i + 1), status="counted", level="WARN", k=_k(backlash=0.2))
        for i in range(4)
    )
    return UnitView(
        unit_id="u-backlash",
        run_id="run-2",
        level="WARN",
        fault="backlash",
        headline="backlash at 0.20: WARN, not growing",
        rul_cycles=None,
        rul_hours=None,
        last_cycle=200,
        windows=4,
        counted=4,
        commissioned=True,
        history=history,
    )


def _healthy(unit_id: str = "u-ok") -> UnitView:
    k = tuple(float(v) for v in NOMINAL)
    history = tuple(
        WindowPoint(cycle=10 * (i + 1), status="counted", level="OK", k=k) for i in range(3)
    )
    return UnitView(unit_id, "run-3", "OK", None, "healthy", None, None, 30, 3, 3, True, history)


def _unknown(unit_id: str = WEIRD_ID) -> UnitView:
    history = tuple(
        WindowPoint(cycle=5 * (i + 1), status="skipped", reason="too short") for i in range(3)
    )
    return UnitView(
        unit_id, "run-4", "UNKNOWN", None, "<i>no fit</i>", None, None, 15, 3, 0, False, history
    )


def _fleet(*units: UnitView) -> FleetView:
    return FleetView(units, "sqlite:///fleet.db", 1, "2025-01-01T00:00:00Z")


@pytest.fixture(scope="module")
def fleet() -> FleetView:
    return _fleet(_degrading(), _backlash_warn(), _healthy(), _unknown())


@pytest.fixture(scope="module")
def page(fleet: FleetView) -> str:
    return report.render_html(fleet)


class _Rows(HTMLParser):
    """The data-* attributes of every <tr data-unit> and the ids of every <section>."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[dict[str, str | None]] = []
        self.sections: list[str | None] = []
        self.images: list[str | None] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "tr" and "data-unit" in a:
            self.rows.append(a)
        elif tag == "section":
            self.sections.append(a.get("id"))
        elif tag == "img":
            self.images.append(a.get("src"))


def _parse(text: str) -> _Rows:
    p = _Rows()
    p.feed(text)
    p.close()
    return p


def test_rows_follow_the_view_order_with_their_fault_and_level(page: str) -> None:
    rows = _parse(page).rows
    assert [r["data-unit"] for r in rows] == ["u-friction", "u-backlash", "u-ok", WEIRD_ID]
    assert [r["data-fault"] for r in rows] == ["friction", "backlash", "", ""]
    assert [r["data-level"] for r in rows] == ["ERROR", "WARN", "OK", "UNKNOWN"]


def test_a_reordered_view_reorders_the_rows(fleet: FleetView) -> None:
    units = tuple(reversed(fleet.units))
    rows = _parse(report.render_html(_fleet(*units))).rows
    assert [r["data-unit"] for r in rows] == [u.unit_id for u in units]


def test_every_unit_has_a_section_and_only_fitted_units_a_figure(page: str) -> None:
    parsed = _parse(page)
    assert parsed.sections == [
        "unit-u-friction",
        "unit-u-backlash",
        "unit-u-ok",
        f"unit-{WEIRD_ID}",
    ]
    assert len(parsed.images) == 3
    assert all(s and s.startswith("data:image/png;base64,") for s in parsed.images)
    unknown = page[page.index(f'id="unit-{html.escape(WEIRD_ID)}"') :]
    assert "<img" not in unknown and "nothing to plot" in unknown


def test_overview_counts_levels_and_names_units_per_fault(page: str) -> None:
    for level, n in (("ERROR", 1), ("WARN", 1), ("OK", 1), ("UNKNOWN", 1)):
        assert f'data-level="{level}">{n}</td>' in page
    faults = page[page.index('id="faults"') : page.index("</table>", page.index('id="faults"'))]
    assert 'data-fault="friction"' in faults and "u-friction" in faults
    assert 'data-fault="backlash"' in faults and "u-backlash" in faults
    assert "u-ok" not in faults


def test_rul_cells_show_percentiles_and_infinity(page: str) -> None:
    row = page[page.index('data-unit="u-friction"') :].split("</tr>", maxsplit=1)[0]
    # last window: p5 = 40 - 30, p50 = 60 - 40, p95 = 90 - 45; hours a tenth
    assert ">10</td>" in row and ">20</td>" in row and ">45</td>" in row
    assert "1.0 / 2.0 / 4.5" in row
    inf_fleet = _fleet(_degrading(n=2))  # last window's p95 is inf
    row = report.render_html(inf_fleet).split('data-unit="u-friction"')[1].split("</tr>")[0]
    assert 'data-v="Infinity">&infin;</td>' in row


def test_the_page_is_self_contained(page: str) -> None:
    assert not re.search(r"""(src|href|action)\s*=\s*["']?\s*(https?:)?//""", page, re.I)
    assert not re.search(r"<link\b|@import|url\(", page, re.I)
    assert "<script src" not in page


def test_data_text_is_escaped(page: str) -> None:
    assert WEIRD_ID not in page and "<i>no fit</i>" not in page
    assert "&lt;b&gt;&amp;x" in page and "&lt;i&gt;no fit&lt;/i&gt;" in page
    title = report.render_html(_fleet(), title="a <script>")
    assert "<title>a &lt;script&gt;</title>" in title


def test_an_empty_fleet_renders_sentences() -> None:
    page = report.render_html(_fleet())
    parsed = _parse(page)
    assert parsed.rows == [] and parsed.sections == [] and parsed.images == []
    assert "holds no units" in page and 'data-level="ERROR">0</td>' in page


def test_a_unit_without_a_name_plots_its_most_severe_entry() -> None:
    gain = _k(gain_drift=0.7, friction=0.05)  # gain severity 0.2 beats friction's 0.05
    unit = UnitView(
        "u-gain", "r", "WARN", None, "h", None, None, 10, 1, 1, True,
        (WindowPoint(cycle=10, status="counted", k=gain),),
    )  # fmt: skip
    page = report.render_html(_fleet(unit))
    assert "k8 gain" in page and "most severe entry" in page


def test_write_report_writes_a_page_that_parses(tmp_path: Path, fleet: FleetView) -> None:
    out = report.write_report(fleet, tmp_path / "sub" / "fleet.html")
    assert out == tmp_path / "sub" / "fleet.html"
    assert len(_parse(out.read_text(encoding="utf-8")).rows) == 4
    assert sorted(p.name for p in out.parent.iterdir()) == ["fleet.html"]


def test_a_failing_render_leaves_no_file(
    tmp_path: Path, fleet: FleetView, monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken(*_: object, **__: object) -> str:
        raise RuntimeError("render failed")

    monkeypatch.setattr(report, "_unit_section", broken)
    with pytest.raises(RuntimeError, match="render failed"):
        report.write_report(fleet, tmp_path / "fleet.html")
    assert list(tmp_path.iterdir()) == []


def test_a_failing_write_keeps_the_old_file_and_no_temporary(
    tmp_path: Path, fleet: FleetView, monkeypatch: pytest.MonkeyPatch
) -> None:
    target = tmp_path / "fleet.html"
    target.write_text("old", encoding="utf-8")

    def full_disk(*_: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", full_disk)
    with pytest.raises(ConfigError, match="cannot write report .*No space left"):
        report.write_report(fleet, target)
    assert target.read_text(encoding="utf-8") == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["fleet.html"]


def test_a_40_unit_fleet_stays_under_5_mb(tmp_path: Path) -> None:
    units = [_degrading(f"unit-{i:02d}", n=10) for i in range(40)]
    out = report.write_report(_fleet(*units), tmp_path / "big.html")
    size = out.stat().st_size
    assert size < 5_000_000, f"{size} bytes"
    assert len(_parse(out.read_text(encoding="utf-8")).images) == 40


# --- headless Chromium ---------------------------------------------------------------


def test_the_console_detector_reads_both_formats() -> None:
    log = (
        "[1:1:1126/063857.289996:ERROR:dbus/bus.cc:405] Failed to connect to the bus\n"
        '[1:1:1126/063857.289996:INFO:CONSOLE:1] "x", source: file:///a.html (1)\n'
        '[1:1:1126/063857.289996:INFO:CONSOLE(12)] "Uncaught Error: y", source: a (12)\n'
    )
    assert len(console_messages(log)) == 2


@pytest.mark.parametrize(
    ("script", "needle"),
    [('console.error("x-console-error")', "x-console-error"), ("throw new Error('x-up')", "x-up")],
    ids=["console.error", "uncaught"],
)
def test_the_console_detector_catches_a_real_page_error(
    tmp_path: Path, script: str, needle: str
) -> None:
    page = tmp_path / "bad.html"
    page.write_text(f"<!DOCTYPE html><html><body><script>{script}</script></body></html>")
    run = load(page)
    assert run.returncode == 0, run.stderr
    found = console_messages(run.stderr)
    assert any(needle in line for line in found), run.stderr


def test_the_report_loads_in_chromium_without_console_errors(
    tmp_path: Path, fleet: FleetView
) -> None:
    out = report.write_report(fleet, tmp_path / "fleet.html")
    run = load(out)
    assert run.returncode == 0, run.stderr
    assert console_messages(run.stderr) == [], run.stderr
    body = re.search(r"<body[^>]*>", run.stdout)
    assert body and 'data-ready="1"' in body.group(0), run.stdout[:2000]
    rows = _parse(run.stdout).rows
    assert [r["data-unit"] for r in rows] == [u.unit_id for u in fleet.units]


# --- issue 30: the entry named and plotted, page-wide figures, why there is no RUL ----------


def _row(cycle: int, k: np.ndarray, half: np.ndarray, tracker: PrognosticTracker) -> dict:
    """A stored window as `Store.unit_rows` gives it: `health.assess`'s verdict, the summary."""
    interval = np.column_stack([np.clip(k - half, 0, 1), np.clip(k + half, 0, 1)])
    a = health.assess(k, k_interval=interval, window_t0=2.0 * cycle, window_t1=2.0 * cycle + 2)
    summary = tracker.observe(a)
    return {
        "cycle": cycle, "run_id": "r", "status": "counted", "reason": "",
        "level": health.LEVEL_NAMES[a.level], "dominant": NAMES[a.dominant],
        "message": a.message, "k": [float(v) for v in k], "k_interval": interval.tolist(),
        "k_true": None, "adequacy": None, "prognosis": summary.as_dict(),
    }  # fmt: skip


def _stored_unit(unit_id: str, ks: list[np.ndarray], half: np.ndarray) -> UnitView:
    """A unit read back as `summary.read_view` reads it, from windows judged by the monitor."""
    tracker = PrognosticTracker()
    rows = [_row(c, k, half, tracker) for c, k in enumerate(ks)]
    return summary.unit_view(unit_id, rows, None)


#: Short circuit c has the largest |k - nominal| but an interval holding healthy; the gain is
#: barely off healthy with a narrow interval: the verdict names the gain, as the headline does.
_SC_C_WIDE = np.array(k_with(short_circuit_c=0.12, gain_drift=0.494))
_HALF_WIDE_SC_C = np.where(np.arange(len(NAMES)) == fault("short_circuit_c").index, 0.2, 0.003)


def _ambiguous() -> UnitView:
    return _stored_unit("u-ambiguous", [_SC_C_WIDE] * 2, _HALF_WIDE_SC_C)


def test_the_plot_shows_the_entry_the_headline_names() -> None:
    unit = _ambiguous()
    k = np.array(unit.history[-1].k)
    raw_largest = NAMES[int(np.argmax(np.abs(k - NOMINAL)))]
    assert unit.fault is None and raw_largest == "short_circuit_c"  # the old rule's pick
    assert view.shown_fault(unit) == "gain_drift" and "largest: gain_drift" in unit.headline
    page = report.render_html(_fleet(unit))
    assert '<p class="shown" data-fault="gain_drift">' in page
    assert '<img data-fault="gain_drift"' in page
    # a window stored without its verdict's entry is judged again by the same rule
    old = dataclasses.replace(unit.history[-1], dominant="")
    assert view.shown_fault(dataclasses.replace(unit, history=(old,))) == "gain_drift"


def test_a_named_fault_is_the_one_plotted() -> None:
    unit = _degrading()
    assert view.shown_fault(unit) == "friction" == unit.fault
    assert '<img data-fault="friction"' in report.render_html(_fleet(unit))


def _rising(n: int, rate: float = 0.03) -> UnitView:
    ks = [np.array(k_with(friction=0.05 + rate * c)) for c in range(n)]
    return _stored_unit(f"u-rising-{n}", ks, np.full(len(NAMES), 0.02))


def test_a_rising_fault_without_enough_windows_says_how_many_more_it_needs() -> None:
    unit = _rising(3)
    assert view.shown_fault(unit) == "friction"
    why = view.no_rul_reason(unit, "friction")
    assert why == (
        "no RUL yet: needs 2 more explained windows for a trend "
        "(3 estimates; a trend needs at least 5)"
    )
    page = report.render_html(_fleet(unit))
    assert f'<p class="no-rul" data-fault="friction">friction: {html.escape(why)}</p>' in page


def test_a_fault_not_yet_a_trend_says_which_test_failed() -> None:
    flat = [np.array(k_with(friction=0.05 + 0.01 * (c % 2))) for c in range(6)]
    unit = _stored_unit("u-flat", flat, np.full(len(NAMES), 0.02))
    why = view.no_rul_reason(unit, "friction")
    assert why.startswith("no RUL yet: no degradation detected (P(")
    assert "friction: " + html.escape(why) in report.render_html(_fleet(unit))


def test_a_fault_with_a_rul_says_nothing_and_one_without_any_says_why() -> None:
    unit = _rising(8, rate=0.05)
    assert unit.history[-1].rul.get("friction") is not None
    assert view.no_rul_reason(unit, "friction") == ""
    assert 'class="no-rul"' not in report.render_html(_fleet(unit))
    assert view.no_rul_reason(unit, "gain_drift").startswith("no RUL for this fault: ")
    # a window stored before the reasons were: the fault table's, or a sentence saying so
    old = dataclasses.replace(unit.history[-1], no_rul={}, rul={})
    bare = dataclasses.replace(unit, history=(old,))
    assert view.no_rul_reason(bare, "gain_drift").startswith("no RUL for this fault: ")
    assert "keeps no reason" in view.no_rul_reason(bare, "friction")


#: Measures, after the page loaded, each figure's width over the content width of <body>.
_MEASURE = """<script>
window.addEventListener("load", function () {
  var body = document.body, cs = getComputedStyle(body);
  var content = body.clientWidth - parseFloat(cs.paddingLeft) - parseFloat(cs.paddingRight);
  var shares = Array.prototype.map.call(document.querySelectorAll("section img"), function (im) {
    return (im.getBoundingClientRect().width / content).toFixed(3);
  });
  body.setAttribute("data-viewport", String(window.innerWidth));
  body.setAttribute("data-content", String(content));
  body.setAttribute("data-img-shares", shares.join(","));
});
</script>"""


def test_in_chromium_figures_span_the_page_and_name_what_the_headline_names(
    tmp_path: Path,
) -> None:
    healthy = _stored_unit("u-ok", [NOMINAL.copy()] * 2, np.full(len(NAMES), 0.02))
    units = (_degrading(), _ambiguous(), _rising(3), healthy)
    out = report.write_report(_fleet(*units), tmp_path / "fleet.html")
    measured = tmp_path / "measured.html"
    measured.write_text(
        out.read_text(encoding="utf-8").replace("</body>", _MEASURE + "</body>"), encoding="utf-8"
    )
    run = load(measured, window_size=(1400, 1000))
    assert run.returncode == 0, run.stderr
    assert console_messages(run.stderr) == [], run.stderr
    body = re.search(r"<body[^>]*>", run.stdout)
    assert body, run.stdout[:2000]
    attrs = dict(re.findall(r'(data-[a-z-]+)="([^"]*)"', body.group(0)))
    assert attrs.get("data-viewport") == "1400", attrs
    shares = [float(v) for v in attrs["data-img-shares"].split(",")]
    assert len(shares) == len(units) and min(shares) >= 0.8, attrs
    dom = run.stdout
    # (a) each section's caption, figure and headline name one entry
    for unit in units:
        name = view.shown_fault(unit)
        section = dom[dom.index(f'id="unit-{unit.unit_id}"') :].split("</section>")[0]
        assert f'<p class="shown" data-fault="{name}">' in section
        assert f'<img data-fault="{name}"' in section
        assert unit.fault == name or f"largest: {name}" in unit.headline
    # (c) the rising fault without a RUL says why, as rendered
    rising = dom[dom.index('id="unit-u-rising-3"') :].split("</section>")[0]
    assert "needs 2 more explained windows" in rising
