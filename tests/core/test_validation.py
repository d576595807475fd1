"""One strict base for every validated file: every numeric field of every schema is
bounded and states its unit; NaN and ±inf are refused wherever a float is read."""

from __future__ import annotations

import math
import re

import pytest
from pydantic import ValidationError

from hardware.config import HardwareConfig
from twin.core.scenario import Scenario
from twin.core.validation import StrictModel
from twin.sensing.perception import ModelHeader
from twin.world.dome.registry import DOME_MODELS

#: each dome model's scenario `physics` schema
DOME_SETTINGS = tuple(b.settings for b in DOME_MODELS.values())
SCHEMAS = (Scenario, HardwareConfig, ModelHeader, *DOME_SETTINGS)


def numeric_leaves(schema: dict, defs: dict, path: str = "", described: str | None = None):
    """(path, sub-schema, description in force) of every number/integer in a JSON schema,
    through $ref, anyOf, oneOf, items and properties."""
    described = schema.get("description") or described
    if "$ref" in schema:
        yield from numeric_leaves(defs[schema["$ref"].split("/")[-1]], defs, path, described)
        return
    for key in ("anyOf", "oneOf", "allOf", "prefixItems"):
        for sub in schema.get(key, []):
            yield from numeric_leaves(sub, defs, path, described)
    if "items" in schema:
        yield from numeric_leaves(schema["items"], defs, path + "[]", described)
    for name, sub in schema.get("properties", {}).items():
        yield from numeric_leaves(sub, defs, f"{path}.{name}")
    if schema.get("type") in ("number", "integer"):
        yield path, schema, described


@pytest.mark.parametrize("model", SCHEMAS, ids=lambda m: m.__name__)
def test_every_numeric_field_is_bounded_and_has_a_unit(model: type[StrictModel]) -> None:
    schema = model.model_json_schema()
    leaves = list(numeric_leaves(schema, schema.get("$defs", {})))
    assert len(leaves) > (3 if model in DOME_SETTINGS else 5)  # the walk finds them
    unbounded = [
        p
        for p, s, _ in leaves
        if not (
            {"const", "enum"} & s.keys()
            or ({"minimum", "exclusiveMinimum"} & s.keys() and {"maximum", "exclusiveMaximum"} & s.keys())
        )
    ]
    assert not unbounded, f"numeric fields without physical bounds: {unbounded}"
    unit = re.compile(
        r"\b(mm|deg|px|s|MPa|mm/s|deg/s|1/px|dimensionless|TCP port|index|frames|100 µs|restarts|"
        r"components|cells|steps|samples per px|grey levels)\b"
    )
    undocumented = [p for p, s, d in leaves if not ({"const", "enum"} & s.keys() or (d and unit.search(d)))]
    assert not undocumented, f"numeric fields without a unit in their description: {undocumented}"


def test_every_schema_derives_from_the_strict_base() -> None:
    seen, todo = set(), list(SCHEMAS)
    while todo:
        model = todo.pop()
        if model in seen:
            continue
        seen.add(model)
        assert issubclass(model, StrictModel), model
        assert model.model_config["allow_inf_nan"] is False and model.model_config["extra"] == "forbid"
        for field in model.model_fields.values():
            for arg in _types_in(field.annotation):
                if isinstance(arg, type) and issubclass(arg, StrictModel.__mro__[1]):  # pydantic BaseModel
                    todo.append(arg)
    assert len(seen) >= 15


def _types_in(annotation):
    yield annotation
    for arg in getattr(annotation, "__args__", ()) or ():
        yield from _types_in(arg)
    origin = getattr(annotation, "__origin__", None)
    if origin is not None:
        yield from _types_in(origin)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize(
    "where",
    [
        {"placement": {"yaw_deg": None}},
        {"placement": {"position_mm": [None, 0.0]}},
        {"work_frame": [0, 0, None, 180, 0, 0]},
        {"protocol": {"kind": "contour", "gain": None}},
        {"protocol": {"kind": "taps", "depths_mm": [2.0, None]}},
        {"sensor": {"camera": {"fov_y_deg": None}}},
    ],
)
def test_scenario_non_finite_values_are_refused_naming_the_field(where: dict, bad: float) -> None:
    def fill(d):
        if isinstance(d, dict):
            return {k: fill(v) for k, v in d.items()}
        if isinstance(d, list):
            return [fill(v) for v in d]
        return bad if d is None else d

    with pytest.raises(ValidationError) as err:
        Scenario.model_validate({"name": "x", "object": {"name": "rectangle"}, **fill(where)})
    assert "finite number" in str(err.value) or "greater than" in str(err.value) or "less than" in str(err.value)


@pytest.mark.parametrize(
    "field,value",
    [
        ("robot", {"tcp_mm_deg": [0, 0, math.nan, 0, 0, 0]}),
        ("robot", {"linear_speed_mm_s": math.inf}),
        ("camera", {"exposure": math.nan}),
        ("safety", {"x_mm": [-math.inf, 80]}),
        ("safety", {"max_depth_mm": math.nan}),
    ],
)
def test_hardware_config_non_finite_values_are_refused(field: str, value: dict) -> None:
    with pytest.raises(ValidationError) as err:
        HardwareConfig.model_validate({field: value})
    (error,) = err.value.errors()  # refused for the non-finite value, not for anything else
    assert error["type"] == "finite_number" and error["loc"][:2] == (field, next(iter(value))), error
