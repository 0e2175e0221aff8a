"""``real2code reconstruct``: a posed RGB-D capture in, an articulated object and every
export out — the whole Real2Code pipeline.

Stages, each one's output kept in the output folder for inspection (the first two, finding
the object in the room (:mod:`pipeline.isolate`) and the depth cleanup
(:mod:`pipeline.depth_cleanup`), are summarised in report.json)::

    segmentation/  per-view part labels (16-bit PNG) and colour overlays, summary.json
    clouds/        the fused foreground and one point cloud per part (PLY)
    part_meshes/   one watertight mesh per part (OBJ), world frame, from shape completion
    articulation/  the boxes the joint predictor read, the code it wrote, build_object.py
    object.json, <name>.xml/.urdf/.usda/.glb   the model and its exports
    check.json     the cross-tool check of the exports; report.json  what ran, how long

Segmentation: ``learned`` (a shipped mask network, prompted the paper's way: the one trained
for exact depth, or where the cleanup measured the depth noisy the one trained on noisy
sensors, :mod:`pipeline.segment.choose`), ``sam``
(a SAM checkpoint) or ``gt`` (the capture's masks). Completion: ``learned`` (the shipped
occupancy network) or ``segment_only`` (surface reconstruction of the raw points, the
paper's baseline).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from real2code_export.errors import InputError, Real2CodeError, warn

from .capture import Capture, read_capture
from .segment import PromptingOptions, Segmentation, segment
from .segment.choose import DEFAULT as DEFAULT_MASK_WEIGHTS

COMPLETIONS = ("learned", "segment_only")
PALETTE = np.array([[230, 25, 75], [60, 180, 75], [255, 225, 25], [0, 130, 200],
                    [245, 130, 48], [145, 30, 180], [70, 240, 240], [240, 50, 230],
                    [210, 245, 60], [250, 190, 212], [0, 128, 128], [220, 190, 255],
                    [170, 110, 40], [255, 250, 200], [128, 0, 0], [170, 255, 195]], np.uint8)


class ReconstructionError(Real2CodeError):
    """The capture cannot be reconstructed (names the stage and what is wrong)."""


@dataclass
class ReconstructResult:
    capture: Capture
    segmentation: Segmentation
    clouds: dict[str, np.ndarray]  # part name -> world points
    meshes: dict[str, object]  # part name -> trimesh.Trimesh, world frame
    colors: dict[str, tuple]  # part name -> linear RGBA from the images
    articulation: object  # pipeline.articulate.Articulation
    timings: dict[str, float] = field(default_factory=dict)
    written: dict[str, Path] = field(default_factory=dict)
    check: object | None = None  # real2code_export.check.CheckReport
    cleanup: dict = field(default_factory=dict)  # what the depth cleanup changed
    isolation: dict = field(default_factory=dict)  # what of the room was left out


def _srgb_to_linear(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def part_colors(capture: Capture, labels: list[np.ndarray], names: dict[int, str],
                ) -> dict[str, tuple]:
    """Each part's median colour over its pixels, as linear RGBA (the model's convention)."""
    out = {}
    for k, name in names.items():
        pixels = np.concatenate([f.rgb[lab == k] for f, lab in
                                 zip(capture.frames, labels, strict=True)])
        if len(pixels):
            srgb = np.median(pixels, axis=0) / 255.0
            out[name] = (*np.clip(_srgb_to_linear(srgb), 0, 1).tolist(), 1.0)
    return out


def complete_parts(clouds: dict[str, np.ndarray], completion: str, model=None,
                   progress: Callable[[str], None] | None = None) -> dict[str, object]:
    """One watertight mesh per part cloud: the occupancy network, given the other parts as
    context, or the segment-only surface reconstruction."""
    if completion not in COMPLETIONS:
        raise InputError(f"unknown completion {completion!r}; choose from {list(COMPLETIONS)}")
    if completion == "learned":
        from .complete import complete_part, load_model

        model = model or load_model()
    else:
        from .complete.baseline import ALPHA_SPACINGS_FUSED, segment_only_mesh
    meshes = {}
    for name, points in clouds.items():
        if completion == "learned":
            others = [p for n, p in clouds.items() if n != name]
            context = np.concatenate(others) if others else None
            meshes[name] = complete_part(points, context=context, model=model)
        else:
            from .complete.learned import CompletionError

            try:
                meshes[name] = segment_only_mesh(points, alpha_spacings=ALPHA_SPACINGS_FUSED)
            except CompletionError as e:  # a sliver (63 points nearly on a line): no surface
                warn(f"reconstruct: segment {name}: {e}; left out")
                continue
        if progress:
            progress(f"  {name}: {len(points)} points -> {len(meshes[name].faces)} faces")
    return meshes


def reconstruct_capture(capture: Capture, *, segmentation: str = "learned",
                        completion: str = "learned", predictor: str = "learned",
                        segmenter=None, completion_model=None,
                        mask_weights=DEFAULT_MASK_WEIGHTS,
                        prompting: PromptingOptions | None = None,
                        sam_checkpoint: str | Path | None = None, sam_model_type: str = "vit_b",
                        name: str = "reconstruction", collision: str = "auto",
                        precomputed_segmentation: Segmentation | None = None,
                        texture: bool = True, box=None,
                        progress: Callable[[str], None] | None = None) -> ReconstructResult:
    """Every stage in memory (the evaluation calls this; :func:`reconstruct` also writes).
    ``box``: the object's world extent (lo, hi) where the user knows it; found otherwise
    (:mod:`.isolate`: the room around the object is left out first).
    ``texture``: bake the views' colours onto the parts (:mod:`.texture`; the evaluation,
    which scores geometry and joints, leaves it out).
    ``precomputed_segmentation`` skips the segmentation stages (segmentation, then the
    compartments behind open doors back to the carcass; the evaluation segments once and
    completes twice).
    ``mask_weights``: which mask network the learned segmentation uses (auto, clean, noisy,
    a weights file, or a loaded :class:`pipeline.segment.choose.MaskWeights`; by default
    the shipped one, ``choose.DEFAULT``); auto chooses by the depth noise the cleanup
    measured. A ``segmenter`` given is used as it is."""
    from real2code_export.model import Mesh

    from .articulate import articulate
    from .compartments import return_to_carcass
    from .complete.data import MIN_POINTS  # the fewest points completion takes
    from .depth_cleanup import clean_capture
    from .fuse import oriented_part_clouds
    from .isolate import isolate_object
    from .predictors import get_predictor

    say = progress or (lambda _msg: None)
    timings: dict[str, float] = {}
    t = time.perf_counter()
    capture, isolation = isolate_object(capture, box)
    timings["isolation"] = time.perf_counter() - t
    if isolation["plane_pixels_dropped"] or isolation["other_pixels_dropped"]:
        say(f"the object found: {isolation['plane_pixels_dropped']} pixels of the room's "
            f"planes and {isolation['other_pixels_dropped']} of other things left out "
            f"({timings['isolation']:.1f} s)")
    t = time.perf_counter()
    capture, cleanup = clean_capture(capture)
    timings["cleanup"] = time.perf_counter() - t
    if cleanup["dropped"] or cleanup["filled"]:
        say(f"depth cleanup: {cleanup['dropped']} pixels dropped, {cleanup['filled']} filled, "
            f"poses moved up to {max(cleanup['pose_moves_m']):.3f} m "
            f"({timings['cleanup']:.1f} s)")
    t = time.perf_counter()
    say(f"segmentation ({segmentation}) of {len(capture.frames)} views ...")
    seg = precomputed_segmentation
    choice = None
    if seg is None:
        if segmentation == "learned" and segmenter is None:
            from .segment.choose import MaskWeights

            chooser = mask_weights if isinstance(mask_weights, MaskWeights) else \
                MaskWeights(mask_weights)
            segmenter, choice = chooser.for_capture(cleanup)
            say(f"  mask network: {choice.used} ({choice.weights.name}; {choice.why})")
        seg = return_to_carcass(capture, segment(
            capture, segmentation, segmenter=segmenter, options=prompting,
            sam_checkpoint=sam_checkpoint, sam_model_type=sam_model_type))
        if choice is not None:
            seg.details["mask_weights"] = choice.record()
    timings["segmentation"] = time.perf_counter() - t
    say(f"  {seg.n_parts} parts ({timings['segmentation']:.1f} s)")

    t = time.perf_counter()
    # stray points: at predicted masks' borders, and wherever the depth itself was noisy (a
    # true mask over smeared depth holds points of what lies behind); the boxes of such
    # points are squared to the largest part's (articulate's align_boxes) for the same reason
    from .depth_cleanup import measured_noisy

    noisy = measured_noisy(cleanup)
    by_label = oriented_part_clouds(capture, seg.labels, clean=segmentation != "gt" or noisy)
    names = {k: (capture.parts[k - 1] if segmentation == "gt" and k <= len(capture.parts)
                 else f"part_{k}") for k in by_label}
    clouds, normals = {}, {}
    for k, (points, measured) in by_label.items():
        if len(points) < MIN_POINTS:
            warn(f"reconstruct: segment {k} has only {len(points)} points; left out")
            continue
        clouds[names[k]], normals[names[k]] = points, measured
    if len(clouds) < 2:
        raise ReconstructionError(f"segmentation found {len(clouds)} part(s) with at least "
                                  f"{MIN_POINTS} points; an articulated object needs two")
    colors = part_colors(capture, seg.labels, {k: n for k, n in names.items() if n in clouds})
    timings["fusion"] = time.perf_counter() - t

    t = time.perf_counter()
    say(f"shape completion ({completion}) of {len(clouds)} parts ...")
    meshes = complete_parts(clouds, completion, completion_model, progress)
    if len(meshes) < 2:
        raise ReconstructionError(f"completion gave {len(meshes)} part surface(s); an "
                                  "articulated object needs two")
    clouds = {n: clouds[n] for n in meshes}
    colors = {n: c for n, c in colors.items() if n in meshes}
    timings["completion"] = time.perf_counter() - t

    t = time.perf_counter()
    say(f"joints ({predictor} predictor) ...")
    art = articulate({n: Mesh.from_trimesh(m) for n, m in meshes.items()},
                     get_predictor(predictor), name=name, colors=colors,
                     metadata={"reconstructed_from": str(capture.path or ""),
                               "segmentation": segmentation, "completion": completion,
                               **({"mask_weights": seg.details["mask_weights"]}
                                  if "mask_weights" in seg.details else {})},
                     collision=collision, align_boxes=segmentation != "gt" or noisy,
                     observed={n: (clouds[n], normals[n]) for n in clouds})
    timings["articulation"] = time.perf_counter() - t
    if texture:
        from .texture import bake_textures

        t = time.perf_counter()
        say("texture baking ...")
        labels = {n: (k, seg.labels) for k, n in names.items() if n in clouds}
        art.obj = bake_textures(art.obj, capture, labels)
        timings["texture"] = time.perf_counter() - t
    for j in art.obj.movable_joints:
        say(f"  {j.name:20s} {j.type.value:9s} state {j.state:+.3f}  "
            f"range [{j.limits.lower:.3f}, {j.limits.upper:.3f}]")
    return ReconstructResult(capture, seg, clouds, meshes, colors, art, timings, cleanup=cleanup,
                             isolation=isolation)


def _label_png(labels: np.ndarray) -> bytes:
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(labels.astype(np.uint16)).save(buf, format="PNG")
    return buf.getvalue()


def _overlay_png(rgb: np.ndarray, labels: np.ndarray) -> bytes:
    import io

    from PIL import Image

    colour = PALETTE[(labels.astype(int) - 1) % len(PALETTE)]
    out = np.where(labels[..., None] > 0, 0.45 * rgb + 0.55 * colour, rgb).astype(np.uint8)
    buf = io.BytesIO()
    Image.fromarray(out).save(buf, format="PNG")
    return buf.getvalue()


def write_stages(result: ReconstructResult, folder: Path,
                 formats: list[str] | None = None) -> dict[str, Path]:
    """Every stage's output and the model's files into ``folder`` (a staging folder)."""
    import trimesh

    from real2code_export.formats import export_formats, write_formats

    from .program_source import program_source

    seg_dir = folder / "segmentation"
    seg_dir.mkdir(parents=True)
    for frame, lab in zip(result.capture.frames, result.segmentation.labels, strict=True):
        (seg_dir / f"{frame.name}.png").write_bytes(_label_png(lab))
        (seg_dir / f"{frame.name}_overlay.png").write_bytes(_overlay_png(frame.rgb, lab))
    (seg_dir / "summary.json").write_text(json.dumps(
        {"method": result.segmentation.method, **result.segmentation.details}, indent=1) + "\n")
    cloud_dir = folder / "clouds"
    cloud_dir.mkdir()
    trimesh.PointCloud(result.segmentation.points).export(cloud_dir / "foreground.ply")
    for name, points in result.clouds.items():
        trimesh.PointCloud(points).export(cloud_dir / f"{name}.ply")
    mesh_dir = folder / "part_meshes"  # meshes/ holds the model's (part-frame) meshes
    mesh_dir.mkdir()
    for name, mesh in result.meshes.items():
        mesh.export(mesh_dir / f"{name}.obj")
    art = result.articulation
    staged = write_formats(art.obj, folder, ["json", *(formats or export_formats())])
    code_dir = folder / "articulation"
    code_dir.mkdir()
    (code_dir / "boxes.txt").write_text(art.prompt + "\n")
    (code_dir / "joints.py").write_text(art.code + "\n")
    # the script keeps every body at its captured pose: it takes the world-frame meshes
    mesh_files = {i: f"../part_meshes/{n}.obj" for i, n in enumerate(art.part_names)}
    (code_dir / "build_object.py").write_text(program_source(art.boxes, art.program, mesh_files))
    return staged


def reconstruct(capture: str | Path, out: str | Path, *, segmentation: str = "learned",
                completion: str = "learned", predictor: str = "learned",
                sam_checkpoint: str | Path | None = None, sam_model_type: str = "vit_b",
                mask_weights: str | Path = DEFAULT_MASK_WEIGHTS, formats: list[str] | None = None,
                check_configurations: int = 100,
                name: str | None = None, texture: bool = True, box=None,
                progress: Callable[[str], None] | None = None) -> ReconstructResult:
    """Read the capture folder, run every stage, write everything into ``out`` (atomically:
    all of it or nothing) and check the exports against each other in their own tools."""
    from real2code_export import atomic
    from real2code_export.check import check_files

    capture = read_capture(capture)
    say = progress or (lambda _msg: None)
    if segmentation == "learned":  # a bad weights file fails before any stage runs
        from .segment.choose import MaskWeights

        mask_weights = MaskWeights(mask_weights)
    result = reconstruct_capture(
        capture, segmentation=segmentation, completion=completion, predictor=predictor,
        sam_checkpoint=sam_checkpoint, sam_model_type=sam_model_type,
        mask_weights=mask_weights,
        name=name or capture.extra.get("object") or capture.path.name, texture=texture,
        box=box, progress=progress)
    out = Path(out)
    t = time.perf_counter()
    with atomic.staged_output(out) as staging:
        staged = write_stages(result, staging, formats)
        say(f"checking {len(staged)} files in their own tools ...")
        report = check_files(list(staged.values()), n_configurations=check_configurations)
        checked = atomic.as_moved(report.to_json(), staging, out)
        (staging / "check.json").write_text(json.dumps(checked, indent=1) + "\n")
        result.timings["export_and_check"] = time.perf_counter() - t
        (staging / "report.json").write_text(json.dumps({
            "capture": str(capture.path), "segmentation": segmentation,
            "completion": completion, "predictor": predictor,
            "mask_weights": result.segmentation.details.get("mask_weights"),
            "parts": list(result.meshes), "joints": [
                {"name": j.name, "type": j.type.value, "parent": j.parent, "child": j.child,
                 "state": j.state, "lower": j.limits.lower, "upper": j.limits.upper}
                for j in result.articulation.obj.movable_joints],
            "object_isolation": result.isolation, "depth_cleanup": result.cleanup,
            "segmentation_details": result.segmentation.details,
            "seconds": {k: round(v, 2) for k, v in result.timings.items()},
            "check_ok": report.ok}, indent=1) + "\n")
    result.written = {n: out / p.relative_to(staging) for n, p in staged.items()}
    result.check = report
    return result
