"""The public surface: every name gyroid exports resolves, and the version is the package's."""

from importlib.metadata import version

import gyroid


def test_every_exported_name_resolves_and_the_version_is_the_installed_one():
    for name in gyroid.__all__:
        assert getattr(gyroid, name) is not None, name
    assert gyroid.__version__ == version("gyroid")
    assert callable(gyroid.fit_log) and callable(gyroid.find_roll_discrepancies)
