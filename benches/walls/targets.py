"""The walls against issue 14's targets, from one set of `bench_dynamic` runs.

`python benches/walls/targets.py DIR` reads the four series `make bench-walls-targets` writes
under DIR, each a `bench_dynamic` output (`dynamic.csv`, `growth.csv`) with native and rapier in
the same runs:

- `wall-215`: the 215-block running-bond wall under El Centro x2 for 5 s, default settings;
- `standing`: the walls of 43 to 860 blocks over the record's first second (they stand);
- `sliding`: the walls of 215 to 860 blocks sliding under a 0.8 g pulse, ten steps, impacts
  at the end of their step (every block in motion);
- `long`: the same pulse on walls of 10 courses grown along their length instead (21 / 42 / 84
  blocks a course: 215, 425 and 845 blocks), whose Newton matrices keep their envelope's width
  where the issue's series widens it to a course (docs/walls.md, "Walls grown along their
  length").

It prints, and writes to DIR/targets.md, one row a target: what was measured and whether it
is met, and below the table what made the figures, from each series' `provenance.json`: the
program (commit and sources), each engine's version, the machine and when each series ran.
Series made by different programs or on different machines are named apart, so that a table
of mixed runs says so. The targets (docs/walls.md):

- the 215-block wall at most `WALL_215_MS` a step, no slower than rapier, no fallback;
- the standing series' cost growing with log-log slope at most `SLOPE` in the blocks;
- the walls in motion growing with slope at most `SLOPE` in the blocks in motion, and the
  860-block wall in motion at most `WALL_860_MS` a step;
- the same two read on the walls grown along their length (the 845-block wall for the 860-block
  one), so that either reading of "the dynamic series" is judged by the same command.

Milliseconds depend on the machine; rapier's step in the same run is the yardstick beside them.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from dataclasses import dataclass
from pathlib import Path

WALL_215_MS = 1.0
WALL_860_MS = 5.0
SLOPE = 1.2

SERIES = ("wall-215", "standing", "sliding", "long")


class BadRun(Exception):
    """A series that is missing or not `bench_dynamic`'s output: one line naming the file."""


@dataclass
class Row:
    blocks: int
    engine: str
    ms_per_step: float
    fallbacks: str
    rescues: str


@dataclass
class Series:
    rows: list[Row]
    # (engine, against) -> (slope, standard error)
    slopes: dict[tuple[str, str], tuple[float, float]]

    def row(self, blocks: int, engine: str, path: Path) -> Row:
        for r in self.rows:
            if r.blocks == blocks and r.engine == engine:
                return r
        raise BadRun(f"{path}: no row of {engine} on the {blocks}-block wall")

    def slope(self, engine: str, against: str, path: Path) -> tuple[float, float]:
        try:
            return self.slopes[(engine, against)]
        except KeyError:
            raise BadRun(f"{path}: no slope of {engine} against {against}") from None


def read_csv(path: Path, columns: tuple[str, ...]) -> list[dict[str, str]]:
    """The rows of a CSV file with at least `columns` (none: a header alone, as the growth of
    a series of one wall)."""
    try:
        with path.open(newline="") as f:
            reader = csv.DictReader(f)
            rows = list(reader)
            header = reader.fieldnames or []
    except OSError as e:
        raise BadRun(f"{path}: {e.strerror or e}") from None
    missing = [c for c in columns if c not in header]
    if missing:
        raise BadRun(f"{path}: no column {', '.join(missing)}")
    return rows


