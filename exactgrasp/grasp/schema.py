"""The grasp-file JSON Schema (``grasp-file.schema.json`` beside this module) and
`check_grasp_data`, which applies it.

The schema is the one list of the keys of a grasp file, their types and meanings (see
``docs/grasp-file.md``). `check_grasp_data` applies the subset of JSON Schema 2020-12 the schema
uses (type, const, enum, minimum, properties, required, dependentRequired, patternProperties,
additionalProperties, items, prefixItems, min/maxItems, anyOf, oneOf, $ref), so an unknown key,
a missing one or a wrong type is refused naming the file and the key, without a JSON Schema
package.
"""

from __future__ import annotations

import copy
import difflib
import json
import numbers
import operator
import os
import re
from functools import cache
from importlib import resources
from typing import Any

import numpy as np

from exactgrasp.errors import GraspFileError

__all__ = [
    "DOCS",
    "INFORMATIONAL",
    "SCHEMA_FILE",
    "check_grasp_data",
    "grasp_file_schema",
    "schema_dict",
]

#: Name of the grasp-file JSON Schema shipped in this package.
SCHEMA_FILE = "grasp-file.schema.json"
#: Marks schema keys that the shared data carries and exactgrasp does not read.
INFORMATIONAL = "Informational"
#: Where the format is described, for messages.
DOCS = "docs/grasp-file.md"


@cache
def schema_dict() -> dict:
    """The schema as parsed (shared: do not change it; `grasp_file_schema` gives a copy)."""
    return json.loads(resources.files(__package__).joinpath(SCHEMA_FILE).read_text())


def grasp_file_schema() -> dict:
    """The JSON Schema (draft 2020-12) of grasp files, as a new dict."""
    return copy.deepcopy(schema_dict())


# -- checking a file against the schema -----------------------------------------------------


def _resolve(schema: Any) -> Any:
    while isinstance(schema, dict) and "$ref" in schema:
        target = schema_dict()
        for part in schema["$ref"].removeprefix("#/").split("/"):
            target = target[part]
        # Keywords beside "$ref" (descriptions, defaults) are annotations here.
        schema = {**target, **{k: v for k, v in schema.items() if k != "$ref"}}
    return schema


def _is_type(value: Any, kind: str) -> bool:
    if kind == "object":
        return isinstance(value, dict)
    if kind == "array":
        return isinstance(value, list | tuple | np.ndarray)
    if kind == "string":
        return isinstance(value, str | os.PathLike)
    if kind == "boolean":
        return isinstance(value, bool | np.bool_)
    if kind == "null":
        return value is None
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        return False
    return kind == "number" or float(value).is_integer()


def _same(a: Any, b: Any) -> bool:
    """JSON equality: ``true`` is not ``1``."""
    a, b = (v.tolist() if isinstance(v, np.ndarray | np.generic) else v for v in (a, b))
    return a == b and isinstance(a, bool) == isinstance(b, bool)


_NOUNS = {"number": "number", "integer": "integer", "string": "string", "object": "object"}


def _article(noun: str) -> str:
    return ("an " if noun[0] in "aeiou" else "a ") + noun


def _form(schema: Any, plural: bool = False) -> str:
    """The expected form of a value, in words ("a list of 4 lists of 4 numbers")."""
    schema = _resolve(schema)
    if "const" in schema:
        return json.dumps(schema["const"])
    if "enum" in schema:
        return "one of " + ", ".join(json.dumps(v) for v in schema["enum"])
    branches = [_resolve(b) for b in schema.get("anyOf") or schema.get("oneOf") or []]
    tag = _discriminator(branches) if branches else None
    if tag is not None:
        consts = dict.fromkeys(b["properties"][tag]["const"] for b in branches)
        tags = ", ".join(map(json.dumps, consts))
        return f"an object with {json.dumps(tag)} one of {tags}"
    if "type" not in schema:
        return " or ".join(_form(b, plural) for b in branches) if branches else "any value"
    kinds = [schema["type"]] if isinstance(schema["type"], str) else schema["type"]
    words = []
    for kind in kinds:
        if kind == "array":
            words.append(_array_form(schema, plural))
        elif kind in ("boolean", "null"):
            words.append("true or false" if kind == "boolean" else "null")
        else:
            noun = _NOUNS[kind] + ("s" if plural else "")
            words.append(noun if plural else _article(noun))
            for word, key in ((">=", "minimum"), (">", "exclusiveMinimum")):
                if key in schema:
                    words[-1] += f" {word} {schema[key]}"
    return " or ".join(words)


