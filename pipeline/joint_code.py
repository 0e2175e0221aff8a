"""Joints as code: Real2Code's text format between oriented boxes and an articulation.

The input lists the part boxes::

    bboxes={
     0: {'center': [0.0, 0.0, 0.4], 'R': [[1, 0, 0], [0, 1, 0], [0, 0, 1]], 'extent': [...]},
     ...}

The output (what a predictor writes) picks the root box and, per moving part, the joint
type, one of its box's three axes (``idx``), one of the four box edges along that axis
(``edge``: the signs of the other two axes, in increasing axis order) and the axis
direction (``sign``)::

    root_geom = 0
    child_joints = [
     dict(box=1, type='hinge', idx=2, edge=[1, -1], sign=1),
     dict(box=2, type='slide', idx=0, edge=[0, 0], sign=1),
    ]

An optional ``parent=k`` names a parent box other than the root. Model output is parsed
with :mod:`ast` (never executed) and checked; a malformed program raises
:class:`CodeFormatError` naming the line.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass, field

import numpy as np

from real2code_export.errors import InputError, Real2CodeError

from .obb import OBB

JOINT_TYPES = ("hinge", "slide")


class CodeFormatError(Real2CodeError):
    def __init__(self, line: int | None, message: str):
        self.line = line
        super().__init__(f"line {line}: {message}" if line else message)


@dataclass(frozen=True)
class ChildJoint:
    box: int
    type: str  # 'hinge' or 'slide'
    idx: int  # 0, 1 or 2: which box axis is the joint axis
    edge: tuple[int, int] = (0, 0)  # signs of the two other box axes (hinge position)
    sign: int = 1  # the joint axis is sign * R[:, idx]
    parent: int | None = None  # None: the root box


@dataclass(frozen=True)
class ArticulationProgram:
    root_geom: int
    child_joints: tuple[ChildJoint, ...] = field(default_factory=tuple)

    def parent_of(self, joint: ChildJoint) -> int:
        return self.root_geom if joint.parent is None else joint.parent


# -- geometry ----------------------------------------------------------------------------------
def other_axes(idx: int) -> tuple[int, int]:
    a, b = (i for i in range(3) if i != idx)
    return a, b


def joint_axis_and_position(box: OBB, idx: int, edge, sign: int) -> tuple[np.ndarray, np.ndarray]:
    """Absolute joint axis (unit) and a point on it, from a box, an axis index, an edge and a
    sign. A slide joint's position is the box centre (edge [0, 0])."""
    a, b = other_axes(idx)
    axis = float(sign) * box.R[:, idx]
    position = box.center + edge[0] * box.extent[a] * box.R[:, a] + edge[1] * box.extent[b] * box.R[:, b]
    return axis / np.linalg.norm(axis), position


def line_distance(p1, d1, p2, d2) -> float:
    """Distance between two lines (point, direction), correct for parallel lines."""
    d1 = np.asarray(d1, float) / np.linalg.norm(d1)
    d2 = np.asarray(d2, float) / np.linalg.norm(d2)
    w = np.asarray(p2, float) - np.asarray(p1, float)
    n = np.cross(d1, d2)
    if np.linalg.norm(n) < 1e-9:  # parallel: distance from p2 to line 1
        return float(np.linalg.norm(w - np.dot(w, d1) * d1))
    return float(abs(np.dot(w, n)) / np.linalg.norm(n))


def encode_joint(box: OBB, joint_type: str, axis, position=None) -> ChildJoint:
    """The (idx, edge, sign) that best describe an absolute joint on a box (for labelling
    training data from ground truth): the box axis most parallel to the joint axis, and for a
    hinge the box edge closest to the joint line."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    dots = box.R.T @ axis
    idx = int(np.argmax(np.abs(dots)))
    sign = 1 if dots[idx] >= 0 else -1
    edge = (0, 0)
    if joint_type == "hinge":
        if position is None:
            raise InputError("a hinge needs a position to pick its edge")
        edge = min(
            ((ea, eb) for ea in (-1, 1) for eb in (-1, 1)),
            key=lambda e: line_distance(joint_axis_and_position(box, idx, e, sign)[1], axis,
                                        position, axis),
        )
    return ChildJoint(box=-1, type=joint_type, idx=idx, edge=edge, sign=sign)


# -- text --------------------------------------------------------------------------------------
def _fmt(values, digits: int) -> str:
    return "[" + ", ".join(f"{v:.{digits}f}" for v in np.asarray(values, float).ravel()) + "]"


def format_boxes(boxes: list[OBB], digits: int = 2) -> str:
    """The predictor's input text (numbers rounded as the paper's prompts are)."""
    lines = ["bboxes={"]
    for i, b in enumerate(boxes):
        rows = "[" + ", ".join(_fmt(row, digits) for row in b.R) + "]"
        lines.append(f" {i}: {{'center': {_fmt(b.center, digits)}, 'R': {rows}, "
                     f"'extent': {_fmt(b.extent, digits)}}},")
    lines.append("}")
    return "\n".join(lines)


def format_program(program: ArticulationProgram) -> str:
    """The predictor's output text; :func:`parse_program` reads it back."""
    lines = [f"root_geom = {program.root_geom}", "child_joints = ["]
    for j in program.child_joints:
        parent = "" if j.parent is None else f", parent={j.parent}"
        lines.append(f" dict(box={j.box}, type='{j.type}', idx={j.idx}, "
                     f"edge=[{j.edge[0]}, {j.edge[1]}], sign={j.sign}{parent}),")
    lines.append("]")
    return "\n".join(lines)


