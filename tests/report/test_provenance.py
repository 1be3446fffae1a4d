"""A report's provenance names paths without this machine's folders."""

from __future__ import annotations

from omnislam.report.provenance import command_line, shown_path


def test_paths_are_shown_relative_to_the_working_folder_or_the_cache(tmp_path):
    work, cache = tmp_path / "repo", tmp_path / "cache"
    (work / "runs" / "suite").mkdir(parents=True)
    (cache / "renders" / "demo-s0").mkdir(parents=True)

    def shown(path):
        return shown_path(path, cwd=work, cache=cache)

    assert shown(work / "runs" / "suite") == "runs/suite"
    assert shown(work) == "."
    assert shown(cache / "renders" / "demo-s0") == "$OMNISLAM_CACHE/renders/demo-s0"
    assert shown(tmp_path / "elsewhere" / "suite-final") == ".../suite-final"
    assert shown("runs/suite") == "runs/suite"  # relative paths and dataset names as given
    assert shown("mrclam6-r1") == "mrclam6-r1"


def test_the_command_line_hides_absolute_paths(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    line = command_line(["omnislam", "report", str(tmp_path / "results"), "--out", "/x/y/rep"])
    assert line == "omnislam report results --out .../rep"