def number(path: Path, column: str, text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise BadRun(f"{path}: {column} {text!r} is not a number") from None


def load(directory: Path) -> Series:
    runs = directory / "dynamic.csv"
    rows = [
        Row(
            blocks=int(number(runs, "blocks", r["blocks"])),
            engine=r["engine"],
            ms_per_step=number(runs, "ms_per_step", r["ms_per_step"]),
            fallbacks=r["fallbacks"],
            rescues=r["rescues"],
        )
        for r in read_csv(
            runs, ("blocks", "engine", "ms_per_step", "fallbacks", "rescues")
        )
    ]
    growth = directory / "growth.csv"
    slopes = {
        (r["engine"], r["against"]): (
            number(growth, "slope", r["slope"]),
            number(growth, "std_error", r["std_error"]),
        )
        for r in read_csv(growth, ("engine", "against", "slope", "std_error"))
    }
    return Series(rows, slopes)


@dataclass
class MadeBy:
    """What made a series' timings (`bench_dynamic`'s `provenance.json`)."""

    program: str
    machine: str
    date: str
    engines: dict[str, str]


def made_by(directory: Path) -> MadeBy:
    path = directory / "provenance.json"
    try:
        data = json.loads(path.read_text())
    except OSError as e:
        raise BadRun(f"{path}: {e.strerror or e}") from None
    except json.JSONDecodeError as e:
        raise BadRun(f"{path}: not JSON ({e.msg}, line {e.lineno})") from None
    try:
        p = data["provenance"]
        engines = data["engine_versions"]
        made = MadeBy(
            program=f"rockbench {p['rockbench_version']} (commit {p['git_commit']}, "
            f"sources {p['source_hash']})",
            machine=f"{p['hostname']} ({p['cpu']}, {p['cores']} cores), {p['os']}",
            date=p["date"],
            engines={str(e): str(v) for e, v in engines.items()},
        )
    except (KeyError, TypeError, AttributeError) as e:
        raise BadRun(f"{path}: not bench_dynamic's provenance (no {e})") from None
    return made


def provenance(directory: Path) -> str:
    """The Markdown section below the table: one line for what every series shares, and the
    series named apart where they differ."""
    made = {name: made_by(directory / name) for name in SERIES}
    lines = ["", "## Provenance", ""]

    def one_or_each(what: str, value) -> None:
        values = {name: value(m) for name, m in made.items()}
        if len(set(values.values())) == 1:
            lines.append(f"- {what}: {next(iter(values.values()))}")
        else:
            lines.append(f"- {what}, differing between the series:")
            lines.extend(f"  - `{name}`: {v}" for name, v in values.items())

    one_or_each("program", lambda m: m.program)
    engines = sorted({e for m in made.values() for e in m.engines})
    for engine in engines:
        one_or_each(f"engine `{engine}`", lambda m, e=engine: m.engines.get(e, "not run"))
    one_or_each("machine", lambda m: m.machine)
    lines.append(
        "- series run (UTC): " + ", ".join(f"`{name}` {m.date}" for name, m in made.items())
    )
    return "\n".join(lines) + "\n"


def verdict(met: bool) -> str:
    return "met" if met else "not met"


def targets(directory: Path) -> list[tuple[str, str, str]]:
    """(target, measured, verdict) for each target, from the series under `directory`."""
    series = {name: load(directory / name) for name in SERIES}
    out: list[tuple[str, str, str]] = []

    def judge(target: str, measured: str, met: bool) -> None:
        out.append((target, measured, verdict(met)))

    def native_and_rapier(name: str, blocks: int) -> tuple[Row, Row]:
        """The native and rapier rows of one wall of a series."""
        path = directory / name / "dynamic.csv"
        return series[name].row(blocks, "native", path), series[name].row(blocks, "rapier", path)

    native, rapier = native_and_rapier("wall-215", 215)
    judge(
        f"215-block wall, El Centro x2, 5 s: at most {WALL_215_MS:g} ms a step",
        f"{native.ms_per_step:.3f} ms",
        native.ms_per_step <= WALL_215_MS,
    )
    judge(
        "the same: no slower than rapier in the same run",
        f"{native.ms_per_step / rapier.ms_per_step:.2f} of rapier's "
        f"{rapier.ms_per_step:.3f} ms",
        native.ms_per_step <= rapier.ms_per_step,
    )
    judge(
        "the same: no Clarabel fallback",
        f"{native.fallbacks} fallbacks, {native.rescues} interior-point rescues",
        native.fallbacks == "0",
    )

    path = directory / "standing" / "growth.csv"
    slope, error = series["standing"].slope("native", "blocks", path)
    rapier_slope, _ = series["standing"].slope("rapier", "blocks", path)
    judge(
        "walls standing under the record (first second): "
        f"slope at most {SLOPE:g} in the blocks",
        f"{slope:.3f} +- {error:.3f} (rapier {rapier_slope:.3f})",
        slope <= SLOPE,
    )

    def in_motion(name: str, label: str, largest: int) -> None:
        """The slope of a series in motion and the cost of its largest wall."""
        path = directory / name / "growth.csv"
        slope, error = series[name].slope("native", "blocks in motion", path)
        rapier_slope, _ = series[name].slope("rapier", "blocks", path)
        judge(
            f"{label}: slope at most {SLOPE:g} in the blocks in motion",
            f"{slope:.3f} +- {error:.3f} (rapier {rapier_slope:.3f} in the blocks)",
            slope <= SLOPE,
        )
        native, rapier = native_and_rapier(name, largest)
        judge(
            f"the {largest}-block wall in motion: at most {WALL_860_MS:g} ms a step",
            f"{native.ms_per_step:.1f} ms (rapier {rapier.ms_per_step:.2f})",
            native.ms_per_step <= WALL_860_MS,
        )

    in_motion("sliding", "walls in motion (sliding)", 860)
    in_motion("long", "the same pulse on walls grown along their length (10 courses)", 845)
    return out


def markdown(rows: list[tuple[str, str, str]]) -> str:
    lines = ["| target | measured | verdict |", "|---|---|---|"]
    lines += [f"| {t} | {m} | {v} |" for t, m, v in rows]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("directory", type=Path, help="where the four series were written")
    args = parser.parse_args(argv)
    try:
        text = markdown(targets(args.directory)) + provenance(args.directory)
    except BadRun as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    (args.directory / "targets.md").write_text(text)
    print(text, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
