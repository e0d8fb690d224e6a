"""`simgap NAME` imports only NAME's module: the map from command names to modules is whole, and a
command registered alone is still called by its name."""

from __future__ import annotations

import subprocess
import sys

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
