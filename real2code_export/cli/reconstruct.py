"""The reconstruction stages' commands: ``render``, ``reconstruct``, ``demo`` (on the shipped
capture), ``evaluate reconstruction`` and ``evaluate completion``.

Building their parsers imports no stage; each ``cmd_*`` imports its ``pipeline`` stage when it
runs and returns an exit status (0 success, 1 the final check disagreed); errors are raised
as ``Real2CodeError``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from .options import model_help

# The renderer's defaults, for --help without importing it (a test holds them equal to
# pipeline.render's DEFAULT_VIEWS and DEFAULT_SIZE, and pipeline.camera_paths' names).
RENDER_VIEWS, RENDER_SIZE = 12, 256
CAMERA_PATHS, CAMERA_DISTANCES = ("ring", "half-ring", "handheld", "front-arc"), \
    ("near", "mid", "far")
CAPTURE_PRESETS = ("clean", "phone-lidar", "structured-light", "time-of-flight")
MASK_WEIGHTS = ("auto", "clean", "noisy")  # pipeline.segment.choose.MODES, or a file
MASK_WEIGHTS_DEFAULT = "auto"  # pipeline.segment.choose.DEFAULT (why: there)
# (segmentation, completion) of evaluate reconstruction, by the names its --settings takes
EVALUATION_SETTINGS = {"gt+completion": ("gt", "learned"),
                       "gt+segment-only": ("gt", "segment_only"),
                       "predicted+completion": ("learned", "learned"),
                       "predicted+segment-only": ("learned", "segment_only")}


def add_camera_options(s) -> None:
    """``--cameras`` and ``--distance``: where a rendered capture's cameras stand."""
    s.add_argument("--cameras", choices=CAMERA_PATHS, default=CAMERA_PATHS[0],
                   help="camera path: a full ring (default), a half ring, a hand-held path "
                   "(uneven spacing and height), or front-arc (an arc facing where the "
                   "ground-truth joints open: for comparison only)")
    s.add_argument("--distance", choices=CAMERA_DISTANCES, default="mid",
                   help="how far the cameras stand: near (the object fills the view), mid, far")
    s.add_argument("--capture", default="clean", metavar="PRESET",
                   help="the depth camera's faults: " + ", ".join(CAPTURE_PRESETS)
                   + " (default clean), or a sensor JSON file of pipeline.sensors' fields")
    s.add_argument("--room", action="store_true",
                   help="stand the object on a floor before a wall, with clutter around it "
                   "(seeded by --seed; the pipeline must find the object)")


def add_mask_weights_option(s) -> None:
    """``--mask-weights``: which mask network the learned segmentation uses."""
    s.add_argument("--mask-weights", default=MASK_WEIGHTS_DEFAULT,
                   metavar="|".join(MASK_WEIGHTS) + "|PATH",
                   help="the mask network (with learned segmentation): clean (default) the "
                   "shipped one; noisy the one trained on noisy sensors (better on noisy rings, "
                   "worse on hand-held views of 4-5 parts: docs/evaluation.md); auto takes "
                   "noisy where the depth cleanup measures the capture's depth noisy and clean "
                   "otherwise; or a weights file (python -m pipeline.segment.train)")


def add_demo_parser(sub) -> None:
    s = sub.add_parser("demo", help="the main job: reconstruct the sample capture shipped with "
                       "the package")
    s.add_argument("--out", default="demo_out", help="output folder (default: demo_out)")
    s.add_argument("--room", action="store_true",
                   help="the shipped capture of the same cabinet in a room (floor, wall, "
                   "clutter), taken on a hand-held path with the phone-LiDAR preset's faults")
    s.set_defaults(func=cmd_demo)


def add_parsers(sub) -> None:
    add_render_parser(sub)
    add_reconstruct_parser(sub)


def add_evaluate_parsers(evaluate_sub) -> None:
    add_evaluate_completion_parser(evaluate_sub)
    add_evaluate_reconstruction_parser(evaluate_sub)


