"""Adversarial scenarios, built from the schema (hypothesis): NaN, ±inf, huge, negative,
wrong types, missing and unknown keys, broken meshes and outlines. Each one either passes
`twin check` and then runs a short protocol (`twin run`) without a traceback, or exits 2
with a message naming the file and the field (or the broken mesh/outline file). Zero
tracebacks. TWIN_FUZZ_EXAMPLES sets how many are tried (default 30 in the suite;
docs/reliability.md reports a longer run)."""

from __future__ import annotations

import contextlib
import io
import itertools
import math
import os
from collections import Counter

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from twin.core.scenario import RenderProtocol, Scenario, SlideProtocol, TapProtocol
from twin.tools.cli import main

N_EXAMPLES = int(os.environ.get("TWIN_FUZZ_EXAMPLES", "30"))

PROTOCOLS = {
    "render": {"kind": "render", "poses": [[0.0, 0.0, -5.0, 0.0, 0.0, 0.0], [0.0, 0.0, 2.0, 0.0, 0.0, 30.0]]},
    "taps": {"kind": "taps", "orientations_deg": [0.0], "lateral_mm": [2.0], "depths_mm": [2.0]},
    "slides": {
        "kind": "slides",
        "orientations_deg": [0.0],
        "directions_deg": [90.0],
        "lateral_mm": [0.0, -2.0],
        "depth_mm": 2.0,
    },
}
BAD_VALUES = [
    math.nan,
    math.inf,
    -math.inf,
    1e308,
    -1e308,
    -1.0,
    0.0,
    10**30,
    -(10**30),
    "twelve",
    None,
    [],
    {},
    True,
    [math.nan] * 6,
    [1e9] * 6,
    "",
    [[]],
]

STLS = {
    "empty.stl": b"",
    "garbage.stl": bytes(range(256)) * 4,
    "no_facets.stl": b"solid x\nendsolid x\n",
    "one_triangle.stl": b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 10 0 0\nvertex 0 10 0\n"
    b"endloop\nendfacet\nendsolid t\n",
    "nan_vertex.stl": b"solid t\nfacet normal 0 0 1\nouter loop\nvertex nan 0 0\nvertex 10 0 0\nvertex 0 10 0\n"
    b"endloop\nendfacet\nendsolid t\n",
}
OUTLINES = {
    "two_points.csv": "x,y\n0,0\n10,0\n",
    "bowtie.csv": "x,y\n-20,-20\n20,20\n20,-20\n-20,20\n",
    "nan.csv": "x,y\n0,0\nnan,10\n10,0\n",
    "words.csv": "x,y\na,b\nc,d\ne,f\n",
    "huge.csv": "x,y\n0,0\n1e12,0\n0,1e12\n",
    "duplicates.csv": "x,y\n0,0\n0,0\n0,0\n",
    "triangle.csv": "x,y\n-30,-20\n30,-20\n0,30\n",
}


def schema_paths(model: type, prefix: tuple = ()) -> list[tuple]:
    """Every field path of a pydantic model, nested models included (from the schema)."""
    out = []
    for name, field in model.model_fields.items():
        out.append((*prefix, name))
        sub = field.annotation
        if isinstance(sub, type) and hasattr(sub, "model_fields"):
            out += schema_paths(sub, (*prefix, name))
    return out


SHARED_PATHS = [
    p for p in schema_paths(Scenario) if p[0] not in ("protocol", "name", "description", "backend", "hardware_config")
] + [("name",)]


def _protocol_fields(kind: str) -> list[tuple]:
    model = {"render": RenderProtocol, "taps": TapProtocol, "slides": SlideProtocol}[kind]
    return [("protocol", name) for name in model.model_fields if name != "kind"]


def _set(data: dict, path: tuple, value) -> None:
    for key in path[:-1]:
        data = data.setdefault(key, {}) if isinstance(data.get(key, {}), dict) else {}
    if value is _MISSING:
        data.pop(path[-1], None)
    else:
        data[path[-1]] = value


_MISSING = object()


@st.composite
def scenarios(draw) -> tuple[dict, dict, list[str]]:
    """(scenario dict, extra files {name: bytes}, the field names mutated)."""
    kind = draw(st.sampled_from(sorted(PROTOCOLS)))
    data = {
        "name": "fuzz",
        "object": {"name": "rectangle"},
        "fidelity": "fast",
        "effects": ["contact", "friction"],
        "protocol": dict(PROTOCOLS[kind]),
    }
    files: dict[str, bytes] = {}
    touched: list[str] = []
    source = draw(st.sampled_from(["builtin", "builtin", "stl", "outline"]))
    if source == "stl":
        name = draw(st.sampled_from(sorted(STLS)))
        data["object"] = {"stl": name}
        files[name] = STLS[name]
        touched.append(name)
    elif source == "outline":
        name = draw(st.sampled_from(sorted(OUTLINES)))
        data["object"] = {"outline": name, "thickness_mm": 8}
        files[name] = OUTLINES[name].encode()
        touched.append(name)
    paths = SHARED_PATHS + _protocol_fields(kind)
    for _ in range(draw(st.integers(0, 3))):
        path = draw(st.sampled_from(paths))
        value = draw(
            st.one_of(
                st.sampled_from(BAD_VALUES),
                st.just(_MISSING),
                st.floats(allow_nan=True, allow_infinity=True),
                st.integers(-(2**70), 2**70),
                st.text(max_size=5),
            )
        )
        _set(data, path, value)
        touched.append(path[-1])
    if draw(st.booleans()):
        where = draw(st.sampled_from([(), ("placement",), ("protocol",), ("sensor", "camera"), ("object",)]))
        _set(data, (*where, "extra_key"), 1)
        touched.append("extra_key")
    return data, files, touched


def _cli(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = main(argv)  # anything escaping main here would be a traceback: the test fails
    return rc, err.getvalue()


def _try(case: tuple[dict, dict, list[str]], folder) -> str:
    """Check (then run) one scenario; returns its outcome, failing on a traceback or a vague error."""
    data, files, touched = case
    for name, content in files.items():
        (folder / name).write_bytes(content)
    path = folder / "scenario.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    rc, err = _cli(["check", str(path)])
    assert "Traceback" not in err
    if rc == 2:
        assert str(path) in err or any(f in err for f in files), err
        assert any(str(t) in err for t in touched) or "out of reach" in err, (touched, err)
        return "refused by twin check (exit 2)"
    assert rc == 0, err
    rc, err = _cli(["run", str(path), "--out", str(folder / "run"), "--workers", "1", "--quiet"])
    assert "Traceback" not in err
    assert rc in (0, 2), err  # 2: a user error only the run can see (e.g. a pose the dome cannot settle at)
    return f"passed check, then ran: exit {rc}"


def test_adversarial_scenarios_pass_or_exit_2_naming_file_and_field(tmp_path_factory, capsys) -> None:
    """Tries N_EXAMPLES scenarios, then prints what they did (one test: it needs no other to run first)."""
    outcomes: Counter = Counter()
    ids = itertools.count()

    @settings(max_examples=N_EXAMPLES, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
    @given(case=scenarios())
    def each(case) -> None:
        outcomes[_try(case, tmp_path_factory.mktemp(f"fuzz{next(ids)}"))] += 1

    each()
    with capsys.disabled():
        print(
            f"\nscenario fuzz: {sum(outcomes.values())} scenarios: "
            + ", ".join(f"{k}: {v}" for k, v in sorted(outcomes.items()))
        )
    assert sum(outcomes.values()) >= min(N_EXAMPLES, 10)  # hypothesis really tried them
