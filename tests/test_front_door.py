"""The one front door: the format registry is the only list of formats (a toy format
registered in one place is offered everywhere), every command fails with an exit status and
a message (never a bare traceback), and a format whose dependency is broken is not offered."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import types
from pathlib import Path

import pytest

from real2code_export import formats
from real2code_export.cli import EXIT_ERROR, EXIT_INTERNAL, EXIT_OK, build_parser, run
from real2code_export.formats import object_json
from real2code_export.probes.model import ModelProbe

from conftest import REPO
from helpers import small_cabinet


# -- a toy format, registered in one place ------------------------------------------------------
def _toy_module() -> types.ModuleType:
    """A format storing object.json's document under another suffix (meshes shared)."""
    toy = types.ModuleType("toy_format")

    def save(obj, out_dir, *, write_meshes=True):
        path = Path(out_dir) / f"{obj.name}.toy"
        path.write_text(object_json.dumps(obj))
        return path

    def load(path):
        path = Path(path)
        return object_json.from_dict(json.loads(path.read_text()), path)

    class ToyProbe(ModelProbe):
        label = "toy"

    def open_probes(path):
        return [ToyProbe(load(path), Path(path))]

    toy.save, toy.load, toy.open_probes = save, load, open_probes
    return toy


@pytest.fixture
def toy_format(monkeypatch):
    monkeypatch.setitem(sys.modules, "toy_format", _toy_module())
    monkeypatch.setattr(formats, "FORMATS", dict(formats.FORMATS))
    formats.register(formats.Format("toy", "Toy", "A toy format for tests", "toy_format",
                                    (".toy",), probes=("toy_format",)))
    yield formats.FORMATS["toy"]
    formats.forget_availability()


@pytest.fixture
def cabinet_json(tmp_path) -> Path:
    object_json.save(small_cabinet(), tmp_path / "model")
    return tmp_path / "model" / "object.json"


def test_a_registered_format_is_offered_by_the_cli_batch_and_check(toy_format, cabinet_json,
                                                                   tmp_path, capsys):
    from real2code_export.batch.inputs import is_model_file

    out = tmp_path / "out"
    assert run(["export", str(cabinet_json), "--to", "urdf,toy", "--out", str(out)]) == EXIT_OK
    toy = next(out.glob("*.toy"))
    assert "toy" in formats.export_formats()  # the default --to offers it
    assert is_model_file(toy)  # batch finds it in a folder
    capsys.readouterr()
    assert run(["check", str(cabinet_json), str(toy), str(next(out.glob("*.urdf")))]) == EXIT_OK
    assert "toy" in capsys.readouterr().out


def test_a_registered_format_is_offered_by_the_blender_addon(toy_format, monkeypatch):
    """The add-on's import filter and export menu are the registry's (bpy stubbed: the
    add-on itself is tested inside Blender by blender_addon/tests)."""

    class Stub(types.ModuleType):
        def __getattr__(self, name):
            if name.startswith("__"):
                raise AttributeError(name)
            value = type(name, (), {"__init__": lambda self, *a, **k: None})
            setattr(self, name, value)
            return value

    for name in ("bpy", "bpy.props", "bpy.types", "bpy.utils", "bpy_extras",
                 "bpy_extras.io_utils", "mathutils"):
        monkeypatch.setitem(sys.modules, name, Stub(name))
    sys.modules["bpy"].props = sys.modules["bpy.props"]
    sys.modules["bpy"].types = sys.modules["bpy.types"]
    sys.modules["bpy_extras.io_utils"].poll_file_object_drop = lambda *a: True
    for name in [m for m in sys.modules if m.split(".")[0] == "blender_addon"]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.syspath_prepend(str(REPO))
    from blender_addon import ops_export, ops_import

    assert ".toy" in ops_import.EXTENSIONS and ".toy" in ops_import.MENU_TEXT
    assert ("toy", "Toy", "A toy format for tests") in ops_export.FORMAT_ITEMS
    assert "Toy" in ops_export.EXPORTED and "Toy" in ops_import.IMPORT_SCENE_OT_real2code.bl_description
    for name in [m for m in sys.modules if m.split(".")[0] == "blender_addon"]:
        monkeypatch.delitem(sys.modules, name)


