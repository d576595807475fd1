"""The on-disk array cache (twin.core.resources.cached_arrays): computed once, loaded
after, recomputed when an entry is damaged, never fatal when the directory is not
writable."""

from __future__ import annotations

import numpy as np
import pytest

from twin.core.resources import SEARCH_FOLDER, cached_arrays, code_digest, searching

SHAPES = {"a": (3, 4), "b": (5,)}


class Computation:
    """Counts how often the cache had to compute."""

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self) -> dict[str, np.ndarray]:
        self.calls += 1
        rng = np.random.default_rng(7)
        return {"a": rng.normal(size=(3, 4)), "b": rng.normal(size=5)}


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TWIN_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache" / "test"


def test_computed_once_then_loaded_bit_for_bit(cache):
    compute = Computation()
    first = cached_arrays("test", {"x": 1}, compute, SHAPES)
    second = cached_arrays("test", {"x": 1}, compute, SHAPES)
    assert compute.calls == 1
    assert len(list(cache.glob("*.npz"))) == 1
    for name in SHAPES:
        assert np.array_equal(first[name], second[name])


def test_another_key_is_another_entry(cache):
    compute = Computation()
    cached_arrays("test", {"x": 1}, compute, SHAPES)
    cached_arrays("test", {"x": 2}, compute, SHAPES)
    assert compute.calls == 2
    assert len(list(cache.glob("*.npz"))) == 2


@pytest.mark.parametrize("damage", ["garbage", "truncated", "wrong shape"])
def test_a_damaged_entry_is_computed_again_and_rewritten(cache, damage):
    compute = Computation()
    cached_arrays("test", {"x": 1}, compute, SHAPES)
    (entry,) = cache.glob("*.npz")
    if damage == "garbage":
        entry.write_bytes(b"not an npz file")
    elif damage == "truncated":
        entry.write_bytes(entry.read_bytes()[:100])
    else:
        np.savez(entry, a=np.zeros((2, 2)), b=np.zeros(5))
    with pytest.warns(UserWarning, match="computing it again"):
        again = cached_arrays("test", {"x": 1}, compute, SHAPES)
    assert compute.calls == 2
    assert again["a"].shape == (3, 4)
    cached_arrays("test", {"x": 1}, compute, SHAPES)
    assert compute.calls == 2  # the rewritten entry loads


def test_entries_over_the_size_limit_are_not_stored(cache):
    compute = Computation()
    cached_arrays("test", {"x": 1}, compute, SHAPES, max_bytes=64)
    cached_arrays("test", {"x": 1}, compute, SHAPES, max_bytes=64)
    assert compute.calls == 2
    assert not cache.exists()


def test_an_unwritable_cache_only_warns(tmp_path, monkeypatch):
    blocker = tmp_path / "a-file"
    blocker.write_text("the cache directory cannot be created under a file")
    monkeypatch.setenv("TWIN_CACHE", str(blocker))
    with pytest.warns(UserWarning, match="could not store"):
        arrays = cached_arrays("test", {"x": 1}, Computation(), SHAPES)
    assert arrays["b"].shape == (5,)
    assert not list(tmp_path.glob("**/*.partial.npz")) and not list(tmp_path.glob("**/*.tmp"))


def test_refresh_computes_and_stores_even_a_present_entry(cache):
    compute = Computation()
    cached_arrays("test", {"x": 1}, compute, SHAPES)
    (entry,) = cache.glob("*.npz")
    entry.write_bytes(b"stale")
    cached_arrays("test", {"x": 1}, compute, SHAPES, refresh=True)
    assert compute.calls == 2
    cached_arrays("test", {"x": 1}, compute, SHAPES)
    assert compute.calls == 2  # the refreshed entry loads


