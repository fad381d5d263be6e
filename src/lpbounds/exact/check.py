r"""Check lpbounds' exact certificates with Python's standard library alone.

Run it as ``python -m lpbounds.exact.check FILE...`` or, from any Python 3.10+, as a plain
script: ``python check.py FILE...`` (``python -I -S check.py FILE`` proves the point: no
site-packages at all). Exit status 0 when every file proves its claim, 1 otherwise.

A certificate (a JSON file written by :func:`lpbounds.exact.files.write_certificate`)
states a claim of the paper about one instance and carries its proof: the instance's data
(every double as a hex float, so exact), the exact optimal points ``x`` and duals ``y`` of
the LPs the claim is about, exact fixed points, and the comparisons that decide the claim.
A vector is ``{"den": D, "num": [N_1, ...]}`` (entry ``i`` is ``N_i / D``); a number is a
``"p/q"`` string or a hex float. This file re-derives everything from the data:

1. it builds each LP ``min c'x  s.t.  A x >= b`` from the model in rational arithmetic:
   ELP (eq. 8), RLP (eq. 9), IB (eq. 20-22), SLP (eq. 12, its rows multiplied by the
   common denominator of ``mu``, a positive factor), LLP (eq. 18, surplus lifting), ALP
   (eq. 10) or ROWS (a row system given as data: UBLP, LBLP);
2. it checks ``A x >= b``, ``y >= 0``, ``A'y = c`` and ``c'x = b'y`` exactly: by weak
   duality ``x`` is then optimal. With ``"unique"`` it also checks that the rows with
   ``y > 0`` hold one row per variable forming a strictly diagonally dominant matrix:
   every optimum makes those rows tight (complementary slackness with ``y``), so it is
   ``x``;
3. it checks fixed points: ``x = T x`` (``T``: the max over each variable's rows) or, for
   the disjunctive NLP, ``x = G x`` (``G``: max over actions of the min over its rows);
4. it evaluates every comparison of the claim and requires the exact difference and
   the verdict stated in the file.

A failure names the entry (the LP or fixed point, the row or column, the comparison).

**What it trusts:** Python's ``int``, :class:`fractions.Fraction`, :mod:`json`,
``float.fromhex`` (exact on the strings ``float.hex`` writes), :mod:`hashlib` (the
digest that ties the claim to the model data) and this file, about 410 lines; nothing
from numpy, a solver, python-flint or the rest of lpbounds. Mathematics: LP weak duality
(above) and, for claims stated on fixed points, Facts 1 and 2 of :mod:`lpbounds.rows`
(for rows that contract, ``lambda max_r sum_l p_rl < 1``, which is checked here: the fixed
point of ``T`` is the least point satisfying the rows, so the LP optimum for every cost
``c >= 0``; the fixed point of ``G`` is the disjunctive NLP's optimum for every ``c >= 0``).
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
from collections.abc import Callable
from fractions import Fraction

FORMAT = "lpbounds-exact-certificate"
VERSION = 1


class CheckError(Exception):
    """A certificate that does not prove its claim; the message names the entry."""


def integer(s: object) -> int:
    """An integer of a certificate: an int, or a decimal or ``0x`` hexadecimal string (the
    writer uses hex beyond 4,000 digits: Python limits decimal conversions of larger ints)."""
    if isinstance(s, int) and not isinstance(s, bool):
        return s
    if not isinstance(s, str):
        raise CheckError(f"not an integer: {s!r}")
    return int(s, 0)


def rat(s: object) -> Fraction:
    """A number of a certificate: an integer, a ``"p/q"`` string, or a hex float."""
    if isinstance(s, Fraction):
        return s
    if isinstance(s, str) and "p" in s.lower():
        return Fraction(float.fromhex(s))
    if not isinstance(s, str):
        return Fraction(integer(s))
    p, _, q = s.partition("/")
    den = integer(q) if q else 1
    if den <= 0:
        raise CheckError(f"non-positive denominator in {show(s)}")
    return Fraction(integer(p), den)


def show(x: object) -> str:
    """``x`` for a message: exact when short, else about 17 digits and its size."""
    if isinstance(x, (int, Fraction)) and abs(Fraction(x)) >= 10**60:
        f = Fraction(x)
        bits = f"{f.numerator.bit_length()}-bit / {f.denominator.bit_length()}-bit"
        try:
            return f"{float(f):.17g} (exact: {bits})"
        except OverflowError:
            return f"{'-' if f < 0 else ''}huge (exact: {bits})"
    text = str(x)
    return text if len(text) <= 80 else text[:77] + "..."


def vector(v: dict, name: str) -> tuple[list[int], int]:
    """``(numerators, denominator)`` of a vector ``{"den": D, "num": [...]}``, ``D > 0``."""
    den = integer(v["den"])
    if den <= 0:
        raise CheckError(f"{name}: non-positive denominator")
    return [integer(t) for t in v["num"]], den


def digest(model: dict) -> str:
    """SHA-256 of the model's canonical JSON (ties the claim to this data)."""
    return hashlib.sha256(
        json.dumps(model, sort_keys=True, separators=(",", ":")).encode()
    ).hexdigest()


