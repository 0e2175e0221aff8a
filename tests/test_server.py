"""``real2code server``: a command run in the server's fork is the command run on its own (same
output, files, messages and exit status, from the caller's folder and environment), signals
reach it, and a caller whose interpreter or environment differs runs on its own."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from real2code_export.cli import serving

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="the server forks: Linux only")

FIXTURES = Path(__file__).parent / "fixtures" / "urdf"
GRIPPER = FIXTURES / "mimic_gripper.urdf"
CLI = [sys.executable, "-m", "real2code_export.cli"]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """A server in a runtime folder of its own; its environment for callers."""
    folder = tmp_path_factory.mktemp("runtime")
    folder.chmod(0o700)
    env = {**os.environ, "XDG_RUNTIME_DIR": str(folder)}
    env.pop(serving.ENV_SWITCH, None)
    started = _cli(["server", "start", "--idle-timeout", "5"], env)
    assert started.returncode == 0, started.stderr
    assert "real2code server started" in started.stdout
    yield env
    stopped = _cli(["server", "stop"], env)
    assert stopped.returncode == 0 and "stopped" in stopped.stdout
    assert not any(folder.rglob("*.sock")), "the socket goes with the server"


def _cli(args, env, cwd=None, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], env=env, cwd=cwd, capture_output=True, text=True,
                          timeout=120, **kw)


def _served(env) -> int:
    said = _cli(["server", "status"], env).stdout
    return int(said.split(" commands served")[0].rsplit(" ", 1)[1])


def _alone(env) -> dict:
    return {**env, serving.ENV_SWITCH: "off"}


def test_a_command_in_the_server_is_the_command_on_its_own(server, tmp_path):
    before = _served(server)
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    # relative paths: the command runs in the caller's folder
    args = ["export", str(GRIPPER), "--to", "mjcf,urdf", "--out", "out"]
    warm = _cli(args, server, cwd=tmp_path / "a")
    alone = _cli(args, _alone(server), cwd=tmp_path / "b")
    assert _served(server) == before + 1, "the command did not run in the server"
    assert warm.returncode == alone.returncode == 0, warm.stderr
    assert warm.stdout.replace("/a/", "/b/") == alone.stdout.replace("/a/", "/b/")
    assert warm.stderr == alone.stderr
    for name in ("mimic_gripper.xml", "mimic_gripper.urdf"):
        assert (tmp_path / "a/out" / name).read_bytes() == \
            (tmp_path / "b/out" / name).read_bytes()


@pytest.mark.parametrize("args, status", [
    (["export", str(FIXTURES / "joint_cycle.urdf"), "--to", "mjcf", "--out", "x"], 2),
    (["export"], 2),  # a usage error: argparse exits
    (["--version"], 0),
    (["check", "--help"], 0),
])
def test_exit_status_and_messages_come_back(server, tmp_path, args, status):
    before = _served(server)
    warm = _cli(args, server, cwd=tmp_path)
    alone = _cli(args, _alone(server), cwd=tmp_path)
    assert _served(server) == before + 1
    assert warm.returncode == alone.returncode == status
    assert (warm.stdout, warm.stderr) == (alone.stdout, alone.stderr)
    assert not (tmp_path / "x").exists()


def test_the_callers_environment_reaches_the_command(server, tmp_path):
    # ROS_PACKAGE_PATH is read when the command runs: each caller's own, never sticky
    import trimesh

    package = tmp_path / "pkgs" / "my_robot"
    package.mkdir(parents=True)
    trimesh.creation.box((0.1, 0.1, 0.1)).export(package / "palm.stl")
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(GRIPPER.read_text().replace(
        '<link name="palm">', '<link name="palm"><visual><geometry>'
        '<mesh filename="package://my_robot/palm.stl"/></geometry></visual>'))
    args = ["export", str(urdf), "--to", "mjcf", "--out", "o"]
    env = {**server, "ROS_PACKAGE_PATH": str(tmp_path / "pkgs")}
    found = _cli(args, env, cwd=tmp_path)
    assert found.returncode == 0, found.stderr
    lost = _cli(args, {k: v for k, v in server.items() if k != "ROS_PACKAGE_PATH"},
                cwd=tmp_path)
    assert lost.returncode == 2 and "my_robot" in lost.stderr, lost.stderr


def test_another_import_time_environment_runs_on_its_own(server, tmp_path):
    before = _served(server)
    env = {**server, "OMP_NUM_THREADS": "3"}
    done = _cli(["--version"], env)
    assert done.returncode == 0 and "real2code" in done.stdout
    assert _served(server) == before
    said = _cli(["server", "status"], env).stdout
    assert "run on their own: environment variable(s) OMP_NUM_THREADS differ" in said


def test_signals_reach_the_command_and_a_lost_caller_stops_it(server, tmp_path):
    # `view` serves until Ctrl-C: the caller's SIGINT must reach the fork
    view = [*CLI, "view", str(GRIPPER), "--no-browser", "--port", "0"]
    caller = subprocess.Popen(view, env=server, stdout=subprocess.PIPE, text=True)
    assert "real2code view:" in caller.stdout.readline()
    caller.send_signal(signal.SIGINT)
    assert caller.wait(timeout=30) == 0  # view ends quietly on Ctrl-C
    caller.stdout.close()

    caller = subprocess.Popen(view, env=server, stdout=subprocess.PIPE, text=True)
    assert "real2code view:" in caller.stdout.readline()
    caller.kill()  # the caller gone: its command must not serve on
    caller.wait()
    caller.stdout.close()
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and " 0 running" not in _cli(["server", "status"],
                                                                  server).stdout:
        time.sleep(0.1)
    assert " 0 running" in _cli(["server", "status"], server).stdout


def test_a_second_start_finds_the_first(server):
    again = _cli(["server", "start"], server)
    assert again.returncode == 0 and "already runs" in again.stdout


def test_identity_tells_stale_code_from_another_runtime(tmp_path):
    package = tmp_path / "pkg"
    (package / "sub").mkdir(parents=True)
    (package / "a.py").write_text("x = 1\n")
    (package / "sub" / "b.py").write_text("y = 2\n")
    first = serving.code_stamp(package)
    assert first[0] == 2
    (package / "sub" / "b.py").write_text("y = 22\n")
    assert serving.code_stamp(package) != first

    mine = serving.identity(serving.Installation())
    changed = {**mine, "code": {**mine["code"], "stamp": [0, 0, 0]}}
    assert serving.mismatch(mine, changed, "code") == \
        "the package's sources changed since the server started"
    assert serving.mismatch(mine, changed, "runtime") is None
    other = {**mine, "runtime": {**mine["runtime"], "environment": {
        **mine["runtime"]["environment"], "MUJOCO_GL": "egl-other"}}}
    assert serving.mismatch(mine, other, "runtime") == \
        "environment variable(s) MUJOCO_GL differ"
    assert serving.mismatch(mine, mine, "code") is None


def test_a_start_from_another_checkouts_folder_serves_this_package(tmp_path):
    """The server is this installation's whatever folder ``server start`` runs in: a
    package of the same name there (another checkout) is not the one it imports."""
    runtime = tmp_path / "runtime"
    runtime.mkdir(mode=0o700)
    other = tmp_path / "checkout" / "real2code_export"
    (other / "cli").mkdir(parents=True)
    (other / "__init__.py").write_text("raise ImportError('another checkout')\n")
    (other / "cli" / "__init__.py").write_text("")
    env = {**os.environ, "XDG_RUNTIME_DIR": str(runtime)}
    env.pop(serving.ENV_SWITCH, None)
    # -P: the caller imports this package, not the folder's, as the console script does
    start = [sys.executable, "-P", "-m", "real2code_export.cli", "server"]
    done = subprocess.run([*start, "start", "--idle-timeout", "1"], env=env,
                          cwd=other.parent, capture_output=True, text=True, timeout=120)
    try:
        assert done.returncode == 0, done.stderr
        assert "real2code server started" in done.stdout
    finally:
        subprocess.run([*start, "stop"], env=env, cwd=other.parent, capture_output=True,
                       timeout=120)


def test_a_folder_open_to_others_is_refused(tmp_path):
    tmp_path.chmod(0o755)
    assert "open to other users" in serving.private(tmp_path)
    tmp_path.chmod(0o700)
    assert serving.private(tmp_path) is None
    env = {**os.environ, "XDG_RUNTIME_DIR": str(tmp_path)}
    (tmp_path / "real2code").mkdir(mode=0o777)
    (tmp_path / "real2code").chmod(0o777)
    done = _cli(["server", "start"], env)
    assert done.returncode == 2 and "not private" in done.stderr


def test_an_idle_server_stops_by_itself(tmp_path):
    tmp_path.chmod(0o700)
    env = {**os.environ, "XDG_RUNTIME_DIR": str(tmp_path)}
    done = _cli(["server", "run", "--idle-timeout", "0.01"], env)  # 0.6 s
    assert done.returncode == 0
    assert "idle for 0.01 min: stopping" in done.stderr
    assert not any(tmp_path.rglob("*.sock"))


def test_the_servers_commands_are_parsed_by_the_parser_built_once(monkeypatch, capsys):
    """The runner a server is given parses with the parser that parsed ``server run`` (built
    once in the server), not a new one per command."""
    from real2code_export import cli

    args = cli.build_parser().parse_args(["server", "run"])

    def built_again():
        raise AssertionError("a served command built the parser again")

    monkeypatch.setattr(cli, "build_parser", built_again)
    with pytest.raises(SystemExit) as said:
        args.runner(["--version"])
    assert said.value.code == 0 and "real2code" in capsys.readouterr().out


def test_the_forks_allocator_keeps_what_a_command_frees():
    """In the server (and so its forks) glibc maps no memory of its own for a large block:
    it comes from the heap, and what is freed stays there for the command's next arrays."""
    code = """
import ctypes, sys
from real2code_export.cli import server_loop
libc = ctypes.CDLL(None)
if not hasattr(libc, "mallinfo2"):
    sys.exit(77)
class Info(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd",
                                                "usmblks", "fsmblks", "uordblks", "fordblks",
                                                "keepcost")]
libc.mallinfo2.restype = Info
libc.malloc.restype = ctypes.c_void_p
libc.free.argtypes = [ctypes.c_void_p]
def mapped_for(size):
    block = libc.malloc(size)
    mapped = libc.mallinfo2().hblkhd
    libc.free(block)
    return mapped
before = mapped_for(64 << 20)
server_loop._allocator_for_commands()
print(before, mapped_for(64 << 20))
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=60)
    if done.returncode == 77:
        pytest.skip("not glibc (no mallinfo2)")
    assert done.returncode == 0, done.stderr
    before, after = map(int, done.stdout.split())
    assert before >= 64 << 20 and after < 64 << 20
