"""ctest python.import_path: plain /usr/bin/python3, without PYTHONPATH, imports this build's mca (the
set-up's mca.pth names the build's python/ folder; README, "Python")."""
import os
import sys

expected = os.path.realpath(sys.argv[1])
try:
    import mca
except ImportError as e:
    sys.exit(f"import mca failed ({e}): run scripts/setup.sh as root (it writes mca.pth into "
             f"/usr/local/lib/python3.11/dist-packages), or set PYTHONPATH={os.path.dirname(expected)}")
found = os.path.realpath(os.path.dirname(mca.__file__))
if found != expected:
    sys.exit(f"import mca found {found}, not this build's {expected}: the set-up was last run from another "
             f"checkout; run scripts/setup.sh of this one")
print(f"import mca: {found}")