def _array_form(schema: dict, plural: bool) -> str:
    lo, hi = schema.get("minItems"), schema.get("maxItems")
    count = f"{lo} " if lo == hi and lo is not None else f"{lo} or more " if lo else ""
    if "prefixItems" in schema:
        parts = ", ".join(_form(p) for p in schema["prefixItems"])
        what = f"{lo} to {hi} items ({parts})"
    elif "items" in schema:
        what = count + _form(schema["items"], plural=True)
    else:
        what = count + "values"
    return ("lists of " if plural else "a list of ") + what


def _got(value: Any) -> str:
    if isinstance(value, dict):
        return "an object"
    if isinstance(value, list | tuple | np.ndarray):
        return f"a list of {len(value)} item{'s' * (len(value) != 1)}"
    if isinstance(value, str):
        return f"the string {json.dumps(value)}"
    return json.dumps(value) if value is None or isinstance(value, bool) else repr(value)


def _first_sentence(schema: dict) -> str:
    text = _resolve(schema).get("description", "")
    return re.split(r"\.\s+(?=[A-Z])", text)[0].rstrip(".")


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def check_grasp_data(data: Any, source: str = "<dict>") -> None:
    """Refuse grasp data that does not follow ``grasp-file.schema.json``.

    Parameters
    ----------
    data : dict
        The parsed grasp file.
    source : str
        The grasp file, for messages.

    Raises
    ------
    GraspFileError
        Naming ``source``, the key (dotted for nested keys, e.g. ``hand_options.repair``) and
        what it must be; an unknown key with the closest known key ("did you mean").
    """
    _check(data, schema_dict(), "", source)


def _check(value: Any, schema: Any, path: str, source: str) -> None:
    schema = _resolve(schema)
    where = f"{source}: {path or 'the grasp file'}"
    if "type" in schema:
        kinds = [schema["type"]] if isinstance(schema["type"], str) else schema["type"]
        if not any(_is_type(value, kind) for kind in kinds):
            raise GraspFileError(f"{where} must be {_form(schema)}, got {_got(value)}.")
    if "const" in schema and not _same(value, schema["const"]):
        raise GraspFileError(f"{where} must be {_form(schema)}, got {_got(value)}.")
    if "enum" in schema and not any(_same(value, v) for v in schema["enum"]):
        close = difflib.get_close_matches(str(value), [str(v) for v in schema["enum"]], n=1)
        hint = f" (did you mean {json.dumps(close[0])}?)" if close else ""
        raise GraspFileError(f"{where} must be {_form(schema)}, got {_got(value)}{hint}.")
    for key, test in (("minimum", operator.ge), ("exclusiveMinimum", operator.gt)):
        if key in schema and _is_type(value, "number") and not test(value, schema[key]):
            raise GraspFileError(f"{where} must be {_form(schema)}, got {_got(value)}.")
    if isinstance(value, dict):
        _check_object(value, schema, path, source)
    elif isinstance(value, list | tuple | np.ndarray) and not isinstance(value, str):
        _check_array(list(value), schema, path, source)
    if "anyOf" in schema or "oneOf" in schema:
        _check_branches(value, schema, path, source)


def _check_object(value: dict, schema: dict, path: str, source: str) -> None:
    properties = schema.get("properties", {})
    for key in schema.get("required", []):
        if key not in value:
            meaning = _first_sentence(properties.get(key, {}))
            raise GraspFileError(
                f"{source}: missing required key {_join(path, key)!r}"
                + _misspelt(key, value, properties, path)
                + (f" ({meaning})." if meaning else ".")
            )
    for key, needs in schema.get("dependentRequired", {}).items():
        missing = [k for k in needs if k not in value]
        if key in value and missing:
            raise GraspFileError(
                f"{source}: {_join(path, key)!r} applies to {_join(path, missing[0])!r} only, "
                f"which the file does not give; remove it or give {_join(path, missing[0])!r}."
            )
    patterns = schema.get("patternProperties", {})
    extra = schema.get("additionalProperties", True)
    for key, item in value.items():
        key_path = _join(path, str(key))
        if key in properties:
            _check(item, properties[key], key_path, source)
            continue
        matched = [p for p in patterns if re.search(p, str(key))]
        for pattern in matched:
            _check(item, patterns[pattern], key_path, source)
        if matched:
            continue
        if extra is False:
            raise GraspFileError(_unknown_key(str(key), properties, patterns, path, source))
        if isinstance(extra, dict):
            _check(item, extra, key_path, source)