# -- a broken dependency ---------------------------------------------------------------------
@pytest.fixture
def broken_pxr(monkeypatch):
    """pxr installed but failing to import (None in sys.modules: the import raises)."""
    for name in [m for m in sys.modules if m == "pxr" or m.startswith("pxr.")] or ["pxr"]:
        monkeypatch.setitem(sys.modules, name, None)
    formats.forget_availability()
    yield
    formats.forget_availability()


def test_a_format_whose_dependency_fails_is_not_offered(broken_pxr, cabinet_json, tmp_path,
                                                        capsys):
    assert not formats.available("usd")
    assert "pxr" in formats.unavailable_reason("usd")
    assert "usd" not in formats.export_formats()
    out = tmp_path / "out"
    assert run(["export", str(cabinet_json), "--out", str(out)]) == EXIT_OK
    assert not list(out.glob("*.usd*")) and list(out.glob("*.urdf"))
    capsys.readouterr()
    status = run(["export", str(cabinet_json), "--to", "usd", "--out", str(tmp_path / "o2")])
    err = capsys.readouterr().err
    assert status == EXIT_ERROR and "usd" in err and "pxr" in err, err
    assert not (tmp_path / "o2").exists()
    usda = tmp_path / "x.usda"
    usda.write_text("#usda 1.0\n")
    assert run(["check", str(usda)]) == EXIT_ERROR
    assert "pxr" in capsys.readouterr().err


def test_a_format_whose_reader_alone_fails_is_written_not_read(toy_format, cabinet_json,
                                                               tmp_path, monkeypatch, capsys):
    """``Format.read_requires``: what only the reader imports (USD's schema modules; its
    writer authors through Sdf) failing leaves the format offered to export, refused to
    read with the reason."""
    monkeypatch.setitem(sys.modules, "toy_reader_dependency", None)  # installed, broken
    formats.register(dataclasses.replace(toy_format, read_requires=("toy_reader_dependency",)))
    assert "toy" in formats.export_formats() and not formats.available("toy")
    assert "toy_reader_dependency" in formats.unavailable_reason("toy")
    assert formats.unavailable_reason("toy", writing=True) is None
    out = tmp_path / "out"
    assert run(["export", str(cabinet_json), "--to", "toy", "--out", str(out)]) == EXIT_OK
    capsys.readouterr()
    assert run(["export", str(next(out.glob("*.toy"))), "--to", "urdf",
                "--out", str(tmp_path / "o2")]) == EXIT_ERROR
    assert "toy_reader_dependency" in capsys.readouterr().err


# -- every command: bad input is exit 2 with a message, never a traceback ------------------------
def _no_visuals(tmp_path) -> Path:
    obj = small_cabinet()
    obj = dataclasses.replace(obj, parts=[dataclasses.replace(p, visual=None, collision=[])
                                          for p in obj.parts])
    object_json.save(obj, tmp_path / "bare")
    return tmp_path / "bare" / "object.json"


def _bad_commands(tmp_path: Path) -> dict[str, list[str]]:
    empty = tmp_path / "empty"
    empty.mkdir()
    (tmp_path / "model.obj").write_text("v 0 0 0\n")
    return {
        "export": ["export", str(tmp_path / "missing.urdf"), "--out", str(tmp_path / "o")],
        "check": ["check", str(tmp_path / "model.obj")],
        "generate": ["generate", "--category", "box", "--parts", "0", "--out", str(tmp_path / "o")],
        "articulate": ["articulate", str(empty), "--out", str(tmp_path / "o")],
        "render": ["render", str(_no_visuals(tmp_path)), "--out", str(tmp_path / "o")],
        "reconstruct": ["reconstruct", str(empty), "--out", str(tmp_path / "o")],
        "calibrate": ["calibrate", str(tmp_path / "missing.json"), "--data", "x.csv",
                      "--out", str(tmp_path / "o")],
        "evaluate joints": ["evaluate", "joints", "--objects", "1", "--partnet", str(empty)],
        "evaluate completion": ["evaluate", "completion", "--partnet", str(empty),
                                "--out", str(tmp_path / "o")],
        "evaluate reconstruction": ["evaluate", "reconstruction", "--objects", "1",
                                    "--partnet", str(empty)],
        "simulate": ["simulate", str(tmp_path / "missing.urdf")],
        "view": ["view", str(tmp_path / "missing.urdf"), "--no-browser", "--port", "0"],
        "batch": ["batch", "export", str(tmp_path / "nothing" / "*.urdf"), "--out",
                  str(tmp_path / "o")],
        # (its folder made open to others by the test: refused)
        "server": ["server", "start"],
    }


