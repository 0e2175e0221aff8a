"""The ``real2code`` command line (contracts in DESIGN.md).

Exit status: 0 success, 1 a check found disagreement, 2 bad input or a failed step (the
message names the file, the element and what is wrong; nothing half-written is left).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

from .errors import Real2CodeError, Real2CodeWarning

EXIT_OK, EXIT_DISAGREE, EXIT_ERROR = 0, 1, 2


def _formats_arg(text: str) -> list[str]:
    from .formats import FORMATS

    names = [t.strip().lower() for t in text.split(",") if t.strip()]
    bad = [n for n in names if n not in FORMATS]
    if bad or not names:
        raise argparse.ArgumentTypeError(
            f"unknown format(s) {bad or text!r}; choose from {', '.join(FORMATS)}")
    return names


def _available_export_formats() -> list[str]:
    """The default --to: every export format whose module imports here."""
    import importlib.util

    from .formats import EXPORT_FORMATS, FORMATS

    return [f for f in EXPORT_FORMATS if importlib.util.find_spec(FORMATS[f].module) is not None]


# -- commands ----------------------------------------------------------------------------------
def cmd_export(args) -> int:
    from .formats import export, load

    obj = load(args.input)
    written = export(obj, args.out, args.to or _available_export_formats())
    for name, path in written.items():
        print(f"{name:5s} {path}")
    return EXIT_OK


def cmd_check(args) -> int:
    from .check import check_files, format_table

    report = check_files(
        [Path(p) for p in args.files],
        n_configurations=args.configurations,
        seed=args.seed,
        tol_position=args.tol_position,
        tol_rotation=args.tol_rotation,
    )
    print(format_table(report))
    if args.json:
        from . import atomic

        atomic.write_text(args.json, json.dumps(report.to_json(), indent=1) + "\n")
    return EXIT_OK if report.ok else EXIT_DISAGREE


def cmd_generate(args) -> int:
    from pipeline.procedural import generate

    from . import atomic
    from .formats import object_json

    obj = generate(args.category, args.parts, args.seed)
    with atomic.staged_output(args.out) as staging:
        object_json.save(obj, staging)
    print(f"{obj.name}: {len(obj.parts)} parts, {len(obj.movable_joints)} movable joints -> "
          f"{Path(args.out) / object_json.FILENAME}")
    return EXIT_OK


def cmd_articulate(args) -> int:
    """Part meshes in (Real2Code's ground-truth-boxes setting), articulated object out."""
    from pipeline.articulate import articulate
    from pipeline.parts_io import load_parts
    from pipeline.predictors import get_predictor
    from pipeline.program_source import program_source

    from . import atomic
    from .check import check_files, format_table
    from .formats import write_formats

    parts_path = Path(args.parts)
    meshes, colors = load_parts(parts_path)
    options = {}
    if args.predictor == "llm":
        if not args.llm:
            raise Real2CodeError("--predictor llm needs --llm MODEL_FOLDER")
        options = {"path": args.llm, "adapter": args.adapter}
    elif args.weights:
        options = {"path": args.weights}
    art = articulate(meshes, get_predictor(args.predictor, **options),
                     name=args.name or parts_path.stem, colors=colors,
                     align_boxes=args.align_boxes)
    out = Path(args.out)
    formats = ["json", *(args.to or _available_export_formats())]
    with atomic.staged_output(out) as staging:
        staged = write_formats(art.obj, staging, formats)
        code_dir = staging / "articulation"
        code_dir.mkdir()
        (code_dir / "boxes.txt").write_text(art.prompt + "\n")
        (code_dir / "joints.py").write_text(art.code + "\n")
        mesh_files = {i: f"../meshes/{n}.obj" for i, n in enumerate(art.part_names)}
        (code_dir / "build_object.py").write_text(
            program_source(art.boxes, art.program, mesh_files))
    written = {name: out / p.relative_to(staging) for name, p in staged.items()}
    for j in art.obj.movable_joints:
        print(f"joint {j.name:24s} {j.type.value:9s} state {j.state:+.3f}  "
              f"range [{j.limits.lower:.3f}, {j.limits.upper:.3f}]")
    for name, path in written.items():
        print(f"{name:5s} {path}")
    print(f"code  {out / 'articulation'}")
    report = check_files(list(written.values()), n_configurations=args.configurations)
    print(format_table(report))
    return EXIT_OK if report.ok else EXIT_DISAGREE


def cmd_evaluate_joints(args) -> int:
    """The paper's joint metrics for our predictors, by bucket, with ground-truth parts."""
    from pipeline.evaluate_articulation import evaluate, markdown, partnet_cases, procedural_cases
    from pipeline.predictors import get_predictor

    from . import atomic

    sets = {"procedural test set": procedural_cases(args.objects, args.seed)}
    partnet = Path(args.partnet) if args.partnet else None
    if partnet is not None:
        if not (partnet / "index.json").is_file():
            raise Real2CodeError(f"{partnet}: no PartNet-Mobility index.json here")
        sets["PartNet-Mobility dev"] = partnet_cases(partnet, "dev", args.seed)
        sets["PartNet-Mobility holdout (benchmark, not tuned to)"] = partnet_cases(
            partnet, "holdout", args.seed)
    results: dict = {}
    text = []
    for set_name, cases in sets.items():
        rows = {}
        for name in args.predictors.split(","):
            scores, seconds = evaluate(get_predictor(name.strip()), cases)
            rows[name] = scores.table()
            results.setdefault(set_name, {})[name] = {"buckets": rows[name],
                                                      "seconds_per_object": seconds,
                                                      "objects": len(cases)}
            print(f"{set_name}: {name}: {len(cases)} objects, {seconds:.2f} s per object")
        text.append(markdown(f"{set_name} ({len(cases)} objects)", rows,
                             show_paper=set_name.startswith("procedural")))
    table = "\n\n".join(text)
    print(table)
    if args.json:
        atomic.write_text(args.json, json.dumps(results, indent=1) + "\n")
    if args.markdown:
        atomic.write_text(args.markdown, table + "\n")
    return EXIT_OK


def cmd_demo(args) -> int:
    """The main job on the shipped capture: posed RGB-D views in, the articulated object and
    every export out, checked across the tools (``pipeline.commands.run_demo``)."""
    from pipeline.commands import run_demo

    t0 = time.perf_counter()
    status = run_demo(args.out)
    print(f"done in {time.perf_counter() - t0:.1f} s; outputs in {args.out}")
    return EXIT_OK if status == 0 else EXIT_DISAGREE


def cmd_calibrate(args) -> int:
    """Measured motion in: the named causes, the extended model, its exports and the report."""
    from .calibrate import run_calibrate

    return run_calibrate(Path(args.model), [Path(x) for x in args.data],
                         [Path(x) for x in args.holdout or []], Path(args.out))


# -- parser ------------------------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    # Each stage's module adds its own commands; their heavy imports wait for the command.
    from pipeline.commands import (
        add_evaluate_reconstruction_parser,
        add_reconstruct_parser,
        add_render_parser,
    )
    from pipeline.complete.evaluate import add_evaluate_completion_parser

    from .batch.cli import add_parser as add_batch_parser
    from .dynamics.cli import add_parser as add_simulate_parser

    p = argparse.ArgumentParser(
        prog="real2code",
        description="Articulated objects in, simulation-ready digital twins out "
        "(MJCF, URDF, USD, glTF), proven by loading them back in their own tools.",
    )
    p.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    s = sub.add_parser("demo", help="the main job: reconstruct the capture shipped in samples/")
    s.add_argument("--out", default="demo_out", help="output folder (default: demo_out)")
    s.set_defaults(func=cmd_demo)

    s = sub.add_parser("export", help="convert a model to simulator and content formats")
    s.add_argument("input", help="object.json, .urdf, MJCF .xml, .usd/.usda/.usdc, .glb/.gltf")
    s.add_argument("--to", type=_formats_arg, default=None,
                   help="comma-separated formats (default: mjcf,urdf,usd,gltf)")
    s.add_argument("--out", required=True, help="output folder")
    s.set_defaults(func=cmd_export)

    s = sub.add_parser("check", help="load files in their own tools and compare kinematics")
    s.add_argument("files", nargs="+", help="files to compare (object.json, .xml, .urdf, ...)")
    s.add_argument("--json", help="also write the report as JSON to this file")
    s.add_argument("--configurations", type=int, default=100, help="random configurations")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--tol-position", type=float, default=1e-6, help="metres (default 1e-6)")
    s.add_argument("--tol-rotation", type=float, default=1e-6, help="radians (default 1e-6)")
    s.set_defaults(func=cmd_check)

    add_simulate_parser(sub)

    s = sub.add_parser("generate", help="a procedural articulated object")
    s.add_argument("--category", required=True,
                   choices=["storage_furniture", "table", "refrigerator", "laptop", "box"])
    s.add_argument("--parts", type=int, default=None, help="number of rigid parts")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--out", required=True, help="output folder (object.json and meshes)")
    s.set_defaults(func=cmd_generate)

    s = sub.add_parser("articulate", help="part meshes in, articulated object and exports out")
    s.add_argument("parts", help="a folder with one mesh per rigid part, or a .glb with one "
                   "mesh node per part, all in one world frame")
    s.add_argument("--out", required=True, help="output folder")
    s.add_argument("--predictor", default="learned", choices=["learned", "geometric", "llm"],
                   help="joint predictor (default: learned, the shipped weights)")
    s.add_argument("--weights", help="other weights for the learned predictor")
    s.add_argument("--llm", help="a local Hugging Face causal LM folder (--predictor llm)")
    s.add_argument("--adapter", help="a LoRA adapter folder for --llm")
    s.add_argument("--to", type=_formats_arg, default=None,
                   help="comma-separated formats (default: mjcf,urdf,usd,gltf)")
    s.add_argument("--name", help="object name (default: from PARTS)")
    s.add_argument("--align-boxes", action="store_true",
                   help="refit the parts' boxes in the largest part's frame where they fit "
                        "it (for parts cut from a scan by an imperfect segmentation)")
    s.add_argument("--configurations", type=int, default=100, help="for the final check")
    s.set_defaults(func=cmd_articulate)

    add_render_parser(sub)
    add_reconstruct_parser(sub)

    s = sub.add_parser("calibrate", help="fit joint dynamics to measured motion, name the cause")
    s.add_argument("model", help="object.json, .urdf, MJCF .xml, .usd or .glb")
    s.add_argument("--data", action="append", required=True, metavar="CSV",
                   help="a measured trajectory to fit (repeatable; format in DESIGN.md)")
    s.add_argument("--holdout", action="append", metavar="CSV",
                   help="a measured trajectory to test on, not fitted (repeatable)")
    s.add_argument("--out", required=True, help="output folder: report.json, report.md, "
                   "plots, the calibrated object and its exports")
    s.set_defaults(func=cmd_calibrate)

    s = sub.add_parser("evaluate", help="accuracy tables (the paper's metrics)")
    ev = s.add_subparsers(dest="what", required=True, metavar="WHAT")
    e = ev.add_parser("joints", help="joint prediction from ground-truth part meshes")
    e.add_argument("--objects", type=int, default=200, help="procedural test objects")
    e.add_argument("--seed", type=int, default=0)
    e.add_argument("--predictors", default="learned,geometric")
    e.add_argument("--partnet", help="PartNet-Mobility folder (with index.json) to add")
    e.add_argument("--json", help="write the figures as JSON")
    e.add_argument("--markdown", help="write the tables as markdown")
    e.set_defaults(func=cmd_evaluate_joints)
    add_evaluate_completion_parser(ev)
    add_evaluate_reconstruction_parser(ev)

    add_batch_parser(sub)
    return p


def _version() -> str:
    from . import __version__

    return __version__


def run(argv: list[str] | None) -> int:
    args = build_parser().parse_args(argv)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", Real2CodeWarning)
        try:
            status = args.func(args)
        except Real2CodeError as e:
            _print_warnings(caught)
            print(f"error: {e}", file=sys.stderr)
            return EXIT_ERROR
        except FileNotFoundError as e:
            _print_warnings(caught)
            print(f"error: {e.filename}: no such file or folder", file=sys.stderr)
            return EXIT_ERROR
    _print_warnings(caught)
    return status


def _print_warnings(caught) -> None:
    seen = set()
    for w in caught:
        if issubclass(w.category, Real2CodeWarning) and str(w.message) not in seen:
            seen.add(str(w.message))
            print(f"warning: {w.message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    sys.exit(run(argv))


if __name__ == "__main__":
    main()
