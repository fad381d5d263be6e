"""Weaken each promise of lpbounds by one small source mutation; count the tests that fail.

Each *mutant* is a named regular-expression replacement inside one named function of one
source file (so a reader sees exactly what was weakened), applied to a **copy** of the
tree in a temporary folder (the working files are never touched). The tests that guard
the promise are run on the copy twice: in file order (``-p no:randomly``) and in a random
order (pytest-randomly, the seed printed), both with the derandomized hypothesis profile
of ``tests/conftest.py``. A baseline run of each test set on the unmutated copy must be
green first.

The five weakenings of issue 35 (rows a-e of its table) and the two weak kills it names
(``no-outward-rounding``, ``beyond-always-holds``) come first; the others show that the
checks added with them bite too. Each must make at least three tests fail in both runs::

    python benchmarks/mutants.py              # every mutant (about 45 minutes on 2 cores)
    python benchmarks/mutants.py --only a b   # by name or issue row
    python benchmarks/mutants.py --list       # what each mutant changes

The table printed at the end is the one quoted in docs/testing.md.
"""

from __future__ import annotations

import argparse
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

#: The tests that guard each kind of promise (the issue counted "formulations, row sums"
#: and "patrol").
CERTIFICATES = (
    "tests/formulations",
    "tests/dp/test_row_sums.py",
    "tests/certification/test_exact_brackets.py",
)
DP = (
    "tests/dp/test_dp.py",
    "tests/dp/test_row_sums.py",
    "tests/certification/test_exact_brackets.py",
)
PATROL = ("tests/patrol",)
VERIFY = (
    "tests/studies/test_verify.py",
    "tests/studies/test_verify_planted.py",
    "tests/patrol/test_beyond.py",
    "tests/patrol/test_beyond_planted.py",
)


@dataclass(frozen=True)
class Mutant:
    """One weakening: in ``path``, inside ``def function``, each ``(pattern, replacement,
    count)`` must match exactly ``count`` times."""

    name: str
    row: str  # the row of issue 35's table, or "" for the others
    what: str
    path: str
    function: str
    edits: tuple[tuple[str, str, int], ...]
    tests: tuple[str, ...]


CERT = "src/lpbounds/certification/certificate.py"
REPRO = "src/lpbounds/patrol/reproduce.py"
MARGIN = r"margin = bellman_margin\(n_out, r_abs, kappa, v_abs, tv_abs\)"

