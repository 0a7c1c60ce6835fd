"""``io._outputs``: an output place is accepted exactly when the write it stands for succeeds.

Each case is checked against the write itself, attempted after the check: ``os.makedirs`` for a
folder, a temporary sibling renamed into place for a file (as ``io._atomic`` writes). The check
must leave nothing behind.
"""

import os

import pytest

from voxelmocap.errors import InputError
from voxelmocap.io._outputs import check_output_dir, check_output_file


def _layout(tmp_path):
    (tmp_path / "dir").mkdir()
    (tmp_path / "file.txt").write_text("x")
    (tmp_path / "dir" / "inner").mkdir()
    return tmp_path


FOLDERS = ["dir", "dir/inner", "dir/new", "dir/new/deeper", "file.txt", "file.txt/below",
           "file.txt/below/deeper", "new"]
FILES = ["dir/out.json", "dir/new/out.json", "dir", "dir/inner", "file.txt", "file.txt/out.json",
         "file.txt/a/out.json", "new/out.json", "out.json"]


def _can_make_folder(path):
    try:
        os.makedirs(path, exist_ok=True)
    except OSError:
        return False
    return True


def _can_write_file(path):
    if path.is_dir() or not _can_make_folder(path.parent):
        return False
    temp = path.with_name(f".{path.name}.partial")
    try:
        temp.write_text("{}")
        os.replace(temp, path)
    except OSError:
        return False
    return True


@pytest.mark.parametrize("name", FOLDERS)
def test_an_output_folder_is_accepted_exactly_when_it_can_be_made(tmp_path, name):
    root = _layout(tmp_path)
    before = sorted(p.relative_to(root) for p in root.rglob("*"))
    path = root / name
    try:
        assert check_output_dir(path) == path
        accepted = True
    except InputError as exc:
        accepted = False
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)
    assert sorted(p.relative_to(root) for p in root.rglob("*")) == before   # nothing made
    assert accepted == _can_make_folder(path)


@pytest.mark.parametrize("name", FILES)
def test_an_output_file_is_accepted_exactly_when_it_can_be_written(tmp_path, name):
    root = _layout(tmp_path)
    before = sorted(p.relative_to(root) for p in root.rglob("*"))
    path = root / name
    try:
        assert check_output_file(path) == path
        accepted = True
    except InputError as exc:
        accepted = False
        # the file, or the folder it would go in when that folder cannot be made
        assert str(exc).startswith((f"{path}: ", f"{path.parent}: ")) and "\n" not in str(exc)
    assert sorted(p.relative_to(root) for p in root.rglob("*")) == before
    assert accepted == _can_write_file(path)


@pytest.mark.parametrize("check, name, problem", [
    (check_output_dir, "file.txt", "exists and is not a folder"),
    (check_output_dir, "file.txt/below/deeper", "cannot create the output folder: {root}/file.txt "
                                                "is a file, not a folder"),
    (check_output_file, "dir", "is a folder; give a file name"),
    (check_output_file, "file.txt/out.json", "{root}/file.txt is a file, not a folder"),
    (check_output_file, "file.txt/a/out.json", "cannot create the output folder: {root}/file.txt "
                                               "is a file, not a folder"),
])
def test_the_refusals_say_why(tmp_path, check, name, problem):
    root = _layout(tmp_path)
    with pytest.raises(InputError) as info:
        check(root / name)
    assert info.value.problem == problem.format(root=root)


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_folder_is_refused(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        with pytest.raises(InputError, match="output folder is not writable"):
            check_output_dir(locked)
        with pytest.raises(InputError, match="is not writable"):
            check_output_dir(locked / "new")
        with pytest.raises(InputError, match="cannot write here"):
            check_output_file(locked / "out.json")
    finally:
        locked.chmod(0o700)
