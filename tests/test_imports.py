"""Imports run one way: no module of the project imports itself back through others, and the
core (``real2code_export``) never imports the ``pipeline`` except in its command line (the
registries of commands, the CLI's and batch's tasks, which import a stage when its command
runs).

Every import counts, those inside functions too: a lazy import still ties the two modules
together. Read with ``ast``, nothing is imported.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

from conftest import REPO

PACKAGES = ("real2code_export", "pipeline")
# the registries of commands: the only places the core may reach the pipeline (lazily)
COMMANDS = ("real2code_export.cli", "real2code_export.batch.tasks")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for pkg in PACKAGES for p in sorted((REPO / pkg).rglob("*.py"))}


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """The project modules ``name`` imports (explicitly: a parent package's __init__ that
    Python runs on the way is not counted)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            submodules = [f"{module}.{a.name}" for a in node.names]
            # ``from pkg import submodule`` imports the submodule; pkg only for its names
            names_from_module = any(m not in known for m in submodules)
            targets = submodules + ([module] if names_from_module else [])
        else:
            continue
        out |= {t for t in targets if t in known and t != name}
    return out


@functools.cache  # read once for every test here
def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(name, path, set(modules)) for name, path in modules.items()}


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle, as the modules along it, or None (depth-first search, colours)."""
    colour: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        colour[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if colour.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in colour and (found := visit(nxt)):
                return found
        stack.pop()
        colour[node] = 2
        return None

    for node in sorted(graph):
        if node not in colour and (found := visit(node)):
            return found
    return None


def test_the_cycle_finder_finds_a_cycle():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def test_no_import_cycles():
    cycle = _cycle(_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_the_core_imports_the_pipeline_only_in_its_commands():
    wrong = sorted(f"{name} imports {t}" for name, targets in _graph().items()
                   if name.startswith("real2code_export") and not name.startswith(COMMANDS)
                   for t in targets if t.startswith("pipeline"))
    assert not wrong, wrong


def test_no_format_imports_another():
    """Each format's modules import the core and the registry, never another format's: what
    two formats share (object.json's and glTF's shape JSON) lives in the core."""
    prefix = "real2code_export.formats."

    def fmt(module: str) -> str | None:
        return module[len(prefix):].split(".")[0] if module.startswith(prefix) else None

    wrong = sorted(f"{name} imports {t}" for name, targets in _graph().items() if fmt(name)
                   for t in targets if fmt(t) and fmt(t) != fmt(name))
    assert not wrong, wrong
