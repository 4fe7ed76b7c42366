"""Where setuptools builds: a temporary folder, removed when the build ends.

Everything about the package is in pyproject.toml. pip builds a project in its own folder,
and setuptools writes ``build/`` and ``quad_dob_env.egg-info/`` there and leaves them; a
stale ``build/lib`` then shadows nothing but clutters the clone. Pointing both at a
temporary folder keeps ``pip install .`` from writing into the clone.
"""

import atexit
import shutil
import sys
import tempfile

from setuptools import setup

if "editable_wheel" in sys.argv:
    # an editable install in strict mode links files under build_base: they must outlive
    # the build, so such an install builds where setuptools puts it
    setup()
else:
    scratch = tempfile.mkdtemp(prefix="quad_dob_build_")
    atexit.register(shutil.rmtree, scratch, ignore_errors=True)
    setup(options={"build": {"build_base": scratch}, "egg_info": {"egg_base": scratch}})
