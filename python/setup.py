"""Builds the `fskin` extension with the repository's CMake for `pip install ./python`.

setuptools packages the pure-Python files; the extension `fskin._fskin` comes from
the CMake target fskin_python, configured in FSKIN_BUILD_DIR (default build-pip/
at the repository root; point it at an existing build directory to reuse it) for
the Python that runs pip (its torch must be Debian's python3-torch, the LibTorch
the library links).
"""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent.parent


def version():
    match = re.search(r"project\(fskin VERSION ([0-9.]+)", (ROOT / "CMakeLists.txt").read_text())
    return match.group(1)


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build_dir = Path(os.environ.get("FSKIN_BUILD_DIR", ROOT / "build-pip")).resolve()
        configure = ["cmake", "-S", str(ROOT), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release", "-DFSKIN_PYTHON=ON",
                     f"-DFSKIN_PYTHON_EXECUTABLE={sys.executable}"]
        if not (build_dir / "CMakeCache.txt").exists() and shutil.which("ninja"):
            configure += ["-G", "Ninja"]
        subprocess.check_call(configure)
        subprocess.check_call(["cmake", "--build", str(build_dir), "--target", "fskin_python"])
        built = sorted((build_dir / "python" / "fskin").glob("_fskin*.so"))
        if not built:
            raise RuntimeError(f"fskin: the CMake build in {build_dir} made no _fskin extension")
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(built[0], target)


setup(
    version=version(),
    packages=["fskin", "fskin.compat"],
    package_data={"fskin": ["py.typed", "_fskin.pyi"]},
    ext_modules=[Extension("fskin._fskin", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    zip_safe=False,
)
