"""Logging of the command line: -q / -v, the run folder's voxelmocap.log, tqdm, bad input."""

import logging
import re
import sys

import pytest
from tqdm import tqdm

from voxelmocap import logs
from voxelmocap.cli import main

#: A quick track of the shared walk: 2 frames, 1 layer × 20 particles, 40 mm voxels.
QUICK = ["--frames", "1:2", "--layers", "1", "--particles", "20", "--voxel-size", "40",
         "--no-progress"]


def _track(data, out, *extra):
    return ["track", str(data), "--subject", "S1", "--sequence", "Walking_1", "--out", str(out),
            *QUICK, *extra]


def test_quiet_verbose_and_the_log_file(walk_dataset, tmp_path, capsys):
    run = tmp_path / "run"
    # default: INFO on stdout, no DEBUG
    assert main(_track(walk_dataset, run)) == 0
    out = capsys.readouterr().out
    assert "initialised from the ground truth of frame 1" in out
    assert f"results: {run / 'S1' / 'Walking_1.h5'}" in out
    # the closing line's rate is the whole command's (what the user waited), beside the last
    # pass's frame loop
    closing = re.search(r"tracked 2 frames of 1–2 in (?:(\d+) min )?([0-9.]+) s: ([0-9.]+) "
                        r"frames/s for the whole command \(the last pass's frame loop "
                        r"([0-9.]+) frames/s\)", out)
    assert closing, out
    wall = 60 * int(closing[1] or 0) + float(closing[2])
    # the printed wall is rounded (to 0.1 s under a minute, else to 1 s): the rate must lie
    # within what the rounded wall allows, the rate's own rounding (0.005) added
    half = 0.5 if closing[1] else 0.05
    rate = float(closing[3])
    assert rate >= 2 / (wall + half) - 0.005, out
    assert wall <= half or rate <= 2 / (wall - half) + 0.005, out
    assert "seed 0, frame rate" not in out
    # -q before the subcommand: nothing at INFO (the run is complete: it says so at INFO)
    assert main(["-q", *_track(walk_dataset, run, "--resume")]) == 0
    assert capsys.readouterr().out == ""
    # -v after the subcommand: the DEBUG lines too
    assert main([*_track(walk_dataset, run, "--overwrite"), "-v"]) == 0
    out = capsys.readouterr().out
    assert f"result {run / 'S1' / 'Walking_1.h5'}, frames 1,2, seed 0, frame rate 60 Hz" in out
    assert "initialised from the ground truth of frame 1" in out

    text = (run / logs.LOG_NAME).read_text()
    lines = text.splitlines()
    starts = [line for line in lines if " START " in line]
    # one block per command, appended, each headed by its command line
    assert len(starts) == 3
    assert "voxelmocap track " + str(walk_dataset) in starts[0]
    assert starts[1].split("START   ")[1].startswith("voxelmocap -q track ")
    assert " --overwrite -v " in starts[2] + " "
    stamp = re.compile(r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3} ")
    assert all(stamp.match(line) for line in lines), lines
    # the file holds every level, whatever the console showed: the quiet run's INFO line too
    assert any("INFO    voxelmocap.run.pipeline:" in line and "is already complete" in line
               for line in lines)
    assert sum("initialised from the ground truth of frame 1" in line for line in lines) == 2
    assert any("DEBUG   voxelmocap.run.frame_loop: result " in line for line in lines)
    assert any("voxelmocap.commands.track: results: " in line for line in lines)


def test_bad_input_stays_one_line_and_writes_no_log(walk_dataset, tmp_path, capsys):
    run = tmp_path / "run"
    for argv in (["-v", *_track(walk_dataset, run, "--cameras", "C1,C9")],
                 [*_track(walk_dataset, run, "--cameras", "C1,C9"), "-q"]):
        assert main(argv) == 2
        captured = capsys.readouterr()
        lines = captured.err.strip().splitlines()
        assert lines == ["voxelmocap track: error: --cameras: unknown camera 'C9' (S1/Walking_1 "
                         "has C1, C2, C3, BW1)"]
        assert captured.out == ""
    assert not run.exists()  # refused before the run began: no folder, no log file


