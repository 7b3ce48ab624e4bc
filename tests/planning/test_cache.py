"""The cache folder's arrays (planning.cache): computed once, loaded after, never stale by name."""

import numpy as np

from planning import cache


def test_arrays_are_computed_once_then_loaded_and_keyed_by_their_inputs(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    calls = []

    def compute():
        calls.append(1)
        return {"a": np.arange(5, dtype=np.int64), "big": np.zeros(3, dtype=np.uint64)}

    key = cache.digest("v1", np.array([1, 2], dtype=np.uint64), 7)
    first = cache.arrays("kind", key, compute, "TEST_CACHE", keep=("a",))
    assert set(first) == {"a", "big"} and len(calls) == 1  # computed: every array
    again = cache.arrays("kind", key, compute, "TEST_CACHE", keep=("a",))
    assert set(again) == {"a"} and (again["a"] == np.arange(5)).all() and len(calls) == 1  # loaded: those kept
    assert [p.name for p in (tmp_path / "anticipatory-planning" / "kind").iterdir()] == [f"{key}.npz"]
    # another input, dtype or shape is another entry
    assert cache.digest("v1", np.array([1, 2], dtype=np.int64), 7) != key
    assert cache.digest("v1", np.array([[1, 2]], dtype=np.uint64), 7) != key
    assert cache.digest("v2", np.array([1, 2], dtype=np.uint64), 7) != key
    # too large to keep, or switched off: computed every time, nothing written
    cache.arrays("large", key, compute, "TEST_CACHE", max_bytes=8)
    monkeypatch.setenv("TEST_CACHE", "0")
    cache.arrays("off", key, compute, "TEST_CACHE")
    assert len(calls) == 3
    assert sorted(p.name for p in (tmp_path / "anticipatory-planning").iterdir()) == ["kind"]


def test_an_unwritable_folder_still_gives_the_arrays(tmp_path, monkeypatch):
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocked))
    out = cache.arrays("kind", "k", lambda: {"a": np.ones(2)}, "TEST_CACHE")
    assert (out["a"] == 1).all()
