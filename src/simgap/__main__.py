"""`python -m simgap` is the `simgap` command."""

from simgap.cli.main import main

main()
