"""How well a contour-following run traced its object: path distance from the true contour
(mm), perceived orientation and lateral errors (deg, mm), coverage, and how it ended."""

from __future__ import annotations

import numpy as np

from twin.control.contour import COVERAGE_RADIUS_MM
from twin.core.poses import work_to_object_xy, wrap_deg

#: the stop reasons of a run that traced its contour (the others: step limit, lost the contour, out of reach)
COMPLETED_STOPS = ("loop closed", "end of contour")


def contour_metrics(run, stimulus) -> dict:
    """The per-run metrics of a contour-following run (units in the key names)."""
    samples = run.samples
    xy_work = np.array([[s["pose"][0], s["pose"][1]] for s in samples])
    xy_obj = work_to_object_xy(xy_work)
    lab = {
        k: np.array([s["labels"][k] for s in samples])
        for k in ("perceived_normal_deg", "true_normal_deg", "lateral_hat_mm", "true_lateral_mm", "ok")
    }
    ok = lab["ok"].astype(bool)
    d_angle = wrap_deg(lab["perceived_normal_deg"] - lab["true_normal_deg"])
    path_dist = stimulus.distance_to_contour(xy_obj)
    trace = stimulus.trace_path(1.0)
    gaps = np.min(np.linalg.norm(trace[:, None, :] - xy_obj[None, :, :], axis=2), axis=1) if len(xy_obj) else np.inf
    status = run.meta.get("status")
    stop = run.meta.get("stop_reason", "")
    return {
        "object": stimulus.name,
        "run_state": run.state,
        "completed": bool(status == "completed" and stop in COMPLETED_STOPS),
        "stop_reason": stop,
        "steps": len(samples),
        "orientation_rms_deg": float(np.sqrt(np.mean(d_angle[ok] ** 2))) if ok.any() else float("nan"),
        "lateral_rms_mm": float(np.sqrt(np.mean((lab["lateral_hat_mm"] - lab["true_lateral_mm"])[ok] ** 2)))
        if ok.any()
        else float("nan"),
        "path_distance_mean_mm": float(np.mean(path_dist)),
        "path_distance_max_mm": float(np.max(path_dist)),
        "coverage": float(np.mean(gaps <= COVERAGE_RADIUS_MM)),
        "sim_time_s": float(samples[-1]["time"]) if samples else 0.0,
        "wall_time_s": float(run.meta.get("wall_time_s", float("nan"))),
        "lost_contact_steps": int((~ok).sum()),
    }
