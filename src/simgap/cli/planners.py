"""`simgap planners`: the planners simgap can run (built-in and installed), and one in full."""

from __future__ import annotations

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from simgap.cli.console import output_console
from simgap.cli.main import app
from simgap.planning.registry import (
    ENTRY_POINT_GROUP,
    PLANNERS,
    REQUIRED,
    PlannerClass,
    load_planner,
    planner_names,
    settings_fields,
)

planners_app = typer.Typer(help="The planners: built-in, installed (entry points) and your own classes.",
                           invoke_without_command=True)
app.add_typer(planners_app, name="planners")


@planners_app.callback()
def listing(ctx: typer.Context) -> None:
    """List the built-in and installed planners with their settings.

    Example: simgap planners; simgap planners show frenet; simgap planners show my_planner.py:MyPlanner
    """
    if ctx.invoked_subcommand is not None:
        return
    table = Table(title="planners", title_justify="left")
    for col in ("name", "origin", "class", "settings"):
        table.add_column(col, justify="right" if col == "settings" else "left")
    descriptions = []
    for name in planner_names():
        target = PLANNERS.target(name)
        try:
            planner = load_planner(name)
        except Exception as exc:        # a broken installed package: listed, with why it cannot be used
            table.add_row(escape(name), "installed", escape(target), "—")
            descriptions.append(f"[red]{escape(name)}: {escape(str(exc))}[/red]")
            continue
        model = planner.settings_model
        table.add_row(escape(name), escape(planner.origin), escape(target),
                      str(len(settings_fields(model))) if model else "none")
        descriptions.append(f"{escape(name)}: {escape(planner.description)}")
    console = output_console()
    console.print(table)
    console.print("\n".join(descriptions))
    console.print(f"installed planners: packages declaring the entry-point group '{ENTRY_POINT_GROUP}'; any class "
                  "also runs by reference (--planner my_pkg.module:Class or path/to/file.py:Class), and in a "
                  "process of its own with --isolate; a planner in any language runs over the planner protocol "
                  "(--planner 'exec:COMMAND ARGS' or tcp://HOST:PORT; planner-protocol/README.md); "
                  "`simgap planners show NAME` prints a planner's settings")


@planners_app.command()
def show(ref: str = typer.Argument(..., help="planner name, module:Class or path/to/file.py:Class")) -> None:
    """Print one planner: where it comes from and every setting with its default and meaning.

    Example: simgap planners show frenet
    """
    planner = load_planner(ref)
    console = output_console()
    console.print(f"[bold]{escape(ref)}[/bold] — {escape(planner.origin)}: "
                  f"{escape(planner.cls.__module__)}.{escape(planner.cls.__qualname__)}")
    if planner.description:
        console.print(escape(planner.description))
    _settings_table(console, planner)


def _settings_table(console: Console, planner: PlannerClass) -> None:
    model = planner.settings_model
    if model is None:
        console.print("no settings model: the settings given reach its planners unchecked, in setup.settings")
        return
    table = Table(title=f"settings ({model.__name__}; --planner-config FILE, or settings: in a spec)",
                  title_justify="left")
    for col in ("setting", "default", "meaning"):
        table.add_column(col, justify="right" if col == "default" else "left", no_wrap=col == "setting")
    for f in settings_fields(model):
        default = f.default if f.default == REQUIRED else "null" if f.default is None else \
            str(f.default).lower() if isinstance(f.default, bool) else f"{f.default:g}" \
            if isinstance(f.default, float) else str(f.default)
        table.add_row(escape(f.name), escape(default), escape(f.description))
    console.print(table)
