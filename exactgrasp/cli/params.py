"""``--param KEY=VALUE``: backend parameters on the command line, checked and documented from
the backends' declared ``parameter_constraints``.

Nothing here names a parameter: the keys, what each may be and its default are read from each
backend class (`Backend.parameter_constraints`, the constructor's signature) when a command
checks its ``--param`` items or prints its ``--help``, so a new parameter, or a new backend,
shows up without touching the command line.
"""

from __future__ import annotations

import argparse
import inspect
import json
import textwrap
from collections.abc import Mapping, Sequence
from typing import Any

from exactgrasp.backends import registry
from exactgrasp.backends.base import Backend
from exactgrasp.backends.defaults import COMPARED_BACKENDS
from exactgrasp.backends.params import Param, describe
from exactgrasp.errors import BackendError, ExactGraspError

__all__ = [
    "PARAM_EPILOG",
    "ParamHelpFormatter",
    "add_param",
    "backend_names",
    "build_backend",
    "declared_parameters",
    "params_table",
    "parse_value",
    "split_params",
]

#: Stands for the backend parameter table in a parser's epilog; `ParamHelpFormatter` builds the
#: table only when help is printed, so building the parser loads no backend.
PARAM_EPILOG = "\0backend parameters\0"
NO_DEFAULT = inspect.Parameter.empty


def parse_value(text: str) -> Any:
    """A ``--param`` value: JSON when it parses (numbers, true/false, null, lists), ``None`` as
    None, any other text as itself."""
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return None if text == "None" else text


def backend_names() -> list[str]:
    """Available backends, the compared ones first (``voxel``, ``exact``), then the others."""
    available = registry.available_backends()
    return [b for b in COMPARED_BACKENDS if b in available] + sorted(
        available - set(COMPARED_BACKENDS)
    )


def declared_parameters(cls: type[Backend]) -> dict[str, tuple[Param, Any]]:
    """``{key: (constraint, default)}`` of a backend class, in declaration order.

    The default is the constructor's (``inspect.Parameter.empty`` when it has none: a
    plugin backend may take options through ``**kwargs``; the hint then says it).
    """
    signature = inspect.signature(cls.__init__).parameters
    out = {}
    for key, param in dict(getattr(cls, "parameter_constraints", {}) or {}).items():
        default = signature[key].default if key in signature else NO_DEFAULT
        out[key] = (param, getattr(param, "default", default))
    return out


def _declared(name: str, flag: str) -> dict[str, tuple[Param, Any]] | None:
    """The declared parameters of backend ``name``; None when they cannot be read (it cannot
    be built with its defaults), and then its constructor checks them."""
    if name not in registry.available_backends():
        try:
            registry.get_backend(name)  # says why: an unknown name or a missing package
        except ExactGraspError as exc:
            raise exc.prefixed(f"{flag} {name}: ") from exc
    try:
        return declared_parameters(registry.backend_class(name))
    except ExactGraspError:
        return None


def _value_text(value: Any) -> str:
    """A value as it is typed after ``--param KEY=``."""
    return value if isinstance(value, str) else json.dumps(value) if value is not None else "None"


def _keys_text(name: str, declared: Mapping[str, Any] | None) -> str:
    if declared is None:
        return f"{name} checks its own parameters"
    if not declared:
        return f"{name} declares no parameters"
    return f"{name} takes {', '.join(declared)}"


def params_table(width: int = 79) -> str:
    """The backend parameter section of ``--help``: every available backend's keys, what each
    may be, its default and its meaning."""
    width = max(width, 40)
    lines = [
        textwrap.fill(
            "backend parameters (--param KEY=VALUE, repeatable; --param BACKEND.KEY=VALUE sets "
            "KEY for that backend only; VALUE is read as JSON, else as text):",
            width=width,
        )
    ]
    for name in backend_names():
        try:
            declared = declared_parameters(registry.backend_class(name))
        except Exception as exc:  # one broken plugin must not hide the others' help
            lines.append(f"  {name}: parameters not known here ({exc})")
            continue
        lines.append(f"  {name}:" if declared else f"  {name}: declares no parameters")
        for key, (param, default) in declared.items():
            text = describe(param)
            if default is not NO_DEFAULT:
                text += f"; default {_value_text(default)}"
            if param.hint:
                text += f"; {param.hint}"
            lines.append(
                textwrap.fill(
                    f"{key:<18} {text}",
                    width=width,
                    initial_indent="    ",
                    subsequent_indent=" " * 23,
                )
            )
    return "\n".join(lines)


