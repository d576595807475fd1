"""A full replay's samples on the taps a replay of some of them holds, written as a run
folder: the screens' baseline on their own taps.

    python quarter_base.py FULL_RUN PART_RUN OUT
"""

import json
import shutil
import sys
from pathlib import Path

from twin.runs.pairing import shared_taps
from twin.runs.record import load_run

full_dir, part_dir, out = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
keep = {i for i, _ in shared_taps(load_run(full_dir), load_run(part_dir))}
out.mkdir(parents=True, exist_ok=True)
shutil.copy(full_dir / "run.json", out / "run.json")
lines = (full_dir / "samples.jsonl").read_text().splitlines()
(out / "samples.jsonl").write_text("\n".join(line for line in lines if json.loads(line)["index"] in keep) + "\n")
print(len(keep), "samples")
