"""``real2code evaluate joints``: the paper's joint metrics for our predictors, with
ground-truth part meshes (the paper's "ground-truth boxes" setting), on a held-out
procedural test set and on the PartNet-Mobility objects.

Every object is seen partly open (each joint between 20 % and 100 % of its range, the
paper's assumption), placed by a random rotation about z and a shift; its part meshes go
through :func:`pipeline.articulate.articulate` exactly as a user's would.
"""

from __future__ import annotations

import copy
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from real2code_export.kinematics import world_part_meshes
from real2code_export.markdown import table as markdown_table
from real2code_export.model import ArticulatedObject

from .articulate import articulate
from .predictors.data import ajar_configuration, random_placement
from .predictors.evaluate import BUCKETS, PAPER_FULL, PAPER_GT_BOXES, Scores, score_object

TEST_SEED_OFFSET = 50_000_000  # training uses seeds below this: the test set is disjoint


@dataclass
class Case:
    obj: ArticulatedObject  # states set to the seen configuration
    base: np.ndarray  # where the object stands in the world
    label: str


def _seen(obj: ArticulatedObject, rng: np.random.Generator, place: bool) -> Case:
    obj = copy.deepcopy(obj)
    q = ajar_configuration(obj, rng)
    for j in obj.movable_joints:
        j.state = q[j.name]
    return Case(obj, random_placement(rng) if place else np.eye(4), obj.name)


def procedural_cases(n_objects: int, seed: int = 0) -> list[Case]:
    """A held-out procedural test set, balanced over the paper's part-count buckets."""
    from .procedural import CATEGORIES, generate, part_count_range

    rng = np.random.default_rng(seed + TEST_SEED_OFFSET)
    cases = []
    for k in range(n_objects):
        _, lo, hi = BUCKETS[k % len(BUCKETS)]
        options = [c for c in CATEGORIES if part_count_range(c)[0] <= hi
                   and part_count_range(c)[1] >= lo]
        category = options[rng.integers(len(options))]
        c_lo, c_hi = part_count_range(category)
        n = int(rng.integers(max(lo, c_lo), min(hi, c_hi) + 1))
        obj = generate(category, n, TEST_SEED_OFFSET + seed * 100_000 + k)
        cases.append(_seen(obj, rng, place=True))
    return cases


def partnet_cases(root: Path, split: str, seed: int = 0) -> list[Case]:
    """The PartNet-Mobility objects of one split, rigid groups merged, seen ajar."""
    import warnings

    from real2code_export.formats import load
    from real2code_export.simplify import merge_fixed_joints

    index = json.loads((root / "index.json").read_text())
    rng = np.random.default_rng(seed)
    cases = []
    for entry in index:
        if entry["split"] != split:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # repairs are reported by `export`, not here
            obj = merge_fixed_joints(load(root / entry["id"] / "mobility.urdf"))
        case = _seen(obj, rng, place=False)
        case.label = f"{entry['id']} ({entry['category']})"
        cases.append(case)
    return cases


def evaluate(predictor, cases: list[Case]) -> tuple[Scores, float]:
    scores = Scores()
    t0 = time.perf_counter()
    for case in cases:
        meshes = world_part_meshes(case.obj, None, case.base)
        result = articulate(meshes, predictor, name=case.obj.name)
        score_object(case.obj, case.base, result.obj, scores)
    return scores, (time.perf_counter() - t0) / max(1, len(cases))


def markdown(title: str, rows: dict[str, dict], show_paper: bool) -> str:
    """One table: a row per predictor, and the paper's rows; columns by bucket."""
    names = [b for b, *_ in BUCKETS]
    joints = []
    if show_paper:
        for label, paper in (("Real2Code + gt boxes (paper)", PAPER_GT_BOXES),
                             ("Real2Code, full pipeline (paper)", PAPER_FULL)):
            joints.append([label, *(f"{paper[b][2]:.2f} / {paper[b][0]:.1f} / {paper[b][1]:.2f}"
                                    for b in names)])
    for method, table in rows.items():
        cells = []
        for b in names:
            t = table.get(b)
            pos = ("-" if t is None or np.isnan(t["position_error_rel"])
                   else f"{t['position_error_rel'] * 100:.1f} %")
            cells.append("-" if t is None else
                         f"{t['type_accuracy']:.2f} / {t['axis_error_deg']:.1f} / {pos}")
        joints.append([method, *cells])
    ranges = []
    for method, table in rows.items():
        cells = []
        for b in names:
            t = table.get(b)
            cells.append("-" if t is None else
                         f"{_deg(t['state_error_rad'])}° {_cm(t['state_error_m'])} / "
                         f"{_deg(t['upper_error_rad'])}° {_cm(t['upper_error_m'])}")
        ranges.append([method, *cells])
    return "\n".join([
        f"### {title}", "",
        *markdown_table(["method", *(f"{b} parts: type / axis° / pos" for b in names)], joints),
        "", "Closed state and range (the paper predicts neither): mean error of the observed "
        "opening and of the upper limit, revolute in degrees / prismatic in cm.", "",
        *markdown_table(["method", *(f"{b} parts: state / upper" for b in names)], ranges)])


def _deg(rad: float) -> str:
    return "-" if np.isnan(rad) else f"{np.degrees(rad):.1f}"


def _cm(m: float) -> str:
    return "" if np.isnan(m) else f"{100 * m:.1f} cm"
