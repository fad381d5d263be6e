"""The one C extension of lpbounds; everything else is declared in pyproject.toml.

``lpbounds._kernels.rowsweeps``: the row sweeps of exact DP (``lpbounds._kernels.native``
says why they are not numba's). No numpy headers (the buffer protocol). ``-ffp-contract=off``:
no fused multiply-add, so the numbers are bit-identical to the numpy twins' on every CPU
(gcc contracts ``a * b + c`` by default where the CPU has FMA).
"""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "lpbounds._kernels.rowsweeps",
            sources=["src/lpbounds/_kernels/rowsweeps.c"],
            extra_compile_args=["-O3", "-ffp-contract=off", "-std=c99"],
        )
    ]
)