MUTANTS = (
    Mutant(
        "modulus-bare-discount", "a",
        "the certificate's contraction modulus taken as the bare discount (rows summing "
        "above 1 within the tolerance ignored)",
        CERT, "contraction_modulus",
        ((r"kappa = sums\.modulus\(rows\.discount\)", "kappa = float(rows.discount)", 1),),
        CERTIFICATES,
    ),
    Mutant(
        "lp-margin-removed", "b",
        "the outward rounding margin removed from the LP certificates only (operator "
        "'max'; the NLP's 'maxmin' keeps it)",
        CERT, "certify",
        ((MARGIN, r'\g<0> if operator == "maxmin" else 0.0', 1),),
        CERTIFICATES,
    ),
    Mutant(
        "theorem-differences-zero", "c",
        "the reproduction's Theorem 3 / 4 differences reported as 0 (both modes)",
        REPRO, "check_general",
        ((r"(theorem[34]_max_abs_diff=)[^\n]+,", r"\g<1>0.0,", 4),),
        PATROL,
    ),
    Mutant(
        "sandwich-chain-clipped", "d",
        "the sandwich's and the policy chain's violations reported as 0, margins made "
        "non-negative",
        REPRO, "inequality",
        (
            (r"margin=float\(diff\.min\(\)\)", "margin=max(0.0, float(diff.min()))", 1),
            (r"violations=int\(bad\.size\)", "violations=0", 1),
        ),
        PATROL,
    ),
    Mutant(
        "margin-zero", "e",
        "the certificates' rounding margin set to 0 (LP and NLP)",
        CERT, "certify",
        ((MARGIN, "margin = 0.0", 1),),
        CERTIFICATES,
    ),
    Mutant(
        "no-outward-rounding", "weak kill",
        "all outward rounding of the certificate removed: margin 0, 1 - kappa not rounded "
        "down, no (1 + 4 eps), no final nextafter",
        CERT, "certify",
        (
            (MARGIN, "margin = 0.0", 1),
            (r"\(1\.0 - kappa\) \* \(1\.0 - 2\.0 \* _EPS\)", "(1.0 - kappa)", 1),
            (r" \* \(1\.0 \+ 4\.0 \* _EPS\)", "", 2),
            (r"np\.nextafter\((vv [+-] c_(?:up|down)), -?np\.inf\)", r"\g<1>", 2),
        ),
        CERTIFICATES,
    ),
    Mutant(
        "beyond-always-holds", "weak kill",
        "the beyond-the-paper verdict always 'holds'",
        "src/lpbounds/patrol/beyond.py", "certified_check",
        ((r"verdict=cmp\.verdict,", "verdict=Verdict.HOLDS,", 1),),
        PATROL,
    ),
    Mutant(
        "dual-bound-cancellation", "",
        "the weak-duality objective bound's allowance for the rows' rounding taken "
        "relative to the entries of A (after a self-loop's cancellation), as before issues 35 "
        "and 38: the stored rows' distance from the exact ones (row_rounding) ignored",
        CERT, "dual_objective_bound",
        ((r"if row_rounding:", "if False:", 1),),
        CERTIFICATES,
    ),
    Mutant(
        "dp-modulus-bare-discount", "",
        "the exact DP's error bound with the bare discount as contraction modulus",
        "src/lpbounds/dp/operators.py", "modulus",
        ((r"return ops\.row_sums\(\)\.modulus\(ops\.discount\)", "return float(ops.discount)", 1),),
        DP,
    ),
    Mutant(
        "dp-error-bound-shrunk", "",
        "the exact DP's error bound divided by 1000 (too narrow)",
        "src/lpbounds/tolerances.py", "error_bound",
        ((r"return \(float\(residual\) \+ slack\)", "return 1e-3 * (float(residual) + slack)", 1),),
        DP,
    ),
    Mutant(
        "dp-error-bound-inflated", "",
        "the exact DP's error bound multiplied by 1e6 (vacuous)",
        "src/lpbounds/tolerances.py", "error_bound",
        ((r"return \(float\(residual\) \+ slack\)", "return 1e6 * (float(residual) + slack)", 1),),
        DP,
    ),
    Mutant(
        "porteus-margin-zero", "",
        "the Porteus bounds without their rounding margin",
        "src/lpbounds/dp/porteus.py", "porteus_bounds",
        ((r"\n    tail = _PorteusTail\(", "\n    m = 0.0\n    tail = _PorteusTail(", 1),),
        DP,
    ),
    Mutant(
        "lemma3-always-agrees", "",
        "Lemma 3: the full MDP's counts always equal to the construction",
        REPRO, "lemma3_summary",
        (
            (r"bool\(np\.array_equal\(counted, card\.construction\)\)", "True", 1),
            (r"int\(\(counted != card\.construction\)\.sum\(\)\)", "0", 1),
        ),
        PATROL,
    ),
    Mutant(
        "claim2-never-violated", "",
        "Claim 2 never violated (state and partition level)",
        REPRO, "_state_claims|_partition_claims",
        ((r"(p?bad = p?excess) > tol_claim", r"\g<1> > np.inf", 2),),
        PATROL,
    ),
    Mutant(
        "verify-at-least-never-violated", "",
        "verify's inequality verdict never 'violated' (compare_at_least)",
        "src/lpbounds/certification/checks.py", "compare_at_least",
        ((r"if np\.any\(proven_short > 0\):", "if False:", 1),),
        VERIFY,
    ),
)  # fmt: skip


