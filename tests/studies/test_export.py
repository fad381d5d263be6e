"""``lpbounds export`` / ``lpbounds score``: the written model is the formulation's LP, HiGHS
(reading the file back) solves it to the sidecar's optimum within its certificate, and a
solver's solution file is scored with numbers recomputed here from HiGHS' own copy of the
model; malformed input is a one-line error with exit status 2."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import lpbounds as lb
from lpbounds.certification.certificate import certify
from lpbounds.cli.main import main
from lpbounds.formulations.highs import quiet_highs
from lpbounds.studies.compare import FORMULATIONS, load_case
from lpbounds.studies.export import EXPORT_FILES, exact_optimum, load_export, read_solution
from tests.conftest import reference_solve

GARNET = "garnet:40:6:3"
CASES = [(GARNET, "ELP"), (GARNET, "RLP"), (GARNET, "SLP"), (GARNET, "IB"),
         ("patrol-small", "UBLP"), ("patrol-small", "LBLP")]  # fmt: skip


def export(tmp_path: Path, model: str, formulation: str, *extra: str) -> Path:
    out = tmp_path / f"{formulation.lower()}-out"
    assert main(["export", model, "--formulation", formulation, "--out", str(out), *extra]) == 0
    return out


def highs_read(path: Path):
    """The model file read back and solved by HiGHS (no lpbounds code involved)."""
    h = quiet_highs()
    h.readModel(str(path))
    h.run()
    assert h.getModelStatus().name == "kOptimal"
    return h


def highs_matrix(h) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """``(A, row_lower, cost)`` of the model HiGHS holds."""
    lp = h.getLp()
    a = lp.a_matrix_
    mat = sp.csc_matrix(
        (np.asarray(a.value_), np.asarray(a.index_), np.asarray(a.start_)),
        shape=(lp.num_row_, lp.num_col_),
    )
    assert np.all(np.isinf(lp.row_upper_)) and np.all(np.isinf(lp.col_lower_))
    return mat.tocsr(), np.asarray(lp.row_lower_), np.asarray(lp.col_cost_)


@pytest.mark.parametrize(("model", "formulation"), CASES)
def test_highs_solves_the_exported_mps_to_the_sidecar_optimum(tmp_path, model, formulation):
    out = export(tmp_path, model, formulation)
    side = json.loads((out / "lp.json").read_text())
    x_star = np.load(out / "optimum.npy")
    opt = side["optimum"]
    assert opt["exact"] is True
    form = FORMULATIONS[formulation].build(load_case(model))
    h = highs_read(out / "lp.mps")
    # the file holds the formulation's data, read back by HiGHS
    a, b, c = highs_matrix(h)
    assert a.shape == form.A.shape == (side["sizes"]["rows"], side["sizes"]["columns"])
    assert abs(a - form.A).max() == 0 and np.array_equal(b, form.b) and np.array_equal(c, form.c)
    x_h = np.asarray(h.getSolution().col_value)
    err_h = certify(form.rows, x_h).error_bound
    err_star = opt["certificate"]["error_bound"]
    scale = float(np.abs(form.rows.reward).max()) / (1 - form.rows.discount)
    assert err_star <= 1e-10 * scale
    # both points lie within their certified distance of the one exact optimum
    assert np.abs(x_h - x_star).max() <= err_h + err_star
    lo, hi = opt["objective_bracket"]
    assert lo <= float(c @ x_star) <= hi and hi - lo <= 1e-9 * scale * c.sum()
    slack = c.sum() * err_h * (1 + 1e-12) + 1e-12 * abs(hi)
    assert lo - slack <= h.getInfo().objective_function_value <= hi + slack


def test_elp_optimum_is_the_plain_value_iteration_answer(tmp_path):
    out = export(tmp_path, GARNET, "ELP")
    v = reference_solve(load_case(GARNET).mdp)  # plain numpy VI, independent of lpbounds DP
    assert np.abs(np.load(out / "optimum.npy") - v).max() <= 1e-10 * np.abs(v).max()


def test_the_lp_format_reads_back_with_the_same_optimum(tmp_path):
    out = export(tmp_path, GARNET, "RLP", "--format", "lp")
    assert (out / "lp.lp").is_file() and not (out / "lp.mps").exists()
    h = highs_read(out / "lp.lp")
    x_star = np.load(out / "optimum.npy")
    err = json.loads((out / "lp.json").read_text())["optimum"]["certificate"]["error_bound"]
    rows = FORMULATIONS["RLP"].build(load_case(GARNET)).rows
    x_h = np.asarray(h.getSolution().col_value)
    assert np.abs(x_h - x_star).max() <= err + certify(rows, x_h).error_bound


def test_sidecar_names_columns_rows_and_provenance(tmp_path):
    out = export(tmp_path, "patrol-small", "UBLP")
    side = json.loads((out / "lp.json").read_text())
    prov = side["provenance"]
    path = Path(prov["model_path"])
    assert path.name == "patrol-small.toml"
    assert prov["model_sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert prov["model_parameters"]["N"] == 6 and prov["formulation"] == "UBLP"
    assert prov["command"].startswith("lpbounds export patrol-small --formulation UBLP")
    assert side["sizes"]["columns"] == 176  # M of patrol-small (the model file's comment)
    (block,) = side["naming"]["column_blocks"]
    assert (block["variable"], block["first"], block["count"]) == ("w", 0, 176)
    rows = np.load(out / "rows.npz")
    assert rows["column_keys"].shape == (176, len(side["naming"]["column_keys"]))
    assert rows["owner"].shape == (side["sizes"]["rows"],)
    names = {e["name"] for e in json.loads((out / "manifest.json").read_text())["files"]}
    assert names == {"lp.mps", "lp.json", "optimum.npy", "rows.npz"}


def test_partition_option_replaces_the_partition(tmp_path):
    out = export(tmp_path, GARNET, "RLP", "--partition", "random:5:2")
    part = lb.random_partition(40, 5, seed=2)
    assert np.array_equal(np.load(out / "rows.npz")["partition_labels"], part.labels)
    rows = lb.BellmanRows.aggregate(load_case(GARNET).mdp, part, reduce="max")
    v = lb.solve_exact(rows, tol=1e-13).values
    assert np.abs(np.load(out / "optimum.npy") - v).max() <= 1e-10 * np.abs(v).max()


def test_a_random_partition_keeps_the_sink_alone(tmp_path):
    """``random:M`` of a model with a sink: ``random_partition(mdp, M)``, the sink alone."""
    pytest.importorskip("gymnasium")
    out = export(tmp_path, "frozenlake", "RLP", "--partition", "random:5:2")
    labels = np.load(out / "rows.npz")["partition_labels"]
    mdp = load_case("frozenlake").mdp
    assert np.array_equal(labels, lb.random_partition(mdp, 5, seed=2).labels)
    assert (labels == labels[-1]).sum() == 1  # state 16, the sink, alone


def test_partition_from_a_labels_file(tmp_path, capsys):
    labels = np.arange(40) % 4
    np.save(tmp_path / "labels.npy", labels)
    out = export(tmp_path, GARNET, "SLP", "--partition", str(tmp_path / "labels.npy"))
    assert np.array_equal(np.load(out / "rows.npz")["partition_labels"], labels)
    assert json.loads((out / "lp.json").read_text())["sizes"]["columns"] == 4
    np.save(tmp_path / "bad.npy", labels - 1)  # label -1 at state 0
    bad = ["--partition", str(tmp_path / "bad.npy"), "--out", str(tmp_path / "o")]
    assert main(["export", GARNET, "--formulation", "RLP", *bad]) == 2
    one_line_error(capsys, "--partition", "labels[0] = -1 is negative")


# ---------------------------------------------------------------------- score
def parse_highs_columns(path: Path) -> np.ndarray:
    """The primal columns of a HiGHS raw solution file, read by the simplest loop."""
    lines = path.read_text().splitlines()
    k = lines.index("# Primal solution values")
    k = next(i for i in range(k, len(lines)) if lines[i].startswith("# Columns"))
    n = int(lines[k].split()[2])
    return np.array([float(ln.split()[1]) for ln in lines[k + 1 : k + 1 + n]])


@pytest.fixture
def rlp_export(tmp_path) -> Path:
    return export(tmp_path, GARNET, "RLP")


def test_score_of_a_highs_solution_file(rlp_export, tmp_path, capsys):
    h = highs_read(rlp_export / "lp.mps")
    sol = tmp_path / "sol.txt"
    h.writeSolution(str(sol), 0)
    capsys.readouterr()
    js = tmp_path / "score.json"
    assert main(["score", str(rlp_export), str(sol), "--json", str(js)]) == 0
    assert "certified error" in capsys.readouterr().out
    got = json.loads(js.read_text())
    x = parse_highs_columns(sol)
    a, b, c = highs_matrix(h)
    x_star = np.load(rlp_export / "optimum.npy")
    rows = FORMULATIONS["RLP"].build(load_case(GARNET)).rows
    assert got["format"] == "highs-raw" and got["model_status"] == "Optimal"
    assert got["objective"] == pytest.approx(float(c @ x), rel=1e-14)
    assert got["max_deviation"] == pytest.approx(np.abs(x - x_star).max(), rel=1e-9, abs=1e-15)
    assert got["primal_infeasibility"] == pytest.approx(max(0.0, (b - a @ x).max()), abs=1e-15)
    assert got["certified_error"] == certify(rows, x).error_bound
    assert got["status"] == "optimal"


def test_every_solution_format_gives_the_same_score(rlp_export, tmp_path):
    h = highs_read(rlp_export / "lp.mps")
    raw, sparse = tmp_path / "raw.sol", tmp_path / "sparse.sol"
    h.writeSolution(str(raw), 0)
    h.writeSolution(str(sparse), 4)
    x = parse_highs_columns(raw)
    np.save(tmp_path / "x.npy", x)
    np.savetxt(tmp_path / "x.txt", x, fmt="%.17g")
    n = x.size
    for f in (raw, sparse, tmp_path / "x.npy", tmp_path / "x.txt"):
        assert np.array_equal(read_solution(f, n)[0], x), f


def test_a_perturbed_optimum_is_caught(rlp_export, tmp_path):
    x_star = np.load(rlp_export / "optimum.npy")
    x = x_star.copy()
    x[3] -= 0.25  # below the least feasible point: infeasible, and 0.25 from the optimum
    np.save(tmp_path / "bad.npy", x)
    js = tmp_path / "s.json"
    assert main(["score", str(rlp_export), str(tmp_path / "bad.npy"), "--json", str(js)]) == 0
    got = json.loads(js.read_text())
    a, b, _ = highs_matrix(highs_read(rlp_export / "lp.mps"))
    assert got["max_deviation"] == 0.25 and got["worst_column"] == 3
    assert got["primal_infeasibility"] == pytest.approx((b - a @ x).max(), rel=1e-12)
    assert got["primal_infeasibility"] > 0.1
    assert got["certified_error"] >= 0.25 - 1e-9  # the certificate cannot miss a known error
    assert got["status"] == "inaccurate"


def test_no_exact_optimum_is_written_as_null_with_the_reason(tmp_path, monkeypatch):
    from lpbounds.errors import ConvergenceError
    from lpbounds.formulations.rows_lp import RowsLP

    def fail(self, tol=None):
        raise ConvergenceError("no convergence in 3 iterations")

    monkeypatch.setattr(RowsLP, "fixed_point", fail)
    form = FORMULATIONS["RLP"].build(load_case(GARNET))
    assert exact_optimum(form).x is None
    out = export(tmp_path, GARNET, "RLP")
    opt = json.loads((out / "lp.json").read_text())["optimum"]
    assert opt["exact"] is None and "no convergence" in opt["reason"]
    assert not (out / "optimum.npy").exists()
    x = np.asarray(highs_read(out / "lp.mps").getSolution().col_value)
    np.save(tmp_path / "x.npy", x)
    js = tmp_path / "s.json"
    assert main(["score", str(out), str(tmp_path / "x.npy"), "--json", str(js)]) == 0
    got = json.loads(js.read_text())
    assert got["max_deviation"] is None and got["certified_error"] < 1e-9


# ---------------------------------------------------------------------- hostile input
def one_line_error(capsys, *fragments: str) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    for f in fragments:
        assert f in err, (f, err)
    return err


@pytest.mark.parametrize(
    ("args", "fragments"),
    [
        (["--formulation", "ALP"], ["--formulation 'ALP'", "ELP, RLP"]),
        (["--formulation", "XYZ"], ["not an exportable formulation"]),
        (["--formulation", "RLP", "--format", "csv"], ["--format 'csv'"]),
        (["--formulation", "ELP", "--partition", "random:3"], ["ELP uses no partition"]),
        (["--formulation", "RLP", "--partition", "random:x"], ["random:M[:SEED]"]),
        (["--formulation", "RLP", "--partition", "random:99"], ["--partition", "n_partitions"]),
        (["--formulation", "IB", "--partition", "nope.npy"], ["--partition 'nope.npy'"]),
        (["--formulation", "UBLP"], ["patrol instances only"]),
    ],
)
def test_bad_export_arguments_exit_2_and_write_nothing(tmp_path, capsys, args, fragments):
    out = tmp_path / "o"
    assert main(["export", GARNET, *args, "--out", str(out)]) == 2
    one_line_error(capsys, *fragments)
    assert not out.exists()


def test_a_patrol_mdp_too_large_to_enumerate_is_refused_before_building(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["export", "patrol-m8", "--formulation", "ELP", "--out", str(out)]) == 2
    one_line_error(capsys, "41,665,015,288 states", "UBLP and LBLP")
    assert not out.exists()


def test_out_dir_with_foreign_files_is_refused_and_an_export_is_replaced(tmp_path, capsys):
    out = tmp_path / "o"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert main(["export", GARNET, "--formulation", "RLP", "--out", str(out)]) == 2
    one_line_error(capsys, "--out", "notes.txt")
    assert [p.name for p in out.iterdir()] == ["notes.txt"]
    (out / "notes.txt").unlink()
    assert main(["export", GARNET, "--formulation", "RLP", "--out", str(out)]) == 0
    assert main(["export", GARNET, "--formulation", "ELP", "--out", str(out)]) == 0
    assert json.loads((out / "lp.json").read_text())["formulation"] == "ELP"
    assert {p.name for p in out.iterdir()} <= set(EXPORT_FILES)


def _bad_solutions(tmp: Path, n: int) -> list[tuple[Path, list[str]]]:
    cases = []
    short = tmp / "short.npy"
    np.save(short, np.zeros(n - 1))
    cases.append((short, ["short.npy", f"shape ({n - 1},)", f"{n} columns"]))
    nan = tmp / "nan.txt"
    nan.write_text("\n".join(["1.0"] * 4 + ["nan"] + ["1.0"] * (n - 5)) + "\n")
    cases.append((nan, ["nan.txt", "x[4] = nan is not finite"]))
    word = tmp / "word.txt"
    word.write_text("1.0\n2.0\nabc\n")
    cases.append((word, ["word.txt' line 3", "'abc' is not a number"]))
    binary = tmp / "blob.bin"
    binary.write_bytes(bytes(range(256)))
    cases.append((binary, ["blob.bin", "neither text nor a .npy"]))
    strings = tmp / "s.npy"
    np.save(strings, np.array(["a"] * n))
    cases.append((strings, ["s.npy", "real numbers"]))
    cases.append((tmp / "missing.sol", ["missing.sol", "does not exist"]))
    empty_highs = tmp / "none.sol"
    empty_highs.write_text("Model status\nInfeasible\n\n# Primal solution values\nNone\n")
    cases.append((empty_highs, ["none.sol' line 5", "'None'", "no point to score"]))
    return cases


def test_malformed_solution_files_exit_2_naming_file_and_entry(rlp_export, tmp_path, capsys):
    n = np.load(rlp_export / "optimum.npy").size
    for path, fragments in _bad_solutions(tmp_path, n):
        assert main(["score", str(rlp_export), str(path)]) == 2, path
        one_line_error(capsys, *fragments)
    # the model file itself, given as the solution
    assert main(["score", str(rlp_export), str(rlp_export / "lp.mps")]) == 2
    one_line_error(capsys, "lp.mps' line 1", "'NAME' is not a number")


def test_a_solution_of_another_model_is_refused(rlp_export, tmp_path, capsys):
    other = export(tmp_path, GARNET, "ELP")  # 40 columns, RLP has 6
    sol = tmp_path / "elp.sol"
    highs_read(other / "lp.mps").writeSolution(str(sol), 0)
    assert main(["score", str(rlp_export), str(sol)]) == 2
    one_line_error(capsys, "elp.sol' line", "40 columns", "6")
    text = sol.read_text().replace("\nc3 ", "\nx3 ", 1)
    sol.write_text(text)
    assert main(["score", str(other), str(sol)]) == 2
    one_line_error(capsys, "column 'x3' where 'c3' was expected")


def test_score_of_a_folder_that_is_not_an_export(tmp_path, capsys):
    (tmp_path / "x.npy").write_bytes(b"")
    assert main(["score", str(tmp_path), str(tmp_path / "x.npy")]) == 2
    one_line_error(capsys, "not an lpbounds export", "lp.json")
    assert main(["score", str(tmp_path / "nope"), str(tmp_path / "x.npy")]) == 2
    one_line_error(capsys, "does not exist")


def test_load_export_refuses_a_truncated_rows_file(rlp_export):
    (rlp_export / "rows.npz").write_bytes(b"PK\x03\x04 truncated")
    with pytest.raises(lb.ValidationError, match=r"rows\.npz"):
        load_export(rlp_export)


def test_export_argument_errors_carry_data_not_options(tmp_path):
    """The library names the argument and its value; only the command line says --format."""
    from lpbounds.studies.export import ExportArgumentError, export_lp

    with pytest.raises(ExportArgumentError) as info:
        export_lp(GARNET, "RLP", tmp_path / "o", fmt="csv")
    assert (info.value.argument, info.value.value) == ("fmt", "csv")
    assert "--" not in str(info.value)
    assert info.value.message("--format").startswith("--format 'csv': choose one of")
