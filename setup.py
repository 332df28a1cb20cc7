"""Builds the native contact core (native/, C11) as the extension learned_contact._native.

setuptools' own Extension, not scikit-build-core: the core is a handful of C files with no
dependency beyond libc and libm, so the compiler setuptools already finds (gcc, clang, MSVC)
builds it without CMake or a second build backend in the install. The integrator's kit
(native/Makefile) builds the same sources into a library for C and C++ programs.

On a machine without a C compiler the build of the extension fails, setuptools says so, and
the install goes on: learned_contact.native then answers through the numpy reference and every
command says so in one line (learned_contact/native.py).
"""

from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

HERE = Path(__file__).resolve().parent
SOURCES = sorted(str(p.relative_to(HERE)) for p in (HERE / "native" / "src").glob("*.c")) + sorted(
    str(p.relative_to(HERE)) for p in (HERE / "native" / "python").glob("*.c"))


class OptionalBuildExt(build_ext):
    """build_ext that reports a failed compile in one line and installs without the core."""

    def run(self):
        try:
            super().run()
        except Exception as error:  # noqa: BLE001 (distutils raises several unrelated kinds)
            print(f"container-contact-testbed: the native core was not built ({error}); "
                  "commands will use the numpy reference path (install a C compiler and reinstall)")

    def build_extension(self, ext):
        try:
            if ext.name == "learned_contact._native":  # the predictor's fast path reads arrays via numpy's C API
                import numpy

                ext.include_dirs.append(numpy.get_include())
            super().build_extension(ext)
        except Exception as error:  # noqa: BLE001
            print(f"container-contact-testbed: the native core was not built ({error}); "
                  "commands will use the numpy reference path (install a C compiler and reinstall)")


# IEEE arithmetic as written: no fused multiply-adds or reassociation, so the core's answers
# match the numpy reference to 1e-12 m whatever the compiler's defaults
# -fvisibility=hidden: the extension exports its module's init function alone (PyMODINIT_FUNC is
# visible by default), not the core's internal functions (native/Makefile builds the C library so too)
FLAGS = ["-std=c11", "-O2", "-ffp-contract=off", "-fno-fast-math", "-fvisibility=hidden"]

setup(
    ext_modules=[Extension(
        "learned_contact._native", sources=SOURCES, include_dirs=["native/include", "native/src"],
        extra_compile_args=FLAGS, libraries=["m"]),
        # the testbed's own instrumentation (signed distances of recorded box pairs), in the
        # geometry layer below learned_contact: its own small module
        Extension("testbed.geometry._pairwise", sources=["native/geometry/pairwise.c"], extra_compile_args=FLAGS,
                  libraries=["m"])],
    cmdclass={"build_ext": OptionalBuildExt},
)
