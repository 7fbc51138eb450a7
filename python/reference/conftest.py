# Makes `import ivdyn_ref` (and the pinref helpers) work when pytest runs from the repo root.
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