# ---------------------------------------------------------------------------- the model
def load_model(m: dict) -> dict:
    """The model as ``pairs``: ``(x, u, R, {target: p})`` per allowed pair, in row-major
    order (``kind="mdp"``) or per given row (``kind="rows"``: ``x`` is the row's owner)."""
    lam, pairs = rat(m["discount"]), []
    if m["kind"] == "mdp":
        n, na = m["n_states"], m["n_actions"]
        allowed = m.get("allowed") or [[1] * na for _ in range(n)]
        owners = [(x, u) for x in range(n) for u in range(na) if allowed[x][u]]
        succ = [m["successors"][x][u] for x, u in owners]
        rew = [m["rewards"][x][u] for x, u in owners]
    elif m["kind"] == "rows":
        n = m["n_vars"]
        owners = list(zip(m["owner"], m["action"], strict=True))
        succ, rew = m["targets"], m["reward"]
    else:
        raise CheckError(f"model: unknown kind {m['kind']!r}")
    shared = m.get("shared_probabilities")
    for k, (x, u) in enumerate(owners):
        probs = (
            shared
            if shared is not None
            else (m["probabilities"][x][u] if m["kind"] == "mdp" else m["probs"][k])
        )
        dist: dict[int, Fraction] = {}
        for t, p in zip(succ[k], probs, strict=True):
            if rat(p):
                dist[int(t)] = dist.get(int(t), Fraction(0)) + rat(p)
        pairs.append((x, u, rat(rew[k]), dist))
    if not 0 <= lam < 1 or max((lam * sum(d.values()) for *_, d in pairs), default=0) >= 1:
        raise CheckError("model: the rows do not contract (lambda * row sum >= 1)")
    labels = m.get("partition")
    return {"lam": lam, "n": n, "pairs": pairs, "labels": labels}


def bellman(
    i: int, reward: Fraction, dist: dict, lam: Fraction, col: Callable[[int], int], group: object
) -> tuple:
    """Row ``v(i) - lambda sum_t p_t v(col(t)) >= R``: ``(coefs, rhs, owner, group)``."""
    coefs = {i: Fraction(1)}
    for t, p in dist.items():
        coefs[col(t)] = coefs.get(col(t), Fraction(0)) - lam * p
    return coefs, reward, i, group


def pair_rows(model: dict, aggregate: bool, shift: int = 0, src: int = 0) -> list:
    """One Bellman row per pair, over states or (``aggregate``) partitions; IB's copies
    put the owner ``shift`` and the targets ``src`` partitions further."""
    lab: list[int] = model["labels"] if aggregate else []
    if aggregate and lab is None:
        raise CheckError("model: this LP needs a partition")
    f: Callable[[int], int] = (lambda t: lab[t]) if aggregate else (lambda t: t)
    return [
        bellman(f(x) + shift, r, d, model["lam"], lambda t: f(t) + src, (f(x) + shift, u))
        for x, u, r, d in model["pairs"]
    ]


def n_parts(model: dict) -> int:
    return max(model["labels"]) + 1


