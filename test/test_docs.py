"""The README and the docs: the way in works and the reference builds.

- the Sphinx site in docs/ builds with warnings as errors (no network: no intersphinx);
- every relative link of README.md and docs/**/*.md points to a file that exists and, with an
  `#anchor`, to a heading of that page;
- the README is short, opens with the two front-door commands, and its walkthrough (the code
  blocks after a `<!-- walkthrough -->` line) runs, step by step, in a temporary folder.
"""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import run_shell

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"

#: The README stays a way in; the reference is in docs/.
README_MAX_LINES = 250
#: Seconds one walkthrough step may take (each takes well under a minute on 2 idle cores).
STEP_TIMEOUT_S = 600

_FENCE = re.compile(r"^(```|~~~)")
_LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
_CODE_SPAN = re.compile(r"`+[^`]*`+")
_HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")


def _markdown_files() -> list[Path]:
    return [README, *sorted(DOCS.rglob("*.md"))]


def _prose_lines(text: str) -> list[tuple[int, str]]:
    """(line number, line) outside fenced code blocks."""
    out, fenced = [], False
    for number, line in enumerate(text.splitlines(), 1):
        if _FENCE.match(line.lstrip()):
            fenced = not fenced
            continue
        if not fenced:
            out.append((number, line))
    return out


def slug(heading: str) -> str:
    """A heading's anchor as MyST (and GitHub) make it: lower case, punctuation dropped."""
    text = _CODE_SPAN.sub(lambda m: m.group(0).strip("`"), heading)
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link's text only
    return re.sub(r"[^\w\- ]", "", text.strip().lower().replace(" ", "-"))


def anchors(page: Path) -> set[str]:
    """The anchors of a Markdown page's headings (repeated headings get -1, -2, ...)."""
    counts: dict[str, int] = {}
    found = set()
    for _, line in _prose_lines(page.read_text(encoding="utf-8")):
        match = _HEADING.match(line)
        if match:
            base = slug(match.group(2))
            n = counts.get(base, 0)
            found.add(f"{base}-{n}" if n else base)
            counts[base] = n + 1
    return found


def _relative_links(page: Path) -> list[tuple[int, str]]:
    links = []
    for number, line in _prose_lines(page.read_text(encoding="utf-8")):
        for target in _LINK.findall(_CODE_SPAN.sub("", line)):
            if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):  # http:, https:, mailto:
                continue
            links.append((number, target))
    return links


def test_every_relative_link_points_to_a_file_and_heading_that_exist():
    broken, checked = [], 0
    for page in _markdown_files():
        for number, target in _relative_links(page):
            checked += 1
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            where = f"{page.relative_to(ROOT)}:{number}: {target}"
            if not dest.is_relative_to(ROOT):
                broken.append(f"{where}: outside the repository (absent from a clone)")
            elif not dest.exists():
                broken.append(f"{where}: no such file")
            elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                broken.append(f"{where}: no heading with anchor #{anchor}")
    assert checked > 50, "the link pattern no longer finds the links"
    assert not broken, "broken links:\n" + "\n".join(broken)


def test_the_link_check_sees_a_broken_link_and_a_broken_anchor(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "# Title\n\n## A `code` heading (x)\n\n[ok](#a-code-heading-x) [bad](#nope) "
        "[gone](missing.md) `[not a link](nowhere.md)`\n\n```\n[nor](this.md)\n```\n",
        encoding="utf-8",
    )
    assert anchors(page) == {"title", "a-code-heading-x"}
    assert [t for _, t in _relative_links(page)] == ["#a-code-heading-x", "#nope", "missing.md"]


def test_docs_build_with_warnings_as_errors(tmp_path):
    run = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html"]
        + ["-d", str(tmp_path / "doctrees"), str(DOCS), str(tmp_path / "html")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert run.returncode == 0, f"sphinx-build:\n{run.stdout}{run.stderr}"
    reference = (tmp_path / "html" / "cli_reference.html").read_text(encoding="utf-8")
    for command in ("simulate", "isolate", "calibrate", "prognose", "fleet", "demo"):
        assert f">{command}<" in reference, f"{command} missing from the generated CLI reference"


def test_docs_configuration_reaches_no_network():
    conf = (DOCS / "conf.py").read_text(encoding="utf-8")
    assert "sphinx.ext.intersphinx" not in conf
    assert (DOCS / "index.md").read_text(encoding="utf-8").count("{toctree}") >= 1


def test_readme_is_short_and_opens_with_the_two_commands():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) < README_MAX_LINES
    body = [line for line in lines if line.strip()]
    assert body[0].startswith("# "), "a title, then the commands"
    assert body[1:5] == ["```", "bash scripts/demo.sh", "bash scripts/test.sh", "```"]


def walkthrough_blocks(text: str) -> list[str]:
    """The code blocks the README marks with a `<!-- walkthrough -->` line, in order."""
    return re.findall(r"<!-- walkthrough -->\n```[a-z]*\n(.*?)```", text, re.S)


def test_readme_walkthrough_has_its_five_steps():
    blocks = walkthrough_blocks(README.read_text(encoding="utf-8"))
    assert len(blocks) == 5
    joined = "\n".join(blocks)
    for command in ("demo", "isolate", "calibrate --baseline", "prognose", "fleet ingest"):
        assert f"ema-phm {command}" in joined


@pytest.mark.parametrize(
    "step", range(1, 6), ids=["demo", "isolate", "commission", "prognose", "fleet"]
)
def test_readme_walkthrough_step_runs(step, tmp_path, ema_phm_on_path):
    """Each step in an empty folder, as the README says (ROS traffic on 127.0.0.1: conftest)."""
    block = walkthrough_blocks(README.read_text(encoding="utf-8"))[step - 1]
    start = time.monotonic()
    run = run_shell(block, tmp_path, ema_phm_on_path, timeout=STEP_TIMEOUT_S)
    wall = time.monotonic() - start
    assert run.returncode == 0, f"step {step} failed after {wall:.0f} s:\n{run.stdout}{run.stderr}"
    expected = {
        1: "eq. 6.4",
        2: "friction",
        3: "short_circuit_b",
        4: "friction: RUL",
        5: "most at risk first",
    }[step]
    assert expected in run.stdout, run.stdout
    if step == 5:
        assert (tmp_path / "fleet.html").stat().st_size > 0
