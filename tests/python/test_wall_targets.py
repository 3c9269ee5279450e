"""`benches/walls/targets.py`: each of issue 14's targets is judged from the series
`bench_dynamic` writes, on either side of its threshold, the table names what made its figures,
and a series it cannot read is one line naming the file, with nothing written."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "benches" / "walls"))
import targets  # noqa: E402

RUNS_HEADER = (
    "blocks,courses,engine,blocks_in_motion,overturned,wall_s,steps,ms_per_step,"
    "iterations_per_step,factorisations_per_step,factor_updates_per_step,fallbacks,rescues,"
    "splits_per_step,instructions_per_step"
)
GROWTH_HEADER = "engine,against,walls,slope,std_error,end_to_end,local_min,local_max"


def provenance(commit: str = "abc123", date: str = "2026-12-07T20:00:00Z") -> dict:
    """`bench_dynamic`'s `provenance.json`."""
    return {
        "provenance": {
            "rockbench_version": "0.1.0",
            "git_commit": commit,
            "source_hash": "0123456789abcdef",
            "hostname": "bench",
            "cpu": "AMD EPYC",
            "cores": 2,
            "os": "Debian GNU/Linux 13",
            "date": date,
            "command": "bench_dynamic --courses 10",
        },
        "engine_versions": {"native": "rockbench 0.1.0", "rapier": "rapier2d-f64 0.23.0"},
    }


def series(
    directory: Path,
    runs: list[tuple[int, str, float, str]],
    slopes: list[tuple[str, str, float]],
) -> None:
    """A `bench_dynamic` output: (blocks, engine, ms a step, fallbacks) rows and slopes."""
    directory.mkdir(parents=True)
    lines = [RUNS_HEADER] + [
        f"{b},{b // 21},{e},0,0,1.0,1000,{ms},1,0,0,{fb},{'0' if e == 'native' else '-'},0,"
        for b, e, ms, fb in runs
    ]
    (directory / "dynamic.csv").write_text("\n".join(lines) + "\n")
    lines = [GROWTH_HEADER] + [f"{e},{a},5,{s},0.01,{s},{s},{s}" for e, a, s in slopes]
    (directory / "growth.csv").write_text("\n".join(lines) + "\n")
    (directory / "provenance.json").write_text(json.dumps(provenance()))


def bench(
    root: Path,
    wall_215: float,
    rapier_215: float,
    standing: float,
    moving: float,
    wall_860: float,
    long: float | None = None,
    wall_845: float | None = None,
) -> Path:
    """The four series, with the 215-block wall's steps, the standing series' slope, the
    moving series' slope and the 860-block wall's step given, and the walls grown along their
    length with their slope and the 845-block wall's step (the moving series' by default)."""
    series(
        root / "wall-215",
        [(215, "native", wall_215, "0"), (215, "rapier", rapier_215, "-")],
        [],
    )
    series(
        root / "standing",
        [(43, "native", 0.1, "0"), (43, "rapier", 0.2, "-")],
        [("native", "blocks", standing), ("rapier", "blocks", 1.05)],
    )
    for name, blocks, slope, ms in (
        ("sliding", 860, moving, wall_860),
        ("long", 845, moving if long is None else long, wall_860 if wall_845 is None else wall_845),
    ):
        series(
            root / name,
            [(blocks, "native", ms, "0"), (blocks, "rapier", 8.0, "-")],
            [
                ("native", "blocks in motion", slope),
                ("native", "blocks", slope),
                ("rapier", "blocks", 1.0),
            ],
        )
    return root


def verdicts(root: Path) -> list[str]:
    return [v for _, _, v in targets.targets(root)]


def test_each_target_is_judged_against_its_threshold(tmp_path: Path) -> None:
    met = bench(tmp_path / "met", 0.95, 1.5, 1.2, 1.19, 4.9)
    assert verdicts(met) == ["met"] * 8
    missed = bench(tmp_path / "missed", 1.05, 1.0, 1.21, 1.8, 280.0)
    assert verdicts(missed) == ["not met", "not met", "met"] + ["not met"] * 5
    rows = targets.targets(missed)
    assert rows[1][1] == "1.05 of rapier's 1.000 ms"
    assert rows[5][1] == "280.0 ms (rapier 8.00)"


