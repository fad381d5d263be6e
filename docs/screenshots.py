"""Screenshots of the built documentation site in headless Chromium, offline.

Looks at the site the way a reader does: the home page, a formulation page with a wide
display equation (RLP), an API page (the formulations' docstrings, with their math) and a
notebook page, each loaded from ``file://`` in headless Chromium with every host name
unresolvable, so a page that needed the network (a math script from a CDN, a web font)
shows it. The PNGs go to ``<site>/_screenshots/`` (build output, not committed)::

    mkdocs build --strict            # or: python docs/screenshots.py --build
    python docs/screenshots.py       # writes site/_screenshots/*.png

Chromium comes from the system's packages (Debian: ``apt-get install chromium``). The
formulas are MathML rendered by the browser (``docs/_hooks/math.py``); look at the PNGs
to see them typeset, not as raw TeX. Beside each PNG the browser measures the page: how
many formulas it laid out (a ``<math>`` element the browser does not render has no
height), and each display formula wider than its box, which must scroll
(``overflow-x: auto``) rather than be clipped; the script exits 1 if a formula is not laid
out or is clipped. ``tests/test_docs_html.py`` checks the same pages' HTML where no browser
is installed.
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
PAGES = {
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
                   overflow: getComputedStyle(d).overflowX }));
  const probe = document.createElement("pre");
  probe.id = "lpb-probe";
  probe.hidden = true;
  probe.textContent = JSON.stringify({
    formulas: all.length,
    unrendered: all.filter((m) => m.getBoundingClientRect().height <= 0).length,
    wide: wide,
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


def shoot(chromium: str, page: Path, anchor: str, out: Path, size: tuple[int, int]) -> dict:
    """Screenshot ``page`` (from ``anchor`` on) to ``out``; the browser's measurements.

    The page is copied beside itself with :data:`PROBE` added (so its links still
    resolve), loaded twice (screenshot, then the DOM after the scripts ran), and removed.
    """
    probe = PROBE.replace("ANCHOR", json.dumps(anchor))
    copy = page.with_name(f"_lpb_shot_{out.stem}.html")
    copy.write_text(page.read_text().replace("</body>", probe + "</body>", 1))
    try:
        _chromium(chromium, copy.as_uri(), *size, f"--screenshot={out}")
        dom = _chromium(chromium, copy.as_uri(), *size, "--dump-dom")
    finally:
        copy.unlink(missing_ok=True)
    if not out.exists():
        raise SystemExit(f"chromium wrote no screenshot of {page}")
    found = re.search(r'<pre id="lpb-probe"[^>]*>(.*?)</pre>', dom, re.S)
    if not found:
        raise SystemExit(f"the page {page} did not finish loading in the browser")
    return dict(json.loads(found.group(1)))


def main(argv: list[str] | None = None) -> int:
    """Build (optionally) and screenshot the site; print the PNGs written."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--site", default=str(ROOT / "site"), help="the built site (default site/)")
    ap.add_argument("--build", action="store_true", help="run mkdocs build --strict first")
    ap.add_argument("--chromium", help="the browser executable (default: found on PATH)")
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
    for name, (page, width, height) in PAGES.items():
        path, _, anchor = page.partition("#")
        if not (site / path).exists():
            raise SystemExit(f"{site / path} is missing: is the site built from this tree?")
        out = folder / f"{name}.png"
        seen = shoot(chromium, site / path, anchor, out, (width, height))
        clipped = [w for w in seen["wide"] if w["overflow"] not in ("auto", "scroll")]
        bad += seen["unrendered"] + len(clipped)
        print(
            f"{out}  ({page}, {width} x {height}): {seen['formulas']} formulas, "
            f"{seen['unrendered']} not laid out; {len(seen['wide'])} display formulas wider "
            f"than their box, {len(clipped)} of them clipped"
        )
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