def _literal(node: ast.AST, what: str):
    try:
        return ast.literal_eval(node)
    except (ValueError, SyntaxError, TypeError) as e:
        raise CodeFormatError(getattr(node, "lineno", None),
                              f"{what} must be a literal, got {ast.unparse(node)!r}") from e


def _int(value, line: int, what: str, allowed=None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise CodeFormatError(line, f"{what} must be an integer, got {value!r}")
    if allowed is not None and value not in allowed:
        raise CodeFormatError(line, f"{what} must be one of {sorted(allowed)}, got {value}")
    return value


def _child_joint(node: ast.AST, k: int, n_boxes: int | None) -> ChildJoint:
    line = getattr(node, "lineno", None)
    what = f"child_joints[{k}]"
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict":
        if node.args:
            raise CodeFormatError(line, f"{what}: dict() takes keyword arguments only")
        fields = {kw.arg: _literal(kw.value, f"{what}.{kw.arg}") for kw in node.keywords}
    elif isinstance(node, ast.Dict):
        fields = _literal(node, what)
    else:
        raise CodeFormatError(line, f"{what} must be dict(...), got {ast.unparse(node)!r}")
    unknown = set(fields) - {"box", "type", "idx", "edge", "sign", "parent"}
    if unknown:
        raise CodeFormatError(line, f"{what}: unknown field(s) {sorted(unknown)}")
    for key in ("box", "type", "idx"):
        if key not in fields:
            raise CodeFormatError(line, f"{what}: missing {key!r}")
    boxes = set(range(n_boxes)) if n_boxes is not None else None
    box = _int(fields["box"], line, f"{what}.box", boxes)
    jtype = fields["type"]
    if jtype not in JOINT_TYPES:
        raise CodeFormatError(line, f"{what}.type must be 'hinge' or 'slide', got {jtype!r}")
    idx = _int(fields["idx"], line, f"{what}.idx", {0, 1, 2})
    edge = fields.get("edge", [0, 0])
    if not isinstance(edge, (list, tuple)) or len(edge) != 2:
        raise CodeFormatError(line, f"{what}.edge must be [a, b], got {edge!r}")
    allowed_edge = {-1, 1} if jtype == "hinge" else {-1, 0, 1}
    edge = tuple(_int(e, line, f"{what}.edge", allowed_edge) for e in edge)
    sign = _int(fields.get("sign", 1), line, f"{what}.sign", {-1, 1})
    parent = fields.get("parent")
    if parent is not None:
        parent = _int(parent, line, f"{what}.parent", boxes)
    return ChildJoint(box, jtype, idx, edge, sign, parent)


def parse_program(text: str, n_boxes: int | None = None) -> ArticulationProgram:
    """Parse predictor output (never executed). ``n_boxes`` bounds the box indices."""
    try:
        tree = ast.parse(text)
    except SyntaxError as e:
        raise CodeFormatError(e.lineno, f"not valid Python: {e.msg}") from e
    root, joints, joints_line = None, None, None
    for stmt in tree.body:
        if not (isinstance(stmt, ast.Assign) and len(stmt.targets) == 1
                and isinstance(stmt.targets[0], ast.Name)):
            raise CodeFormatError(stmt.lineno, "expected only `root_geom = ...` and "
                                  f"`child_joints = [...]`, got {ast.unparse(stmt)[:60]!r}")
        name = stmt.targets[0].id
        if name == "root_geom":
            root = _int(_literal(stmt.value, "root_geom"), stmt.lineno, "root_geom",
                        set(range(n_boxes)) if n_boxes is not None else None)
        elif name == "child_joints":
            if not isinstance(stmt.value, ast.List):
                raise CodeFormatError(stmt.lineno, "child_joints must be a list")
            joints = [_child_joint(n, k, n_boxes) for k, n in enumerate(stmt.value.elts)]
            joints_line = stmt.lineno
        else:
            raise CodeFormatError(stmt.lineno, f"unexpected assignment to {name!r}")
    if root is None:
        raise CodeFormatError(None, "missing `root_geom = <box index>`")
    if joints is None:
        raise CodeFormatError(None, "missing `child_joints = [...]`")
    seen: set[int] = set()
    for j in joints:
        if j.box == root:
            raise CodeFormatError(joints_line, f"box {j.box} is the root and cannot be a child")
        if j.box in seen:
            raise CodeFormatError(joints_line, f"box {j.box} has two joints")
        seen.add(j.box)
    program = ArticulationProgram(root, tuple(joints))
    _check_tree(program, joints_line)
    return program


def _check_tree(program: ArticulationProgram, line: int | None) -> None:
    parent = {j.box: program.parent_of(j) for j in program.child_joints}
    for start in parent:
        seen, node = set(), start
        while node in parent:
            if node in seen:
                raise CodeFormatError(line, f"joints form a cycle through box {start}")
            seen.add(node)
            node = parent[node]
        if node != program.root_geom:
            raise CodeFormatError(line, f"box {start} does not connect to the root box")