def test_the_log_is_held_until_the_run_starts(tmp_path):
    logs.configure(0, log_dir=tmp_path / "run", argv=["track", "x"])
    try:
        logging.getLogger("voxelmocap.run.pipeline").info("before")
        assert not (tmp_path / "run").exists()
        logs.run_started()
        path = tmp_path / "run" / logs.LOG_NAME
        assert "before" in path.read_text()
        logging.getLogger("voxelmocap.run.pipeline").info("after")
        assert path.read_text().splitlines()[-1].endswith("voxelmocap.run.pipeline: after")
    finally:
        logs.finish(False)
    # finished: the package logger is silent again and the file is closed
    assert not any(isinstance(h, logs.RunLogHandler) for h in logs.PACKAGE.handlers)
    logs.configure(0, log_dir=tmp_path / "other", argv=["track", "y"])
    logging.getLogger("voxelmocap.run.pipeline").info("dropped")
    logs.finish(False)  # never started, failed: nothing written
    assert not (tmp_path / "other").exists()


def test_messages_do_not_break_a_progress_bar(capsys):
    logs.configure(0)
    try:
        with tqdm(total=3, file=sys.stdout, ascii=True) as bar:
            bar.update(1)
            logging.getLogger("voxelmocap.run.pipeline").info("hello")
            logging.getLogger("voxelmocap.run.pipeline").warning("careful")
            bar.update(1)
    finally:
        logs.finish(True)
    # The bar's line is cleared before each message, which then stands alone on its line (a
    # plain print would append it to the bar's text: "…1/3 [00:00<…]hello").
    pieces = re.split(r"[\r\n]", capsys.readouterr().out)
    assert "hello" in pieces and "warning: careful" in pieces


@pytest.mark.parametrize("verbosity, shown", [(-1, ["w"]), (0, ["i", "w"]), (1, ["d", "i", "w"])])
def test_verbosity_levels(verbosity, shown, capsys):
    logs.configure(verbosity)
    try:
        log = logging.getLogger("voxelmocap.anything")
        log.debug("d")
        log.info("i")
        log.warning("w")
    finally:
        logs.finish(True)
    out = capsys.readouterr().out.splitlines()
    assert out == [("warning: " if s == "w" else "") + s for s in shown]
    # unconfigured, the package is silent (a library must not print)
    logging.getLogger("voxelmocap.anything").warning("nobody sees this")
    assert capsys.readouterr() == ("", "")


class _Terminal:
    """A stand-in for a terminal on standard error: collects what is written, says it is a TTY."""

    def __init__(self):
        self.text = ""

    def write(self, text):
        self.text += text
        return len(text)

    def flush(self):
        pass

    def isatty(self):
        return True


def test_progress_bars_only_on_a_terminal(walk_dataset, tmp_path, capsys, monkeypatch):
    track = _track(walk_dataset, tmp_path / "run")
    track.remove("--no-progress")
    # under pytest's capture standard error is no terminal: no bar, though none was refused
    assert not logs.progress_to_terminal()
    assert main(track) == 0
    captured = capsys.readouterr()
    assert "frame/s" not in captured.err + captured.out and "\r" not in captured.err, captured.err
    assert "initialised from the ground truth of frame 1" in captured.out
    # on a terminal, the bar is drawn (on standard error), unless --no-progress
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert logs.progress_to_terminal()
    assert main([*track, "--overwrite"]) == 0
    assert "2/2" in terminal.text and "frame" in terminal.text, terminal.text
    terminal.text = ""
    assert main([*track, "--overwrite", "--no-progress"]) == 0
    assert terminal.text == ""
    assert not logs.progress_to_terminal(object())  # no isatty: not a terminal


def test_the_closing_line_of_a_complete_result_says_nothing_was_tracked(walk_dataset, tmp_path,
                                                                        capsys):
    run = tmp_path / "run"
    assert main(_track(walk_dataset, run)) == 0
    capsys.readouterr()
    assert main(_track(walk_dataset, run, "--resume")) == 0
    out = capsys.readouterr().out
    assert re.search(r"nothing to track: the result of frames 1–2 was complete \([0-9.]+ s\)",
                     out), out
    assert "frames/s" not in out


@pytest.mark.parametrize(("seconds", "text"), [
    (0.04, "0.0 s"), (42.26, "42.3 s"), (59.94, "59.9 s"), (59.96, "1 min 0 s"),
    (60.0, "1 min 0 s"),
    (725.4, "12 min 5 s"), (3599.4, "59 min 59 s"), (3600.0, "1 h 0 min"),
    (3 * 3600 + 7 * 60 + 29, "3 h 7 min"),
])
def test_duration_reads_as_a_person_would(seconds, text):
    assert logs.duration(seconds) == text
