# The build of `pip install --no-build-isolation ./clients/python`: configures and builds the
# repository's top-level CMake project (targets of the Python package only) and puts its
# build/python/coopdyn (generated types, lcmlog, the compiled coopdyn._core) into the wheel.
# COOPDYN_CMAKE_ARGS adds CMake options (e.g. "-DCOOPDYN_NATIVE=OFF" for a wheel run on other CPUs);
# COOPDYN_BUILD_JOBS sets the parallel build (default 2).
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

TOP = Path(__file__).resolve().parents[2]


class CMakeBuild(build_ext):
    def run(self):
        build = Path(self.build_temp).resolve() / "cmake"
        cfg = ["cmake", "-S", str(TOP), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
               "-DCOOPDYN_BUILD_BENCH=OFF", f"-DCOOPDYN_PYTHON3={sys.executable}",
               *shlex.split(os.environ.get("COOPDYN_CMAKE_ARGS", ""))]
        subprocess.check_call(cfg)
        jobs = os.environ.get("COOPDYN_BUILD_JOBS", "2")
        subprocess.check_call(["cmake", "--build", str(build), "-j", jobs, "--target",
                               "coopdyn_python_init", "coopdyn_python"])
        src = build / "python" / "coopdyn"
        if not (src / "__init__.py").read_text().count("coopdyn._core"):
            raise RuntimeError("the compiled bindings were not built (see CMake's warnings: pybind11-dev, python3-dev)")
        dst = Path(self.build_lib) / "coopdyn"
        shutil.copytree(src, dst, dirs_exist_ok=True, ignore=shutil.ignore_patterns("__pycache__"))

    def get_outputs(self):
        return []


setup(packages=[], py_modules=[], ext_modules=[Extension("coopdyn._core", sources=[])],
      cmdclass={"build_ext": CMakeBuild}, zip_safe=False)
