"""The C extensions of lpbounds; everything else is declared in pyproject.toml.

``lpbounds._kernels.rowsweeps``: the row sweeps of exact DP (``lpbounds._kernels.native``
says why they are not numba's); ``lpbounds._kernels.rowkernels``: the other Bellman-row
kernels (Q-values, the game operator, the post-decision form, the aggregation of rows;
``lpbounds._kernels.ckernels``). No numpy headers (the buffer protocol).
``-ffp-contract=off``: no fused multiply-add, so the numbers are bit-identical to the numpy
twins' on every CPU (gcc contracts ``a * b + c`` by default where the CPU has FMA).
"""

from setuptools import Extension, setup

FLAGS = ["-O3", "-ffp-contract=off", "-std=c99"]

setup(
    ext_modules=[
        Extension(
            "lpbounds._kernels.rowsweeps",
            sources=["src/lpbounds/_kernels/rowsweeps.c"],
            extra_compile_args=FLAGS,
        ),
        Extension(
            "lpbounds._kernels.rowkernels",
            sources=["src/lpbounds/_kernels/rowkernels.c"],
            extra_compile_args=FLAGS,
        ),
        Extension(
            "lpbounds._kernels.patrolsweeps",
            sources=["src/lpbounds/_kernels/patrolsweeps.c"],
            depends=["src/lpbounds/_kernels/patrol.h", "src/lpbounds/_kernels/buffers.h"],
            extra_compile_args=FLAGS,
        ),
        Extension(
            "lpbounds._kernels.patrolmc",
            sources=["src/lpbounds/_kernels/patrolmc.c"],
            depends=["src/lpbounds/_kernels/patrol.h", "src/lpbounds/_kernels/buffers.h"],
            extra_compile_args=FLAGS,
        ),
    ]
)
