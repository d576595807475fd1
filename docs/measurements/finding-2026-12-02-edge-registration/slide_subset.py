"""Taps of an imported (or replayed) sheared-tap run whose lateral slide lies within ±LIMIT
mm, as a run of its own. usage: slide_subset.py RUN OUT LIMIT"""

import json
import shutil
import sys
from pathlib import Path

source, out, limit = Path(sys.argv[1]), Path(sys.argv[2]), float(sys.argv[3])
meta = json.loads((source / "run.json").read_text())
rows = [json.loads(line) for line in (source / "samples.jsonl").read_text().splitlines()]
kept = [r for r in rows if r["labels"].get("no_contact")][:1]
kept += [r for r in rows if not r["labels"].get("no_contact") and abs(r["labels"]["slide_lateral_mm"]) <= limit]
given = meta["scenario"]["protocol"]["given"]
taps = []
(out / "frames").mkdir(parents=True)
for k, row in enumerate(kept):
    if row.get("frame") and (source / row["frame"]).exists():
        shutil.copy(source / row["frame"], out / row["frame"])
    if not row["labels"].get("no_contact"):
        taps.append(given[row["labels"]["tap"]])
        row["labels"]["tap"] = len(taps) - 1
    row["index"] = k
meta["scenario"]["protocol"]["given"] = taps
meta["scenario"]["protocol"]["taps"] = len(taps)
meta["samples"] = len(kept)
(out / "run.json").write_text(json.dumps(meta))
(out / "samples.jsonl").write_text("".join(json.dumps(r) + "\n" for r in kept))
print(f"{out}: {len(taps)} taps of {len(given)}")
