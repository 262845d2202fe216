"""Make a source checkout import like the installed package.

setuptools installs the top-level ``drivers/`` folder as ``walkmon.drivers`` (``package-dir`` in pyproject.toml).
When Python imports walkmon straight from a checkout instead (``python -m pytest`` or ``python -m walkmon.commands.cli``
run in the repository root put the checkout first on ``sys.path``), there is no ``walkmon/drivers`` folder, and
``import walkmon.drivers`` would fail. This maps the same folder to the same name, as the installer does, and
does nothing in an installed copy (where ``walkmon/drivers`` exists).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

__all__ = ["map_checkout_drivers"]


def map_checkout_drivers(package_dir: Path) -> None:
    """Register ``<checkout>/drivers`` as ``walkmon.drivers`` when ``package_dir`` is a checkout's walkmon/."""
    if "walkmon.drivers" in sys.modules or (package_dir / "drivers").is_dir():
        return
    drivers = package_dir.parent / "drivers"
    if not (drivers / "__init__.py").is_file() or not (package_dir.parent / "pyproject.toml").is_file():
        return
    spec = importlib.util.spec_from_file_location(
        "walkmon.drivers", drivers / "__init__.py", submodule_search_locations=[str(drivers)]
    )
    if spec is None or spec.loader is None:
        return
    module = importlib.util.module_from_spec(spec)
    sys.modules["walkmon.drivers"] = module
    spec.loader.exec_module(module)
    parent = sys.modules.get("walkmon")
    if parent is not None:
        parent.drivers = module  # type: ignore[attr-defined]  # what the import system does for a subpackage it loads itself
