"""The build behind pyproject.toml (docs/PYTHON.md "Install with pip").

The package is python/reefgen with the compiled modules (_reefgen, and
_reefgen_infer where LibTorch is there) and the shipped model. The modules
come from a CMake build tree: $REEFGEN_BUILD_DIR when set (a tree
scripts/build.sh made: nothing is compiled again), else build-pip/ in the
source tree, configured and built here (Release, Ninja when there is one).
"""
import glob
import os
import shutil
import subprocess

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.dist import Distribution

HERE = os.path.dirname(os.path.abspath(__file__))
# setuptools' own files (egg-info, build/lib) go here, not into the CMake tree or the sources.
os.makedirs(os.path.join(HERE, "build-pip"), exist_ok=True)


def cmake_tree():
    given = os.environ.get("REEFGEN_BUILD_DIR")
    if given:
        tree = os.path.abspath(given)
        if not glob.glob(os.path.join(tree, "python", "reefgen", "_reefgen*.so")):
            raise SystemExit(f"reefgen: REEFGEN_BUILD_DIR={given} holds no python/reefgen/_reefgen*.so: "
                             "build it first (bash scripts/build.sh) or leave the variable unset")
        return tree
    tree = os.path.join(HERE, "build-pip")
    generator = ["-G", "Ninja"] if shutil.which("ninja") else []
    subprocess.run(["cmake", "-S", HERE, "-B", tree, "-DCMAKE_BUILD_TYPE=Release", *generator], check=True)
    jobs = str(os.cpu_count() or 2)
    subprocess.run(["cmake", "--build", tree, "--target", "_reefgen", "-j", jobs], check=True)
    # LibTorch's half only where the configure found LibTorch.
    if "_reefgen_infer" in subprocess.run(["cmake", "--build", tree, "--target", "help"], capture_output=True,
                                          text=True).stdout:
        subprocess.run(["cmake", "--build", tree, "--target", "_reefgen_infer", "-j", jobs], check=True)
    return tree


class BuildWithCMake(build_py):
    """The sources as setuptools copies them, then the modules and the model beside them."""

    def run(self):
        super().run()
        tree = cmake_tree()
        package = os.path.join(self.build_lib, "reefgen")
        modules = glob.glob(os.path.join(tree, "python", "reefgen", "_reefgen*.so"))
        for so in modules:
            shutil.copy2(so, package)
        os.makedirs(os.path.join(package, "models"), exist_ok=True)
        shutil.copy2(os.path.join(HERE, "models", "reef-256.pt"), os.path.join(package, "models"))


class BinaryDistribution(Distribution):
    """Compiled modules inside: a wheel for this platform and Python, not a pure one."""

    def has_ext_modules(self):
        return True


setup(
    packages=["reefgen"],
    package_dir={"reefgen": "python/reefgen"},
    package_data={"reefgen": ["*.pyi", "py.typed"]},
    cmdclass={"build_py": BuildWithCMake},
    distclass=BinaryDistribution,
    options={"build": {"build_base": "build-pip/setuptools"}, "egg_info": {"egg_base": "build-pip"}},
)
