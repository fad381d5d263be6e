"""The C extensions of lpbounds; everything else is declared in pyproject.toml.

Every hot loop of lpbounds is C, compiled here when lpbounds is installed (no JIT):
``lpbounds._kernels.rowsweeps`` (the row sweeps of exact DP), ``rowkernels`` (Q-values, the
game operator, the post-decision form, the aggregation of rows), ``patrolsweeps`` (the
patrol's matrix-free sweeps, encoding and partition key) and ``patrolmc`` (its greedy
Monte Carlo and simulator). Each C file includes ``buffers.h`` first (``patrol.h`` too for
the patrol's); they read arrays through the buffer protocol, so no numpy headers are
needed at build time. ``lpbounds._kernels.extensions`` imports them.

Floating point: no fused multiply-add, so the numbers are bit-identical to the numpy twins'
on every CPU and compiler. gcc and clang contract ``a * b + c`` into an FMA by default where
the CPU has one (and Apple's clang on arm64 always does): ``-ffp-contract=off``. MSVC:
``/fp:precise`` (and ``#pragma fp_contract(off)`` in buffers.h, for versions that contract
under it). The sources are plain C99 with no compiler extensions (no VLAs, no GNU
builtins), so gcc, clang and MSVC build them alike.
"""

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

KERNELS = "src/lpbounds/_kernels"
HEADERS = [f"{KERNELS}/buffers.h"]
PATROL_HEADERS = [*HEADERS, f"{KERNELS}/patrol.h"]

#: compile flags per compiler family (``build_ext.compiler.compiler_type``)
FLAGS = {
    "msvc": ["/O2", "/fp:precise"],
    "unix": ["-O3", "-ffp-contract=off", "-std=c99"],  # gcc, clang (Linux, macOS)
    "mingw32": ["-O3", "-ffp-contract=off", "-std=c99"],
}


class BuildKernels(build_ext):
    """``build_ext`` with the flags of the compiler it found (MSVC takes none of gcc's)."""

    def build_extensions(self) -> None:
        flags = FLAGS.get(self.compiler.compiler_type, FLAGS["unix"])
        for ext in self.extensions:
            ext.extra_compile_args = list(flags)
        super().build_extensions()


def kernel(name: str, headers: list[str]) -> Extension:
    return Extension(f"lpbounds._kernels.{name}", sources=[f"{KERNELS}/{name}.c"], depends=headers)


setup(
    ext_modules=[
        kernel("rowsweeps", HEADERS),
        kernel("rowkernels", HEADERS),
        kernel("patrolsweeps", PATROL_HEADERS),
        kernel("patrolmc", PATROL_HEADERS),
    ],
    cmdclass={"build_ext": BuildKernels},
)
