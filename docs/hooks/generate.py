"""Reference pages generated from the code when the site is built (a mkdocs hook).

A page asks for a generated table with an HTML comment on a line of its own:

- ``<!-- gen:cli -->``: every `simgap` command with its arguments and options (from typer);
- ``<!-- gen:settings module:Model -->``: every field of a pydantic settings model, nested models
  flattened to dotted names (type, default, range, unit, description);
- ``<!-- gen:backends -->``: each backend's settings model;
- ``<!-- gen:knobs -->``, ``<!-- gen:sensing -->``: the reality knobs and the sensing profiles;
- ``<!-- gen:actuators -->``: the actuator channels (a vehicle file's ``actuators`` subsections);
- ``<!-- gen:planner_sdk -->``: every field of every type a planner sees (the planner SDK's,
  `simgap_planner`, and simgap's in-process type of the same field names);
- ``<!-- gen:include PATH -->``: a Markdown file of the repository (PATH from its root) as it is, the
  files it links beside it appended as code blocks (the planner protocol's specification and its
  ``.proto``), so the text lives once, where its code is.

Nothing in these tables is typed by hand, so a default documented here is the code's default.
"""

from __future__ import annotations

import enum
import importlib
import importlib.util
import re
import types
import typing
import warnings
from pathlib import Path
from typing import Any

from pydantic import BaseModel, RootModel
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

# the libraries simgap imports (protobuf through commonroad-io) warn of their own deprecations
warnings.filterwarnings("ignore", category=DeprecationWarning)

MARKER = re.compile(r"^<!-- gen:(\w+)(?: ([\w.:,/-]+))? -->$", re.M)
ROOT = Path(__file__).resolve().parents[2]
LINK = re.compile(r"\]\(([\w.-]+)\)")          # a link to a file beside the linking one
LEXERS = {".proto": "protobuf", ".py": "python", ".toml": "toml", ".yaml": "yaml"}
UNIT = re.compile(r"\[([^\]]*[A-Za-z%^°][^\]]*)\]")


def _cell(text: Any) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _code(value: Any) -> str:
    return "`" + str(value).replace("`", "'") + "`" if str(value) != "" else ""


# --- settings models ----------------------------------------------------------------------------

def _type_name(annotation: Any) -> str:
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _type_name(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_type_name(a) for a in typing.get_args(annotation))
    if origin is typing.Literal:
        return " or ".join(repr(a) for a in typing.get_args(annotation))
    if origin is not None:
        args = ", ".join(_type_name(a) for a in typing.get_args(annotation))
        return f"{getattr(origin, '__name__', str(origin))}[{args}]"
    if annotation is type(None):
        return "null"
    if isinstance(annotation, type) and issubclass(annotation, enum.Enum):
        return " or ".join(repr(m.value) for m in annotation)
    return getattr(annotation, "__name__", str(annotation))


def default_of(field: FieldInfo) -> Any:
    """The field's default as the code gives it (PydanticUndefined: required)."""
    if field.default_factory is not None:
        return field.default_factory()
    return field.default


def default_text(field: FieldInfo) -> str:
    value = default_of(field)
    if value is PydanticUndefined:
        return "required"
    if isinstance(value, enum.Enum):
        value = value.value
    if value is None:
        return "`null`"
    if isinstance(value, BaseModel):
        return "see below"
    return _code(value)


def _bounds(field: FieldInfo) -> list[Any]:
    metadata = list(field.metadata)
    for arg in typing.get_args(field.annotation):
        for info in getattr(arg, "__metadata__", ()):
            metadata += getattr(info, "metadata", [info])
    return metadata


def range_text(field: FieldInfo) -> str:
    parts = []
    for m in _bounds(field):
        for attr, sign in (("gt", ">"), ("ge", "≥"), ("lt", "<"), ("le", "≤")):
            if getattr(m, attr, None) is not None:
                parts.append(f"{sign} {getattr(m, attr):g}" if isinstance(getattr(m, attr), (int, float))
                             else f"{sign} {getattr(m, attr)}")
    return ", ".join(parts)


def _nested_model(annotation: Any) -> type[BaseModel] | None:
    candidates = [annotation] + [a for a in typing.get_args(annotation) if a is not type(None)]
    for c in candidates:
        if isinstance(c, type) and issubclass(c, BaseModel):
            return c
    return None


