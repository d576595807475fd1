"""Every EVERY-th tap of an imported lab recording from tap OFFSET, as a recording of its
own: the no-contact frame, then those taps with their frames, their rows renumbered and the
scenario's given taps cut to match (finding-2026-11-29-pin-posts' quarter.py with the step
and the first tap as arguments). 200 fitted: EVERY 25, OFFSET 0; 200 held out: 25, 12.
usage: subset.py IMPORTED OUT EVERY OFFSET"""

import json
import shutil
import sys
from pathlib import Path

source, out = Path(sys.argv[1]), Path(sys.argv[2])
EVERY, OFFSET = int(sys.argv[3]), int(sys.argv[4])
meta = json.loads((source / "run.json").read_text())
rows = [json.loads(line) for line in (source / "samples.jsonl").read_text().splitlines()]
kept = [r for r in rows if r["labels"].get("no_contact")][:1]
kept += [r for r in rows if not r["labels"].get("no_contact") and r["labels"]["tap"] % EVERY == OFFSET]
given = meta["scenario"]["protocol"]["given"]
taps = []
(out / "frames").mkdir(parents=True)
for k, row in enumerate(kept):
    if row.get("frame"):
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
