"""Reading the project's validated files (scenarios, hardware configs and the calibration
they carry, controller parameters, perception model headers) with errors that name the
file, the field and the value; the CLI turns them into exit code 2.

Every schema derives from `StrictModel`: unknown keys are refused, NaN and ±inf are
refused in every float field (nested lists included), and every numeric field carries
physical bounds with its unit in its description (`bounded`, `bounded_list`, `PoseList`;
tests/core/test_validation.py walks every schema and holds this).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, Any

import yaml
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError

from twin.core.errors import UserError


class StrictModel(BaseModel):
    """Base of every validated file: unknown keys refused, frozen, NaN and ±inf refused."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def bounded(lo: float, hi: float, unit: str, what: str = "", default: Any = ..., *, open_lo: bool = False) -> Any:
    """A Field bounded to [lo, hi] (or (lo, hi] with `open_lo`), with its meaning and unit
    in the description: ``yaw_deg: float = bounded(-360, 360, "deg", "yaw", 0.0)``."""
    low = {"gt": lo} if open_lo else {"ge": lo}
    span = f"{'(' if open_lo else '['}{lo:g}, {hi:g}]"
    return Field(default, le=hi, description=f"{what} ({unit}; {span})".strip(), **low)


def bounded_list(lo: float, hi: float, unit: str, length: int | None = None, max_length: int = 10_000) -> Any:
    """The type of a list of floats each in [lo, hi] `unit`: exactly `length` items when
    given, else 1 to `max_length`."""
    item = Annotated[float, Field(ge=lo, le=hi, description=f"{unit}; [{lo:g}, {hi:g}]")]
    n_min, n_max = (length, length) if length is not None else (1, max_length)
    return Annotated[
        list[item], Field(min_length=n_min, max_length=n_max, description=f"{unit}; items in [{lo:g}, {hi:g}]")
    ]


def _angles_within_a_turn(values: list[float]) -> list[float]:
    for name, v in zip(("alpha", "beta", "gamma"), values[3:]):
        if not -360.0 <= v <= 360.0:
            raise ValueError(f"{name} = {v} deg is outside [-360, 360] deg")
    return values


#: A pose [x, y, z, α, β, γ] (mm, deg; docs/conventions.md): positions within ±1000 mm
#: (the IRB120 reaches 580 mm), angles within one turn either way.
PoseList = Annotated[
    list[Annotated[float, Field(ge=-1000, le=1000)]],
    Field(
        min_length=6,
        max_length=6,
        description="pose [x, y, z mm, α, β, γ deg]: x, y, z in [-1000, 1000] mm, angles in [-360, 360] deg",
    ),
    AfterValidator(_angles_within_a_turn),
]


#: The most bytes a validated YAML file may hold (B); the shipped ones hold a few kB.
MAX_YAML_BYTES = 4 * 2**20
#: The most nodes a YAML document may hold once its aliases are expanded: anchors and
#: aliases are allowed, but a few hundred bytes of nested aliases (an alias bomb) expand
#: to billions of nodes, which validation would walk.
MAX_YAML_NODES = 200_000


#: The deepest a YAML document may nest (levels); the shipped ones nest 4.
MAX_YAML_DEPTH = 64


class _BoundedLoader(yaml.SafeLoader):
    """yaml.SafeLoader refusing a document nested deeper than MAX_YAML_DEPTH or of more
    than MAX_YAML_NODES nodes counted with its aliases expanded (each aliased node counted
    where it is used)."""

    _depth = 0

    def compose_node(self, parent, index):
        self._depth += 1
        try:
            if self._depth > MAX_YAML_DEPTH:
                raise yaml.YAMLError(f"nested deeper than {MAX_YAML_DEPTH} levels")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def get_single_node(self):
        node = super().get_single_node()
        if node is not None:
            _expanded_size(node, {})
        return node


