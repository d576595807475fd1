"""Run videos: an MP4 per recorded run, one video frame per sample, made from the run
directory (twin.runs.record), so a video can be made during `twin run --video` or after
the fact with `twin video RUN`; and a side-by-side video of two runs (`twin compare --video`).

A run's frame (1120 × 480 px for a 640 × 480 camera):

| left (camera frame, scaled to 480 px high)   | right top: the rig (arm, sensor, object), 480 × 240 |
| pins (green, red = lost) and their           | right bottom: the object seen from above, the path  |
| displacement from rest ×DISPLACEMENT_GAIN;   | so far (blue) and the perceived edge normals (grey) |
| time, pose, θ̂ / l̂ (or the protocol's labels) |                                                      |

Encoded with imageio's ffmpeg plugin (H.264, yuv420p), headless.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np
from matplotlib import font_manager
from PIL import Image, ImageDraw, ImageFont

from twin.analysis.comparison import paired_runs
from twin.core.errors import UserError
from twin.core.poses import Pose
from twin.core.scenario import scenario_from_dict
from twin.runs.contour_run import object_path
from twin.runs.record import Run, load_run
from twin.runs.spec import load_scenario_stimulus, scene_spec
from twin.world.render import OverviewRenderer
from twin.world.scene import Overview

VIDEO_FPS = 10  # frames/s: one frame per sample
QUALITY = 8  # imageio-ffmpeg quality, 0–10 (10 = best)
PANEL_HEIGHT = 480  # px: the camera frame is scaled to this height
SIDE_SIZE = (480, 240)  # px (width, height) of the scene and path panels
COMPARE_PANEL = (480, 360)  # px (width, height) of each panel of a comparison
DISPLACEMENT_GAIN = 3.0  # pin displacement arrows drawn this many times their length
NORMAL_LENGTH_MM = 8.0  # perceived edge normals drawn this long
PIN_COLOUR, LOST_COLOUR, ARROW_COLOUR = (60, 230, 60), (255, 60, 60), (255, 210, 0)
PAIR_COLOURS = ((255, 150, 30), (40, 200, 255))  # run A, run B (RGB)
TEXT_COLOUR = (255, 255, 255)
FONT_PX = 17


@lru_cache(maxsize=1)
def _font() -> ImageFont.FreeTypeFont:
    """DejaVu Sans (shipped with matplotlib): it has θ and the combining circumflex."""
    return ImageFont.truetype(font_manager.findfont("DejaVu Sans"), FONT_PX)


def write_text(image: np.ndarray, lines: list[str], corner: str = "top-left", colour=TEXT_COLOUR) -> np.ndarray:
    """Write `lines` into a corner of an RGB image (in place; returned)."""
    font = _font()
    h, w = image.shape[:2]
    step = FONT_PX + 4
    block_w = max(int(font.getlength(line)) for line in lines) + 12
    x = 6 if corner.endswith("left") else w - block_w + 6
    y = 4 if corner.startswith("top") else h - step * len(lines) - 4
    y0, y1, x0, x1 = max(y - 2, 0), min(y + step * len(lines) + 2, h), max(x - 6, 0), min(x - 6 + block_w, w)
    pil = Image.fromarray(np.ascontiguousarray(image[y0:y1, x0:x1]))
    draw = ImageDraw.Draw(pil)
    for n, line in enumerate(lines):
        draw.text((x - x0, y - y0 + n * step), line, font=font, fill=colour)
    image[y0:y1, x0:x1] = np.asarray(pil)
    return image


def draw_pin_field(
    image: np.ndarray,
    pins_px: np.ndarray,
    rest_px: np.ndarray,
    scale: float = 1.0,
    found: np.ndarray | None = None,
    colour=PIN_COLOUR,
    arrow_colour=ARROW_COLOUR,
) -> np.ndarray:
    """Draw pins (127, 2) px and their displacement from `rest_px` (×DISPLACEMENT_GAIN) on
    an RGB image whose pixels are `scale` camera pixels (in place; returned). Lost pins
    (found False) are drawn in LOST_COLOUR, pins without a position (NaN) not at all."""
    ok = np.all(np.isfinite(pins_px), axis=1) & np.all(np.isfinite(rest_px), axis=1)
    lost = np.zeros(len(pins_px), bool) if found is None else ~np.asarray(found, bool)
    with np.errstate(invalid="ignore"):
        starts, ends, centres = (
            np.nan_to_num(np.round(p)).astype(int).tolist()
            for p in (rest_px * scale, (rest_px + DISPLACEMENT_GAIN * (pins_px - rest_px)) * scale, pins_px * scale)
        )
    for k in np.flatnonzero(ok):
        if starts[k] != ends[k]:
            cv2.line(image, starts[k], ends[k], arrow_colour, 1, cv2.LINE_AA)
        cv2.circle(image, centres[k], 2, LOST_COLOUR if lost[k] else colour, -1, cv2.LINE_AA)
    return image


def sensor_panel(
    frame: np.ndarray | None,
    resolution: tuple[int, int],
    pins_px: np.ndarray | None,
    rest_px: np.ndarray,
    found: np.ndarray | None = None,
    height: int = PANEL_HEIGHT,
) -> np.ndarray:
    """The camera frame (black where a run kept none), scaled to `height` px, with the
    pins and their displacement from rest drawn on it (RGB uint8)."""
    width_cam, height_cam = resolution
    scale = height / height_cam
    width = 2 * int(round(width_cam * scale / 2))  # even: H.264 with 4:2:0 chroma
    if frame is None:
        panel = np.zeros((height, width, 3), np.uint8)
    elif frame.shape[:2] == (height, width):
        panel = frame.copy()
    else:
        panel = cv2.resize(frame, (width, height), interpolation=cv2.INTER_AREA)
    if pins_px is not None:
        draw_pin_field(panel, np.asarray(pins_px, float), rest_px, scale, found)
    return panel


def _pose_text(pose) -> str:
    x, y, z, _, _, gamma = pose
    return f"x {x:.1f}  y {y:.1f}  z {z:.1f} mm  γ {gamma:.0f}°"


def percept_text(labels: dict) -> str:
    """θ̂ / l̂ of a contour step, or the labels an open-loop protocol recorded (θ, l)."""
    if "theta_hat_deg" in labels:
        return f"θ̂ {labels['theta_hat_deg']:.1f}°  l̂ {labels['lateral_hat_mm']:.2f} mm"
    parts = []
    if "theta_deg" in labels:
        parts.append(f"θ {labels['theta_deg']:.0f}°")
    if "lateral_mm" in labels:
        parts.append(f"l {labels['lateral_mm']:.1f} mm")
    if "direction_deg" in labels:
        parts.append(f"slide {labels['direction_deg']:.0f}°")
    return "  ".join(parts) or "no labels"


class PathPanel:
    """The object seen from above (object frame, mm), the sensor's path so far and the
    perceived edge normals, drawn with OpenCV at a fixed scale for the whole run."""

    def __init__(
        self, run: Run, outline_mm: np.ndarray, size: tuple[int, int] = SIDE_SIZE, margin_mm: float = 12.0
    ) -> None:
        self.xy, self.normals_deg = object_path(run.samples)
        w, h = size
        points = np.vstack([outline_mm, self.xy]) if len(self.xy) else outline_mm
        lo, hi = points.min(axis=0) - margin_mm, points.max(axis=0) + margin_mm
        self.scale = min(w / (hi[0] - lo[0]), h / (hi[1] - lo[1]))  # px per mm
        self.origin = np.array([w / 2, h / 2]) - self.scale * np.array([(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2])
        self.background = np.full((h, w, 3), 255, np.uint8)
        outline = self._px(outline_mm)
        cv2.fillPoly(self.background, [outline], (232, 232, 232), cv2.LINE_AA)
        cv2.polylines(self.background, [outline], True, (128, 128, 128), 1, cv2.LINE_AA)

    def _px(self, xy_mm: np.ndarray) -> np.ndarray:
        """Object-frame mm (seen from above, y up) → panel px (y down), int32 for OpenCV."""
        xy = np.atleast_2d(xy_mm)
        return np.round(self.origin + self.scale * np.column_stack([xy[:, 0], -xy[:, 1]])).astype(np.int32)

    def draw(self, k: int) -> np.ndarray:
        """The panel after sample k (RGB uint8)."""
        panel = self.background.copy()
        if self.normals_deg is not None:
            a = np.radians(self.normals_deg[: k + 1])
            tips = self.xy[: k + 1] - NORMAL_LENGTH_MM * np.column_stack([np.cos(a), np.sin(a)])
            for p, q in zip(self._px(self.xy[: k + 1]), self._px(tips)):
                cv2.line(panel, tuple(map(int, p)), tuple(map(int, q)), (150, 150, 150), 1, cv2.LINE_AA)
        path = self._px(self.xy[: k + 1])
        cv2.polylines(panel, [path], False, (31, 119, 180), 2, cv2.LINE_AA)
        cv2.circle(panel, tuple(map(int, path[0])), 4, (44, 160, 44), -1, cv2.LINE_AA)
        cv2.circle(panel, tuple(map(int, path[-1])), 4, (214, 39, 40), -1, cv2.LINE_AA)
        return panel


class ScenePanel:
    """The rig (table, IRB120, TacTip, object) with the arm re-posed per sample: the
    overview model is compiled once and rendered with one GL context, without shadows
    (on llvmpipe they took 140 of a frame's 160 ms)."""

    def __init__(self, scenario, size: tuple[int, int] = SIDE_SIZE) -> None:
        self.overview = Overview(scene_spec(scenario))
        lookat = self.overview.object2world[:3, 3] + np.array([-0.15, 0.0, 0.2])  # between base and object
        self.renderer = OverviewRenderer(
            self.overview.model, *size, lookat=lookat, distance=1.0, azimuth=120.0, elevation=-25.0, shadows=False
        )

    def draw(self, pose) -> np.ndarray:
        """The rig with the sensor at `pose` (work frame, [x, y, z, α, β, γ] mm/deg)."""
        self.overview.pose_sensor(Pose.from_array(pose))
        return self.renderer.render(self.overview.data)

    def close(self) -> None:
        self.renderer.close()


def run_scenario_of(run: Run):
    """The validated scenario a run recorded (paths resolved against its original file)."""
    return scenario_from_dict(run.meta["scenario"], run.meta.get("scenario_file") or "<inline>")


@dataclass
class VideoWriter:
    """An MP4 file written frame by frame (H.264, yuv420p, VIDEO_FPS)."""

    path: Path
    fps: float = VIDEO_FPS

    def __enter__(self) -> VideoWriter:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._writer = imageio.get_writer(
            str(self.path),
            format="FFMPEG",
            fps=self.fps,
            codec="libx264",
            quality=QUALITY,
            pixelformat="yuv420p",
            macro_block_size=2,
            ffmpeg_log_level="error",
        )
        self.frames = 0
        return self

    def add(self, image: np.ndarray) -> None:
        self._writer.append_data(image)
        self.frames += 1

    def __exit__(self, *exc) -> None:
        self._writer.close()


def run_frame(run: Run, k: int, scene: ScenePanel, path: PathPanel, rest_px: np.ndarray) -> np.ndarray:
    """Video frame of sample k: camera frame with pins | rig over path (RGB uint8)."""
    s = run.samples[k]
    found = None if s["found"] is None else np.asarray(s["found"], bool)
    left = sensor_panel(run.frame(k), run.resolution, run.sample_pins(k), rest_px, found)
    write_text(left, [f"t {s['time']:.2f} s   sample {k + 1}/{len(run.samples)}", _pose_text(s["pose"])])
    write_text(left, [percept_text(s["labels"])], "bottom-left")
    write_text(left, [f"pins, displacement ×{DISPLACEMENT_GAIN:g}"], "bottom-right")
    right = np.vstack([scene.draw(s["pose"]), path.draw(k)])
    pad = left.shape[0] - right.shape[0]
    if pad > 0:
        right = np.vstack([right, np.zeros((pad, right.shape[1], 3), np.uint8)])
    return np.hstack([left, right[: left.shape[0]]])


def write_run_video(run_dir: Path, out: Path | None = None) -> Path:
    """Write the MP4 of a recorded run (default RUN/video.mp4); returns its path."""
    run = load_run(run_dir)
    if not run.samples:
        raise UserError(f"{run_dir}: the run recorded no samples: nothing to show")
    out = Path(out) if out is not None else Path(run_dir) / "video.mp4"
    scenario = run_scenario_of(run)
    outline = np.asarray(load_scenario_stimulus(scenario).outline.exterior.coords)
    scene, path = ScenePanel(scenario), PathPanel(run, outline)
    rest = run.rest_pins_px
    try:
        with VideoWriter(out) as writer:
            for k in range(len(run.samples)):
                writer.add(run_frame(run, k, scene, path, rest))
    finally:
        scene.close()
    return out


def compare_frame(a: Run, b: Run, i: int, j: int, n: int, total: int) -> np.ndarray:
    """Video frame of the pair (sample i of a, sample j of b): A's frame, B's frame, and
    both pin fields overlaid (A orange, B blue), COMPARE_PANEL each (RGB uint8)."""
    w, h = COMPARE_PANEL
    panels = []
    overlay = np.zeros((h, w, 3), np.uint8)
    for run, k, colour, tag in ((a, i, PAIR_COLOURS[0], "A"), (b, j, PAIR_COLOURS[1], "B")):
        s, rest = run.samples[k], run.rest_pins_px
        panel = sensor_panel(run.frame(k), run.resolution, None, rest, height=h)
        scale = h / run.resolution[1]
        for image in (panel, overlay):
            draw_pin_field(image, run.sample_pins(k), rest, scale, colour=colour, arrow_colour=colour)
        meta = run.meta
        write_text(
            panel,
            [
                f"{tag}: {meta['scenario']['name']} ({meta['backend']}, {meta['scenario']['fidelity']})",
                f"sample {k + 1}  t {s['time']:.2f} s",
            ],
            colour=colour,
        )
        write_text(panel, [percept_text(s["labels"])], "bottom-left")
        panels.append(panel[:, :w] if panel.shape[1] >= w else np.pad(panel, ((0, 0), (0, w - panel.shape[1]), (0, 0))))
    d2 = np.sum((a.sample_pins(i) - b.sample_pins(j)) ** 2, axis=1)
    rms = float(np.sqrt(np.mean(d2[np.isfinite(d2)]))) if np.isfinite(d2).any() else float("nan")
    write_text(
        overlay,
        [f"pair {n + 1}/{total}", "target " + _pose_text(a.samples[i]["target"]), f"pin RMS difference {rms:.2f} px"],
    )
    write_text(overlay, ["A"], "bottom-left", colour=PAIR_COLOURS[0])
    write_text(overlay, [f"B   (displacement ×{DISPLACEMENT_GAIN:g})"], "bottom-right", colour=PAIR_COLOURS[1])
    return np.hstack([*panels, overlay])


def write_compare_video(dir_a: Path, dir_b: Path, out: Path) -> Path:
    """Write the MP4 of two runs side by side, paired as `twin compare` pairs them
    (twin.analysis.comparison.paired_runs); returns its path."""
    a, b = load_run(dir_a), load_run(dir_b)
    pairs, _ = paired_runs(a, b)
    with VideoWriter(Path(out)) as writer:
        for n, (i, j) in enumerate(pairs):
            writer.add(compare_frame(a, b, i, j, n, len(pairs)))
    return Path(out)
