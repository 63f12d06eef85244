"""Packs the CMake build's products with the Python sources: the protobuf
modules (tribo/v1/*_pb2.py, generated with protoc from proto/ when the build
tree lacks them) and the native module tribo_native (when built: it needs
pybind11-dev). Metadata lives in pyproject.toml."""

import glob
import os
import shutil
import subprocess
import tempfile

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE_DIR = os.path.normpath(os.path.join(HERE, "..", ".."))


def build_dir():
    return os.environ.get("TRIBO_BUILD_DIR", os.path.join(SOURCE_DIR, "build"))


def out_of_tree(name, fresh=False):
    """setuptools' scratch space (build/, *.egg-info) under the CMake build
    tree rather than in the checkout, which `pip install client/python`
    leaves as it was; a temporary directory when there is no build tree.
    fresh: emptied first, so that no module removed from the sources stays
    in the wheel."""
    base = build_dir() if os.path.isdir(build_dir()) else tempfile.mkdtemp(prefix="tribo-pip-")
    path = os.path.join(base, "python-package", name)
    if fresh:
        shutil.rmtree(path, ignore_errors=True)
    os.makedirs(path, exist_ok=True)
    return path


class BuildWithTriboModules(build_py):
    def run(self):
        super().run()
        generated = os.path.join(build_dir(), "python")
        target_v1 = os.path.join(self.build_lib, "tribo", "v1")
        os.makedirs(target_v1, exist_ok=True)
        modules = glob.glob(os.path.join(generated, "tribo", "v1", "*_pb2.py"))
        if modules:
            for module in modules:
                shutil.copy2(module, target_v1)
        else:
            protos = sorted(glob.glob(os.path.join(SOURCE_DIR, "proto", "tribo", "v1", "*.proto")))
            if not protos:
                raise SystemExit(f"neither {generated}/tribo/v1 nor {SOURCE_DIR}/proto: build tribo first")
            subprocess.check_call(["protoc", f"--python_out={self.build_lib}",
                                   "-I", os.path.join(SOURCE_DIR, "proto")] + protos)
        natives = glob.glob(os.path.join(generated, "tribo_native*.so"))
        for native in natives:
            shutil.copy2(native, self.build_lib)
        if not natives:
            print("note: tribo_native not built (pybind11-dev missing?): tribo_client.sim will not import")


class BinaryDistribution(Distribution):
    """The native module makes the wheel platform-specific."""

    def has_ext_modules(self):
        return bool(glob.glob(os.path.join(build_dir(), "python", "tribo_native*.so")))


setup(cmdclass={"build_py": BuildWithTriboModules}, distclass=BinaryDistribution,
      options={"build": {"build_base": out_of_tree("build", fresh=True)}, "egg_info": {"egg_base": out_of_tree("egg-info")}})
