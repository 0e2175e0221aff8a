"""What comparing the dynamics adds to ``check --reference``: per robot file, exported to all
four formats, the CPU seconds of the whole check against the source (100 configurations,
validators off: they run beside it in their own processes) and of the dynamics comparison
alone (``probes.dynamics.against_source``), each after one warm run, and of the USD and glTF
exports' part of it given the probes check has opened (their schemas read from the stage
and document those probes hold).

    .venv/bin/python bench/check_reference.py FILE...
"""

from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe  # noqa: E402

from real2code_export.check import check_files  # noqa: E402
from real2code_export.formats import export, load  # noqa: E402
from real2code_export.probes import dynamics, open_probes  # noqa: E402


def cpu(fn, *args, **kwargs) -> float:
    start = time.process_time()
    fn(*args, **kwargs)
    return time.process_time() - start


def main() -> None:
    print(f"machine: {describe()}")
    print("| file | check --reference (s CPU) | dynamics comparison (s CPU) | share | "
          "of it USD and glTF (s CPU) |")
    print("|---|---|---|---|---|")
    for source in map(Path, sys.argv[1:]):
        with warnings.catch_warnings(record=True) as caught, \
                tempfile.TemporaryDirectory() as tmp:
            warnings.simplefilter("always")
            written = export(load(source), Path(tmp) / "out")
            said = [str(w.message) for w in caught]
            files = list(written.values())

            options = {"source": source, "validate": False, "warned": said}
            check_files(files, **options)  # warm: imports, MuJoCo's mesh cache
            whole = cpu(check_files, files, **options)
            part = cpu(dynamics.against_source, source, files)
            schemas = [written[name] for name in ("usd", "gltf") if name in written]
            opened = {f: open_probes(f)[0] for f in schemas}
            schema = cpu(dynamics.against_source, source, schemas, opened=opened)
        print(f"| {source.name} | {whole:.2f} | {part:.2f} | {100 * part / whole:.0f} % | "
              f"{schema:.2f} |", flush=True)


if __name__ == "__main__":
    main()
