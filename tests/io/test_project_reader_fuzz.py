"""Property-based fuzzing of the readers issue 36 hardened: every input parses or is refused with
one :class:`~voxelmocap.errors.InputError` line naming the file; nothing else escapes, and no
example allocates more than 2 GB (the address space is capped while each reader runs).

Readers: Qualisys ``.qca.txt``; EasyMocap ``intri.yml`` / ``extri.yml`` (OpenCV FileStorage);
a project's ``Config.toml`` and anipose's ``config.toml`` with its ``cam_regex``; image files of
a numbered folder (headers and integrity); the ``.mat`` size guard; the ``.mp`` subject file;
TRC and CSV references and the mapping TOML; a result's export table.
"""

from __future__ import annotations

import contextlib
import resource
import shutil
import struct
import zlib

import numpy as np
import pytest
from fuzzing import is_one_line_about, mutated, refusal
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from voxelmocap.errors import InputError

FUZZ = settings(max_examples=60, deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])
#: Address space a reader may add while it runs (bytes).
MEMORY_CAP = 2 << 30


@contextlib.contextmanager
def memory_cap():
    """Cap this process's address space at its current size + :data:`MEMORY_CAP` (a reader that
    allocates more gets a MemoryError, which fails the example)."""
    with open("/proc/self/statm") as fh:
        pages = int(fh.read().split()[0])
    used = pages * resource.getpagesize()
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    limit = used + MEMORY_CAP
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def refused_in_one_line(call, path) -> None:
    with memory_cap():
        message = refusal(call)
    assert is_one_line_about(message, path), message


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    """Valid files of every format, as bytes."""
    from humaneva_fixture import RIG_DIR
    from humaneva_mocap_fixture import write_mp
    from project_fixture import qca_rig, write_qca

    from voxelmocap.io.calibration import read_rig
    from voxelmocap.io.easymocap import write_easymocap
    from voxelmocap.io.trc import write_trc

    folder = tmp_path_factory.mktemp("seeds")
    rig = read_rig(RIG_DIR, names=["C1", "C2", "BW1"])
    write_qca(qca_rig(rig), folder / "c.qca.txt")
    write_easymocap(rig, folder)
    write_trc(folder / "r.trc", np.arange(18.0).reshape(3, 2, 3), ["Head", "Hip"],
              frame_rate=60.0)
    import cv2

    image = (np.arange(24 * 32 * 3) % 251).astype(np.uint8).reshape(24, 32, 3)
    encoded = {ext: cv2.imencode(ext, image)[1].tobytes() for ext in (".png", ".jpg", ".bmp")}
    return {"qca": (folder / "c.qca.txt").read_bytes(),
            "intri": (folder / "intri.yml").read_bytes(),
            "extri": (folder / "extri.yml").read_bytes(),
            "trc": (folder / "r.trc").read_bytes(),
            "mp": write_mp(folder / "s.mp").read_bytes(),
            "csv": b"frame,landmark,x_mm,y_mm,z_mm\n1,Head,0,1,2\n2,Head,3,4,5\n",
            "mapping": b'[landmarks]\nhead = "Head"\npelvis = ["Hip", "Head"]\n'
                       b"[reference]\nframe_offset = 0\n",
            "config": b"[project]\nframe_rate = 60\n[calibration.convert.qualisys]\n"
                      b"binning_factor = 1\n",
            "anipose": b"[triangulation]\ncam_regex = '-cam([A-Z])'\n",
            **{ext[1:]: data for ext, data in encoded.items()}}


def test_seeds_are_valid(seeds, tmp_path):
    from voxelmocap.io._image_headers import check_image
    from voxelmocap.io.easymocap import read_easymocap
    from voxelmocap.io.qualisys import read_qca

    (tmp_path / "c.qca.txt").write_bytes(seeds["qca"])
    assert len(read_qca(tmp_path / "c.qca.txt")) == 3
    (tmp_path / "intri.yml").write_bytes(seeds["intri"])
    (tmp_path / "extri.yml").write_bytes(seeds["extri"])
    assert len(read_easymocap(tmp_path / "intri.yml", tmp_path / "extri.yml")[0]) == 3
    for ext in ("png", "jpg", "bmp"):
        (tmp_path / f"a.{ext}").write_bytes(seeds[ext])
        assert check_image(tmp_path / f"a.{ext}") == (32, 24)


