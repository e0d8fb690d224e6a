"""YAML inputs: a key given twice and an alias (the way to a memory bomb) are refused in one line
naming the file and the line, before anything is built from them."""

from __future__ import annotations

import time

import pytest

from simgap.errors import InputError
from simgap.files import read_yaml_mapping


def test_a_key_given_twice_is_refused_naming_both_lines(tmp_path):
    path = tmp_path / "spec.yaml"
    path.write_text("name: a\nlogical: curve\nsampler: {kind: grid}\nname: b\n")
    with pytest.raises(InputError) as err:
        read_yaml_mapping(path, "spec")
    assert err.value.file == str(path)
    assert err.value.reason == "malformed YAML at line 4, column 1: the key 'name' is given twice (first on line 1)"


def test_a_key_given_twice_in_a_nested_mapping_is_refused(tmp_path):
    path = tmp_path / "spec.yaml"
    path.write_text("fidelities:\n  - {backend: ideal, backend: mujoco}\n")
    with pytest.raises(InputError, match="line 2, .*'backend' is given twice"):
        read_yaml_mapping(path, "spec")


def test_an_alias_bomb_is_refused_at_once(tmp_path):
    levels = ["a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    levels += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 12)]   # 9^12 strings
    path = tmp_path / "bomb.yaml"
    path.write_text("\n".join(levels) + "\n")
    start = time.monotonic()
    with pytest.raises(InputError) as err:
        read_yaml_mapping(path, "spec")
    assert time.monotonic() - start < 1.0
    assert err.value.reason.startswith("malformed YAML at line 2, column 10: the alias *a0")


def test_a_plain_mapping_reads_as_before(tmp_path):
    path = tmp_path / "spec.yaml"
    path.write_text("name: a\nparameters: {radius: {values: [10, 20]}}\n1: one\n")
    assert read_yaml_mapping(path, "spec") == {"name": "a", "parameters": {"radius": {"values": [10, 20]}}, 1: "one"}
