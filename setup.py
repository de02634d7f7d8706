"""Build of haptex's C core (``haptex.core._ext``); everything else is in pyproject.toml.

The core's sources are real C99 files under ``src/haptex/core/`` (shipped in the package
too: ``haptex export`` copies them). A failed build says which compiler and header it needed.
"""

import os
import sysconfig
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy
from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

CORE = Path("src/haptex/core")
GCC_FLAGS = ("-std=c99", "-O2", "-fno-fast-math", "-fno-math-errno")
"""gcc's, clang's and mingw-w64's flags for the core (IEEE arithmetic: the NumPy oracle's)."""
MSVC_FLAGS = ("/O2", "/fp:precise", "/std:c11")
"""MSVC's (untried here: the core's atomics are gcc's and clang's __atomic builtins, which MSVC
lacks; see the firmware guide's 'Where it runs')."""


class BuildCore(build_ext):
    """build_ext whose failure names what the C core needs, compiling the core's sources on all
    cores (setuptools compiles an extension's sources one after another: 8.6 s here, 4.6 s on 2)."""

    def build_extension(self, ext):
        # flags by compiler, set here only: MSVC takes its own spelling (its C is C11/C17;
        # /fp:precise is its default IEEE behaviour, -fno-fast-math's); gcc, clang and mingw-w64
        # take gcc's
        if self.compiler.compiler_type == "msvc":
            ext.extra_compile_args = list(MSVC_FLAGS)
        else:
            ext.extra_compile_args = list(GCC_FLAGS)
        serial = self.compiler.compile

        def compile_each(sources, *args, **kwargs):  # one compiler process a source, on a pool of threads
            with ThreadPoolExecutor(max(1, min(len(sources), os.cpu_count() or 1))) as pool:
                return [obj for objs in pool.map(lambda src: serial([src], *args, **kwargs), sources) for obj in objs]

        self.compiler.compile = compile_each
        try:
            super().build_extension(ext)
        finally:
            self.compiler.compile = serial

    def run(self):
        try:
            super().run()
        except Exception as exc:  # the compiler's own message is above; this says what to install
            include = sysconfig.get_paths()["include"]
            raise SystemExit(
                f"haptex: building the C core failed ({exc}). It needs a C99 compiler (gcc or clang; on Debian: "
                f"apt-get install gcc) and Python's headers ({include}/Python.h; on Debian: apt-get install "
                "python3-dev). Users without a compiler install a prebuilt wheel (see README, 'Wheels')."
            ) from exc


setup(
    ext_modules=[
        Extension(
            "haptex.core._ext",
            sources=[str(CORE / "_ext.c"), *(str(c) for c in sorted(CORE.glob("hx_*.c")))],
            include_dirs=[str(CORE), numpy.get_include()],  # NumPy's C API: Renderer.step reads a row in place
            depends=[str(h) for h in sorted(CORE.glob("*.h"))],
        )
    ],
    cmdclass={"build_ext": BuildCore},
)
