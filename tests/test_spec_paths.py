"""`trigint run` keeps every file inside the output folder: spec ids are plain names, and each
output path is resolved and checked before anything runs."""

import contextlib
import io
from pathlib import Path

import pytest

from trigint import cli, experiments


def _spec_with_id(tmp_path, fid):
    text = (experiments.spec.resources.files("trigint.experiments") / "specs" / "fig5.toml").read_text()
    path = tmp_path / "mine.toml"
    path.write_text(text.replace('id = "fig5"', f"id = {fid!r}"))
    return path


@pytest.mark.parametrize("fid", ["../escaped", "sub/../../escaped", "/tmp/trigint-escaped-absolute", ".."])
def test_spec_ids_cannot_write_outside_the_output_folder(tmp_path, fid):
    path = _spec_with_id(tmp_path, fid)
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = cli.main(["run", str(path), "--quick", "--out", str(tmp_path / "out" / "deeper")])
    assert code == 2
    assert f"mine.toml: id: {fid!r} cannot name output files: it must be one plain name" in err.getvalue()
    assert "without '/', '\\' or '..', so that every file stays in the output folder" in err.getvalue()
    written = [p for p in tmp_path.rglob("*") if p.is_file() and p != path]
    assert written == []
    assert not Path("/tmp/trigint-escaped-absolute.nc").exists()


def test_a_plain_id_names_the_files(tmp_path):
    path = _spec_with_id(tmp_path, "my-figure_2")
    out = tmp_path / "out"
    with contextlib.redirect_stdout(io.StringIO()):
        claims, _ = experiments.run_spec(experiments.load(path, quick=True), out, log=lambda *a: None)
    assert sorted(p.name for p in out.iterdir()) == ["my-figure_2.nc", "my-figure_2.pdf", "my-figure_2.png"]
    assert all(c.passed for c in claims)


def test_output_files_resolve_inside_the_output_folder(tmp_path):
    """A link in the output folder that points elsewhere is refused before the run."""
    out = tmp_path / "out"
    out.mkdir()
    (tmp_path / "elsewhere").mkdir()
    (out / "fig5.nc").symlink_to(tmp_path / "elsewhere" / "fig5.nc")
    with pytest.raises(ValueError, match=r"figure.id: 'fig5' would write fig5.nc outside the output folder"):
        experiments.run_spec(experiments.load("fig5", quick=True), out, log=lambda *a: None)
    with pytest.raises(ValueError, match=r"would write fig5.nc outside the output folder"):
        experiments.reproduce(["fig5"], out, quick=True, log=lambda *a: None)
    assert list((tmp_path / "elsewhere").iterdir()) == []
