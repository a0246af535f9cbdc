"""An external algorithm that crashes (slamlab's failure test): a Python exception, exit 1."""
import sys

print("reading the inputs ...", file=sys.stderr)
print(1 / 0)
