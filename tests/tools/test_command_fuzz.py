"""Every command, driven in-process (twin.tools.cli.main) with generated bad arguments and
files (hypothesis, derandomized): scenario files, settings and edited run folders,
outputs at impossible paths, out-of-range numbers. Each case ends with exit 2 (a user's
mistake, one `error:` line naming the file, field or value) and never a traceback; the
inputs are bad by construction, so no case simulates. Each test counts its cases
(docs: the reliability figures quote the total, ≥ 2,000)."""

from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from twin.core.environment import Observation
from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.record import RunRecorder
from twin.tools.cli import main

FUZZ = settings(derandomize=True, database=None, deadline=None, suppress_health_check=list(HealthCheck))
TAPS = {
    "name": "fuzz_taps",
    "object": {"name": "rectangle"},
    "fidelity": "fast",
    "effects": ["contact", "friction"],
    "protocol": {"kind": "taps", "orientations_deg": [0], "lateral_mm": [2, -2], "depths_mm": [2]},
}


def _call(argv: list[str]) -> tuple[int, str]:
    """main(argv) in this process: (exit code, stderr); SystemExit (argparse --help) caught."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as stop:
            code = stop.code if isinstance(stop.code, int) else 1
    return code, err.getvalue()


def _assert_user_error(argv: list[str], counter: list[int]) -> None:
    code, err = _call(argv)
    counter[0] += 1
    assert "Traceback" not in err, (argv, err)
    assert code == 2 and err.startswith("error: "), (argv, code, err)


# ------------------------------------------------------------------ arguments

BAD_INT = ["-1", "-5", "4294967296", "99999999999999999999", "abc", "", "1.5", "nan", "0x10", "\n", "1e3"]
BAD_FLOAT = ["nan", "inf", "-inf", "-1", "1e400", "abc", "", "1e30"]
#: per command: a valid start of its arguments, then options each of which may be given a bad value
COMMANDS = {
    "run": (
        ["fuzz.yaml"],
        {
            "--seed": BAD_INT,
            "--workers": BAD_INT + ["0"],
            "--first-taps": BAD_INT + ["0"],
            "--every-nth-tap": BAD_INT + ["0"],
            "--backend": ["real", ""],
        },
    ),
    "check": (["fuzz.yaml"], {"--bogus": ["1"]}),
    "evaluate": (["--train", "a", "--test", "b", "--out", "o"], {"--seed": BAD_INT}),
    "compare": (["a", "b", "--out", "o"], {"--bogus": ["x"]}),
    "calibrate": (["a", "--scenario", "s", "--out", "o"], {"--workers": BAD_INT + ["0"]}),
    "video": (["a"], {"--bogus": ["x"]}),
    "view": (["fuzz.yaml"], {"--seed": BAD_INT}),
    "serve-robot": (
        [],
        {
            "--port": BAD_INT + ["70000", "65536"],
            "--log-limit": BAD_INT + ["0"],
            "--realtime": BAD_FLOAT,
            "--idle-timeout": BAD_FLOAT + ["0"],
            "--stall-timeout": BAD_FLOAT + ["0"],
        },
    ),
    "bench": (["--quick"], {"--workers": BAD_INT + ["0"], "--what": ["x"]}),
    "import-lab": (["f", "--targets", "t", "--out", "o"], {"--depth-mm": BAD_FLOAT, "--limit": BAD_INT + ["0"]}),
    "demo": ([], {"--seed": BAD_INT}),
    "figure": (["shear"], {"--fidelity": ["best"], "--dome": ["gel"]}),
}
N_ARGUMENTS = 900


@st.composite
def bad_arguments(draw) -> list[str]:
    command = draw(st.sampled_from(sorted(COMMANDS)))
    start, options = COMMANDS[command]
    names = draw(st.lists(st.sampled_from(sorted(options)), min_size=1, max_size=3, unique=True))
    argv = [command, *start]
    for name in names:
        argv += [name, draw(st.sampled_from(options[name]))]
    return argv


def test_bad_arguments_are_one_line_and_exit_2() -> None:
    counter = [0]

    @settings(FUZZ, max_examples=N_ARGUMENTS)
    @given(bad_arguments())
    def case(argv: list[str]) -> None:
        _assert_user_error(argv, counter)

    case()
    for argv in (["run"], ["nocommand"], [], ["run", "--resume"], ["check", "--no-compile"]):
        _assert_user_error(argv, counter)
    assert counter[0] >= N_ARGUMENTS
    print(f"bad arguments: {counter[0]} cases, 0 tracebacks")


# ------------------------------------------------------------------ files named by the user


def _bomb() -> str:
    lines = ['a: &a ["x","x","x","x","x","x","x","x","x"]']
    return "\n".join(lines + [f"{c}: &{c} [{', '.join(['*' + p] * 9)}]" for p, c in zip("abcdefgh", "bcdefghi")])


BAD_SCENARIOS = {
    "empty": "",
    "list": "[1, 2, 3]",
    "text": "just words",
    "tab": "name:\tx\n",
    "bomb": _bomb(),
    "deep": "a: " + "[" * 5000 + "]" * 5000,
    "binary": "\x00\x01\x02",
    "unknown key": "name: x\nobject: {name: rectangle}\nextra: 1\n",
    "dots": "name: ../../x\nobject: {name: rectangle}\n",
    "slash": "name: /tmp/x\nobject: {name: rectangle}\n",
    "newline": 'name: "a\\nb"\nobject: {name: rectangle}\n',
    "nul": 'name: "a\\0b"\nobject: {name: rectangle}\n',
    "long": f"name: {'x' * 300}\nobject: {{name: rectangle}}\n",
    "seed -5": "name: x\nseed: -5\nobject: {name: rectangle}\n",
    "seed 2**32": "name: x\nseed: 4294967296\nobject: {name: rectangle}\n",
    "nan": "name: x\nobject: {name: rectangle}\nplacement: {x_mm: .nan}\n",
    "missing outline": "name: x\nobject: {outline: nope.csv, thickness_mm: 5}\n",
    "linked outline": "name: x\nobject: {outline: linked.csv, thickness_mm: 5}\n",
    "passwd model": "name: x\nobject: {name: rectangle}\nprotocol: {kind: contour, model: /etc/passwd}\n",
    "missing model": "name: x\nobject: {name: rectangle}\nprotocol: {kind: contour, model: nope.npz}\n",
    "missing controller": "name: x\nobject: {name: rectangle}\nprotocol: {kind: contour, controller: 'nope.py:C'}\n",
    **{
        f"plug-in {k}": f"name: x\nobject: {{name: rectangle}}\nprotocol: {{kind: contour, controller: '{k}.py:C'}}\n"
        for k in ("syntax", "no_class", "raises", "exits", "not_a_class")
    },
    "passwd controller": "name: x\nobject: {name: rectangle}\nprotocol: {kind: contour, controller: '/etc/passwd:C'}\n",
    "missing calibration": "name: x\nobject: {name: rectangle}\nsensor: {calibration: nope.yaml}\n",
}
PLUG_INS = {
    "syntax": "def (:\n",
    "no_class": "X = 1\n",
    "raises": "raise RuntimeError('at import')\n",
    "exits": "import sys\nsys.exit(0)\n",
    "not_a_class": "C = 5\n",
}
BAD_SETTINGS = [
    "[1, 2]",
    "parameters: 5",
    "optimiser: {popsize: -1}",
    "optimiser: {max_generations: .nan}",
    _bomb(),
    "parameters: {camera.focal_px: {fit: maybe}}",
    "unknown: 1",
]
N_FILES = 400


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("files")
    for name, text in BAD_SCENARIOS.items():
        (root / f"{name.replace(' ', '_')}.yaml").write_text(text)
    for name, text in PLUG_INS.items():
        (root / f"{name}.py").write_text(text)
    (root / "linked.csv").symlink_to("/etc/passwd")
    for k, text in enumerate(BAD_SETTINGS):
        (root / f"settings_{k}.yaml").write_text(text)
    (root / "taps.yaml").write_text(yaml.safe_dump(TAPS))
    (root / "a_file").write_text("x")
    (root / "broken_link").symlink_to(root / "nowhere" / "x")
    return root


@st.composite
def bad_file_calls(draw, root: Path) -> list[str]:
    scenario = str(root / f"{draw(st.sampled_from(sorted(BAD_SCENARIOS))).replace(' ', '_')}.yaml")
    good = str(root / "taps.yaml")
    bad_out = draw(
        st.sampled_from(
            [
                str(root / "a_file" / "child"),
                "/proc/x/out",
                str(root / "broken_link"),
                str(root / "a_file"),
                "/dev/null/x",
                "x\0y",
            ]
        )
    )
    return draw(
        st.sampled_from(
            [
                ["check", scenario],
                ["check", "--no-compile", scenario],
                ["check", "--no-compile", good, scenario],
                ["run", scenario],
                ["run", scenario, "--out", str(root / "o")],
                ["view", scenario],
                ["render", scenario, "--out", str(root / "f.png")],
                ["calibrate", str(root), "--scenario", scenario, "--out", str(root / "cal")],
                [
                    "calibrate",
                    str(root),
                    "--scenario",
                    good,
                    "--out",
                    str(root / "cal"),
                    "--settings",
                    str(root / f"settings_{draw(st.integers(0, len(BAD_SETTINGS) - 1))}.yaml"),
                ],
                ["run", good, "--out", bad_out],
                ["render", good, "--out", bad_out],
                ["evaluate", "--train", bad_out, "--test", bad_out, "--out", bad_out],
                ["compare", bad_out, bad_out, "--out", str(root / "cmp")],
                ["video", bad_out],
                ["run", "--resume", bad_out],
                ["import-lab", bad_out, "--targets", bad_out, "--out", str(root / "imp")],
            ]
        )
    )


def test_bad_files_are_named_and_exit_2(files: Path) -> None:
    counter = [0]

    @settings(FUZZ, max_examples=N_FILES)
    @given(bad_file_calls(files))
    def case(argv: list[str]) -> None:
        _assert_user_error(argv, counter)

    case()
    assert counter[0] >= N_FILES
    print(f"bad files: {counter[0]} cases, 0 tracebacks")


# ------------------------------------------------------------------ edited run folders


def _sample_edits() -> dict:
    def field(name, value):
        return lambda row: json.dumps({**row, name: value})

    return {
        "{}": lambda row: "{}",
        "list": lambda row: "[1, 2, 3]",
        "null": lambda row: "null",
        "number": lambda row: "5",
        "text": lambda row: '"abc"',
        "not json": lambda row: "{abc",
        "deep": lambda row: "[" * 200_000 + "]" * 200_000,
        "bad utf-8": lambda row: b"\xff\xfe".decode("latin-1"),
        "pins 100 rows": field("pins_px", [[1.0, 2.0]] * 100),
        "pins text": field("pins_px", "abc"),
        "pins strings": field("pins_px", [["1", "2"]] * 127),
        "pins deep": field("pins_px", [[[1.0]]] * 127),
        "target abc": field("target", "abc"),
        "target 5": field("target", [1, 2, 3, 4, 5]),
        "target nan": lambda row: json.dumps({**row, "target": [float("nan")] * 6}),
        "target bools": field("target", [True] * 6),
        "pose null": field("pose", None),
        "pose dict": field("pose", {}),
        "labels list": field("labels", [1]),
        "label text": field("labels", {"theta_deg": "abc"}),
        "label nested": field("labels", {"x": {"y": 1}}),
        "found ints": field("found", [1] * 127),
        "found short": field("found", [True] * 5),
        "frame passwd": field("frame", "/etc/passwd"),
        "frame up": field("frame", "../../secret.png"),
        "frame number": field("frame", 5),
        "frame empty": field("frame", ""),
        "time text": field("time", "x"),
        "truth list": field("truth", [1]),
        "no target": lambda row: json.dumps({k: v for k, v in row.items() if k != "target"}),
    }


def _meta_edits() -> dict:
    def field(name, value):
        return lambda meta: json.dumps({**meta, name: value})

    return {
        "[1,2,3]": lambda meta: "[1, 2, 3]",
        "{}": lambda meta: "{}",
        "deep": lambda meta: "[" * 200_000 + "]" * 200_000,
        "not json": lambda meta: "{",
        "seed -5": field("seed", -5),
        "seed -1": field("seed", -1),
        "seed 2**32": field("seed", 2**32),
        "seed text": field("seed", "x"),
        "seed float": field("seed", 1.5),
        "status": field("status", "weird"),
        "backend": field("backend", "x"),
        "format": field("format_version", 2),
        "scenario list": field("scenario", [1]),
        "scenario name": lambda meta: json.dumps({**meta, "scenario": {**meta["scenario"], "name": 5}}),
        "scenario kind": lambda meta: json.dumps({**meta, "scenario": {**meta["scenario"], "protocol": {"kind": []}}}),
        "camera 0": field("camera", {"width": 0, "height": 480}),
        "rest pins": field("rest_pins_px", [[1.0]] * 100),
        "process": field("process", 5),
        "scenario_file": field("scenario_file", 5),
    }


SAMPLE_EDITS, META_EDITS = _sample_edits(), _meta_edits()
N_RUNS = 750


@pytest.fixture(scope="module")
def base_run(tmp_path_factory) -> Path:
    """A tap run of 2 samples, frames and pins, recorded by RunRecorder (no simulation)."""
    out = tmp_path_factory.mktemp("base") / "run"
    rng = np.random.default_rng(0)
    with RunRecorder(out, scenario_from_dict(TAPS), seed=0, backend="sim") as rec:
        for i, lateral in enumerate((2.0, -2.0)):
            obs = Observation(
                time=float(i),
                pose=Pose(0, lateral, 2, 0, 0, 0),
                frame=rng.integers(0, 256, (24, 32, 3), dtype=np.uint8),
            )
            rec.add(
                obs,
                Pose(0, lateral, 2, 0, 0, 0),
                {"theta_deg": 0.0, "lateral_mm": lateral, "depth_mm": 2.0},
                pins_px=rng.normal(300, 20, (127, 2)),
                found=np.ones(127, bool),
            )
    return out


@st.composite
def edited_runs(draw) -> list[tuple[str, str, int]]:
    """One to three edits: (where, which edit, line) with where "samples" or "meta"."""
    one = st.one_of(
        st.tuples(st.just("samples"), st.sampled_from(sorted(SAMPLE_EDITS)), st.integers(0, 1)),
        st.tuples(st.just("meta"), st.sampled_from(sorted(META_EDITS)), st.just(0)),
    )
    return draw(st.lists(one, min_size=1, max_size=3, unique_by=lambda e: (e[0], e[2])))


def test_edited_run_folders_are_named_and_exit_2(base_run: Path, files: Path, tmp_path: Path) -> None:
    counter = [0]
    commands = [
        lambda run: ["compare", str(run), str(base_run), "--out", str(tmp_path / "cmp")],
        lambda run: ["compare", str(base_run), str(run), "--out", str(tmp_path / "cmp")],
        lambda run: ["evaluate", "--train", str(run), "--test", str(base_run), "--out", str(tmp_path / "ev")],
        lambda run: ["calibrate", str(run), "--scenario", str(files / "taps.yaml"), "--out", str(tmp_path / "cal")],
        lambda run: ["video", str(run), "--out", str(tmp_path / "v.mp4")],
        lambda run: ["run", "--resume", str(run)],
    ]

    @settings(FUZZ, max_examples=N_RUNS // len(commands))
    @given(edited_runs())
    def case(edits) -> None:
        run = tmp_path / "edited"
        shutil.rmtree(run, ignore_errors=True)
        shutil.copytree(base_run, run)
        for where, name, line in edits:
            if where == "samples":
                lines = (run / "samples.jsonl").read_text().splitlines()
                lines[line] = SAMPLE_EDITS[name](json.loads(lines[line]))
                (run / "samples.jsonl").write_text("\n".join(lines) + "\n")
            else:
                meta = json.loads((run / "run.json").read_text())
                (run / "run.json").write_text(META_EDITS[name](meta))
        for command in commands:
            _assert_user_error(command(run), counter)

    case()
    assert counter[0] >= N_RUNS - len(commands)
    print(f"edited run folders: {counter[0]} cases, 0 tracebacks")


# ------------------------------------------------------------------ the boundary itself


def test_an_internal_fault_is_one_line_and_its_traceback_goes_to_the_log(tmp_path: Path, monkeypatch) -> None:
    from twin.tools.boundary import LOG_ENV, guarded

    monkeypatch.setenv(LOG_ENV, str(tmp_path / "logs"))
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = guarded(lambda: {}["missing key"])
    line = err.getvalue()
    assert (
        code == 1
        and line.count("\n") == 1
        and line.startswith("internal error: KeyError: 'missing key' (traceback in ")
    )
    log = Path(line.split("traceback in ")[1].rstrip(")\n"))
    assert log.parent == tmp_path / "logs" and "Traceback (most recent call last)" in log.read_text()


@pytest.mark.parametrize(
    "errno_, code, start",
    [
        (28, 1, "failed: /x/run.json: No space left on device"),
        (2, 2, "error: /x/run.json: No such file or directory"),
        (13, 2, "error: /x/run.json: Permission denied"),
    ],
)
def test_a_write_error_is_the_user_s_when_the_path_is_wrong_and_the_machine_s_when_the_disk_is(
    errno_: int, code: int, start: str
) -> None:
    from twin.tools.boundary import guarded

    def fail():
        raise OSError(errno_, os.strerror(errno_), "/x/run.json")

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert guarded(fail) == code
    assert err.getvalue() == start + "\n"


@pytest.mark.parametrize("argv", [["--help"], ["run", "--help"], ["bench", "--help"], ["serve-robot", "-h"]])
def test_help_is_printed_and_exits_0(argv: list[str], capsys) -> None:
    # argparse ends --help with sys.exit(0): the boundary had taken it for a plug-in's and exited 2
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert out.startswith("usage: twin") and err == ""
