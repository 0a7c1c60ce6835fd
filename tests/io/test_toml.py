"""The one TOML reader: one-line errors for every bad file, never a traceback."""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from voxelmocap.errors import InputError
from voxelmocap.io.toml import parse_toml, read_toml, write_toml


def test_round_trip_and_byte_order_mark(tmp_path):
    data = {"a": 1, "t": {"x": [1.5, 2.0], "name": "é"}}
    path = tmp_path / "x.toml"
    write_toml(path, data)
    assert read_toml(path) == data
    assert [p.name for p in tmp_path.iterdir()] == ["x.toml"]  # no temporary left
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())  # as Notepad saves UTF-8
    assert read_toml(path) == data


@pytest.mark.parametrize("content, message", [
    (None, "file not found"),
    (b"a = \"caf\xe9\"\n", r"not UTF-8 text \(byte 9 is 0xe9\)"),  # Latin-1 é
    (b"\xff\xfea\x00=\x001\x00", r"not UTF-8 text \(byte 1 is 0xff\)"),  # UTF-16
    (b"a = = 1\n", r"invalid TOML \(.*line 1"),
    (b"[t\n", "invalid TOML"),
    (b"a = " + b"[" * 5000 + b"]" * 5000 + b"\n", "invalid TOML"),
])
def test_bad_files_give_one_line_naming_the_file(tmp_path, content, message):
    path = tmp_path / "bad.toml"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(InputError, match=message) as info:
        read_toml(path)
    text = str(info.value)
    assert text.startswith(f"{path}: ") and "\n" not in text


def test_a_folder_is_not_a_file(tmp_path):
    with pytest.raises(InputError, match="is a folder"):
        read_toml(tmp_path)


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs POSIX permissions")
def test_unreadable_file(tmp_path):
    path = tmp_path / "secret.toml"
    path.write_text("a = 1\n")
    path.chmod(0)
    try:
        with pytest.raises(InputError, match="cannot read"):
            read_toml(path)
    finally:
        path.chmod(0o600)


def test_parse_names_the_source():
    with pytest.raises(InputError, match=r"^stored config: invalid TOML"):
        parse_toml("[x", "stored config")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.one_of(
    st.binary(max_size=200),
    st.sampled_from([b'a = 1\n[t]\nb = "x"\n', b"x = [1, 2]\n", b"[[a]]\nb = 1.5e3\n"]).flatmap(
        lambda valid: st.tuples(st.integers(0, len(valid)), st.binary(max_size=4)).map(
            lambda cut: valid[: cut[0]] + cut[1] + valid[cut[0] + len(cut[1]):]))))
def test_arbitrary_bytes_parse_or_raise_input_error(tmp_path, data):
    path = tmp_path / "fuzz.toml"
    path.write_bytes(data)
    try:
        assert isinstance(read_toml(path), dict)
    except InputError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)
