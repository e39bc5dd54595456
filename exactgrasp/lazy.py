"""Names of a package loaded on first use, so that importing the package costs nothing.

`lazy_names` makes the ``__getattr__`` and ``__dir__`` of a package (PEP 562) from a table of
public names and the modules that define them. The command line's ``--help`` imports the
package without the numerical libraries (trimesh, scipy, mujoco, the compiled kernels) that its
modules pull in; they load when a name that needs them is first used. Each package also imports
the same names under ``TYPE_CHECKING``, so that type checkers, editors and the API reference
see them.

"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping

__all__ = ["lazy_names"]


def lazy_names(
    package: str,
    names: Mapping[str, tuple[str, ...]],
    modules: Mapping[str, str] | None = None,
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` of ``package`` for the names of ``names`` and ``modules``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    names : mapping of str to tuple of str
        Module (``"exactgrasp.x.y"``) -> the names it defines that the package exports.
    modules : mapping of str to str, optional
        Public name -> a module exported as that name (``{"hands": "exactgrasp.hands"}``).

    Returns
    -------
    tuple of callable
        The module-level ``__getattr__`` (imports the defining module, keeps the value in the
        package and returns it; `AttributeError` for any other name) and ``__dir__``.
    """
    namespace = importlib.import_module(package).__dict__
    table = {name: (module, name) for module, exported in names.items() for name in exported}
    table.update({name: (module, None) for name, module in (modules or {}).items()})

    def __getattr__(name: str) -> object:
        if name not in table:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module_name, attribute = table[name]
        module = importlib.import_module(module_name)
        value = module if attribute is None else getattr(module, attribute)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(table))

    return __getattr__, __dir__
