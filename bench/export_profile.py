"""Where ``real2code export FILE --to FORMAT`` spends its CPU, per format: each file and
format in a fresh process (the imports counted as a user's command pays them), under
cProfile with a CPU clock, the stages' CPU seconds and the functions with the most of
their own time.

    .venv/bin/python bench/export_profile.py FILE... [--to usd,gltf,mjcf,urdf] [--top 8]

``imports``: numpy, our modules and the four writers' packages (``pxr.Sdf`` is imported by
the USD writer itself, so it falls in ``write``); ``read``: loading the file (MuJoCo's import
and compile for an MJCF, the mesh files); ``write``: the export to that one format, its mesh
files included. cProfile's own cost inflates both read and write; read the shares.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe, load_average  # noqa: E402

_ONE = """
import cProfile, io, pstats, sys, tempfile, time, warnings
warnings.simplefilter("ignore")
start = time.process_time()
import numpy  # noqa: F401
from real2code_export.formats import FORMATS, export, load
for name in ("usd", "gltf", "mjcf", "urdf"):
    FORMATS[name].load_module(writing=True)
imports = time.process_time() - start
path, fmt, top = sys.argv[1], sys.argv[2], int(sys.argv[3])
profile = cProfile.Profile(timer=time.process_time)
start = time.process_time()
profile.enable()
obj = load(path)
profile.disable()
read = time.process_time() - start
start = time.process_time()
profile.enable()
with tempfile.TemporaryDirectory() as out:
    export(obj, out, formats=[fmt])
profile.disable()
write = time.process_time() - start
print(f"{path.rsplit('/', 1)[-1]} --to {fmt}: imports {imports:.2f}, read {read:.2f}, "
      f"write {write:.2f} s CPU; own time:")
text = io.StringIO()
pstats.Stats(profile, stream=text).sort_stats("tottime").print_stats(top)
rows = [line for line in text.getvalue().splitlines() if line.strip()]
start = next(k for k, line in enumerate(rows) if line.lstrip().startswith("ncalls"))
print("\\n".join("    " + line.strip() for line in rows[start + 1:]))
"""


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("files", nargs="+", type=Path)
    p.add_argument("--to", default="usd,gltf,mjcf,urdf")
    p.add_argument("--top", type=int, default=8, help="functions listed per run")
    args = p.parse_args()
    repo = Path(__file__).resolve().parents[1]
    print(f"machine: {describe()}; load average at start {load_average()}")
    for path in args.files:
        for fmt in args.to.split(","):
            subprocess.run([sys.executable, "-c", _ONE, str(path.resolve()), fmt,
                            str(args.top)], check=True, cwd=repo)
    print(f"load average at end {load_average()}")


if __name__ == "__main__":
    main()