def test_every_command_refuses_bad_input_with_exit_2(tmp_path, capsys, monkeypatch):
    import pipeline.capture

    monkeypatch.setattr(pipeline.capture, "SAMPLE_CAPTURE", tmp_path / "no_capture")
    runtime = tmp_path / "runtime"
    (runtime / "real2code").mkdir(parents=True)
    (runtime / "real2code").chmod(0o777)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(runtime))
    commands = {**_bad_commands(tmp_path), "demo": ["demo", "--out", str(tmp_path / "d")]}
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    evaluate = next(a for a in sub.choices["evaluate"]._actions if a.dest == "what")
    names = set(sub.choices) | {f"evaluate {w}" for w in evaluate.choices}
    assert names - {"evaluate"} == set(commands)
    for name, argv in commands.items():
        status = run(argv)
        err = capsys.readouterr().err
        assert status == EXIT_ERROR, (name, status, err)
        assert err.startswith(("error: ", "warning: ")) and "Traceback" not in err, (name, err)
    assert not (tmp_path / "o").exists() and not (tmp_path / "d").exists()


def test_render_without_visual_meshes_names_the_object(tmp_path, capsys):
    assert run(["render", str(_no_visuals(tmp_path)), "--out", str(tmp_path / "o")]) == 2
    assert "no visual meshes" in capsys.readouterr().err


