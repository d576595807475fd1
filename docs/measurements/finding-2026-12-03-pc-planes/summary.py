"""The B-against-A table of each `twin compare` output folder (the recording as A), as the
tool prints it (twin.tools.edge_figures_report.format_figure_differences), under the pin
RMS difference.

    python summary.py NAME=COMPARE_DIR [NAME=COMPARE_DIR ...]
"""

import json
import sys
from pathlib import Path

from twin.tools.edge_figures_report import format_figure_differences

for arg in sys.argv[1:]:
    name, folder = arg.split("=", 1)
    result = json.loads((Path(folder) / "comparison.json").read_text())
    differences = result["edge_figure_differences"]
    in_a = differences.get("b_in_a_plane")
    if in_a:  # JSON keys are text
        in_a["pc23_deg_per_mm"] = {float(l): v for l, v in in_a["pc23_deg_per_mm"].items()}
    print(f"{name}: pin RMS difference {result['pin_rms_difference_px']:.3f} px")
    print(format_figure_differences(differences))
    print()
