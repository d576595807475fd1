"""`twin` command line. Every sub-command is a thin layer over a module function.

Exit codes: 0 success, 1 the run failed (e.g. PhysicsError, HardwareError),
2 user error (bad scenario, file, pose or argument), 130 interrupted by SIGINT (Ctrl-C),
143 stopped by SIGTERM; an interrupted run keeps what it recorded (`twin run --resume`).
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
import threading
import time
from pathlib import Path
from types import ModuleType

from twin.core.errors import Terminated, UserError
from twin.core.scenario import DEFAULT_DOME, Scenario
from twin.runs.lab_recording import import_lab_recording, nominal_depth_mm, with_taps_from
from twin.runs.parallel import one_blas_thread
from twin.runs.record import load_run
from twin.runs.run import resume_run, run_scenario
from twin.runs.sim_env import check_reachable, render_scenario_view
from twin.runs.spec import load_scenario, load_scenario_stimulus, scene_spec
from twin.tools.boundary import OneLineParser, bounded_float, bounded_int, guarded, output_file, output_folder
from twin.world.dome.registry import DOME_MODELS
from twin.world.scene import build_scene


def _command_module(name: str) -> ModuleType:
    """A command's implementation, imported by name when that command runs: `twin run` of a
    tap set does not load the contour stack, the video writer or the robot server."""
    return importlib.import_module(name)


def _check_named_files(scenario: Scenario) -> None:
    """Load every file `scenario` names, without simulating: its object's STL or outline,
    its calibration, hardware config, perception model and controller plug-in (imported
    and constructed: a plug-in runs as the user's code). UserError naming the first that fails."""
    load_scenario_stimulus(scenario)
    scenario.calibration()
    if scenario.hardware_config is not None:
        _command_module("hardware.config").load_hardware_config(scenario.resolve(scenario.hardware_config))
    if scenario.protocol.kind == "contour":
        if scenario.protocol.model is not None:
            path = scenario.resolve(scenario.protocol.model)
            if not path.is_file():
                raise UserError(f"{scenario.source}: field 'protocol.model': no such model file {path}")
            _command_module("twin.sensing.perception").PerceptionModel.load(path)
        _command_module("twin.control.controllers").load_controller(
            scenario.protocol.controller, scenario.protocol, scenario.source_dir
        )


def _checked_scenario(path: str) -> Scenario:
    """The scenario at `path` with every file it names loaded (`_check_named_files`): a
    command fails on them before it simulates."""
    scenario = load_scenario(path)
    _check_named_files(scenario)
    return scenario


def _cmd_check(args: argparse.Namespace) -> int:

    for path in args.scenarios:
        scenario = _checked_scenario(path)
        reach = ""
        if args.compile and scenario.backend == "sim":
            reach = f", {check_reachable(scenario, build_scene(scene_spec(scenario)))} poses in reach"
        print(
            f"{path}: ok ({scenario.protocol.kind}, object {scenario.object.name or scenario.object.stl or scenario.object.outline}, "
            f"effects {', '.join(scenario.effects) or 'none'}{reach})"
        )
    return 0


def _cmd_render(args: argparse.Namespace) -> int:

    scenario = _checked_scenario(args.scenario)
    out = render_scenario_view(scenario, output_file(Path(args.out), "twin render --out", ".png"), view=args.view)
    print(f"wrote {out}")
    return 0


def _cmd_run(args: argparse.Namespace) -> int:

    if args.scenario is None and args.resume is None:
        raise UserError("twin run: give a SCENARIO to run, or --resume DIR to continue a run")
    scenario = None if args.scenario is None else _checked_scenario(args.scenario)
    if scenario is not None and args.backend:
        scenario = scenario.with_changes(backend=args.backend)
    for given, option in ((args.without_slides, "--without-slides"), (args.every_nth_tap, "--every-nth-tap")):
        if given and not args.taps_from:
            raise UserError(f"twin run: {option} replays a recording's taps; give --taps-from RUN")
    if scenario is not None and args.taps_from:
        recorded = load_run(Path(args.taps_from))
        scenario = with_taps_from(scenario, recorded, args.first_taps, args.without_slides, args.every_nth_tap or 1)
        recorded_depth = nominal_depth_mm(recorded)
        if recorded_depth is not None and abs(recorded_depth - scenario.protocol.depth_mm) > 1e-9:
            print(
                f"note: {args.scenario} presses to protocol.depth_mm = {scenario.protocol.depth_mm:g} mm, and "
                f"{args.taps_from}'s taps are offsets from {recorded_depth:g} mm (the depth it was imported at): "
                f"the replay presses {scenario.protocol.depth_mm - recorded_depth:+g} mm deeper than the recording "
                "as imported",
                file=sys.stderr,
            )
        calibration = scenario.calibration()
        if calibration is None or calibration.camera.focal_px is None:
            print(
                f"note: {args.scenario} has no fitted camera (sensor.calibration.camera.focal_px), so the replay's "
                f"pixels are its nominal camera's: its edge figures compare with {args.taps_from}'s only through "
                "the camera twin calibrate fits to that recording",
                file=sys.stderr,
            )
    if scenario is not None and args.hardware_config:
        scenario = scenario.with_changes(hardware_config=str(Path(args.hardware_config).resolve()))
    if args.resume is not None:
        if args.out is not None:
            raise UserError("twin run: --resume continues a run in its own directory; leave out --out")
        run_dir = resume_run(
            Path(args.resume),
            scenario,
            seed=args.seed,
            workers=args.workers,
            cluster=args.cluster,
            progress=not args.quiet,
        )
        print(f"recorded {run_dir}")
        if args.video:
            print(f"wrote {_command_module('twin.tools.video').write_run_video(run_dir)}")
        return 0
    out = (
        Path(args.out)
        if args.out
        else Path("runs") / f"{scenario.name}_seed{args.seed if args.seed is not None else scenario.seed}"
    )
    t0 = time.perf_counter()
    run_dir = run_scenario(
        scenario, out, seed=args.seed, workers=args.workers, cluster=args.cluster, progress=not args.quiet
    )
    run_s = time.perf_counter() - t0
    print(f"recorded {run_dir}")
    if args.video:
        t1 = time.perf_counter()
        video = _command_module("twin.tools.video").write_run_video(run_dir)
        video_s = time.perf_counter() - t1
        print(f"wrote {video} in {video_s:.1f} s ({video_s / run_s:.2f}× the run's {run_s:.1f} s)")
    return 0


def _cmd_import_lab(args: argparse.Namespace) -> int:

    if args.object_side not in ("+y", "-y"):
        raise UserError(f"twin import-lab: --object-side is +y or -y, got {args.object_side!r}")
    r = import_lab_recording(
        Path(args.folder),
        Path(args.targets),
        Path(args.out),
        init=Path(args.init) if args.init else None,
        depth_mm=args.depth_mm,
        object_side=1 if args.object_side == "+y" else -1,
        edge_radius_mm=args.edge_radius_mm,
        limit=args.limit,
        progress=not args.quiet,
    )
    print(
        f"imported {r['frames']} frames (the no-contact frame first) into {args.out}: "
        f"{r['complete']} with every pin tracked, "
        f"{len(r['incomplete'])} with pins not found (recorded, flagged in 'found'), "
        f"{len(r['unreadable'])} missing or unreadable (recorded without pins)"
    )
    return 0


def _cmd_video(args: argparse.Namespace) -> int:

    out = output_file(Path(args.out), "twin video --out", ".mp4") if args.out else None
    print(f"wrote {_command_module('twin.tools.video').write_run_video(Path(args.run), out)}")
    return 0


def _cmd_view(args: argparse.Namespace) -> int:

    shown = _command_module("twin.tools.view").view_scenario(
        _checked_scenario(args.scenario), seed=args.seed, wait=not args.no_wait
    )
    print(f"showed {shown} samples")
    return 0


def _warn(notes: list[str]) -> None:
    for note in notes:
        print(f"warning: {note}", file=sys.stderr)


def _cmd_evaluate(args: argparse.Namespace) -> int:

    result = _command_module("twin.tools.evaluation_report").evaluate_and_report(
        Path(args.train),
        Path(args.test),
        output_folder(Path(args.out), "twin evaluate --out"),
        seed=args.seed,
        **_reach_at(args),
        shift_free=args.shift_free,
    )
    _warn(result["unfinished"])
    if "heldout_by_lateral_mm" in result:
        print(_command_module("twin.tools.evaluation_report").format_heldout(result["heldout_by_lateral_mm"]))
        for name in result["lateral_rms_mm"]:
            print(
                f"{name}, all held-out taps: θ RMS {result['orientation_rms_deg'][name]:.2f}°, "
                f"lateral RMS {result['lateral_rms_mm'][name]:.2f} mm"
            )
        if "edge_figures" in result:
            print(_command_module("twin.tools.edge_figures_report").format_edge_figures([result["edge_figures"]]))
        print(f"wrote {args.out}/heldout.csv and heldout.json")
        return 0
    print(_command_module("twin.tools.evaluation_report").format_table(result["table_i_rms_orientation_deg"]))
    if "table_i_shift_free" in result:
        print(_command_module("twin.tools.evaluation_report").format_shift_free(result["table_i_shift_free"]))
    print(
        _command_module("twin.tools.evaluation_report").format_paper_finding(
            result["paper_finding"], result["paper"]["finding"]
        )
    )
    for name, v in result["lateral_rms_mm"].items():
        print(f"lateral RMS error, {name}: {v:.2f} mm (paper: 2.15 mm)")
    print(f"variance explained by 3 PCs: {100 * result['variance_explained_3pc']:.1f} % (paper: 88.3 %)")
    print(_command_module("twin.tools.evaluation_report").format_orientation_signal(result["orientation_signal_px"]))
    print(_command_module("twin.tools.evaluation_report").format_along_edge_drag(result["along_edge_drag_px"]))
    print(_command_module("twin.tools.evaluation_report").format_along_edge_reading(result["along_edge_reading"]))
    print(f"wrote {args.out}/table_i.csv, table_i.json and the PCA figures")
    return 0


def _cmd_serve_robot(args: argparse.Namespace) -> int:

    _command_module("hardware.virtual_controller").serve_robot(
        args.host,
        args.port,
        realtime_factor=args.realtime,
        idle_timeout_s=args.idle_timeout,
        stall_timeout_s=args.stall_timeout,
        log_limit=args.log_limit,
    )
    return 0


def _cmd_compare(args: argparse.Namespace) -> int:

    r = _command_module("twin.tools.comparison_report").compare_and_report(
        Path(args.run_a),
        Path(args.run_b),
        output_folder(Path(args.out), "twin compare --out"),
        model_path=Path(args.model) if args.model else None,
        slides_a=Path(args.slides_a) if args.slides_a else None,
        slides_b=Path(args.slides_b) if args.slides_b else None,
        **_reach_at(args),
        **({} if args.resamples is None else {"resamples": args.resamples}),
        seed=args.seed,
    )
    _warn(r["unfinished"])
    if not r["n_pairs"]:
        print(
            "no paired samples (no target pose in contact shared, or another camera resolution): compared by "
            "their edge figures"
        )
    else:
        print(f"{r['n_pairs']} paired samples ({r['pairing']})")
        print(f"pin RMS difference: {r['pin_rms_difference_px']:.3f} px")
        c = r["pin_displacement_correlation"]
        if c["mean"] is not None:
            print(f"per-pin displacement correlation: mean {c['mean']:.3f}, min {c['min']:.3f} over {c['pins']} pins")
    if r.get("ssim"):
        print(f"image SSIM: mean {r['ssim']['mean']:.3f}, min {r['ssim']['min']:.3f} over {r['ssim']['frames']} frames")
    for tag in ("a", "b"):
        perc = r.get(f"perception_{tag}") or (r.get(f"metrics_{tag}") or None)
        if perc:
            print(
                f"run {tag.upper()} perception: θ RMS {perc['orientation_rms_deg']:.1f}°, l RMS {perc['lateral_rms_mm']:.2f} mm"
            )
    if "path_distance" in r:
        print(
            f"path distance: mean {r['path_distance']['mean_mm']:.2f} mm, Hausdorff {r['path_distance']['hausdorff_mm']:.2f} mm"
        )
    for tag in ("a", "b"):
        if "orientation_signal_px" in r:
            print(
                _command_module("twin.tools.evaluation_report").format_orientation_signal(
                    r["orientation_signal_px"][tag], f"run {tag.upper()}:"
                )
            )
        if "along_edge_drag_px" in r:
            print(
                _command_module("twin.tools.evaluation_report").format_along_edge_drag(
                    r["along_edge_drag_px"][tag], f"run {tag.upper()}: along-edge"
                )
            )
    if "edge_figures" in r:
        report = _command_module("twin.tools.edge_figures_report")
        if r["shared_taps"]:
            print(f"edge figures on the {r['shared_taps']} samples both runs have (the same taps)")
        print(
            report.format_edge_figures(
                [r["edge_figures"]["a"], r["edge_figures"]["b"]],
                [f"A: {r['edge_figures']['a']['name']}", f"B: {r['edge_figures']['b']['name']}"],
            )
        )
        if "edge_figure_differences" in r:
            print(report.format_figure_differences(r["edge_figure_differences"]))
    print(f"wrote {args.out}/comparison.json and plots")
    if args.video:
        print(
            f"wrote {_command_module('twin.tools.video').write_compare_video(Path(args.run_a), Path(args.run_b), Path(args.out) / 'comparison.mp4')}"
        )
    return 0


def _cmd_calibrate(args: argparse.Namespace) -> int:

    settings = _command_module("twin.analysis.calibration_fit.settings").load_settings(
        Path(args.settings) if args.settings else None
    )
    r = _command_module("twin.tools.calibration_report").calibrate_and_report(
        [Path(r) for r in args.runs],
        _checked_scenario(args.scenario),
        output_folder(Path(args.out), "twin calibrate --out"),
        settings,
        workers=args.workers,
        cluster=args.cluster,
        progress=not args.quiet,
        held_out=[Path(r) for r in args.held_out or []],
    )
    _warn(r["unfinished"] + r["without_pins"])
    print(f"{r['status']} ({r['stop_reason']}); pin RMS {r['before']['overall']:.3f} -> {r['after']['overall']:.3f} px")
    if r["held_out"]:
        h = r["held_out"]
        print(
            f"  held out ({h['samples']} samples, not fitted): {h['before']['overall']:.3f} -> {h['after']['overall']:.3f} px"
        )
    if r["failed_simulations"]:
        print(f"  {len(r['failed_simulations'])} candidates failed their physics checks (ranked last; report.md)")
    rest = r["camera_from_rest"] or {}
    for name, v in rest.get("values", {}).items():
        print(f"  {name} from the no-contact frames = {v:.5g} ± {rest['std'][name]:.2g}")
        if name in rest.get("at_fit", {}):
            flag = "  AT A BOUND: the cameras that meet them end there" if name in rest["at_fit_at_bound"] else ""
            print(f"    tied to them, at the fitted camera = {rest['at_fit'][name]:.5g}{flag}")
    for run, depth in r["nominal_depth_mm"].items():
        print(f"  {run}: its taps press from {depth:g} mm (an import's --depth-mm): tcp.z_mm is measured from there")
    for name, u in r["uncertainty"]["parameters"].items():
        flag = (
            ""
            if u["identifiable"]
            else f"  NOT IDENTIFIABLE ({'; '.join(u['not_identifiable_because'])}): left at the default"
        )
        print(f"  {name} = {u['value']:.5g} ± {u['std']:.2g} (default {u['default']:.5g}){flag}")
    print(
        f"wrote {r['calibration_file']} and {args.out}/report.md ({r['wall_time_s']:.1f} s, "
        f"{r['evaluations_per_s']:.3g} evaluations/s)"
    )
    return 0


def _cmd_figure(args: argparse.Namespace) -> int:

    numbers = _command_module("twin.tools.shear_report").write_shear_figure(
        output_file(Path(args.out), "twin figure --out", ".png"),
        fidelity=args.fidelity,
        friction=not args.no_friction,
        dome=args.dome,
    )
    print(f"wrote {args.out}")
    for key, value in numbers.items():
        print(f"  {key}: {value}")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:

    return _command_module("twin.tools.demo").run_demo(
        output_folder(Path(args.out), "twin demo --out"), seed=args.seed, video=args.video
    )


def _cmd_bench(args: argparse.Namespace) -> int:

    return _command_module("twin.tools.bench").run_bench(
        args.what,
        quick=args.quick,
        out=output_folder(Path(args.out), "twin bench --out") if args.out else None,
        workers=args.workers,
        cluster=args.cluster,
        settings=None if args.settings is None else [n.strip() for n in args.settings.split(",") if n.strip()],
        scenarios=[Path(p) for p in args.scenario],
    )


#: argument types: a seed as the scenario schema bounds it, local processes, a count, seconds
SEED = bounded_int(0, 2**32 - 1, "")
WORKERS = bounded_int(1, 4096, "processes")
COUNT = bounded_int(1, 10**9, "")
TIMEOUT = bounded_float(0, 1e6, "s", open_lo=True)


def _add_reach_at(p: argparse.ArgumentParser) -> None:
    """The edge figures' `--reach-at L [L ...]`: where the reach profile is taken."""
    p.add_argument(
        "--reach-at",
        nargs="+",
        type=bounded_float(-20.0, 20.0, "mm"),
        default=None,
        metavar="L",
        help="lateral positions (mm, + off the object) of the edge figures' reach profile (default: -4 4)",
    )


def _reach_at(args: argparse.Namespace) -> dict:
    """`--reach-at` as the report functions' keyword, when given (their default otherwise)."""
    return {} if args.reach_at is None else {"reach_at": tuple(args.reach_at)}


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(prog="twin", description="TacTip digital twin (Aquilina et al., ICRA 2019)")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("check", help="validate scenario files (and compile their scenes)")
    p.add_argument("scenarios", nargs="+")
    p.add_argument("--no-compile", dest="compile", action="store_false", help="only validate the file")
    p.set_defaults(func=_cmd_check)

    p = sub.add_parser("render", help="render the inside-camera frame or an overview of a scenario")
    p.add_argument("scenario")
    p.add_argument("--out", required=True, help="PNG file to write")
    p.add_argument("--view", choices=("sensor", "scene"), default="sensor")
    p.set_defaults(func=_cmd_render)

    p = sub.add_parser("run", help="run a scenario and record it, or continue an unfinished run (--resume)")
    p.add_argument("scenario", nargs="?", default=None, help="scenario file or shipped name (optional with --resume)")
    p.add_argument(
        "--resume",
        default=None,
        metavar="DIR",
        help="continue an interrupted or killed run after its last complete sample (same scenario and seed)",
    )
    p.add_argument("--out", default=None, help="run directory (default runs/<name>_seed<N>)")
    p.add_argument("--seed", type=SEED, default=None)
    p.add_argument("--backend", choices=("sim", "hardware"), default=None)
    p.add_argument("--hardware-config", default=None, help="robot/camera config for --backend hardware")
    p.add_argument("--workers", type=WORKERS, default=None, help="local processes (default: all cores)")
    p.add_argument("--cluster", default=None, help="Ray address ('local' starts one); needs the ray extra")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument(
        "--video", action="store_true", help="also write RUN/video.mp4: frame, pins, rig and path per sample"
    )
    p.add_argument(
        "--taps-from",
        default=None,
        metavar="RUN",
        help="sheared_taps scenarios: replay the taps of RUN (an imported lab recording) in order",
    )
    p.add_argument(
        "--first-taps", type=COUNT, default=None, metavar="N", help="with --taps-from: only the first N taps"
    )
    p.add_argument(
        "--every-nth-tap",
        type=COUNT,
        default=None,
        metavar="K",
        help="with --taps-from: every K-th tap from the first (before --first-taps): a sample spread over "
        "a recording ordered by pose",
    )
    p.add_argument(
        "--without-slides",
        action="store_true",
        help="with --taps-from: each tap without its in-contact slide and twist (the unslid imprint at its pose)",
    )
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser(
        "import-lab",
        help="import a recording in the lab's format (frames, targets CSV, init_0.png) "
        "as a run that evaluate, compare and calibrate read",
    )
    p.add_argument("folder", help="the folder of frames (with init_0.png or init.png)")
    p.add_argument("--targets", required=True, help="the targets CSV (image_name, pose_1..6, move_1..6)")
    p.add_argument("--out", required=True, help="run directory to write")
    p.add_argument("--init", default=None, help="the no-contact frame (default FOLDER/init_0.png or init.png)")
    p.add_argument(
        "--depth-mm",
        type=bounded_float(-50, 50, "mm"),
        default=3.0,
        help="the taps' depth at pose_3 = 0, which the lab does not record (mm; default 3)",
    )
    p.add_argument(
        "--object-side",
        default="+y",
        help="the lab's y side the object lies on: +y (default, the DigiTac edge set) or -y",
    )
    p.add_argument(
        "--edge-radius-mm",
        type=bounded_float(0, 10, "mm"),
        default=0.0,
        help="the tapped edge's radius, which the lab does not record: the run's rectangle is "
        "rounded by it, as a twin calibrated on the run must be (mm; default 0, sharp)",
    )
    p.add_argument("--limit", type=COUNT, default=None, metavar="N", help="only the first N targets")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_import_lab)

    p = sub.add_parser("video", help="write the MP4 of a recorded run (one frame per sample)")
    p.add_argument("run", help="run directory")
    p.add_argument("--out", default=None, help="MP4 file (default RUN/video.mp4)")
    p.set_defaults(func=_cmd_video)

    p = sub.add_parser("view", help="run a scenario in MuJoCo's interactive viewer (needs a display)")
    p.add_argument("scenario")
    p.add_argument("--seed", type=SEED, default=None)
    p.add_argument("--no-wait", action="store_true", help="close the window when the scenario ends")
    p.set_defaults(func=_cmd_view)

    p = sub.add_parser(
        "evaluate",
        help="the paper's offline test: Table I from a tap run and a slides run (or the errors on a held-out tap run)",
    )
    p.add_argument("--train", required=True, help="tap run directory")
    p.add_argument(
        "--test",
        required=True,
        help="multi-directional slides run directory, or a held-out tap run (scenarios/taps_heldout.yaml)",
    )
    p.add_argument("--out", required=True)
    p.add_argument("--seed", type=SEED, default=0)
    p.add_argument(
        "--shift-free",
        action="store_true",
        help="Table I's PCA + GP row also with every frame's uniform shift taken out (one more training)",
    )
    _add_reach_at(p)
    p.set_defaults(func=_cmd_evaluate)

    p = sub.add_parser("serve-robot", help="answer the IRB120's RAPID socket protocol with the simulated arm")
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument(
        "--port",
        type=bounded_int(0, 65535, "(TCP port)"),
        default=5000,
        help="TCP port to listen on; 0 = any free port (the one taken is printed)",
    )
    p.add_argument(
        "--realtime",
        type=bounded_float(0, 1000, "(time scale)"),
        default=0.0,
        help="1 = moves take their real duration; 0 = instant",
    )
    p.add_argument(
        "--idle-timeout",
        type=TIMEOUT,
        default=300.0,
        metavar="S",
        help="drop a client that sends nothing for S seconds (default 300)",
    )
    p.add_argument(
        "--stall-timeout",
        type=TIMEOUT,
        default=5.0,
        metavar="S",
        help="drop a client that stops S seconds into a command (default 5)",
    )
    p.add_argument(
        "--log-limit",
        type=bounded_int(1, 10_000_000, "commands"),
        default=10_000,
        metavar="N",
        help="keep the last N commands and moves in memory (default 10000)",
    )
    p.set_defaults(func=_cmd_serve_robot)

    p = sub.add_parser("compare", help="compare two runs of one scenario (sim vs sim, sim vs real)")
    p.add_argument("run_a")
    p.add_argument("run_b")
    p.add_argument("--out", required=True)
    p.add_argument("--model", default=None, help="perception model file to score labelled runs (taps, slides)")
    p.add_argument(
        "--video", action="store_true", help="also write OUT/comparison.mp4: the paired samples side by side"
    )
    p.add_argument(
        "--slides-a",
        default=None,
        metavar="RUN",
        help="a plain tap run A's slides run: its along-edge drag in the edge figures",
    )
    p.add_argument("--slides-b", default=None, metavar="RUN", help="the same for run B")
    _add_reach_at(p)
    p.add_argument(
        "--resamples",
        type=bounded_int(0, 1000, "(bootstrap resamples)"),
        default=None,
        help="sheared taps both runs share: bootstrap resamples of them for each edge figure's difference "
        "(default 50; 0: none)",
    )
    p.add_argument("--seed", type=SEED, default=0, help="seed of those resamples")
    p.set_defaults(func=_cmd_compare)

    p = sub.add_parser(
        "calibrate", help="fit the twin's camera, rest pins, dome material, friction and TCP to recorded runs"
    )
    p.add_argument(
        "runs", nargs="+", help="recorded run directories (sim or hardware) of the scenario's sensor and object"
    )
    p.add_argument("--scenario", required=True, help="the twin to fit (its object, fidelity, effects)")
    p.add_argument("--out", required=True, help="directory for calibration.yaml, the report and the checkpoint")
    p.add_argument(
        "--settings",
        default=None,
        help="fitted parameters, bounds, priors, weights, optimiser "
        "(merged over assets/tactip/calibration_settings.yaml)",
    )
    p.add_argument("--workers", type=WORKERS, default=None, help="local processes (default: all cores)")
    p.add_argument("--cluster", default=None, help="Ray address ('local' starts one); needs the ray extra")
    p.add_argument(
        "--held-out",
        nargs="+",
        default=None,
        metavar="RUN",
        help="runs not fitted, only predicted before and after (pin RMS with the fit's rest layout)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_calibrate)

    p = sub.add_parser(
        "figure", help="the paper's Fig. 2: pin traces tapping vs sliding across the edge in 8 directions"
    )
    p.add_argument("which", choices=("shear",))
    p.add_argument("--out", default="out/fig2_shear.png")
    p.add_argument("--fidelity", choices=("fast", "default", "reference"), default="default")
    p.add_argument("--no-friction", action="store_true", help="frictionless contact: slides should match taps")
    p.add_argument("--dome", choices=list(DOME_MODELS), default=DEFAULT_DOME, help="the dome model (scenario `dome`)")
    p.set_defaults(func=_cmd_figure)

    p = sub.add_parser("demo", help="the main job: the six-object contour-following demo")
    p.add_argument("--out", default="out/demo")
    p.add_argument("--seed", type=SEED, default=0)
    p.add_argument("--video", action="store_true", help="also write OUT/<run>/video.mp4 for each object")
    p.set_defaults(func=_cmd_demo)

    p = sub.add_parser("bench", help="print speed figures and sweep what accuracy costs in time")
    p.add_argument(
        "what",
        nargs="?",
        default="all",
        choices=("all", "render", "pixels", "physics", "perception", "throughput", "startup", "sweep"),
        help="one section (default: all; 'sweep' = the fidelity sweep: CSV, Pareto plot, markdown table)",
    )
    p.add_argument("--quick", action="store_true", help="small sections and the quick sweep (< 2 min on 2 cores)")
    p.add_argument(
        "--out", default=None, help="directory for the CSVs and the sweep's files (sweep default: out/bench)"
    )
    p.add_argument("--workers", type=WORKERS, default=None, help="sweep: local processes (default: all cores)")
    p.add_argument("--cluster", default=None, help="sweep: Ray address ('local' starts one); needs the ray extra")
    p.add_argument(
        "--settings",
        default=None,
        help="sweep: only these settings of the full sweep, comma-separated (names as in sweep.md; "
        "the reference must be among them), e.g. reference,fast,default,gl_renderer",
    )
    p.add_argument(
        "--scenario",
        action="append",
        default=[],
        metavar="FILE",
        help="physics: also time this scenario's dome (its physics, dome material and friction) on the same "
        "edge and steps, beside the flex default (repeatable)",
    )
    p.set_defaults(func=_cmd_bench)
    return parser


def _raise_terminated(signum, frame) -> None:
    raise Terminated("SIGTERM")


def main(argv: list[str] | None = None) -> int:
    """Run one command; its exit code (twin.tools.boundary: 0, 1, 2, 130, 143)."""
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _raise_terminated) if main_thread else None
    try:
        return guarded(lambda: _run(argv))
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, previous)


def _run(argv: list[str] | None) -> int:
    args = build_parser().parse_args(argv)
    one_blas_thread()
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
