"""`simgap vehicles`: the vehicle catalogue, and one vehicle in full."""

from __future__ import annotations

import math

import typer
import yaml
from rich.markup import escape
from rich.table import Table

from simgap.cli.console import output_console
from simgap.cli.main import app
from simgap.vehicles import load_vehicle, vehicle_names
from simgap.vehicles.channels import CHANNELS, in_words
from simgap.vehicles.constants import GRAVITY

LONG_TEXT = 40      # characters: a longer text field is printed under the table

vehicles_app = typer.Typer(help="The vehicle catalogue (one data file per vehicle).", no_args_is_help=False,
                           invoke_without_command=True)
app.add_typer(vehicles_app, name="vehicles")


@vehicles_app.callback()
def catalogue(ctx: typer.Context) -> None:
    """List the catalogue with each vehicle's key parameters.

    Example: simgap vehicles; simgap vehicles show suv
    """
    if ctx.invoked_subcommand is not None:
        return
    table = Table(title="vehicle catalogue", title_justify="left")
    for col in ("name", "L x W [m]", "wheelbase [m]", "mass [kg]", "CoG [m]", "drive", "power [kW]",
                "peak mu", "understeer [deg/g]", "steer [deg]"):
        table.add_column(escape(col), justify="left" if col in ("name", "drive") else "right")
    descriptions = []
    for name in vehicle_names():
        v = load_vehicle(name)
        p = v.physics
        descriptions.append(f"{name}: {v.description}")
        size = (f"{v.length:.2f}x{v.width:.2f}", f"{v.wheelbase:.2f}")
        if p is None:
            table.add_row(name, *size, *["—"] * 7)
            continue
        table.add_row(name, *size, f"{p.mass:.0f}", f"{p.cg_height:.2f}", p.driven_axles,
                      f"{p.max_power / 1000:.0f}", f"{p.tyre_friction:.2f}",
                      f"{round(math.degrees(p.understeer_gradient(v.wheelbase, v.rear_axle_to_center) * GRAVITY), 2) + 0.0:.2f}",
                      f"{math.degrees(p.steering.max_angle):.0f}")
    console = output_console()
    console.print(table)
    console.print("\n".join(escape(d) for d in descriptions))
    console.print("data files: src/simgap/vehicles/data/NAME.yaml (units: SI); "
                    "`simgap vehicles show NAME` prints one")


@vehicles_app.command()
def show(name: str = typer.Argument(..., help="catalogue name or path of a vehicle data file"),
         as_yaml: bool | None = typer.Option(False, "--yaml", help="print the data file's content as YAML")) -> None:
    """Print one vehicle: every parameter with its unit and source, its actuators' dead times and
    lags among them (the steering's angle and rate limits are physics.steering's).

    Example: simgap vehicles show sedan
    """
    v = load_vehicle(name)
    console = output_console()
    if as_yaml:
        console.print(yaml.safe_dump(v.model_dump(), sort_keys=False), end="", markup=False, highlight=False)
        return
    console.print(f"[bold]{v.name}[/bold] — {v.description}")
    if v.source:
        console.print(f"source: {escape(v.source)}")
    table = Table(show_header=True)
    table.add_column("parameter")
    table.add_column("value", justify="right")
    table.add_column("meaning")
    for field_name in ("length", "width", "wheelbase", "rear_axle_to_center"):
        table.add_row(field_name, f"{getattr(v, field_name):g}", escape(type(v).model_fields[field_name].description or ""))
    for field_name, info in type(v.limits).model_fields.items():
        table.add_row(f"limits.{field_name}", f"{getattr(v.limits, field_name):g}", escape(info.description or ""))
    notes: list[str] = []
    if v.physics is not None:
        _add_model_rows(table, "physics", v.physics, notes)
    if v.actuators is not None:
        for channel, numbers in v.actuators.items():
            _add_model_rows(table, f"actuators.{channel.section}", numbers, notes)
    else:
        notes.append(f"actuators: none in the data file: {in_words(CHANNELS.values())} act at once")
    for controller, gains in v.controllers.items():
        table.add_row(f"controllers.{controller}", str(gains), "gains overriding the defaults")
    console.print(table)
    for note in notes:
        console.print(escape(note))


def _add_model_rows(table: Table, prefix: str, model, notes: list[str]) -> None:
    """One row per field of a (nested) data model: dotted name, value, meaning; long texts (a
    source) go to ``notes``, printed under the table."""
    for field_name, info in type(model).model_fields.items():
        value = getattr(model, field_name)
        name = f"{prefix}.{field_name}"
        if hasattr(value, "model_fields"):
            _add_model_rows(table, name, value, notes)
        elif isinstance(value, str) and len(value) > LONG_TEXT:
            notes.append(f"{name}: {value}")
        else:
            shown = "—" if value is None else value if isinstance(value, str) else f"{value:g}"
            table.add_row(name, escape(shown), escape(info.description or ""))