@FUZZ
@given(data=st.data())
def test_qca(seeds, tmp_path_factory, data):
    from voxelmocap.io.calibration_files import read_calibration_file

    raw = data.draw(st.one_of(st.binary(max_size=300), mutated(seeds["qca"])))
    path = tmp_path_factory.mktemp("qca") / "c.qca.txt"
    path.write_bytes(raw)
    refused_in_one_line(lambda: read_calibration_file(path), path)


@FUZZ
@given(data=st.data(), which=st.sampled_from(["intri", "extri"]))
def test_easymocap_yaml(seeds, tmp_path_factory, data, which):
    from voxelmocap.io.calibration_files import read_calibration_file

    folder = tmp_path_factory.mktemp("emc")
    for name in ("intri", "extri"):
        (folder / f"{name}.yml").write_bytes(seeds[name])
    raw = data.draw(st.one_of(st.binary(max_size=300), mutated(seeds[which]),
                              st.builds(lambda k: b"a: " + b"[" * k, st.integers(1, 5000))))
    (folder / f"{which}.yml").write_bytes(raw)
    with memory_cap():
        message = refusal(lambda: read_calibration_file(folder / "intri.yml"))
    assert message is None or (message.startswith((str(folder / "intri.yml"),
                                                   str(folder / "extri.yml")))
                               and "\n" not in message), message


@pytest.fixture(scope="module")
def project_template(tmp_path_factory):
    """A Pose2Sim project and an anipose session (videos from the tiny data set)."""
    from bad_project_cases import _anipose, _qca_project
    from humaneva_fixture import make_tiny_dataset

    folder = tmp_path_factory.mktemp("template")
    data = make_tiny_dataset(folder / "data", n_frames=2)
    return _qca_project(data, folder / "p"), _anipose(data, folder / "a", None)


@FUZZ
@given(data=st.data(), kind=st.sampled_from(["config", "anipose"]))
def test_project_configs(seeds, project_template, tmp_path_factory, data, kind):
    from voxelmocap.io.project import Project

    source = project_template[0] if kind == "config" else project_template[1]
    root = tmp_path_factory.mktemp("proj") / "p"
    shutil.copytree(source, root, symlinks=True)
    raw = data.draw(st.one_of(st.binary(max_size=200), mutated(seeds[kind])))
    path = root / ("Config.toml" if kind == "config" else "config.toml")
    path.write_bytes(raw)

    def call():
        project = Project(root)
        for trial in project.trials.values():
            project.calibration(trial)
        project.frame_rate_setting()

    refused_in_one_line(call, path)


@FUZZ
@given(pattern=st.one_of(st.text(max_size=30),
                         st.text(alphabet="()+*?|[]{}^$.\\aA-1,", max_size=16)),
       name=st.text(alphabet="aAb-cm_1", min_size=0, max_size=60))
def test_cam_regex(pattern, name):
    # A pattern is refused, or it matches any file name without blowing up.
    from voxelmocap.io._regex import bounded_search, user_regex

    try:
        regex = user_regex(pattern, "config.toml")
    except InputError as exc:
        assert str(exc).startswith("config.toml: ") and "\n" not in str(exc)
        return
    try:
        bounded_search(regex, name, "config.toml")
    except InputError as exc:  # the time limit: acceptable, as one line
        assert str(exc).startswith("config.toml: ")


@FUZZ
@given(data=st.data(), ext=st.sampled_from(["png", "jpg", "bmp"]))
def test_image_files(seeds, tmp_path_factory, data, ext):
    from voxelmocap.io._image_headers import check_image
    from voxelmocap.io.video import VideoStream

    folder = tmp_path_factory.mktemp("img") / "cam"
    folder.mkdir()
    raw = data.draw(st.one_of(st.binary(max_size=300), mutated(seeds[ext]),
                              st.builds(_png_declaring, st.integers(0, 2**32 - 1),
                                        st.integers(0, 2**32 - 1))))
    path = folder / f"frame_000001.{ext}"
    path.write_bytes(raw)

    def call():
        if check_image(path) is not None:  # whole and sized: the decoder must agree
            stream = VideoStream(folder, gray=False)
            stream.frame_size()
            list(stream.read([0]))

    refused_in_one_line(call, path)


def _png_declaring(w: int, h: int) -> bytes:
    import zlib

    body = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    chunk = b"IHDR" + body
    end = b"IEND"
    return (b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + chunk
            + struct.pack(">I", zlib.crc32(chunk)) + struct.pack(">I", 0) + end
            + struct.pack(">I", zlib.crc32(end)))