# -- render -----------------------------------------------------------------------------------
def add_render_parser(sub) -> argparse.ArgumentParser:
    s = sub.add_parser("render", help="a synthetic posed RGB-D capture with part masks")
    s.add_argument("model", help=model_help("the model to render"))
    s.add_argument("--out", required=True, help="capture folder to write")
    s.add_argument("--views", type=int, default=RENDER_VIEWS, help="number of views (12)")
    s.add_argument("--width", type=int, default=RENDER_SIZE, help="pixels (256)")
    s.add_argument("--height", type=int, default=RENDER_SIZE, help="pixels (256)")
    s.add_argument("--state", choices=["observed", "random"], default="observed",
                   help="the model's observed state, or every joint partly open (random)")
    s.add_argument("--seed", type=int, default=0, help="cameras and the random state")
    add_camera_options(s)
    s.set_defaults(func=cmd_render)
    return s


def cmd_render(args) -> int:
    from pipeline.render import render_model

    from ..errors import Real2CodeError

    if args.views < 1 or args.width < 8 or args.height < 8:
        raise Real2CodeError("--views must be >= 1 and --width/--height >= 8")
    capture = render_model(args.model, args.out, views=args.views, width=args.width,
                           height=args.height, state=args.state, seed=args.seed,
                           cameras=args.cameras, distance=args.distance, sensor=args.capture,
                           room=args.room)
    print(f"{len(capture.frames)} views of {capture.extra['object']} "
          f"({len(capture.parts)} parts) -> {Path(args.out) / 'transforms.json'}")
    print(f"ground truth -> {capture.ground_truth_path()}")
    return 0


# -- reconstruct ------------------------------------------------------------------------------
def add_reconstruct_parser(sub) -> argparse.ArgumentParser:
    s = sub.add_parser("reconstruct", help="posed RGB-D capture in, articulated object and "
                       "every export out")
    s.add_argument("capture", help="capture folder (transforms.json, images, depth)")
    s.add_argument("--out", required=True, help="output folder")
    _reconstruct_options(s)
    s.set_defaults(func=cmd_reconstruct)
    return s


def _reconstruct_options(s) -> None:
    s.add_argument("--segmentation", choices=["learned", "gt", "sam"], default="learned",
                   help="learned (shipped mask network), gt (the capture's masks) or sam")
    s.add_argument("--sam-checkpoint", help="a SAM checkpoint (with --segmentation sam)")
    s.add_argument("--sam-model-type", default="vit_b", choices=["vit_b", "vit_l", "vit_h"])
    add_mask_weights_option(s)
    s.add_argument("--completion", choices=["learned", "segment_only"], default="learned",
                   help="learned occupancy network, or the raw points' surface (baseline)")
    s.add_argument("--predictor", default="learned", choices=["learned", "geometric"],
                   help="joint predictor (default: learned)")
    s.add_argument("--configurations", type=int, default=100, help="for the final check")
    s.add_argument("--no-texture", dest="texture", action="store_false",
                   help="leave each part its flat colour instead of baking the views onto it")
    s.add_argument("--box", metavar="XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX",
                   help="the object's extent in the capture's world frame (metres); without "
                   "it the object is found: what the cameras look at, off the room's planes")


def _run_reconstruct(capture, out, args) -> int:
    from pipeline.isolate import parse_box
    from pipeline.reconstruct import reconstruct

    from ..check import format_table
    from ..errors import Real2CodeError

    if args.mask_weights != MASK_WEIGHTS_DEFAULT and args.segmentation != "learned":
        raise Real2CodeError(f"--mask-weights {args.mask_weights} is for --segmentation "
                             f"learned, not {args.segmentation}")
    result = reconstruct(capture, out, segmentation=args.segmentation,
                         mask_weights=args.mask_weights,
                         box=parse_box(args.box) if args.box else None,
                         completion=args.completion, predictor=args.predictor,
                         sam_checkpoint=args.sam_checkpoint, sam_model_type=args.sam_model_type,
                         check_configurations=args.configurations, texture=args.texture,
                         progress=lambda msg: print(msg, flush=True))
    out = Path(out)
    for stage in ("segmentation", "clouds", "part_meshes", "articulation"):
        print(f"{stage:13s} {out / stage}")
    for fmt, path in result.written.items():
        print(f"{fmt:13s} {path}")
    print(format_table(result.check))
    seconds = ", ".join(f"{k} {v:.1f} s" for k, v in result.timings.items())
    print(f"stages: {seconds}")
    return 0 if result.check.ok else 1


