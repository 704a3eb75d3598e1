#!/usr/bin/env bash
# rost's mutation check: curated small bugs (scripts/mutants.txt), each applied
# in a scratch copy of this tree, rebuilt, and its tests run; the tree itself is
# left unchanged. Usage: scripts/mutants.sh [--list | --quick | NAME...]
# (scripts/mutants.py says more). Exit 0 only when every mutant was caught.
set -euo pipefail
exec /usr/bin/python3 "$(dirname "$0")/mutants.py" "$@"