def lp_of(spec: dict, model: dict) -> tuple[list, list[Fraction]]:
    """``(rows, cost)`` of the LP of ``spec`` (``{"formulation": ..., "cost": [...]}``)."""
    kind = spec["formulation"]
    cost = [rat(c) for c in spec.get("cost", [])]
    if kind in ("ELP", "ROWS", "RLP"):
        return pair_rows(model, kind == "RLP"), cost
    if kind == "IB":
        L, m = int(spec["L"]), n_parts(model)
        return [r for j in range(L) for r in pair_rows(model, True, j * m, (j - 1) % L * m)], cost
    if kind == "SLP":  # eq. 12 times the common denominator of mu
        mu, _ = vector(spec["mu"], "mu")
        sums: dict = {}
        for k, (coefs, rhs, i, g) in enumerate(pair_rows(model, True)):
            if mu[k]:
                acc, b, *_ = sums.setdefault(g, ({}, [Fraction(0)], i, g))
                for j, a in coefs.items():
                    acc[j] = acc.get(j, Fraction(0)) + mu[k] * a
                b[0] += mu[k] * rhs
        return [(a, b[0], i, g) for a, b, i, g in sums.values()], cost
    if kind == "LLP":  # variables (v, z): A v - z >= R, -A v + z >= -R, z >= 0
        rlp = pair_rows(model, True)
        m, kk = n_parts(model), len(rlp)
        lo = [({**a, m + k: Fraction(-1)}, b, -1, None) for k, (a, b, *_) in enumerate(rlp)]
        hi = [
            ({**{j: -t for j, t in a.items()}, m + k: Fraction(1)}, -b, -1, None)
            for k, (a, b, *_) in enumerate(rlp)
        ]
        nonneg = [({m + k: Fraction(1)}, Fraction(0), -1, None) for k in range(kk)]
        return lo + hi + nonneg, cost + [rat(d) for d in spec["d"]]
    if kind == "ALP":  # (Phi r)(x) >= R_u(x) + lambda sum_l p_l (Phi r)(f(x, u, Y_l))
        phi = [[rat(t) for t in row] for row in spec["basis"]]
        kf = len(phi[0])
        rows = []
        for coefs, rhs, _, g in pair_rows(model, False):
            a = [sum((c * phi[x][j] for x, c in coefs.items()), Fraction(0)) for j in range(kf)]
            rows.append(({j: t for j, t in enumerate(a) if t}, rhs, -1, g))
        sc = [rat(c) for c in spec["state_cost"]]
        return rows, [
            sum((sc[x] * phi[x][j] for x in range(len(sc))), Fraction(0)) for j in range(kf)
        ]
    raise CheckError(f"unknown formulation {kind!r}")


def rows_of(spec: dict, model: dict) -> list:
    """The row system of a fixed point: ``ELP``/``ROWS``/``RLP``/``IB``/``SLP`` rows, or ``NLP``'s
    disjunctions (``(i, u)`` kept only when ``u`` is allowed at every state of ``S_i``)."""
    if spec["rows"] != "NLP":
        return lp_of({**spec, "formulation": spec["rows"]}, model)[0]
    lab = model["labels"]
    allowed = {(x, u) for x, u, *_ in model["pairs"]}
    members: dict[int, list[int]] = {}
    for x, part in enumerate(lab):
        members.setdefault(part, []).append(x)
    keep = [all((y, u) in allowed for y in members[lab[x]]) for x, u, *_ in model["pairs"]]
    return [r for r, k in zip(pair_rows(model, True), keep, strict=True) if k]


# ---------------------------------------------------------------------------- the checks
def slack(row: tuple, num: list[int], den: int) -> Fraction:
    """``den * (a'x - b)`` for ``x = num / den``: its sign is the row's."""
    coefs, rhs, *_ = row
    return sum((a * num[j] for j, a in coefs.items()), Fraction(0)) - rhs * den


