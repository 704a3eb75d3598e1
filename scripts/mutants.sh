#!/usr/bin/env bash
# rost's mutation check: curated small bugs (scripts/mutants.txt), each applied
# in a scratch copy of this tree, rebuilt, and its tests run; the tree itself is
# left unchanged. Usage: scripts/mutants.sh [--list | --check | --quick | NAME...]
# [--in-build DIR] (DIR: an existing build of this tree, whose files are then
# mutated in place and restored; CI's throw-away clone uses it to skip the
# scratch build). scripts/mutants.py says more. Exit 0 only when every mutant
# was caught.
set -euo pipefail
exec /usr/bin/python3 "$(dirname "$0")/mutants.py" "$@"