def model_fields(model: type[BaseModel], prefix: str = "") -> list[tuple[str, FieldInfo]]:
    """(dotted name, field) of every field of ``model``, nested models' fields after their own (a
    mapping's, a `RootModel`, has no fields of its own: its page says what its keys are)."""
    rows: list[tuple[str, FieldInfo]] = []
    for name, field in model.model_fields.items():
        dotted = prefix + (field.alias or name)
        rows.append((dotted, field))
        nested = _nested_model(field.annotation)
        if nested is not None and nested is not model and not issubclass(nested, RootModel):
            rows += model_fields(nested, dotted + ".")
    return rows


def settings_table(model: type[BaseModel]) -> str:
    doc = (model.__doc__ or "").strip().split("\n\n")[0].replace("\n", " ")
    rows = [f"`{model.__module__}.{model.__name__}`" + (f": {doc}" if doc else ""), "",
            "| field | type | default | range | unit | meaning |", "|---|---|---|---|---|---|"]
    for name, field in model_fields(model):
        description = field.description or ""
        unit = UNIT.search(description)
        rows.append(f"| `{name}` | {_cell(_type_name(field.annotation))} | {_cell(default_text(field))} | "
                    f"{_cell(range_text(field))} | {_cell(unit.group(1) if unit else '')} | {_cell(description)} |")
    return "\n".join(rows)


def resolve(target: str) -> Any:
    module, _, name = target.partition(":")
    return getattr(importlib.import_module(module), name)


# --- the command line ---------------------------------------------------------------------------

def cli_app() -> Any:
    import typer

    from simgap.cli import main as cli_main

    cli_main._register([])          # every command's module
    return typer.main.get_command(cli_main.app)


def _param_default(param: Any) -> str:
    if param.required:
        return "required"
    default = param.default
    if callable(default) or default is None or default == () or (getattr(param, "is_flag", False) and not default):
        return ""
    if isinstance(default, enum.Enum):
        default = default.value
    return _code(default)


def cli_commands(group: Any, path: str = "simgap") -> list[tuple[str, Any]]:
    out = []
    for name in sorted(group.commands):
        command = group.commands[name]
        if command.hidden:
            continue
        out.append((f"{path} {name}", command))
        if hasattr(command, "commands"):
            out += cli_commands(command, f"{path} {name}")
    return out


def cli_reference() -> str:
    from simgap.cli.exit_codes import MEANINGS

    blocks = ["## Exit codes", "", "Every command exits with one of these:", "",
              *(f"- `{int(code)}`: {_cell(text)}" for code, text in MEANINGS.items()),
              ""]
    for path, command in cli_commands(cli_app()):
        ctx = command.context_class(command, info_name=path)
        usage = re.sub(r"\{(\w+)\}", lambda m: m.group(1).upper(), " ".join(command.collect_usage_pieces(ctx)))
        blocks += [f"## `{path}`", "", f"```\n{path} {usage}\n```", "", (command.help or "").replace("\b\n", "").strip(), ""]
        params = [p for p in command.params if p.name != "help"]
        if params and not hasattr(command, "commands"):
            blocks += ["| argument or option | type | default | meaning |", "|---|---|---|---|"]
            for p in params:
                names = ", ".join(p.opts + list(p.secondary_opts)) if p.param_type_name == "option" else p.name.upper()
                kind = "flag" if getattr(p, "is_flag", False) else p.display_type(ctx).strip("<>")
                blocks.append(f"| `{_cell(names)}` | {_cell(kind)} | {_cell(_param_default(p))} | "
                              f"{_cell(getattr(p, 'help', None) or '')} |")
            blocks.append("")
    return "\n".join(blocks)


# --- the rest -----------------------------------------------------------------------------------

BACKEND_MODELS = {"ideal": "simgap.sim.ideal:NoSettings", "dynamic": "simgap.sim.dynamic.settings:DynamicSettings",
                  "mujoco": "simgap.sim.mujoco.settings:MujocoSettings",
                  "beamng": "simgap.sim.beamng.settings:BeamngSettings"}


def _backend_model(name: str) -> type[BaseModel]:
    return resolve(BACKEND_MODELS[name])


def include(path: str) -> str:
    """The Markdown file ``path`` (from the repository's root); each file beside it that it links
    is appended as a code block, and the link points at it."""
    source = ROOT / path
    text = source.read_text()
    linked = [name for name in dict.fromkeys(LINK.findall(text))
              if (source.parent / name).is_file() and not name.endswith(".md")]
    for name in linked:
        text = text.replace(f"]({name})", f"](#{_anchor(name)})")
    for name in linked:
        lexer = LEXERS.get(Path(name).suffix, "text")
        text += (f"\n\n## `{name}` {{#{_anchor(name)}}}\n\n`{Path(path).parent / name}`, as it is:\n\n"
                 f"```{lexer}\n{(source.parent / name).read_text().rstrip()}\n```\n")
    return text