def _misspelt(key: str, value: dict, properties: Any, path: str) -> str:
    """``; the file has 'kye': did you mean 'key'?`` when an unknown key of ``value`` is
    close to the missing ``key``; else nothing."""
    unknown = [str(k) for k in value if k not in properties]
    close = difflib.get_close_matches(key, unknown, n=1, cutoff=0.6)
    if not close:
        return ""
    return f"; the file has {_join(path, close[0])!r}: did you mean {_join(path, key)!r}?"


def _unknown_key(key: str, properties: dict, patterns: dict, path: str, source: str) -> str:
    close = difflib.get_close_matches(key, list(properties), n=1, cutoff=0.6)
    hint = f"; did you mean {_join(path, close[0])!r}?" if close else "."
    read = [k for k, v in properties.items() if not _first_sentence(v).startswith(INFORMATIONAL)]
    also = []
    if len(read) < len(properties):
        also.append("the shared data's keys that are not read")
    if "^x-" in patterns:
        also.append("x-... keys for your own notes")
    known = ", ".join(read) + (f"; also {' and '.join(also)}" if also else "")
    owner = path or "a grasp file"
    name = _join(path, key)
    return f"{source}: unknown key {name!r}{hint} Keys of {owner}: {known} (see {DOCS})."


def _check_array(items: list, schema: dict, path: str, source: str) -> None:
    lo, hi = schema.get("minItems", 0), schema.get("maxItems", len(items))
    if not lo <= len(items) <= hi:
        where = f"{source}: {path}"
        raise GraspFileError(f"{where} must be {_form(schema)}, got {_got(items)}.")
    prefix = schema.get("prefixItems", [])
    for i, item in enumerate(items):
        sub = prefix[i] if i < len(prefix) else schema.get("items")
        if sub is not None:
            _check(item, sub, f"{path}[{i}]", source)


def _check_branches(value: Any, schema: dict, path: str, source: str) -> None:
    branches = [_resolve(b) for b in schema.get("oneOf") or schema["anyOf"]]
    if isinstance(value, dict) and _discriminator(branches) is not None:
        _check(value, _pick(value, branches, path, source), path, source)
        return
    if all(set(b) == {"required"} for b in branches):
        if not isinstance(value, dict):  # "required" holds for anything but an object
            return
        met = [b["required"] for b in branches if all(k in value for k in b["required"])]
        if met and ("anyOf" in schema or len(met) == 1):
            return
        forms = [
            repr(b["required"][0])
            if len(b["required"]) == 1
            else "all of " + ", ".join(map(repr, b["required"]))
            for b in branches
        ]
        owner = path or "the grasp file"
        if met:
            raise GraspFileError(f"{source}: {owner} gives {' and '.join(forms)}; give one.")
        raise GraspFileError(f"{source}: {owner} needs {' or '.join(forms)} (see {DOCS}).")
    passed = 0
    for branch in branches:
        try:
            _check(value, branch, path, source)
            passed += 1
        except GraspFileError:
            pass
    if passed == 0 or ("oneOf" in schema and passed > 1):
        form = " or ".join(_form(b) for b in branches)
        raise GraspFileError(f"{source}: {path} must be {form}, got {_got(value)}.")


def _pick(value: dict, branches: list[dict], path: str, source: str) -> dict:
    """The branch an object's tags select (``type``, then ``name`` among the built-in hands)."""
    used: list[str] = []
    while len(branches) > 1 and (tag := _discriminator(branches, used)) is not None:
        tags = list(dict.fromkeys(b["properties"][tag]["const"] for b in branches))
        if tag not in value:
            known = {k for b in branches for k in b.get("properties", {})}
            raise GraspFileError(
                f"{source}: missing required key {_join(path, tag)!r}"
                f"{_misspelt(tag, value, known, path)} (one of "
                f"{', '.join(map(json.dumps, tags))})."
            )
        _check(value[tag], {"enum": tags}, _join(path, tag), source)
        branches = [b for b in branches if _same(b["properties"][tag]["const"], value[tag])]
        used.append(tag)
    return branches[0]


def _discriminator(branches: list[dict], used: list[str] | tuple = ()) -> str | None:
    """A property every branch fixes with a ``const``, not in ``used`` (a hand's ``type``,
    then a built-in hand's ``name``), if any."""
    shared = None
    for branch in branches:
        fixed = {k for k, v in branch.get("properties", {}).items() if "const" in v}
        shared = fixed if shared is None else shared & fixed
    shared = (shared or set()) - set(used)
    if not shared:
        return None
    return "type" if "type" in shared else min(shared)
