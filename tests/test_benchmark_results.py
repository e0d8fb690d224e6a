"""A benchmark's results file says where its figures came from: commit, date, machine, load, command."""

from __future__ import annotations

import json
import sys

from simgap.files import BenchmarkResults


def test_results_file_has_provenance_figures_and_printed_lines(tmp_path, capsys):
    results = BenchmarkResults(argv=[sys.argv[0], "--fast"])
    with results.printed():
        print("| car | 1.5 |")
    path = results.write(tmp_path / "deep" / "r.json", {"figure": 1.5, "commit": "not this"}, printed=True)
    data = json.loads(path.read_text())
    assert set(BenchmarkResults.PROVENANCE) <= set(data)
    assert data["commit"] != "not this" and data["figure"] == 1.5
    assert data["load"]["cpus"] >= 1 and data["command"].endswith("--fast")
    assert data["printed"] == ["| car | 1.5 |"]
    assert "| car | 1.5 |" in capsys.readouterr().out


def test_a_list_of_records_goes_under_rows(tmp_path):
    data = json.loads(BenchmarkResults(argv=["x.py"]).write(tmp_path / "r.json", [{"a": 1}]).read_text())
    assert data["rows"] == [{"a": 1}] and "date" in data
