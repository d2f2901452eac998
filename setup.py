"""Maps the repository's top-level folders onto the single `racer` import namespace."""

from setuptools import find_packages, setup

PACKAGE_DIRS = {
    "racer": "racer",
    "racer.shared": "shared",
    "racer.trainer": "trainer",
    "racer.rollout_worker": "rollout_worker",
    "racer.evaluation_worker": "evaluation_worker",
    "racer.tracks": "tracks",
}

packages = []
for package, folder in PACKAGE_DIRS.items():
    packages.append(package)
    packages += [f"{package}.{sub}" for sub in find_packages(folder)]
# Folders of data files, listed so setuptools ships them as packages of their own: the viewer's page (HTML, JS, CSS),
# the example custom files (racer.defaults: `racer train`'s default --custom-files) and the fast-lap recipe's two.
packages += [
    "racer.viewer.static",
    "racer.defaults.custom_files",
    "racer.defaults.racing.discrete",
    "racer.defaults.racing.continuous",
]

setup(packages=packages, package_dir=PACKAGE_DIRS)
