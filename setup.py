"""The C extensions of lpbounds; everything else is declared in pyproject.toml.

``lpbounds._kernels.rowsweeps``: the row sweeps of exact DP (``lpbounds._kernels.native``
says why they are not numba's). ``lpbounds._kernels.patrolsweeps``: the patrol's
matrix-free sweeps and passes, its encoding and partition key (``lpbounds.patrol.sweeps``);
``lpbounds._kernels.patrolmc``: the greedy policy on the fly, its Monte Carlo returns and
the simulator of Table 1 (``lpbounds.patrol.greedy_mc``, ``.simulation``); both include
``patrol.h`` and ``buffers.h``. No numpy headers (the buffer protocol).
``-ffp-contract=off``: no fused multiply-add, so the numbers are bit-identical to the numpy
twins' on every CPU (gcc contracts ``a * b + c`` by default where the CPU has FMA)."""

from setuptools import Extension, setup

C_ARGS = ["-O3", "-ffp-contract=off", "-std=c99"]
PATROL_H = ["src/lpbounds/_kernels/patrol.h", "src/lpbounds/_kernels/buffers.h"]

setup(
    ext_modules=[
        Extension(
            "lpbounds._kernels.rowsweeps",
            sources=["src/lpbounds/_kernels/rowsweeps.c"],
            extra_compile_args=["-O3", "-ffp-contract=off", "-std=c99"],
        ),
        Extension(
            "lpbounds._kernels.patrolsweeps",
            sources=["src/lpbounds/_kernels/patrolsweeps.c"],
            depends=PATROL_H,
            extra_compile_args=C_ARGS,
        ),
        Extension(
            "lpbounds._kernels.patrolmc",
            sources=["src/lpbounds/_kernels/patrolmc.c"],
            depends=PATROL_H,
            extra_compile_args=C_ARGS,
        ),
    ]
)