def cmd_reconstruct(args) -> int:
    return _run_reconstruct(args.capture, args.out, args)


# -- demo -------------------------------------------------------------------------------------
def cmd_demo(args) -> int:
    """The main job on the shipped capture: posed RGB-D views in, the articulated object and
    every export out, checked across the tools."""
    t0 = time.perf_counter()
    status = run_demo(args.out, room=args.room)
    print(f"done in {time.perf_counter() - t0:.1f} s; outputs in {args.out}")
    return status


def run_demo(out: str | Path, room: bool = False) -> int:
    """``real2code demo``: reconstruct the shipped sample capture with the shipped models,
    print where every stage's output went and what the check found. ``room``: the capture
    of the cabinet in a room, hand-held, with phone-LiDAR faults."""
    from pipeline.capture import ROOM_SAMPLE_CAPTURE, SAMPLE_CAPTURE, TRANSFORMS

    from ..errors import Real2CodeError

    capture = ROOM_SAMPLE_CAPTURE if room else SAMPLE_CAPTURE
    if not (capture / TRANSFORMS).is_file():
        raise Real2CodeError(f"{capture}: the sample capture shipped with the package is "
                             "missing (reinstall real2code-export)")
    parser = argparse.ArgumentParser()
    _reconstruct_options(parser)
    args = parser.parse_args([])
    print(f"capture  {capture}")
    return _run_reconstruct(capture, out, args)


# -- evaluate reconstruction ------------------------------------------------------------------
def add_evaluate_reconstruction_parser(evaluate_sub) -> argparse.ArgumentParser:
    e = evaluate_sub.add_parser("reconstruction", help="the whole pipeline from rendered RGB-D: "
                                "chamfer distances and joint metrics, gt vs predicted masks")
    e.add_argument("--objects", type=int, default=24, help="held-out procedural test objects")
    e.add_argument("--seed", type=int, default=0)
    e.add_argument("--views", type=int, default=12)
    e.add_argument("--size", type=int, default=256, help="render width and height")
    e.add_argument("--partnet", help="PartNet-Mobility folder (with index.json): add its dev "
                   "and holdout objects")
    add_camera_options(e)
    e.add_argument("--settings", default=",".join(EVALUATION_SETTINGS),
                   help="comma-separated, of " + ", ".join(EVALUATION_SETTINGS) + " (all)")
    add_mask_weights_option(e)
    e.add_argument("--splits", default="dev,holdout",
                   help="which PartNet-Mobility splits to add with --partnet (dev,holdout)")
    e.add_argument("--workers", type=int, default=1,
                   help="objects reconstructed in this many processes at once, the CPUs "
                   "shared among them (default 1); the figures are the same")
    e.add_argument("--json", help="write the figures as JSON")
    e.add_argument("--markdown", help="write the tables as markdown")
    e.set_defaults(func=cmd_evaluate_reconstruction)
    return e


