"""The `simgap` command. It only wires the other packages together."""