# ---------------------------------------------------------------------- the copy
def make_copy(dest: Path) -> Path:
    """``src`` (with the compiled extension and numba's caches, mtimes kept so that the
    caches stay valid) and what the tests read (``tests``, ``models``, ``benchmarks``,
    ``docs``, ``examples``, ``pyproject.toml``, ``README.md``) copied to ``dest``."""
    for part in ("src", "tests", "models", "benchmarks", "docs", "examples"):
        shutil.copytree(REPO / part, dest / part, ignore=shutil.ignore_patterns("*.egg-info"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(REPO / name, dest / name)
    return dest


def function_span(text: str, function: str) -> tuple[int, int]:
    """Where ``def function`` (a top-level function) starts and ends in ``text``."""
    m = re.search(rf"^def {function}\(", text, flags=re.M)
    if m is None:
        raise SystemExit(f"no top-level function {function!r}")
    body = text.index("\n", m.end())  # the next line's start is where a def can end
    nxt = re.compile(r"^(?:def |class |@|[A-Za-z_#])", flags=re.M).search(text, body + 1)
    return m.start(), nxt.start() if nxt else len(text)


def mutate(text: str, mutant: Mutant) -> str:
    """``text`` with the mutant's edits applied inside its function(s), each counted."""
    for pattern, repl, count in mutant.edits:
        found = 0
        for function in mutant.function.split("|"):
            start, end = function_span(text, function)
            body, n = re.subn(pattern, repl, text[start:end])
            text = text[:start] + body + text[end:]
            found += n
        if found != count:
            raise SystemExit(f"{mutant.name}: {pattern!r} matched {found} times, not {count}")
    return text


# ---------------------------------------------------------------------- running tests
def run_tests(
    copy: Path, tests: tuple[str, ...], seed: int | None, workers: int
) -> tuple[int, int, list[str]]:
    """Run ``tests`` in ``copy``: (tests run, tests failed, names of the failures)."""
    xml = copy / "junit.xml"
    order = ["-p", "no:randomly"] if seed is None else ["-p", "randomly", f"--randomly-seed={seed}"]
    cmd = [sys.executable, "-m", "pytest", *tests, "-q", "-p", "no:cacheprovider",
           f"--junitxml={xml}", *order]  # fmt: skip
    if workers > 1:
        cmd += ["-n", str(workers)]
    env = {**os.environ, "PYTHONPATH": str(copy / "src")}
    env.pop("HYPOTHESIS_PROFILE", None)
    subprocess.run(cmd, cwd=copy, env=env, capture_output=True, text=True, check=False)
    root = ET.parse(xml).getroot()
    cases = list(root.iter("testcase"))
    failed = [
        f"{c.get('classname')}::{c.get('name')}"
        for c in cases
        if c.find("failure") is not None or c.find("error") is not None
    ]
    return len(cases), len(failed), failed


def check_import(copy: Path) -> None:
    """The copy's lpbounds, not the working tree's, is what the tests import."""
    env = {**os.environ, "PYTHONPATH": str(copy / "src")}
    out = subprocess.run(
        [sys.executable, "-c", "import lpbounds; print(lpbounds.__file__)"],
        cwd=copy, env=env, capture_output=True, text=True, check=True,
    ).stdout.strip()  # fmt: skip
    if not out.startswith(str(copy)):
        raise SystemExit(f"the copy is not imported: lpbounds from {out}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", help="mutant names or issue rows (a-e)")
    ap.add_argument("--list", action="store_true", help="print the mutants and exit")
    ap.add_argument("--seed", type=int, default=None, help="pytest-randomly seed (random)")
    ap.add_argument("-n", "--workers", type=int, default=2, help="pytest-xdist workers")
    ap.add_argument("-v", "--verbose", action="store_true", help="name the failing tests")
    args = ap.parse_args(argv)
    chosen = [m for m in MUTANTS if not args.only or m.name in args.only or m.row in args.only]
    if args.list:
        for m in chosen:
            print(f"{m.name} [{m.row or '-'}]: {m.what}\n  {m.path}::{m.function}")
            for pattern, repl, count in m.edits:
                print(f"    s/{pattern}/{repl}/ x{count}")
        return 0
    seed = args.seed if args.seed is not None else random.randrange(2**31)
    print(f"random-order runs use --randomly-seed={seed}; {time.strftime('%Y-%m-%d %H:%M')}")
    rows = []
    with tempfile.TemporaryDirectory(prefix="lpbounds-mutants-") as tmp:
        copy = make_copy(Path(tmp))
        check_import(copy)
        for tests in dict.fromkeys(m.tests for m in chosen):
            for s in (None, seed):
                n, bad, names = run_tests(copy, tests, s, args.workers)
                print(f"baseline {' '.join(tests)} ({'file' if s is None else 'random'} order): "
                      f"{bad} of {n} fail", flush=True)  # fmt: skip
                if bad:
                    print("  " + "\n  ".join(names))
                    return 1
        for m in chosen:
            target = copy / m.path
            original = target.read_text()
            target.write_text(mutate(original, m))
            try:
                counts, failed = [], []
                for s in (None, seed):
                    n, bad, names = run_tests(copy, m.tests, s, args.workers)
                    counts.append((bad, n))
                    failed += [t for t in names if t not in failed]
            finally:
                target.write_text(original)
            rows.append((m, counts))
            (b1, n1), (b2, n2) = counts
            print(f"{m.name}: {b1} of {n1} fail in file order, {b2} of {n2} in random order",
                  flush=True)  # fmt: skip
            if args.verbose:
                print("  " + "\n  ".join(failed))
    print("\n| weakening | where | tests failing (file order) | (random order) |")
    print("|---|---|---|---|")
    for m, ((b1, n1), (b2, n2)) in rows:
        label = f"{m.row}: {m.what}" if m.row else m.what
        where = f"{m.path.removeprefix('src/')}::{m.function.replace('|', ', ')}"
        print(f"| {label} | `{where}` | {b1} of {n1} | {b2} of {n2} |")
    weak = [m.name for m, counts in rows if min(b for b, _ in counts) < 3]
    if weak:
        print(f"\nfewer than 3 failing tests: {', '.join(weak)}")
    return 1 if weak else 0


if __name__ == "__main__":
    sys.exit(main())
