"""`simgap NAME` imports only NAME's module: the map from command names to modules is whole, and a
command registered alone is still called by its name; a machine that fails the command (a full
disk) or a bug is one line, not a traceback, and exit 3."""

from __future__ import annotations

import errno
import os
import subprocess
import sys

import pytest
from typer.main import get_command

from simgap.cli.main import COMMANDS, _register, app


def test_every_registered_command_is_in_the_map():
    _register([])                                   # no command named: every module
    assert set(get_command(app).commands) == set(COMMANDS)


def test_a_command_registered_alone_is_still_called_by_its_name_and_help_lists_every_command():
    alone = subprocess.run([sys.executable, "-m", "simgap", "run", "--help"], capture_output=True, text=True,
                           timeout=120)
    assert alone.returncode == 0 and "simgap run [OPTIONS] {scenario}" in " ".join(alone.stdout.split()), alone.stdout
    loaded = subprocess.run([sys.executable, "-c", "import sys; sys.argv = ['simgap', 'vehicles']; "
                             "from simgap.cli.main import main\ntry:\n main()\nexcept SystemExit: pass\n"
                             "print(sorted(m for m in sys.modules if m.startswith('simgap.cli.')))"],
                            capture_output=True, text=True, timeout=120)
    assert "'simgap.cli.run'" not in loaded.stdout and "'simgap.cli.vehicles'" in loaded.stdout
    helped = subprocess.run([sys.executable, "-m", "simgap", "--help"], capture_output=True, text=True, timeout=120)
    assert all(name in helped.stdout for name in COMMANDS)
    unknown = subprocess.run([sys.executable, "-m", "simgap", "nosuch"], capture_output=True, text=True, timeout=120)
    assert unknown.returncode == 2 and "No such command" in unknown.stderr and "Traceback" not in unknown.stderr


@pytest.mark.parametrize("code, words", [(errno.ENOSPC, "no space left on the device"),
                                         (errno.EROFS, "the file system is read-only")])
def test_a_full_disk_is_one_line_and_exit_3(monkeypatch, capsys, code, words):
    from simgap.cli import main as entry

    def full(*args, **kwargs):
        raise OSError(code, os.strerror(code), "/runs/r1/run.json")

    monkeypatch.setattr(entry, "app", full)
    monkeypatch.setattr(entry, "_register", lambda argv: None)
    with pytest.raises(SystemExit) as ended:
        entry.main()
    assert ended.value.code == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err and "/runs/r1/run.json" in err and "Traceback" not in err


@pytest.mark.parametrize("error", [OSError(errno.EIO, "I/O error"), KeyError("lanelet 7")])
def test_an_unexpected_error_is_one_line_exit_3_and_its_traceback_in_a_file(monkeypatch, capsys, tmp_path, error):
    from simgap.cli import main as entry

    def broken(*args, **kwargs):
        raise error

    monkeypatch.setattr(entry, "app", broken)
    monkeypatch.setattr(entry, "_register", lambda argv: None)
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    monkeypatch.setattr("tempfile.tempdir", None)          # TMPDIR is read again
    with pytest.raises(SystemExit) as ended:
        entry.main()
    assert ended.value.code == 3
    err = capsys.readouterr().err
    (written,) = tmp_path.glob("simgap-traceback-*.txt")
    assert err.count("\n") == 1 and f"internal error: {type(error).__name__}" in err and str(written) in err
    assert "Traceback" not in err and "Traceback (most recent call last)" in written.read_text()
    assert "in broken" in written.read_text()
