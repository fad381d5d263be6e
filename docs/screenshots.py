"""Screenshots of the built documentation site in headless Chromium, offline.

Looks at the site the way a reader does: the home page, a formulation page with a wide
display equation (RLP, also in a narrow window), an API page (the formulations'
docstrings, with their math) and a notebook page, then every other page that has a
formula, whole (the window as tall as the page), each loaded from ``file://`` in headless
Chromium with every host name unresolvable, so a page that needed the network (a math
script from a CDN, a web font) shows it. The PNGs go to ``<site>/_screenshots/`` (build
output, not committed; mkdocs.yml keeps this script out of the site)::

    mkdocs build --strict            # or: python docs/screenshots.py --build
    python docs/screenshots.py       # writes site/_screenshots/*.png

Chromium comes from the system's packages (Debian: ``apt-get install chromium``). The
formulas are MathML rendered by the browser (``docs/_hooks/math.py``); look at the PNGs
to see them typeset, not as raw TeX. Beside each PNG the browser measures the page: how
many formulas it laid out (a ``<math>`` element the browser does not render has no
height), any formula whose text still holds TeX (a backslash: ``\\{`` where a brace
belongs), and each display formula wider than its box. That one must scroll
(``overflow-x: auto``) rather than be clipped in a narrow window, and must not happen at
all in the 1280-px views of whole pages, where a formula that scrolls shows a reader only
its start (write it as rows: ``\\begin{array}{l} ... \\\\ ... \\end{array}``). The script
exits 1 if a formula is not laid out, shows TeX, is clipped or does not fit.
``tests/project/test_docs_html.py`` checks the same pages' HTML where no browser is installed.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: name -> (page of the site, window width and height in CSS pixels)
PAGES: dict[str, tuple[str, int, int | None]] = {
    "home": ("index.html", 1280, 1100),
    "formulation-rlp": ("formulations/rlp/index.html", 1280, 1400),
    "formulation-rlp-narrow": ("formulations/rlp/index.html", 720, 1400),
    "api-formulations": (
        "api/formulations/index.html#lpbounds.formulations.rlp.RLP",
        1280,
        1400,
    ),
    "notebook-theorem1": ("notebooks/theorem1_cost_independence/index.html", 1280, 2400),
}
#: the tallest window for a whole page (CSS pixels); a longer page is shot from its top
MAX_HEIGHT = 16000
CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
#: run in the page before the screenshot: keep the page from ``anchor`` on (a screenshot of
#: a scrolled headless page comes out blank), and measure its formulas into a hidden <pre>
PROBE = """<script>
addEventListener("DOMContentLoaded", () => {
  const anchor = document.getElementById(ANCHOR);
  const box = document.querySelector(".md-content__inner");
  if (anchor && box) {
    let el = anchor;
    while (el && el !== box) {
      while (el.previousElementSibling && el.parentElement !== box.parentElement)
        el.previousElementSibling.remove();
      el = el.parentElement;
    }
  }
});
addEventListener("load", () => {
  const all = [...document.querySelectorAll(".md-content math")];
  const wide = [...document.querySelectorAll(".md-content .lpb-math-display")]
    .filter((d) => d.scrollWidth > d.clientWidth + 1)
    .map((d) => ({ width: d.scrollWidth, box: d.clientWidth,
                   text: d.textContent.slice(0, 60),
                   overflow: getComputedStyle(d).overflowX }));
  const probe = document.createElement("pre");
  probe.id = "lpb-probe";
  probe.hidden = true;
  probe.textContent = JSON.stringify({
    formulas: all.length,
    unrendered: all.filter((m) => m.getBoundingClientRect().height <= 0).length,
    tex: all.map((m) => m.textContent)
      .filter((t) => t.includes(String.fromCharCode(92))).slice(0, 5),
    wide: wide,
    height: document.documentElement.scrollHeight,
  });
  document.body.appendChild(probe);
});
</script>"""


def find_chromium(given: str | None) -> str:
    """The Chromium executable: ``given``, ``$CHROMIUM`` or the first one on ``PATH``."""
    for name in (given, os.environ.get("CHROMIUM"), *CANDIDATES):
        if name and (path := shutil.which(name)):
            return path
    raise SystemExit("no Chromium found: install it (Debian: apt-get install -y chromium)")


def _chromium(chromium: str, url: str, width: int, height: int, *action: str) -> str:
    """Run headless Chromium on ``url`` offline (no host name resolves); its stdout."""
    with tempfile.TemporaryDirectory(prefix="lpb-chromium-") as profile:
        cmd = [
            chromium,
            "--headless",
            "--no-sandbox",  # root in a container has no user namespace for the sandbox
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
            "--no-first-run",
            f"--user-data-dir={profile}",
            "--host-resolver-rules=MAP * ~NOTFOUND",  # offline: no host name resolves
            "--virtual-time-budget=3000",
            f"--window-size={width},{height}",
            *action,
            url,
        ]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    if proc.returncode != 0:
        raise SystemExit(f"chromium failed on {url}:\n{proc.stderr[-2000:]}")
    return proc.stdout


def shoot(chromium: str, page: Path, anchor: str, out: Path, size: tuple[int, int | None]) -> dict:
    """Screenshot ``page`` (from ``anchor`` on) to ``out``; the browser's measurements.

    The page is copied beside itself with :data:`PROBE` added (so its links still
    resolve), loaded twice or more (the DOM after the scripts ran, then the screenshots),
    and removed. A height of None: the window is as tall as the page, so the screenshot
    shows all of it; a page taller than :data:`MAX_HEIGHT` is shot in parts
    (``out``, then ``<out>-2.png``, ...), each shifted up by the ones before.
    """
    probe = PROBE.replace("ANCHOR", json.dumps(anchor))
    copy = page.with_name(f"_lpb_shot_{out.stem}.html")
    text = page.read_text()
    copy.write_text(text.replace("</body>", probe + "</body>", 1))
    width, height = size
    try:
        dom = _chromium(chromium, copy.as_uri(), width, height or 1200, "--dump-dom")
        found = re.search(r'<pre id="lpb-probe"[^>]*>(.*?)</pre>', dom, re.S)
        if not found:
            raise SystemExit(f"the page {page} did not finish loading in the browser")
        seen = dict(json.loads(found.group(1)))
        total = int(seen["height"])
        parts = 1 if height else -(-total // MAX_HEIGHT)
        height = height or min(total, MAX_HEIGHT)
        seen["files"] = []
        for k in range(parts):
            shot = out if k == 0 else out.with_name(f"{out.stem}-{k + 1}.png")
            shift = f"<style>body {{ position: relative; top: -{k * MAX_HEIGHT}px; }}</style>"
            copy.write_text(text.replace("</body>", (shift if k else "") + probe + "</body>", 1))
            _chromium(chromium, copy.as_uri(), width, height, f"--screenshot={shot}")
            if not shot.exists():
                raise SystemExit(f"chromium wrote no screenshot of {page}")
            seen["files"].append(shot)
    finally:
        copy.unlink(missing_ok=True)
    seen["size"] = (width, height)
    return seen


def formula_pages(site: Path) -> dict[str, tuple[str, int, int | None]]:
    """Every page of ``site`` with a formula (a ``<math>`` element), whole, 1280 wide."""
    found = {}
    for path in sorted(site.rglob("index.html")):
        if "<math " in path.read_text():
            rel = path.relative_to(site).as_posix()
            name = rel.removesuffix("index.html").strip("/").replace("/", "-") or "home"
            found[f"page-{name}"] = (rel, 1280, None)
    return found


def main(argv: list[str] | None = None) -> int:
    """Build (optionally) and screenshot the site; print the PNGs written."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--site", default=str(ROOT / "site"), help="the built site (default site/)")
    ap.add_argument("--build", action="store_true", help="run mkdocs build --strict first")
    ap.add_argument("--chromium", help="the browser executable (default: found on PATH)")
    ap.add_argument("--only", metavar="TEXT", help="only the pages whose path contains TEXT")
    args = ap.parse_args(argv)
    site = Path(args.site).resolve()
    if args.build:
        cmd = [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)]
        subprocess.run(cmd, cwd=ROOT, check=True)
    if not (site / "index.html").exists():
        raise SystemExit(f"no built site in {site}: run mkdocs build --strict (or --build)")
    chromium = find_chromium(args.chromium)
    folder = site / "_screenshots"
    folder.mkdir(parents=True, exist_ok=True)
    bad = 0
    pages: dict[str, tuple[str, int, int | None]] = {**PAGES, **formula_pages(site)}
    if args.only:
        pages = {name: view for name, view in pages.items() if args.only in view[0]}
    for name, (page, width, height) in pages.items():
        path, _, anchor = page.partition("#")
        if not (site / path).exists():
            raise SystemExit(f"{site / path} is missing: is the site built from this tree?")
        out = folder / f"{name}.png"
        seen = shoot(chromium, site / path, anchor, out, (width, height))
        clipped = [w for w in seen["wide"] if w["overflow"] not in ("auto", "scroll")]
        if height is None:  # a whole page at 1280 px: every formula fits, none scrolls
            clipped = seen["wide"]
        bad += seen["unrendered"] + len(clipped) + len(seen["tex"])
        tex = f"; TeX left in {seen['tex']}" if seen["tex"] else ""
        tex += "".join(f"\n    does not fit: {w['text']}..." for w in clipped)
        more = f" (+{len(seen['files']) - 1} parts)" if len(seen["files"]) > 1 else ""
        print(
            f"{out}{more}  ({page}, {seen['size'][0]} x {seen['size'][1]}): {seen['formulas']} "
            f"formulas, {seen['unrendered']} not laid out; {len(seen['wide'])} display "
            f"formulas wider than their box, {len(clipped)} of them clipped{tex}"
        )
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
