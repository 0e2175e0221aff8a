"""Training caches are named by the code that made them: a generator that changed never
feeds a network the data it no longer makes."""

from __future__ import annotations

from pipeline.training_cache import cache_file, code_version, source_hash


def test_the_hash_follows_every_source_file(tmp_path):
    (tmp_path / "gen").mkdir()
    (tmp_path / "gen" / "a.py").write_text("x = 1\n")
    first = source_hash([tmp_path / "gen"])
    assert source_hash([tmp_path / "gen"]) == first  # the same code, the same name
    (tmp_path / "gen" / "a.py").write_text("x = 2\n")
    changed = source_hash([tmp_path / "gen"])
    assert changed != first
    (tmp_path / "gen" / "b.py").write_text("")
    with_module = source_hash([tmp_path / "gen"])
    assert with_module != changed  # a new module counts too
    (tmp_path / "gen" / "notes.txt").write_text("not code")
    assert source_hash([tmp_path / "gen"]) == with_module  # what is not code does not


def test_cache_files_carry_the_code_version(tmp_path):
    assert cache_file(None, "views") is None
    path = cache_file(tmp_path, "joints_train_paper_10_0")
    assert path.parent == tmp_path and path.suffix == ".pkl"
    assert path.stem == f"joints_train_paper_10_0_{code_version()}"
