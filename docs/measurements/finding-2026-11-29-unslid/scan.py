"""The still taps' signal profile (twin.analysis.edge_imprint.signal_profile: the edge's
orientation signal at each l over its value at l = 0) of physics variants, each a change
to BASE's physics (or `depth_mm`, the protocol's), 420 taps over l −6.5 … +0.5 mm, the
same draw for every variant, so differences between variants are paired.

usage: scan.py BASE.yaml VARIANTS.json OUTDIR   (the repository on PYTHONPATH)"""

import json
import subprocess
import sys
from pathlib import Path

import yaml

from twin.analysis.edge_imprint import signal_profile
from twin.runs.record import load_run

base_path, variants_path, out = map(Path, sys.argv[1:4])
out.mkdir(exist_ok=True)
base = yaml.safe_load(base_path.read_text())
base["protocol"].update(taps=420, lateral_range_mm=[-6.5, 0.5])
for name, change in json.loads(variants_path.read_text()).items():
    scenario = json.loads(json.dumps(base))
    for key, value in change.items():
        if key == "depth_mm":
            scenario["protocol"]["depth_mm"] = value
        elif value is None:
            scenario["physics"].pop(key, None)
        else:
            scenario["physics"][key] = value
    scenario["name"] = "still_" + name
    path = out / f"{name}.yaml"
    path.write_text(yaml.safe_dump(scenario, sort_keys=False))
    run_dir = out / f"run_{name}"
    if not (run_dir / "samples.jsonl").exists():
        cmd = ["twin", "run", str(path), "--out", str(run_dir), "--workers", "2", "--quiet"]
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode:
            print(name, "failed", done.stderr[-400:], flush=True)
            continue
    (row,) = signal_profile(load_run(run_dir)).values()
    print(f"{name:24s} " + " ".join(f"{l:+.0f}:{v:.2f}" for l, v in sorted(row.items())), flush=True)
