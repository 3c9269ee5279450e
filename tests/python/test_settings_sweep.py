"""`python -m rockbench.settings_sweep`: a bad --scenes is one line on stderr and exit 2, before
any run and with nothing written."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from conftest import SCENES

from rockbench import settings_sweep


def sweep(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = settings_sweep.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def scenes_dir(tmp_path: Path, square: str) -> Path:
    """A scenes folder: the real housner-slender.toml, and `square` as housner-square.toml."""
    d = tmp_path / "scenes"
    d.mkdir(parents=True)
    (d / "housner-slender.toml").write_text((SCENES / "housner-slender.toml").read_text())
    (d / "housner-square.toml").write_text(square)
    return d


def test_a_bad_scenes_folder_is_one_line_and_writes_nothing(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    missing = tmp_path / "nowhere"
    empty = tmp_path / "empty"
    empty.mkdir()
    a_file = tmp_path / "file.toml"
    a_file.write_text("")
    bad = scenes_dir(tmp_path, 'name = "x"\n\n[[blocks]]\nwidth = 0.2\nheight = 1.0\n')
    cases = {
        missing: f"--scenes {missing}: no such directory",
        a_file: f"--scenes {a_file}: not a directory",
        empty: f"--scenes {empty}: no housner-slender.toml (the sweep needs housner-slender.toml and housner-square.toml)",
        bad: f"--scenes: {bad / 'housner-square.toml'}: blocks[0]: missing field `name`",
    }
    out = tmp_path / "out" / "sweep.md"
    for scenes, message in cases.items():
        code, stdout, stderr = sweep(capsys, "--scenes", str(scenes), "--out", str(out))
        assert (code, stdout, stderr) == (2, "", message + "\n")
    # Scenes, but not of one block rocking freely: Housner's model refuses a column; a block at
    # rest has no impact to measure against.
    column = scenes_dir(tmp_path / "column", (SCENES / "standing-column.toml").read_text())
    at_rest = scenes_dir(tmp_path / "rest", 'name = "still"\nduration = 1.0\n\n[[blocks]]\nname = "b"\nwidth = 0.2\nheight = 1.0\n')
    code, stdout, stderr = sweep(capsys, "--scenes", str(column), "--out", str(out))
    assert code == 2 and stdout == "" and stderr.count("\n") == 1, stderr
    assert stderr.startswith(f"--scenes: {column / 'housner-square.toml'}: engine `housner` cannot run"), stderr
    code, stdout, stderr = sweep(capsys, "--scenes", str(at_rest), "--out", str(out))
    assert (code, stdout, stderr) == (
        2, "", f"--scenes: {at_rest / 'housner-square.toml'}: not a free-rocking block (one block "
        "whose Housner run has an impact and a peak after it)\n"
    )
    assert not (tmp_path / "out").exists()


def test_the_command_gives_no_traceback_for_a_missing_folder(tmp_path: Path) -> None:
    r = subprocess.run(
        [sys.executable, "-m", "rockbench.settings_sweep", "--scenes", str(tmp_path / "x")],
        capture_output=True, text=True, timeout=60,
    )
    assert (r.returncode, r.stdout, r.stderr) == (2, "", f"--scenes {tmp_path / 'x'}: no such directory\n")