# the planner SDK's types (simgap_planner) and the type simgap hands a planner in its own process
SDK_TYPES = {"Setup": "simgap.planning.PlannerSetup", "Vehicle": "simgap.vehicles.Vehicle",
             "VehicleLimits": "simgap.vehicles.catalogue.VehicleLimits", "State": "simgap.trajectory.State",
             "Trajectory": "simgap.trajectory.Trajectory", "World": "simgap.planning.World",
             "Participant": "simgap.planning.TrafficParticipant"}


def _first_line(doc: str | None) -> str:
    return " ".join((doc or "").strip().split("\n\n")[0].split())


def planner_sdk_reference() -> str:
    """One table per type a planner sees: each field the SDK documents (``metadata={"doc": ...}``)
    and each documented property, with its type and meaning."""
    import dataclasses

    import simgap_planner

    out = []
    for name, ours in SDK_TYPES.items():
        sdk_type = getattr(simgap_planner, name)
        rows = []
        if dataclasses.is_dataclass(sdk_type):
            rows += [(f.name, str(f.type), f.metadata["doc"]) for f in dataclasses.fields(sdk_type)
                     if "doc" in f.metadata]
        rows += [(attr, str(getattr(value.fget, "__annotations__", {}).get("return", "")), _first_line(value.__doc__))
                 for attr, value in vars(sdk_type).items()
                 if isinstance(value, property) and value.__doc__ and not attr.startswith("_")]
        if name == "Trajectory":
            rows += [("dt", "float", "the time step of its grid [s]")]
            rows += [(f.name, "numpy array", f"one value per state: {f.metadata['doc']}")
                     for f in dataclasses.fields(simgap_planner.State)]
        if not rows:
            raise ValueError(f"the planner SDK's {name} documents no field")
        table = "| field | type | meaning |\n|---|---|---|\n" + "\n".join(
            f"| {_code(field)} | {_cell(kind)} | {_cell(doc)} |" for field, kind, doc in rows)
        out.append(f"### `{name}`\n\n{_cell(_first_line(sdk_type.__doc__))} In simgap's process: "
                   f"`{ours}`.\n\n{table}\n")
    return "\n".join(out)


def _anchor(name: str) -> str:
    return "file-" + re.sub(r"[^\w-]", "-", name)


def render(kind: str, arg: str | None) -> str:
    if kind == "include":
        return include(arg)
    if kind == "cli":
        return cli_reference()
    if kind == "settings":
        return settings_table(resolve(arg))
    if kind == "backends":
        from simgap.sim.registry import BACKENDS
        missing = set(BACKENDS) - set(BACKEND_MODELS)
        if missing:
            raise ValueError(f"backends without a documented settings model: {sorted(missing)}")
        return "\n".join(f"### `{name}`\n\n{settings_table(_backend_model(name))}\n" for name in BACKEND_MODELS)
    if kind == "knobs":
        from simgap.experiment.knobs import knob_table
        return knob_table()
    if kind == "actuators":
        from simgap.vehicles.actuators import ActuatorChannel
        from simgap.vehicles.channels import channel_table
        return f"{channel_table()}\n\nEach channel's numbers:\n\n{settings_table(ActuatorChannel)}"
    if kind == "sensing":
        from simgap.cosim.sensing import profile_table
        return profile_table()
    if kind == "validation":
        return _validation().render_results(arg)
    if kind == "planner_sdk":
        return planner_sdk_reference()
    raise ValueError(f"unknown generated table gen:{kind}")


def _validation() -> Any:
    """docs/hooks/validation.py, the tables of the benchmarks' results files."""
    spec = importlib.util.spec_from_file_location("simgap_docs_validation", Path(__file__).with_name("validation.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def expand(markdown: str) -> str:
    return MARKER.sub(lambda m: render(m.group(1), m.group(2)), markdown)


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    return expand(markdown)


# an inline name (a knob, a field, an option: no space, up to 40 characters) in the text, not a code
# block's (after <pre> or a highlighting <span>) nor a table's first column (the CSS keeps those whole)
INLINE_NAME = re.compile(r"(?<!<pre>)(?<!</span>)(?<!<td>)<code>([^<\s]{1,40})</code>")


def on_page_content(html: str, page: Any, config: Any, files: Any) -> str:
    """Inline names in the text are wrapped in ``<span class="whole">`` (docs/stylesheets/extra.css
    keeps them on one line: a knob name never breaks at its hyphen or underscore); longer inline
    code wraps at its spaces."""
    return INLINE_NAME.sub(r'<span class="whole"><code>\1</code></span>', html)
