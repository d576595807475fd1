"""Every fourth tap of an imported lab recording as a recording of its own: the no-contact
frame, then taps 0, 4, 8, ... with their frames, their rows renumbered and the scenario's
given taps cut to match, so that `twin run --taps-from OUT` replays those 1,250 taps and
`twin compare OUT RUN` pairs them. A quarter spread over the whole set (the DigiTac set is
ordered by edge angle: its first taps are not a sample of it).
usage: quarter.py IMPORTED OUT [EVERY [FIRST]]  (every EVERY-th tap from tap FIRST; 4, 0)
       quarter.py IMPORTED OUT --slide-across-at-most MM  (the taps that slid at most MM
       across the edge before their frame; finding-2026-12-02-edge-registration)
       quarter.py IMPORTED OUT EVERY FIRST --at-laterals L[,L...]  (of those, the taps whose
       lateral_mm rounds to one of the L, mm; finding-2026-12-02-node-spacing)"""

import json
import shutil
import sys
from pathlib import Path

source, out = Path(sys.argv[1]), Path(sys.argv[2])
if len(sys.argv) > 3 and sys.argv[3] == "--slide-across-at-most":
    limit = float(sys.argv[4])

    def chosen(labels: dict) -> bool:
        return abs(labels["slide_lateral_mm"]) <= limit
else:
    every = int(sys.argv[3]) if len(sys.argv) > 3 else 4
    first = int(sys.argv[4]) if len(sys.argv) > 4 else 0
    laterals = {int(v) for v in sys.argv[6].split(",")} if sys.argv[5:6] == ["--at-laterals"] else None

    def chosen(labels: dict) -> bool:
        at = laterals is None or round(labels["lateral_mm"]) in laterals
        return labels["tap"] % every == first and at


meta = json.loads((source / "run.json").read_text())
rows = [json.loads(line) for line in (source / "samples.jsonl").read_text().splitlines()]
kept = [r for r in rows if r["labels"].get("no_contact")][:1]
kept += [r for r in rows if not r["labels"].get("no_contact") and chosen(r["labels"])]
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
