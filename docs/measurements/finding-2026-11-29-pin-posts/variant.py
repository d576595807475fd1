"""A variant of a replay scenario, written to NAME.yaml: each KEY=VALUE (VALUE in YAML, null
removes the key) sets `physics.KEY`, the calibration's `material.KEY` (dome_material),
`calibration.KEY` or `object.KEY`; a KEY with dots reaches into nested fields
(`calibration.camera.focal_px`). The description lists the changes.
usage: variant.py BASE.yaml NAME KEY=VALUE...
e.g.:  variant.py ../finding-2026-11-29-sensor-roll/lab_roll133_yield_0.05.yaml posts \
           physics.pins_in_gel=false physics.pin_lever_mm=null "calibration.tcp_offset_mm=[0,0,-0.8]" """

import sys

import yaml

scenario = yaml.safe_load(open(sys.argv[1]))
name = sys.argv[2]
scenario["name"] = name
calibration = scenario["sensor"]["calibration"]
sections = {
    "physics": scenario["physics"],
    "material": calibration["dome_material"],
    "calibration": calibration,
    "object": scenario["object"],
}
for change in sys.argv[3:]:
    key, value = change.split("=", 1)
    section, *path, field = key.split(".")
    target = sections[section]
    for part in path:
        target = target[part]
    value = yaml.safe_load(value)
    if value is None:
        target.pop(field, None)
    else:
        target[field] = value
scenario["description"] += "; changed: " + ", ".join(sys.argv[3:])
with open(f"{name}.yaml", "w") as out:
    yaml.safe_dump(scenario, out, sort_keys=False, allow_unicode=True, width=100)
