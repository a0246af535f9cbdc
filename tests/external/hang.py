"""An external algorithm that never finishes (slamlab's timeout test), with a child of its own
that must be killed with it."""
import subprocess
import sys
import time

subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
time.sleep(120)
