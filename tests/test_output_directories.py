"""Where a command writes: an --out that cannot become a directory simgap writes in is refused in
one line, naming it, before any work."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from simgap.errors import InputError
from simgap.files import writable_directory


@pytest.fixture()
def unwritable_folder(tmp_path):
    """A folder this process may not write in (root writes anywhere but in sysfs)."""
    if os.geteuid() != 0:
        folder = tmp_path / "read-only"
        folder.mkdir()
        folder.chmod(0o555)
        yield folder
        folder.chmod(0o755)
    elif os.access("/sys", os.F_OK) and Path("/sys").is_dir():
        yield Path("/sys")
    else:
        pytest.skip("no folder this process cannot write in")


def test_a_new_or_existing_writable_folder_passes(tmp_path):
    assert writable_directory(tmp_path / "new" / "deeper") == tmp_path / "new" / "deeper"
    assert writable_directory(tmp_path) == tmp_path
    assert writable_directory(None) is None


@pytest.mark.parametrize("out, reason", [
    ("notes.txt", "is a file"),
    ("notes.txt/run", "lies inside the file"),
    ("d" * 300, "a name in it is 300 bytes long"),
    ("new/" + "é" * 120, "a name in it is 240 bytes long"),      # within 255 bytes, not with a temporary name's room
])
def test_an_out_that_cannot_become_a_directory_is_refused(tmp_path, out, reason):
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(InputError) as err:
        writable_directory(tmp_path / out)
    assert err.value.file == str(tmp_path / out) and reason in err.value.reason
    assert (tmp_path / "notes.txt").read_text() == "mine" and not (tmp_path / "new").exists()


def test_a_folder_that_cannot_be_written_is_refused(unwritable_folder):
    with pytest.raises(InputError, match="cannot be written"):
        writable_directory(unwritable_folder / "run")