def _expanded_size(node: yaml.Node, sizes: dict[int, int]) -> int:
    """The nodes under `node` with aliases expanded; yaml.YAMLError beyond MAX_YAML_NODES.
    Memoised per node, so an alias bomb is measured in time linear in its size."""
    known = sizes.get(id(node))
    if known is not None:
        return known
    sizes[id(node)] = 1  # a node that holds itself (a recursive alias) counts once
    total = 1
    if isinstance(node, yaml.SequenceNode):
        total += sum(_expanded_size(child, sizes) for child in node.value)
    elif isinstance(node, yaml.MappingNode):
        total += sum(_expanded_size(k, sizes) + _expanded_size(v, sizes) for k, v in node.value)
    if total > MAX_YAML_NODES:
        raise yaml.YAMLError(f"more than {MAX_YAML_NODES} values once its aliases are expanded (an alias bomb?)")
    sizes[id(node)] = total
    return total


#: A run's name (a scenario's `name`): one folder name, the default run folder's start.
RUN_NAME_CHARACTERS = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]*")
RUN_NAME_MAX = 100


def _one_folder_name(name: str) -> str:
    if not 1 <= len(name) <= RUN_NAME_MAX:
        raise ValueError(f"a run name has 1 to {RUN_NAME_MAX} characters, this one {len(name)}")
    if not RUN_NAME_CHARACTERS.fullmatch(name):
        raise ValueError(
            "a run name is one folder name: ASCII letters, digits and _ . + - "
            "(not first: . + -); no /, spaces, NUL or newlines"
        )
    return name


#: A name that is one path segment (no /, no .., no NUL or newline), 1 to RUN_NAME_MAX characters.
RunName = Annotated[str, AfterValidator(_one_folder_name)]


def no_link_out(path: Path, source: str) -> Path:
    """`path` (a file named in `source`), unless it is a symbolic link to a place outside the
    folder that holds the link: an input never leads out of where the user put it."""
    if path.is_symlink():
        try:
            path.resolve(strict=False).relative_to(path.parent.resolve())
        except (ValueError, OSError, RuntimeError):
            raise UserError(f"{source}: {path} is a symbolic link out of its folder; name the file itself") from None
    return path


def read_yaml(path: str | Path, what: str):
    """The parsed contents of a YAML file; UserError naming the file (and line) otherwise.
    Files over MAX_YAML_BYTES, and documents whose aliases expand past MAX_YAML_NODES
    values, are refused; messages never quote the file's contents."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such {what} file")
    try:
        if path.stat().st_size > MAX_YAML_BYTES:
            raise UserError(f"{path}: a {what} file of {path.stat().st_size} B; at most {MAX_YAML_BYTES} B are read")
        return yaml.load(path.read_text(), Loader=_BoundedLoader)  # noqa: S506  (a SafeLoader)
    except OSError as err:
        raise UserError(f"{path}: cannot read the {what} file ({err.strerror or type(err).__name__})") from None
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" line {mark.line + 1}, column {mark.column + 1}:" if mark is not None else ""
        raise UserError(f"{path}:{where} not valid YAML: {getattr(err, 'problem', err)}") from None
    except (UnicodeDecodeError, RecursionError) as err:
        raise UserError(f"{path}: not a readable {what} file ({type(err).__name__})") from None


def validate_mapping(model: type[BaseModel], data, source: str, what: str):
    """`data` validated as a `model`; UserError naming `source` and every invalid field."""
    if not isinstance(data, dict):
        raise UserError(f"{source}: a {what} is a mapping of fields, got {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise validation_error(source, what, err) from None


def validation_error(source: str, what: str, err: ValidationError) -> UserError:
    """One line per invalid field: `  field.path = value: reason`."""
    lines = [f"{source}: invalid {what}"]
    for e in err.errors():
        loc = ".".join(str(p) for p in e["loc"]) or "(top level)"
        value = e.get("input")
        shown = repr(value) if not isinstance(value, dict) else "{…}"
        if len(shown) > 80:
            shown = shown[:77] + "…"
        lines.append(f"  {loc} = {shown}: {e['msg']}")
    return UserError("\n".join(lines))
