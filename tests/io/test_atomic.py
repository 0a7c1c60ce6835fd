"""Atomic writes: hidden digit-free temporaries, nothing left behind on any path."""

from __future__ import annotations

import re

import pytest

from voxelmocap.errors import InputError
from voxelmocap.io._atomic import atomic_path, atomic_write_text, temporary_name


def test_temporary_names_are_hidden_siblings_without_digits(tmp_path):
    target = tmp_path / "run 12" / "S1_Walking_1.mp4"
    names = {temporary_name(target) for _ in range(50)}
    assert len(names) == 50  # random: two writers never share one
    for tmp in names:
        assert tmp.parent == target.parent and tmp.suffix == ".mp4"
        assert tmp.name.startswith(".S1_Walking_1.partial-")
        # no digit after the target's stem: an image writer cannot read a frame counter in it
        assert not re.search(r"\d", tmp.name[len(".S1_Walking_1"):-len(".mp4")])


def test_success_renames_and_leaves_nothing_else(tmp_path):
    with atomic_path(tmp_path / "out" / "a.txt") as tmp:
        assert tmp.exists() and tmp.stat().st_size == 0  # created first: writability checked
        tmp.write_text("done")
        assert not (tmp_path / "out" / "a.txt").exists()
    assert (tmp_path / "out" / "a.txt").read_text() == "done"
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["a.txt"]


def test_failure_inside_leaves_nothing(tmp_path):
    with pytest.raises(RuntimeError), atomic_path(tmp_path / "a.txt") as tmp:
        tmp.write_text("half")
        raise RuntimeError("interrupted")
    assert list(tmp_path.iterdir()) == []


def test_failure_keeps_the_previous_file(tmp_path):
    (tmp_path / "a.txt").write_text("old")
    with pytest.raises(RuntimeError), atomic_path(tmp_path / "a.txt") as tmp:
        tmp.write_text("new")
        raise RuntimeError
    assert (tmp_path / "a.txt").read_text() == "old" and len(list(tmp_path.iterdir())) == 1


@pytest.mark.parametrize("case", ["folder", "under_a_file", "name_too_long"])
def test_unwritable_targets_are_one_input_error(tmp_path, case):
    (tmp_path / "plain").write_text("x")
    (tmp_path / "dir.txt").mkdir()
    target = {"folder": tmp_path / "dir.txt", "under_a_file": tmp_path / "plain" / "a.txt",
              "name_too_long": tmp_path / ("n" * 300 + ".txt")}[case]
    before = sorted(p.name for p in tmp_path.rglob("*"))
    with pytest.raises(InputError) as info:
        atomic_write_text(target, "x")
    assert "\n" not in str(info.value)
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


def test_a_write_removes_the_temporaries_a_killed_writer_left(tmp_path):
    """``kill -9`` between creating a temporary and renaming it leaves the temporary: the next
    write of the same file removes it, and only its own (other files' are left alone)."""
    from voxelmocap.io._atomic import atomic_write_text, create_temporary

    target = tmp_path / "Walking_1.bvh"
    stale = [create_temporary(target) for _ in range(2)]        # two killed writers
    other = create_temporary(tmp_path / "Walking_1.csv")        # another output's, maybe live
    keep = [tmp_path / ".Walking_1.partial-abc.bvh", tmp_path / ".Walking_1.partial-abcdefghij.trc",
            tmp_path / "Walking_1.partial-abcdefghij.bvh"]
    for p in keep:
        p.write_text("not a temporary of the target")
    atomic_write_text(target, "HIERARCHY\n")
    assert target.read_text() == "HIERARCHY\n"
    assert not any(p.exists() for p in stale)
    assert other.exists() and all(p.exists() for p in keep)
