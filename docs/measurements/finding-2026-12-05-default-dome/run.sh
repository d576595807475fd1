#!/bin/bash
# run.sh: the shipped scenarios (scenarios/*.yaml) exactly as they are, on the default dome
# (the fitted compliant dome, its stiffness scaled to the 4.3 N edge press): the runs of
# ../finding-2026-12-05-shipped-scenarios/run.sh without the dome it adds, with only a
# run's name, the contour runs' tap model and, for two contours, the object as a user STL
# changed. → table-i.txt, heldout.txt, contours.txt beside this script.
# usage: bash run.sh [path/to/twin]
here=$(cd "$(dirname "$0")" && pwd)
AS_SHIPPED=1 OUT="$here" exec bash "$here/../finding-2026-12-05-shipped-scenarios/run.sh" "$@"
