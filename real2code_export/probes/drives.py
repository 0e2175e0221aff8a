"""Joint drives as a file's own tool reads them, for ``check``: an MJCF file's actuators as
MuJoCo compiled them (the probe's model), a USD file's PhysicsDriveAPI drives as UsdPhysics
states them (the probe's stage), each mapped by its format's own function to the model's
:class:`~real2code_export.model.Drive` (``formats.mjcf.actuator``, ``formats.usd.drive``).
URDF, glTF and object.json hold drives for our reader only (no tool reads them): None; so
does a USD file of MuJoCo's actuators (``MjcActuator``), which UsdPhysics does not read."""

from __future__ import annotations

from pathlib import Path

from ..model import Drive, sanitize_name


def mjcf_drives(model) -> dict[str, Drive]:
    """Joint name (as our reader names it) -> its drive, of a compiled MuJoCo model: the
    first actuator of a joint that is a drive; its target our ``<custom>`` number, else 0
    (MuJoCo's ctrl)."""
    import mujoco

    from ..formats.mjcf.conventions import custom_name
    from ..mujoco_actuators import drive_of

    out: dict[str, Drive] = {}
    for i in range(model.nu):
        drive, _ = drive_of(model, i)
        if drive is None:
            continue
        raw = model.joint(int(model.actuator_trnid[i, 0])).name
        name = sanitize_name(raw) if raw else None  # (unnamed: named by the probe's rule)
        if name is None or name in out:
            continue
        k = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_NUMERIC, custom_name(raw, "drive_target"))
        if k >= 0:
            drive.target = float(model.numeric_data[int(model.numeric_adr[k])])
        out[name] = drive
    return out


def usd_drives(stage, parsed, meters_per_unit: float,
               names: dict[tuple[str, str], str] | None = None) -> dict[str, Drive]:
    """Joint name -> its drive, of a UsdPhysics parse (``parsed``) of ``stage``: a joint
    prim's ``angular`` or ``linear`` drive drives the joint of its name, a generic joint's
    axis drive (``rotX``) the joint ``<prim>_<axis>`` (our reader's names; ``names``: the
    probe's, (prim path, drive instance) -> the joint it gave that degree of freedom: one
    free axis of a generic joint is the joint itself, names unique in the stage)."""
    from pxr import UsdPhysics

    from ..formats.usd.conventions import source_name
    from ..formats.usd.drive import drive_from_usd, read_drives, read_ours

    kpu = float(UsdPhysics.GetStageKilogramsPerUnit(stage))
    out: dict[str, Drive] = {}
    for kind, (paths, _) in parsed.items():
        if not kind.name.endswith("Joint"):
            continue
        for path in paths:
            prim = stage.GetPrimAtPath(path)
            for schema in prim.GetAppliedSchemas():
                if not schema.startswith("PhysicsDriveAPI:"):
                    continue
                instance = schema.split(":", 1)[1]
                own = instance in ("angular", "linear")
                angular = instance == "angular" or instance.startswith("rot")
                joint = sanitize_name(source_name(prim))  # (as the probe names it)
                name = (names or {}).get((str(path), instance),
                                         joint if own else f"{joint}_{instance}")
                entries, _ = read_drives(prim, {instance: (name, "angular" if angular
                                                           else "linear")},
                                         meters_per_unit, kpu)
                if not entries:
                    continue
                drive, _ = drive_from_usd(entries[0]["attributes"], angular,
                                          read_ours(prim, instance))
                if drive is not None:
                    out[name] = drive
    return out


def file_drives(path: Path, compiled: dict[Path, object], opened: dict) -> \
        dict[str, Drive] | None:
    """The drives of ``path`` as its tool reads them (``compiled``: the MuJoCo models the
    probes compiled; ``opened``: the USD probes), None where no tool reads drives."""
    if Path(path) in compiled:
        return mjcf_drives(compiled[Path(path)])
    probe = opened.get(Path(path))
    if probe is not None and hasattr(probe, "stage"):
        if _has_mjc_actuators(probe.stage):
            return None  # MuJoCo's actuators, which UsdPhysics does not read as drives
        return usd_drives(probe.stage, probe.parsed, probe.meters_per_unit,
                          getattr(probe, "joint_names", None))
    return None


def _has_mjc_actuators(stage) -> bool:
    """Whether ``stage`` holds MuJoCo's actuator prims (mujoco-usd-converter's MjcActuator):
    its joints are driven by them, as MuJoCo compiles them, not by PhysicsDriveAPI, so its
    UsdPhysics drives are not all it has to compare."""
    from pxr import Usd

    from ..formats.usd.mjc_actuator import TYPE_NAME

    return any(p.GetTypeName() == TYPE_NAME
               for p in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()))