def cmd_evaluate_reconstruction(args) -> int:
    import numpy as np

    from pipeline.evaluate_articulation import partnet_cases, procedural_cases
    from pipeline.evaluate_reconstruction import (
        SETTING_NAMES,
        evaluate,
        markdown,
        mask_weights_note,
    )

    from ..errors import Real2CodeError
    from .options import write_evaluation

    names = [n.strip() for n in args.settings.split(",") if n.strip()]
    unknown = [n for n in names if n not in EVALUATION_SETTINGS]
    if unknown or not names:
        raise Real2CodeError(f"--settings: unknown {unknown or names}; choose from "
                             f"{', '.join(EVALUATION_SETTINGS)}")
    settings = tuple(EVALUATION_SETTINGS[n] for n in names)
    if args.workers < 1:
        raise Real2CodeError(f"--workers: expected 1 or more, got {args.workers}")
    sets = {"procedural test set": procedural_cases(args.objects, args.seed)} \
        if args.objects > 0 else {}
    if args.partnet:
        root = Path(args.partnet)
        if not (root / "index.json").is_file():
            raise Real2CodeError(f"{root}: no PartNet-Mobility index.json here")
        splits = [x.strip() for x in args.splits.split(",") if x.strip()]
        if not splits or set(splits) - {"dev", "holdout"}:
            raise Real2CodeError(f"--splits: expected dev and/or holdout, got {args.splits!r}")
        if "dev" in splits:
            sets["PartNet-Mobility dev"] = partnet_cases(root, "dev", args.seed)
        if "holdout" in splits:
            sets["PartNet-Mobility holdout (benchmark, not tuned to)"] = partnet_cases(
                root, "holdout", args.seed)
    conditions = {"cameras": args.cameras, "distance": args.distance, "capture": args.capture,
                  "room": args.room, "mask_weights": args.mask_weights}
    figures, text = {"conditions": conditions}, []
    for set_name, cases in sets.items():
        results = evaluate(cases, views=args.views, size=args.size, seed=args.seed,
                           cameras=args.cameras, distance=args.distance, sensor=args.capture,
                           room=args.room, settings=settings, mask_weights=args.mask_weights,
                           workers=args.workers, progress=lambda msg, s=set_name: print(f"{s}: {msg}", flush=True))
        tables = {SETTING_NAMES[k]: r.table() for k, r in results.items()}
        figures[set_name] = {
            SETTING_NAMES[k]: {"buckets": r.table(), "failures": r.failures,
                               "seconds_per_object": float(np.mean(r.seconds or [0.0])),
                               "mask_weights": r.mask_weights}
            for k, r in results.items()}
        room = "; in a room" if args.room else ""
        note = mask_weights_note(results, args.mask_weights)
        weights = f"; mask weights {args.mask_weights}" if note else ""
        text.append(markdown(f"{set_name} ({len(cases)} objects; cameras {args.cameras}, "
                             f"{args.distance}; capture {args.capture}{room}{weights})", tables,
                             show_paper=set_name.startswith("procedural"),
                             notes=[note] if note else None))
    write_evaluation(args, "\n\n".join(text), figures)
    return 0


# -- evaluate completion ----------------------------------------------------------------------
def add_evaluate_completion_parser(evaluate_sub) -> argparse.ArgumentParser:
    s = evaluate_sub.add_parser("completion",
                                help="shape completion against the segment-only baseline")
    completion_arguments(s)
    s.set_defaults(func=cmd_evaluate_completion)
    return s


def completion_arguments(p: argparse.ArgumentParser) -> None:
    """``evaluate completion``'s options."""
    p.add_argument("--objects", type=int, default=40, help="held-out procedural objects (40)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--partnet", type=Path, default=None,
                   help="the PartNet-Mobility folder (with index.json): add its dev objects")
    p.add_argument("--arc", type=float, default=120.0,
                   help="the cameras' azimuth span in degrees (120; 360: a full ring)")
    p.add_argument("--figure", type=int, default=None,
                   help="also draw this procedural test object (its index)")
    p.add_argument("--out", type=Path, default=Path("completion_eval"),
                   help="folder for completion.json, completion.md and the figures")


def cmd_evaluate_completion(args) -> int:
    from pipeline.complete.evaluate import cmd_evaluate_completion as evaluate_completion

    from ..errors import Real2CodeError

    if args.partnet is not None and not (args.partnet / "index.json").is_file():
        raise Real2CodeError(f"{args.partnet}: no PartNet-Mobility index.json here")

    return evaluate_completion(args)
