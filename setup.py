"""Only for colcon (``ament_python`` runs ``setup.py``): the metadata is in pyproject.toml.

pip builds from pyproject.toml and never needs this file; ``setup.cfg`` adds what colcon needs
(the package name for setuptools 68, the ament index marker and package.xml).
"""

from setuptools import setup

setup()
