#!/bin/sh
# ctest's entry to the Python tools' tests: PYTHON -m pytest DIR, or exit 77 (ctest's SKIP_RETURN_CODE for
# these tests) with a message when that interpreter lacks pytest or numpy.
py=$1
dir=$2
if ! "$py" -c 'import pytest, numpy' >/dev/null 2>&1; then
  echo "SKIPPED: $py cannot import pytest and numpy (apt-get install python3-pytest python3-numpy, or configure with -DMCA_TOOLS_PYTHON=...)"
  exit 77
fi
PYTHONDONTWRITEBYTECODE=1 exec "$py" -m pytest -q -p no:cacheprovider "$dir"