def test_the_walls_grown_along_their_length_are_judged_on_their_own_series(
    tmp_path: Path,
) -> None:
    root = bench(tmp_path / "b", 0.9, 1.5, 1.1, 1.8, 200.0, long=0.95, wall_845=90.0)
    rows = targets.targets(root)
    assert [v for _, _, v in rows[4:]] == ["not met", "not met", "met", "not met"]
    assert rows[6][0].startswith("the same pulse on walls grown along their length")
    assert rows[6][1] == "0.950 +- 0.010 (rapier 1.000 in the blocks)"
    assert rows[7] == (
        "the 845-block wall in motion: at most 5 ms a step",
        "90.0 ms (rapier 8.00)",
        "not met",
    )


def test_a_fallback_misses_its_target(tmp_path: Path) -> None:
    root = bench(tmp_path / "b", 0.9, 1.5, 1.1, 1.1, 4.0)
    text = (root / "wall-215" / "dynamic.csv").read_text().replace(",0,0,0,0,", ",0,0,3,0,", 1)
    (root / "wall-215" / "dynamic.csv").write_text(text)
    rows = targets.targets(root)
    assert rows[2] == (
        "the same: no Clarabel fallback",
        "3 fallbacks, 0 interior-point rescues",
        "not met",
    )


def test_the_table_is_written_beside_the_series(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    root = bench(tmp_path / "b", 0.9, 1.5, 1.1, 1.1, 4.0)
    assert targets.main([str(root)]) == 0
    written = (root / "targets.md").read_text()
    assert written == capsys.readouterr().out
    assert written.count("| met |") == 8
    # Below the table, what made the figures: the four series share all of it.
    made_by = written[written.index("## Provenance") :].splitlines()
    assert made_by[2:7] == [
        "- program: rockbench 0.1.0 (commit abc123, sources 0123456789abcdef)",
        "- engine `native`: rockbench 0.1.0",
        "- engine `rapier`: rapier2d-f64 0.23.0",
        "- machine: bench (AMD EPYC, 2 cores), Debian GNU/Linux 13",
        "- series run (UTC): `wall-215` 2026-12-07T20:00:00Z, `standing` 2026-12-07T20:00:00Z, "
        "`sliding` 2026-12-07T20:00:00Z, `long` 2026-12-07T20:00:00Z",
    ]


def test_series_made_by_different_programs_are_named_apart(tmp_path: Path) -> None:
    root = bench(tmp_path / "b", 0.9, 1.5, 1.1, 1.1, 4.0)
    (root / "sliding" / "provenance.json").write_text(json.dumps(provenance(commit="def456")))
    text = targets.provenance(root)
    assert "- program, differing between the series:" in text
    assert "  - `sliding`: rockbench 0.1.0 (commit def456, sources 0123456789abcdef)" in text
    assert "  - `long`: rockbench 0.1.0 (commit abc123, sources 0123456789abcdef)" in text
    # What they share stays one line.
    assert "- machine: bench (AMD EPYC, 2 cores), Debian GNU/Linux 13" in text


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (
            lambda r: (r / "sliding" / "growth.csv").unlink(),
            "sliding/growth.csv: No such file or directory",
        ),
        (
            lambda r: (r / "standing" / "growth.csv").write_text("engine,slope\n"),
            "standing/growth.csv: no column against, std_error",
        ),
        (
            lambda r: (r / "sliding" / "dynamic.csv").write_text(
                RUNS_HEADER + "\n860,40,native,0,0,1,10,fast,1,1,1,0,0,0,\n"
            ),
            "sliding/dynamic.csv: ms_per_step 'fast' is not a number",
        ),
        (
            lambda r: (r / "wall-215" / "dynamic.csv").write_text(RUNS_HEADER + "\n"),
            "wall-215/dynamic.csv: no row of native on the 215-block wall",
        ),
        (
            lambda r: (r / "long" / "dynamic.csv").unlink(),
            "long/dynamic.csv: No such file or directory",
        ),
        (
            lambda r: (r / "standing" / "provenance.json").unlink(),
            "standing/provenance.json: No such file or directory",
        ),
        (
            lambda r: (r / "wall-215" / "provenance.json").write_text("{"),
            "wall-215/provenance.json: not JSON",
        ),
        (
            lambda r: (r / "long" / "provenance.json").write_text('{"provenance": {}}'),
            "long/provenance.json: not bench_dynamic's provenance (no 'engine_versions')",
        ),
    ],
)
def test_a_series_it_cannot_read_is_one_line_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], damage, message: str
) -> None:
    root = bench(tmp_path / "b", 0.9, 1.5, 1.1, 1.1, 4.0)
    damage(root)
    assert targets.main([str(root)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and message in err, err
    assert not (root / "targets.md").exists()