def check_lp(name: str, spec: dict, model: dict) -> Fraction:
    """Primal and dual feasibility and equal objectives; returns the optimal value."""
    rows, cost = lp_of(spec["lp"], model)
    (xn, xd), (yn, yd) = vector(spec["x"], name + ": x"), vector(spec["y"], name + ": y")
    if len(xn) != len(cost) or len(yn) != len(rows):
        raise CheckError(
            f"{name}: x has {len(xn)} entries for {len(cost)} variables, y "
            f"{len(yn)} for {len(rows)} rows"
        )
    col = [Fraction(0)] * len(cost)
    for r, row in enumerate(rows):
        s = slack(row, xn, xd)
        if s < 0:
            raise CheckError(f"{name}: x violates row {r} by {show(-s / xd)}")
        if yn[r] < 0:
            raise CheckError(f"{name}: y[{r}] = {show(Fraction(yn[r], yd))} is negative")
        for j, a in row[0].items():
            col[j] += a * yn[r]
    for j, cj in enumerate(cost):
        if col[j] != cj * yd:
            raise CheckError(
                f"{name}: column {j} of A'y is {show(col[j] / yd)}, not the cost {show(cj)}"
            )
    primal = sum((c * t for c, t in zip(cost, xn, strict=True)), Fraction(0)) / xd
    dual = sum((row[1] * t for row, t in zip(rows, yn, strict=True)), Fraction(0)) / yd
    if primal != dual or primal != rat(spec["objective"]):
        raise CheckError(
            f"{name}: c'x = {show(primal)}, b'y = {show(dual)}, stated objective "
            f"{show(spec['objective'])}: not all equal"
        )
    if spec.get("unique"):
        check_unique(name, rows, yn, len(cost))
    return primal


def check_unique(name: str, rows: list, yn: list[int], n: int) -> None:
    """Each variable owns a row with ``y > 0`` whose own coefficient exceeds the sum of
    the others' magnitudes (Levy-Desplanques: those rows are nonsingular)."""
    dominant = {
        row[2]
        for row, t in zip(rows, yn, strict=True)
        if t > 0
        and row[2] >= 0
        and abs(row[0][row[2]]) > sum(abs(a) for j, a in row[0].items() if j != row[2])
    }
    missing = [j for j in range(n) if j not in dominant]
    if missing:
        raise CheckError(
            f"{name}: uniqueness not shown for variable {missing[0]} (no "
            "diagonally dominant row with y > 0)"
        )


def check_fixed_point(name: str, spec: dict, model: dict) -> None:
    """``x = T x`` (``spec["game"]`` false) or ``x = G x`` (true), exactly."""
    xn, xd = vector(spec["x"], name + ": x")
    best: dict[int, dict] = {}  # owner -> group -> largest slack of the group's rows
    for row in rows_of(spec, model):
        s, g = slack(row, xn, xd), best.setdefault(row[2], {})
        key = row[3] if spec.get("game") else len(g)  # max over every row: its own group
        g[key] = max(g.get(key, s), s)
    for i in range(len(xn)):
        if i not in best:
            raise CheckError(f"{name}: variable {i} owns no row")
        low = min(best[i].values())  # (Tx)(i) = x(i) - low
        if low != 0:
            what = "G x" if spec.get("game") else "T x"
            raise CheckError(f"{name}: ({what})({i}) - x({i}) = {show(-low / xd)}, not 0")


# ---------------------------------------------------------------------------- the claim
def value(e: dict, found: dict, model: dict) -> tuple[list[int], int]:
    """The vector an expression names: ``{"of": id, "part": ...}`` with part ``"x"``
    (default), ``"objective"`` or ``"lp.<field>"`` (a vector of the LP's data), optionally
    a ``slice`` of it and ``lift``-ed to states; ``{"sum": [...]}`` of such vectors; or
    ``{"vector": VECTOR}``, numbers stated in the file."""
    if "vector" in e:  # numbers stated in the file (e.g. a conjecture's own values)
        return vector(e["vector"], "comparison vector")
    if "sum" in e:
        parts = [value(t, found, model) for t in e["sum"]]
        num, den = parts[0]
        for pn, pd in parts[1:]:
            num, den = [a * pd + b * den for a, b in zip(num, pn, strict=True)], den * pd
        return num, den
    if e["of"] not in found:
        raise CheckError(f"comparison: unknown entry {e['of']!r}")
    entry = found[e["of"]]
    part = e.get("part", "x")
    if part == "objective":
        obj = entry["objective"]
        v = ([obj.numerator], obj.denominator)
    elif part.startswith("lp."):  # a vector of the LP's data, e.g. "lp.state_cost"
        c = [rat(t) for t in entry["spec"]["lp"][part[3:]]]
        den = math.lcm(*(t.denominator for t in c))
        v = ([int(t * den) for t in c], den)
    else:
        v = vector(entry["spec"]["x"], e["of"])
    num, den = v
    if "slice" in e:
        num = num[e["slice"][0] : e["slice"][1]]
    if e.get("lift"):
        num = [num[i] for i in model["labels"]]
    return num, den