def test_the_least_recently_used_entries_make_room(cache):
    """Beyond the kind's limit a stored entry deletes the entries used longest ago; loading
    an entry counts as using it."""
    import os

    compute = Computation()
    cached_arrays("test", {"x": 1}, compute, SHAPES)
    (first,) = cache.glob("*.npz")
    cached_arrays("test", {"x": 2}, compute, SHAPES)
    (second,) = set(cache.glob("*.npz")) - {first}
    size = first.stat().st_size
    os.utime(first, (1000, 1000))  # x = 1 stored long ago ...
    os.utime(second, (2000, 2000))  # ... x = 2 later
    cached_arrays("test", {"x": 1}, compute, SHAPES)  # ... but x = 1 used now
    assert compute.calls == 2
    cached_arrays("test", {"x": 3}, compute, SHAPES, kind_limit_bytes=int(2.5 * size))
    assert len(list(cache.glob("*.npz"))) == 2 and not second.exists() and first.exists()
    cached_arrays("test", {"x": 1}, compute, SHAPES)
    assert compute.calls == 3  # x = 1 kept, x = 3 stored
    cached_arrays("test", {"x": 2}, compute, SHAPES)
    assert compute.calls == 4  # x = 2 was the one to go


def test_a_search_never_evicts_the_kinds_own_entries(cache):
    """What is computed inside `searching` (a calibration's candidate materials) goes to
    the kind's search folder, with its own limit: however many candidates, the kind's own
    entries stay, and an entry is found in either folder, inside and outside the search."""
    compute = Computation()
    cached_arrays("test", {"x": 0}, compute, SHAPES)
    (own,) = cache.glob("*.npz")
    size = own.stat().st_size
    with searching(limit_bytes=int(2.5 * size)):
        for x in range(1, 6):
            cached_arrays("test", {"x": x}, compute, SHAPES, kind_limit_bytes=int(1.5 * size))
        assert compute.calls == 6
        cached_arrays("test", {"x": 0}, compute, SHAPES)  # the kind's own entry serves the search
        assert compute.calls == 6
    assert set(cache.glob("*.npz")) == {own}
    kept = sorted((cache / SEARCH_FOLDER).glob("*.npz"))
    assert len(kept) == 2  # the search's least recently used made room for its newest
    cached_arrays("test", {"x": 5}, compute, SHAPES)  # a candidate the search kept, found outside it
    cached_arrays("test", {"x": 0}, compute, SHAPES)
    assert compute.calls == 6
    cached_arrays("test", {"x": 1}, compute, SHAPES)  # one it let go: computed, and stored as the kind's own
    assert compute.calls == 7 and len(list(cache.glob("*.npz"))) == 2


def test_the_code_digest_follows_the_code_not_its_comments(tmp_path):
    """Cache keys carry a digest of the code that computes an entry: editing comments,
    docstrings or blank lines keeps it (the cached entries stay valid), editing code, adding
    a module or moving one changes it."""
    package = tmp_path / "stages"
    package.mkdir()
    module = package / "scale.py"

    def digest(text: str) -> str:
        module.write_text(text)
        code_digest.cache_clear()  # one digest per process and path: the code of a running process does not change
        return code_digest(package)

    stage = '"""A stage."""\nSCALE = 2.0  # mm\n\n\ndef scaled(x):\n    """Twice x."""\n    return SCALE * x\n'
    original = digest(stage)
    assert (
        digest(
            '"""A stage, documented anew."""\n# units: mm\nSCALE = 2.0\n\ndef scaled(x):\n'
            '    """x, twice (mm)."""\n\n    return SCALE * x  # the same code\n'
        )
        == original
    )
    assert digest("SCALE = 2.0\n\n\ndef scaled(x):\n    return SCALE * x\n") == original
    assert digest(stage.replace("SCALE = 2.0", "SCALE = 3.0")) != original
    digest(stage)
    (package / "extra.py").write_text("OFFSET = 1.0\n")
    code_digest.cache_clear()
    assert code_digest(package) != original
    (package / "extra.py").unlink()
    module.rename(package / "moved.py")
    code_digest.cache_clear()
    assert code_digest(package) != original
    code_digest.cache_clear()
