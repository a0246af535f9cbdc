"""An external algorithm that exits 0 but writes an unreadable trajectory (slamlab's test of
malformed output)."""
import sys

with open(f"{sys.argv[2]}/estimate.tum", "w") as f:
    f.write("0.000000 0 0 0 0 0 0 1\n")
    f.write("this is not a pose\n")
