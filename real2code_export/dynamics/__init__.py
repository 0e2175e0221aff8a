"""The dynamic check: the same experiment simulated by every engine, each from the file it
reads natively, and every joint's trajectory compared with MuJoCo's (MJCF).

An :class:`Experiment` says what to simulate (joints released from a state with a velocity,
gravity, time step, contacts on or off, free boxes dropped among the parts); an engine
module offers
``simulate(path, experiment) -> Trajectory``. Modules are imported only when used, so an
engine that is not installed is skipped with a message (:class:`EngineUnavailable`).
This module needs numpy only: engines with their own venv import it in a subprocess.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from ..errors import Real2CodeError

GRAVITY = (0.0, 0.0, -9.81)


class EngineUnavailable(Real2CodeError):
    """The engine is not installed here (the message says how to get it)."""


@dataclass(frozen=True)
class Experiment:
    """One run: every joint in ``joints`` starts at ``q0`` with ``v0`` (rad, rad/s or m, m/s),
    the base fixed, for ``duration`` s at ``dt`` s, sampled every ``sample_every`` steps.

    With ``contacts``, the parts' collision pieces collide; ``self_contacts`` lets a joint's
    parent and child collide too (the file's exclusions lifted: a door meets its frame);
    ``boxes`` are free cubes of edge ``box_size`` (m) and ``box_mass`` (kg), at rest, axis
    aligned, their centres at these world positions."""

    name: str
    joints: tuple[str, ...]
    angular: tuple[bool, ...]
    q0: tuple[float, ...]
    v0: tuple[float, ...]
    dt: float = 1e-3
    duration: float = 2.0
    gravity: tuple[float, float, float] = GRAVITY
    contacts: bool = False
    sample_every: int = 10
    self_contacts: bool = False
    boxes: tuple[tuple[float, float, float], ...] = ()
    box_size: float = 0.05
    box_mass: float = 0.1
    # its joints meet their limits: engines whose stops look a step ahead and those whose
    # act once a joint is past its limit part there (run.py judges it by the converged motion)
    stops: bool = False

    @property
    def steps(self) -> int:
        return int(round(self.duration / self.dt))

    def to_json(self) -> dict:
        return asdict(self)

    @classmethod
    def from_json(cls, data: dict) -> Experiment:
        tuples = ("joints", "angular", "q0", "v0", "gravity")
        data = {k: tuple(v) if k in tuples else v for k, v in data.items()}
        data["boxes"] = tuple(tuple(b) for b in data.get("boxes", ()))
        return cls(**data)


@dataclass
class Trajectory:
    """Joint values (samples, joints) at ``times``; the experiment's boxes' centres (samples,
    boxes, 3); what the engine said about the run."""

    joints: list[str]
    times: np.ndarray
    q: np.ndarray
    notes: list[str] = field(default_factory=list)
    boxes: np.ndarray | None = None

    def to_json(self) -> dict:
        return {"joints": self.joints, "times": self.times.tolist(), "q": self.q.tolist(),
                "notes": self.notes,
                "boxes": None if self.boxes is None else self.boxes.tolist()}

    @classmethod
    def from_json(cls, data: dict) -> Trajectory:
        boxes = data.get("boxes")
        return cls(list(data["joints"]), np.asarray(data["times"], dtype=float),
                   np.asarray(data["q"], dtype=float).reshape(len(data["times"]), -1),
                   list(data.get("notes", [])),
                   None if boxes is None else
                   np.asarray(boxes, dtype=float).reshape(len(data["times"]), -1, 3))


class Recorder:
    """Collects samples every ``experiment.sample_every`` steps (step 0 included)."""

    def __init__(self, experiment: Experiment):
        self.experiment = experiment
        self.times: list[float] = []
        self.rows: list[np.ndarray] = []
        self.box_rows: list[np.ndarray] = []

    def due(self, step: int) -> bool:
        return step % self.experiment.sample_every == 0

    def add(self, step: int, q, boxes=None) -> None:
        """``boxes``: the boxes' centres (boxes, 3) when the experiment has any."""
        self.times.append(step * self.experiment.dt)
        self.rows.append(np.asarray(q, dtype=float).copy())
        if self.experiment.boxes:
            self.box_rows.append(np.asarray(boxes, dtype=float).reshape(-1, 3).copy())

    def trajectory(self, notes: list[str] | None = None) -> Trajectory:
        boxes = np.array(self.box_rows).reshape(len(self.times), -1, 3) \
            if self.experiment.boxes else None
        return Trajectory(list(self.experiment.joints), np.array(self.times),
                          np.array(self.rows).reshape(len(self.times), -1), notes or [], boxes)


def urdf_laws(path) -> dict[str, dict[str, float]]:
    """Each URDF joint's ``<dynamics>`` attributes by joint name: damping and friction, and
    our ``real2code:`` stiffness, springref and armature (URDF has no place for them), for
    engines whose URDF loaders leave those at their own defaults."""
    from lxml import etree

    from ..formats.urdf.conventions import NAMESPACE

    prefix = f"{{{NAMESPACE}}}"
    out: dict[str, dict[str, float]] = {}
    for joint in etree.parse(str(path)).getroot().iter("joint"):
        dyn = joint.find("dynamics")
        if dyn is not None:
            out[joint.get("name", "")] = {k.removeprefix(prefix): float(v)
                                          for k, v in dyn.attrib.items()}
    return out
