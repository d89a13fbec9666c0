"""Build of the optional compiled kernel (everything else is in pyproject.toml).

``microimpact.engine._ckernel`` is one C file using only the CPython buffer protocol.
It is ``optional``: without a C compiler the install still succeeds and the engine
runs its NumPy kernel (same results, about seven times slower; see docs/performance.md).
The flags keep the IEEE operation order that makes the two kernels agree bit for bit:
no fast-math and no contraction into fused multiply-adds (``-fno-math-errno``
only stops the C library setting errno, which lets GCC vectorise ``sqrt``).
"""

import sys

from setuptools import Extension, setup

if sys.platform == "win32":
    flags = ["/O2", "/fp:precise"]
else:
    # -fno-math-errno: sqrt (areal surfaces) vectorises; it changes no result
    flags = [
        "-O3",
        "-fno-fast-math",
        "-ffp-contract=off",
        "-fno-math-errno",
        "-std=c11",
    ]

setup(
    ext_modules=[
        Extension(
            "microimpact.engine._ckernel",
            sources=["src/microimpact/engine/_ckernel.c"],
            extra_compile_args=flags,
            optional=True,
        )
    ]
)
