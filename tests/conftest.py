"""Run-wide settings for the suite.

Under pytest-xdist (``-n auto``, what README's test command and ``.ci/run`` use) every test
process gets one BLAS / OpenMP thread unless the environment says otherwise: the processes
already take one core each, and two threads each on two shared cores run several times
slower. Set before any test module imports numpy or torch.
"""

import os

if os.environ.get("PYTEST_XDIST_WORKER"):
    for _name in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        os.environ.setdefault(_name, "1")