def evaluate(k: int, c: dict, found: dict, model: dict) -> tuple[Fraction, bool]:
    """Comparison ``k``, ``left REL right`` entrywise: its exact difference (``max |l - r|``
    for ``==``, ``min (l - r)`` otherwise) and whether it holds."""
    (an, ad), (bn, bd) = value(c["left"], found, model), value(c["right"], found, model)
    if len(an) != len(bn):
        raise CheckError(f"comparison {k}: {len(an)} entries against {len(bn)}")
    diffs = [a * bd - b * ad for a, b in zip(an, bn, strict=True)]
    rel = c["relation"]
    if rel == "==":
        d = Fraction(max(abs(t) for t in diffs), ad * bd)
        return d, d == 0
    if rel in (">=", ">"):
        d = Fraction(min(diffs), ad * bd)
        return d, (d >= 0 if rel == ">=" else d > 0)
    raise CheckError(f"comparison {k}: unknown relation {rel!r}")


def compare(k: int, c: dict, found: dict, model: dict) -> bool:
    """Comparison ``k`` evaluated; its difference and verdict must be those stated."""
    d, holds = evaluate(k, c, found, model)
    if d != rat(c["difference"]) or ("holds" if holds else "violated") != c["verdict"]:
        raise CheckError(
            f"comparison {k} ({c.get('claim', '')}): the difference is {show(d)} "
            f"and the verdict {'holds' if holds else 'violated'}; the file states "
            f"{show(c['difference'])} and {c['verdict']}"
        )
    return holds


def check_certificate(cert: dict) -> str:
    """Check one certificate (parsed JSON); the claim's verdict, or CheckError."""
    if cert.get("format") != FORMAT or cert.get("version") != VERSION:
        raise CheckError(f"not a {FORMAT} version {VERSION}")
    if digest(cert["model"]) != cert["model_digest"]:
        raise CheckError("model: the data does not match model_digest (changed after writing)")
    model = load_model(cert["model"])
    found: dict = {}
    for k, spec in enumerate(cert.get("lps", [])):
        name = f"lps[{k}] {spec['id']!r}"
        found[spec["id"]] = {"spec": spec, "objective": check_lp(name, spec, model)}
    for k, spec in enumerate(cert.get("fixed_points", [])):
        check_fixed_point(f"fixed_points[{k}] {spec['id']!r}", spec, model)
        found[spec["id"]] = {"spec": spec, "objective": None}
    claim = cert["claim"]
    holds = all([compare(k, c, found, model) for k, c in enumerate(claim["comparisons"])])
    verdict = "holds" if holds else "violated"
    if verdict != claim["verdict"]:
        raise CheckError(
            f"claim: the comparisons give {verdict}; the file states {claim['verdict']}"
        )
    return verdict


def main(argv: list[str] | None = None) -> int:
    """Check every file named; print one line each; 0 when all prove their claims."""
    files = sys.argv[1:] if argv is None else argv
    if not files:
        print("usage: python -m lpbounds.exact.check FILE...", file=sys.stderr)
        return 2
    failed = 0
    for path in files:
        try:
            with open(path, encoding="utf-8") as f:
                cert = json.load(f)
            verdict = check_certificate(cert)
            print(f"{path}: OK: {cert['claim']['name']} {verdict} on {cert['claim']['instance']}")
        except (CheckError, OSError, ValueError, KeyError, TypeError, IndexError) as exc:
            failed += 1
            kind = "" if isinstance(exc, CheckError) else f"{type(exc).__name__}: "
            print(f"{path}: FAILED: {kind}{exc}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
