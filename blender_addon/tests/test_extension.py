"""The extension zip: built by build.py with Blender's own tool, accepted by its validator,
installed by Blender's installer, running the project code it bundles."""

from __future__ import annotations

import sys
import zipfile
from pathlib import Path

import pytest

from conftest import ADDON, MODULE, REPO, load_build_script


def test_zip_passes_the_extension_validator(extension_zip):
    build = load_build_script()
    assert extension_zip.name == "real2code-0.1.0-linux_x64.zip"
    assert "Success" in build.validate(extension_zip)
    with zipfile.ZipFile(extension_zip) as z:
        names = set(z.namelist())
    assert "blender_manifest.toml" in names and "__init__.py" in names
    assert {f"wheels/{w}" for w in build.manifest_wheels()} <= names
    assert not any(n.startswith(("tests/", "build.py")) for n in names)


def test_validator_refuses_a_broken_manifest(tmp_path):
    """The validator is not a rubber stamp: a manifest without its licence fails."""
    build = load_build_script()
    source = tmp_path / "broken"
    source.mkdir()
    text = (ADDON / "blender_manifest.toml").read_text()
    (source / "blender_manifest.toml").write_text(
        "\n".join(line for line in text.splitlines() if not line.startswith("license")))
    (source / "__init__.py").write_text("")
    with pytest.raises(build.BuildError, match="license"):
        build.validate(source)


def test_manifest_lists_exactly_the_pinned_wheels(tmp_path):
    build = load_build_script()
    wheels = build.fetch_wheels()
    project = f"real2code_export-{build.project_version()}-py3-none-any.whl"
    assert sorted(build.manifest_wheels()) == sorted([w.name for w in wheels] + [project])


def test_installed_addon_runs_the_bundled_project_code(installed):
    import real2code_export

    where = Path(real2code_export.__file__).resolve()
    assert REPO not in where.parents, f"imported from the checkout: {where}"
    assert "extensions" in where.parts
    # the bundled copy is this checkout's code
    assert (where.parent / "model.py").read_text() == (REPO / "real2code_export" /
                                                       "model.py").read_text()
    assert installed.__name__ == MODULE and f"{MODULE}.panel" in sys.modules