@pytest.fixture(scope="module")
def mat_bombs(tmp_path_factory):
    """``.mat`` files whose compressed ``Markers`` declare 240 B, 300 MB and 1.46 GB (holding
    1 MB of them: the declaration is what is checked; the bad-input table has the whole bomb)."""
    from bad_project_cases import write_mat_bomb

    folder = tmp_path_factory.mktemp("bombs")
    return [write_mat_bomb(folder / f"{n}.mat", declared=n, whole=False).read_bytes()
            for n in (24 * 10, 300 << 20, 1_460_000_000)]


@FUZZ
@given(data=st.data())
def test_mat_guard(mat_bombs, tmp_path_factory, data):
    """Forged ``.mat`` sizes (the issue's 1.46 GB bomb among them, and mutations) are refused
    before SciPy allocates them."""
    from voxelmocap.io.humaneva_mocap import read_mocap_mat

    seed = data.draw(st.sampled_from(mat_bombs))
    raw = data.draw(st.one_of(st.just(seed), mutated(seed)))
    path = tmp_path_factory.mktemp("mat") / "x.mat"
    path.write_bytes(raw)
    refused_in_one_line(lambda: read_mocap_mat(path, need_labels=False), path)


@FUZZ
@given(data=st.data(), kind=st.sampled_from(["trc", "csv", "mapping", "mp"]))
def test_reference_and_subject_files(seeds, tmp_path_factory, data, kind):
    from voxelmocap.io.humaneva_mocap import read_mp
    from voxelmocap.io.reference import read_mapping, read_reference

    raw = data.draw(st.one_of(st.binary(max_size=200), mutated(seeds[kind])))
    name = {"trc": "r.trc", "csv": "r.csv", "mapping": "m.toml", "mp": "s.mp"}[kind]
    path = tmp_path_factory.mktemp(kind) / name
    path.write_bytes(raw)
    reader = {"trc": read_reference, "csv": read_reference, "mapping": read_mapping,
              "mp": read_mp}[kind]
    refused_in_one_line(lambda: reader(path), path)


@FUZZ
@given(frames=st.lists(st.integers(-2**63, 2**63 - 1), min_size=1, max_size=4, unique=True),
       rate=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=5),
                      st.integers(-2**70, 2**70)),
       names=st.integers(0, 20))
def test_export_table(frames, rate, names):
    """A result's frame numbers, frame rate and landmark names, as a damaged file may hold
    them: the export table is built or refused in one line, never allocated from them."""
    from voxelmocap.io.exports import landmark_table
    from voxelmocap.io.results import TrackResult

    n = len(frames)
    rng = np.random.default_rng(0)
    result = TrackResult(
        frames=np.sort(np.array(frames, dtype=np.int64)), state=rng.normal(size=(n, 27)),
        landmarks=rng.normal(size=(n, 15, 3)), endpoints=rng.normal(size=(n, 20, 3)),
        part_scores=rng.random((n, 10, 4)), ess=rng.random((n, 2)), betas=rng.random((n, 2)),
        seconds=rng.random(n), log_likelihood=rng.normal(size=n),
        map_state=rng.normal(size=(n, 27)),
        attrs={"frame_rate": rate, "landmark_names": [f"l{i}" for i in range(names)] or None})
    refused_in_one_line(lambda: landmark_table(result, source="r.h5"), "r.h5")


def test_mat_guard_stops_at_the_end_of_a_compressed_stream(tmp_path):
    """A compressed variable whose zlib stream ends before its element does (trailing bytes) is
    read to the stream's end, not looped on: zlib keeps the trailing bytes as an unconsumed tail
    that no further call consumes (a CI run hung on such a draw)."""
    from voxelmocap.io._mat_guard import check_mat_sizes

    inner = zlib.compress(b"\x0e\x00\x00\x00" + b"\x00" * 5)  # inflates past the 8-byte head
    assert zlib.decompress(inner)  # a valid stream: the trailing bytes are the only damage
    body = inner + b"trailing"
    header = b"MATLAB 5.0 MAT-file".ljust(124, b" ") + b"\x00\x01IM"
    path = tmp_path / "x.mat"
    path.write_bytes(header + struct.pack("<II", 15, len(body)) + body)

    check_mat_sizes(path)  # returns: the layout is left to SciPy's reader, which refuses it
    from voxelmocap.io.humaneva_mocap import read_mocap_mat
    refused_in_one_line(lambda: read_mocap_mat(path, need_labels=False), path)