class ParamHelpFormatter(argparse.HelpFormatter):
    """Argparse's formatter, with the `PARAM_EPILOG` stand-in replaced by `params_table`."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        if text == PARAM_EPILOG:
            return textwrap.indent(params_table(width), indent)
        return super()._fill_text(text, width, indent)


def add_param(parser: argparse.ArgumentParser) -> None:
    """The repeatable ``--param KEY=VALUE`` option, and the parameter table in ``--help``."""
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="backend parameter, e.g. --param object_resolution=50 (repeatable; the keys of "
        "each backend are listed below)",
    )
    parser.formatter_class = ParamHelpFormatter
    parser.epilog = PARAM_EPILOG


def split_params(
    items: Sequence[str], backends: Sequence[str], flag: str = "--backend"
) -> dict[str, dict[str, Any]]:
    """Check ``--param`` items against the declared parameters of the backends a command runs.

    Parameters
    ----------
    items : sequence of str
        ``KEY=VALUE`` (given to every backend in ``backends`` that declares KEY) or
        ``BACKEND.KEY=VALUE`` (to that backend only); ``-`` in keys is read as ``_``.
    backends : sequence of str
        Names of the backends the command runs.
    flag : str
        The option that named them, for the message about an unknown backend.

    Returns
    -------
    dict
        ``{backend: {key: value}}`` for every name in ``backends``.

    Raises
    ------
    ExactGraspError
        An unknown backend, naming ``flag``. Naming ``--param`` and the item: no ``=``, a
        backend the command does not run, a key none of the backends declares, or a value the
        key's constraint refuses, with the keys each backend takes.
    """
    names = list(dict.fromkeys(backends))
    declared = {name: _declared(name, flag) for name in names}
    out: dict[str, dict[str, Any]] = {name: {} for name in names}

    def keys() -> str:
        return "; ".join(_keys_text(name, declared[name]) for name in names)

    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip().replace("-", "_")
        if not sep or not key:
            raise ExactGraspError(
                f"--param {item!r}: expected KEY=VALUE, e.g. --param object_resolution=50; "
                f"{keys()}."
            )
        prefix, dot, bare = key.rpartition(".")
        if dot and prefix not in out:
            raise ExactGraspError(
                f"--param {item}: this command runs {', '.join(names)}, not {prefix!r}; {keys()}."
            )
        targets = [prefix] if dot else [n for n in names if bare in (declared[n] or {})]
        if not targets and len(names) == 1 and not declared[names[0]]:
            targets = names  # a backend that declares nothing checks its own parameters
        if not targets or (dot and declared[prefix] and bare not in declared[prefix]):
            raise ExactGraspError(f"--param {bare}: unknown key; {keys()}.")
        value = parse_value(text)
        for name in targets:
            if bare in (declared[name] or {}):
                param = declared[name][bare][0]
                if param.admits(value) is NotImplemented:
                    hint = f" ({param.hint})" if param.hint else ""
                    raise ExactGraspError(
                        f"--param {bare}={text}: {name}'s {bare} must be {describe(param)}, "
                        f"got {value!r}{hint}."
                    )
            out[name][bare] = value
    return out


def build_backend(name: str, params: Mapping[str, Any]) -> Backend:
    """The backend ``name`` built with parameters `split_params` checked.

    Raises
    ------
    BackendError
        Parameters its constructor refuses together, naming ``--param``.
    """
    try:
        return registry.get_backend(name, **params)
    except BackendError as exc:
        raise exc.prefixed("--param: ") from exc