def test_an_internal_error_is_exit_3_with_the_traceback_in_a_file(tmp_path, capsys,
                                                                  monkeypatch, cabinet_json):
    def broken(path, **options):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(formats, "load", broken)
    status = run(["export", str(cabinet_json), "--to", "urdf", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert status == EXIT_INTERNAL and "Traceback" not in err
    assert "internal error: ZeroDivisionError: a bug" in err
    written = Path(err.rsplit("traceback is in ", 1)[1].split(")")[0])
    assert "ZeroDivisionError" in written.read_text()
    written.unlink()


def test_nan_metadata_is_the_same_error_for_every_format(tmp_path):
    from real2code_export.errors import ModelError

    obj = dataclasses.replace(small_cabinet(), metadata={"scale": float("nan")})
    for name in ("json", "mjcf", "urdf", "usd", "gltf"):
        with pytest.raises(ModelError, match="metadata: not JSON"):
            formats.export(obj, tmp_path / name, [name])
        assert not (tmp_path / name).exists()


def test_the_demo_capture_ships_as_package_data():
    """``real2code demo`` reads its capture from the installed package, never a checkout."""
    import tomllib

    import pipeline
    from pipeline.capture import ROOM_SAMPLE_CAPTURE, SAMPLE_CAPTURE

    root = Path(pipeline.__file__).resolve().parent
    config = tomllib.loads((REPO / "pyproject.toml").read_text())
    patterns = config["tool"]["setuptools"]["package-data"]["pipeline"]
    shipped = {p for pattern in patterns for p in root.glob(pattern) if p.is_file()}
    for capture in (SAMPLE_CAPTURE, ROOM_SAMPLE_CAPTURE):
        needed = {p for p in capture.rglob("*") if p.is_file()}
        assert (capture / "transforms.json") in needed and needed <= shipped


def test_building_the_parser_imports_no_stage():
    """``real2code --help`` stays quick: no pipeline, numpy, scipy or format module loads."""
    import subprocess

    code = ("import sys; from real2code_export.cli import build_parser; build_parser(); "
            "print(' '.join(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('pipeline', 'numpy', 'scipy', 'trimesh', 'mujoco', 'pxr', 'pygltflib', 'torch') "
            "or m.startswith(('real2code_export.formats.', 'real2code_export.model')))))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, cwd=REPO)
    assert done.stdout.strip() == "", done.stdout


def test_an_export_imports_no_reader_of_the_format_it_writes(cabinet_json, tmp_path):
    """``export --to usd`` reads object.json and writes USD: USD's reader (its parsed tree,
    pxr.Usd and the schema modules) is not imported, as ``Format.read_requires`` says."""
    code = ("import sys; from real2code_export.cli import run; "
            f"status = run(['export', {str(cabinet_json)!r}, '--to', 'usd', '--out', "
            f"{str(tmp_path / 'out')!r}]); "
            "print(status, sorted(m for m in sys.modules if m in ('pxr.Usd', 'pxr.UsdPhysics') "
            "or m.startswith('real2code_export.formats.usd.read')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, cwd=REPO)
    assert done.stdout.split("\n")[-2] == "0 []", done.stdout


def test_a_format_package_imports_its_reader_and_writer_when_asked():
    """What check's probes and validators reach (a format's conventions, glTF's validator)
    imports no reader or writer; asking the package for a
    reader's or writer's name imports that module."""
    code = ("import sys, importlib; "
            "[importlib.import_module(f'real2code_export.formats.{m}') for m in "
            "('gltf.validator', 'mjcf.conventions', 'urdf.conventions')]; "
            "print(sorted(m for m in sys.modules if m.startswith('real2code_export.formats.') "
            "and m.endswith(('.read', '.write')) or m == 'pygltflib')); "
            "from real2code_export.formats.gltf import load; print(load.__module__)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, cwd=REPO)
    assert done.stdout.split() == ["[]", "real2code_export.formats.gltf.read"], done.stdout


def test_the_parser_restates_no_stage_fact_wrongly():
    """The few facts the parser carries so as not to import a stage match the stage's own."""
    from pipeline.render import DEFAULT_SIZE, DEFAULT_VIEWS
    from real2code_export.batch.inputs import KINDS
    from real2code_export.batch.tasks import TASKS
    from real2code_export.cli import batch, reconstruct

    assert (reconstruct.RENDER_VIEWS, reconstruct.RENDER_SIZE) == (DEFAULT_VIEWS, DEFAULT_SIZE)
    from pipeline import camera_paths

    assert reconstruct.CAMERA_PATHS == camera_paths.PATHS
    assert reconstruct.CAMERA_PATHS[0] == camera_paths.DEFAULT_PATH
    assert tuple(camera_paths.DISTANCES) == reconstruct.CAMERA_DISTANCES
    from pipeline import sensors

    assert tuple(sensors.PRESETS) == reconstruct.CAPTURE_PRESETS
    from pipeline.segment import choose

    assert reconstruct.MASK_WEIGHTS == choose.MODES
    assert reconstruct.MASK_WEIGHTS_DEFAULT == choose.DEFAULT
    assert batch.KINDS == KINDS == tuple(TASKS)


def test_the_process_ends_after_its_exit_handlers_and_buffered_output():
    """The console script skips the interpreter's teardown, not the exit handlers, the
    buffered output or the status; and a library's environment is the user's where set."""
    code = ("import atexit, sys\n"
            "atexit.register(lambda: print('handler ran'))\n"
            "from real2code_export.cli import _end_process, process_defaults\n"
            "process_defaults()\n"
            "import os\n"
            "print(os.environ['MUJOCO_GL'], os.environ['OPENBLAS_NUM_THREADS'], end=' ')\n"
            "sys.stderr.write('said')\n"
            "_end_process(3)\n"
            "print('never')\n")
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "OPENBLAS_NUM_THREADS")}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env | {"OPENBLAS_NUM_THREADS": "2"}, cwd=REPO)
    assert done.returncode == 3, done.stderr
    assert done.stdout == "disable 2 handler ran\n" and done.stderr == "said"


# -- every command: a library it needs failing is exit 2 naming it, nothing written --------------
# Each case runs in a child forked from one process that imported the CLI and numpy only, the
# library made unimportable in the child (None in sys.modules: "installed and broken"), so every
# command imports its stage afresh and meets the broken library where a user's would.
_BROKEN_LIBRARY_DRIVER = r"""
import contextlib, io, json, os, sys
import numpy  # noqa: F401 - shared by every case, never the one broken
from real2code_export.cli import run
results = {}
for case in json.loads(sys.stdin.read()):
    read, write = os.pipe()
    if os.fork() == 0:
        os.close(read)
        broken = case["library"]
        if broken == "three.js":  # the viewer's npm package
            from real2code_export.viewer import server
            server.THREE = server.THREE.parent / "absent"
        else:
            for name in [m for m in sys.modules if m.split(".")[0] == broken] or [broken]:
                sys.modules[name] = None
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            status = run(case["argv"])
        os.write(write, json.dumps([status, err.getvalue()]).encode())
        os._exit(0)
    os.close(write)
    with os.fdopen(read) as f:
        results[case["name"]] = json.loads(f.read() or "[null, \"the child died\"]")
    os.wait()
print(json.dumps(results))
"""


def test_every_command_names_a_library_it_cannot_import_with_exit_2(tmp_path):
    from pipeline.capture import SAMPLE_CAPTURE

    obj = small_cabinet()
    src = tmp_path / "src"
    files = formats.export(obj, src, ["json", "mjcf", "urdf", "usd", "gltf"])
    parts = tmp_path / "parts"
    parts.mkdir()
    for name in ("body", "door"):
        (parts / f"{name}.obj").write_bytes((src / "meshes" / f"{name}.obj").read_bytes())
    csv = tmp_path / "door.csv"
    csv.write_text("time,door_hinge\n" + "".join(f"{i / 100},{i / 1000}\n" for i in range(50)))
    model, urdf = str(files["json"]), str(files["urdf"])
    out = tmp_path / "o"
    cases = {  # command: (the library it cannot do without here, its arguments)
        "export": ("lxml", ["export", urdf, "--to", "urdf", "--out", str(out)]),
        "export --to mjcf": ("mujoco", ["export", model, "--to", "mjcf", "--out", str(out)]),
        "export --to usd": ("pxr", ["export", model, "--to", "usd", "--out", str(out)]),
        "export --to gltf": ("pygltflib", ["export", model, "--to", "gltf", "--out", str(out)]),
        "check (MJCF)": ("mujoco", ["check", str(files["mjcf"]), "--json", str(out)]),
        "check (URDF)": ("pinocchio", ["check", urdf, "--json", str(out)]),
        "check (USD)": ("pxr", ["check", str(files["usd"]), "--json", str(out)]),
        "generate": ("trimesh", ["generate", "--category", "box", "--out", str(out)]),
        "articulate": ("trimesh", ["articulate", str(parts), "--out", str(out)]),
        # (trimesh takes scipy's absence for a flat point set, and fails on that)
        "articulate (scipy)": ("scipy", ["articulate", str(parts), "--predictor", "geometric",
                                          "--out", str(out)]),
        "render": ("open3d", ["render", model, "--out", str(out)]),
        "reconstruct": ("PIL", ["reconstruct", str(SAMPLE_CAPTURE), "--out", str(out)]),
        "demo": ("PIL", ["demo", "--out", str(out)]),
        "calibrate": ("scipy", ["calibrate", model, "--data", str(csv), "--out", str(out)]),
        "simulate": ("mujoco", ["simulate", urdf, "--experiments", "swing",
                                "--json", str(out)]),
        "evaluate joints": ("scipy", ["evaluate", "joints", "--objects", "1",
                                      "--json", str(out)]),
        "evaluate completion": ("scipy", ["evaluate", "completion", "--out", str(out)]),
        "evaluate reconstruction": ("scipy", ["evaluate", "reconstruction", "--objects", "1",
                                               "--json", str(out)]),
        "view": ("three.js", ["view", model, "--no-browser", "--port", "0"]),
        "batch": ("mujoco", ["batch", "export", urdf, "--to", "mjcf", "--out", str(out)]),
    }
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    evaluate = next(a for a in sub.choices["evaluate"]._actions if a.dest == "what")
    names = set(sub.choices) - {"evaluate"} | {f"evaluate {w}" for w in evaluate.choices}
    # (`server` needs the standard library alone: what it imports for its forks is optional,
    # a library missing there is met, and named, by the command that needs it)
    assert names - {"server"} <= {name.split(" (")[0].split(" --")[0] for name in cases}
    done = subprocess.run(
        [sys.executable, "-c", _BROKEN_LIBRARY_DRIVER], cwd=REPO, capture_output=True,
        text=True, check=True, timeout=300,
        input=json.dumps([{"name": name, "library": library, "argv": argv}
                          for name, (library, argv) in cases.items()]))
    results = json.loads(done.stdout.splitlines()[-1])
    for name, (library, _) in cases.items():
        status, err = results[name]
        assert status == EXIT_ERROR, (name, status, err)
        assert err.startswith(("error: ", "warning: ")) and library in err, (name, err)
        assert "Traceback" not in err, (name, err)
        assert not out.exists(), (name, list(out.iterdir()))
