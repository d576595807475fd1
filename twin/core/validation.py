"""Reading the project's validated files (scenarios, hardware configs and the calibration
they carry, controller parameters, perception model headers) with errors that name the
file, the field and the value; the CLI turns them into exit code 2.

Every schema derives from `StrictModel`: unknown keys are refused, NaN and ±inf are
refused in every float field (nested lists included), and every numeric field carries
physical bounds with its unit in its description (`bounded`, `bounded_list`, `PoseList`;
tests/core/test_validation.py walks every schema and holds this).
"""
from __future__ import annotations

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
    return Annotated[list[item], Field(min_length=n_min, max_length=n_max,
                                       description=f"{unit}; items in [{lo:g}, {hi:g}]")]


def _angles_within_a_turn(values: list[float]) -> list[float]:
    for name, v in zip(("alpha", "beta", "gamma"), values[3:]):
        if not -360.0 <= v <= 360.0:
            raise ValueError(f"{name} = {v} deg is outside [-360, 360] deg")
    return values


#: A pose [x, y, z, α, β, γ] (mm, deg; README "Conventions"): positions within ±1000 mm
#: (the IRB120 reaches 580 mm), angles within one turn either way.
PoseList = Annotated[
    list[Annotated[float, Field(ge=-1000, le=1000)]],
    Field(min_length=6, max_length=6, description="pose [x, y, z mm, α, β, γ deg]: x, y, z in [-1000, 1000] mm, "
                                                  "angles in [-360, 360] deg"),
    AfterValidator(_angles_within_a_turn),
]


def read_yaml(path: str | Path, what: str):
    """The parsed contents of a YAML file; UserError naming the file (and line) otherwise."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such {what} file")
    try:
        return yaml.safe_load(path.read_text())
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
