"""Reading the project's YAML files (scenarios, hardware configs) with errors that name
the file, the field and the value; the CLI turns them into exit code 2."""
from __future__ import annotations

from pathlib import Path

import yaml
from pydantic import BaseModel, ValidationError

from twin.core.errors import UserError


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
