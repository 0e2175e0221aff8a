"""``articulate`` (part meshes in, articulated object out) and ``evaluate joints`` (the paper's
joint metrics for the joint predictors)."""

from __future__ import annotations

from pathlib import Path

from .options import EXIT_DISAGREE, EXIT_OK, add_formats_option, chosen_formats, write_evaluation


def add_parsers(sub) -> None:
    s = sub.add_parser("articulate", help="part meshes in, articulated object and exports out")
    s.add_argument("parts", help="a folder with one mesh per rigid part, or a .glb with one "
                   "mesh node per part, all in one world frame")
    s.add_argument("--out", required=True, help="output folder")
    s.add_argument("--predictor", default="learned", choices=["learned", "geometric", "llm"],
                   help="joint predictor (default: learned, the shipped weights)")
    s.add_argument("--weights", help="other weights for the learned predictor")
    s.add_argument("--llm", help="a local Hugging Face causal LM folder (--predictor llm)")
    s.add_argument("--adapter", help="a LoRA adapter folder for --llm")
    add_formats_option(s, "every available one; object.json is always written")
    s.add_argument("--name", help="object name (default: from PARTS)")
    s.add_argument("--align-boxes", action="store_true",
                   help="refit the parts' boxes in the largest part's frame where they fit "
                        "it (for parts cut from a scan by an imperfect segmentation)")
    s.add_argument("--configurations", type=int, default=100, help="for the final check")
    s.set_defaults(func=cmd_articulate)


def add_evaluate_parsers(evaluate_sub) -> None:
    e = evaluate_sub.add_parser("joints", help="joint prediction from ground-truth part meshes")
    e.add_argument("--objects", type=int, default=200, help="procedural test objects")
    e.add_argument("--seed", type=int, default=0)
    e.add_argument("--predictors", default="learned,geometric")
    e.add_argument("--partnet", help="PartNet-Mobility folder (with index.json) to add")
    e.add_argument("--json", help="write the figures as JSON")
    e.add_argument("--markdown", help="write the tables as markdown")
    e.set_defaults(func=cmd_evaluate_joints)


def cmd_articulate(args) -> int:
    """Part meshes in (Real2Code's ground-truth-boxes setting), articulated object out."""
    from pipeline.articulate import articulate
    from pipeline.parts_io import load_parts
    from pipeline.predictors import get_predictor
    from pipeline.program_source import program_source

    from .. import atomic
    from ..check import check_files, format_table
    from ..errors import Real2CodeError
    from ..formats import write_formats

    formats = ["json", *[f for f in chosen_formats(args) if f != "json"]]
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

    from ..errors import Real2CodeError

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
    write_evaluation(args, "\n\n".join(text), results)
    return EXIT_OK
