"""The house rules of the package, read from its source: rooms, layers, circles, sizes.

The layers are the ones `docs/architecture.md` draws; a module may import its own room and the
rooms of lower layers only.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import exactgrasp

PACKAGE = Path(exactgrasp.__file__).parent
ROOT = PACKAGE.parent
MAX_LINES = 400
LONG_REASON = "Long because"

#: room -> layer; a room imports rooms of a lower layer (and itself) only.
LAYERS = {
    "errors": 0,
    "version": 0,
    "cache": 0,
    "datapath": 0,
    "lazy": 0,
    "given": 0,
    "geometry": 1,
    "progress": 1,
    "hands": 2,
    "paths": 2,
    "grasp": 3,
    "backends": 4,
    "diagnostics": 5,
    "descriptor": 6,
    "overlap": 6,
    "separation": 6,
    "view": 6,
    "compare": 7,
    "vertex_gradients": 7,
    "batch": 8,
    "report": 8,
    "torch": 8,
    "evaluation": 9,
    "cli": 10,
}


def modules() -> dict[str, Path]:
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        found[".".join(parts)] = path
    return found


MODULES = modules()

#: The lazy public names (`exactgrasp.lazy`), the backend registry (entry points) and `require`
#: of optional packages are the only places that import by name at run time.
DYNAMIC_IMPORTERS = {
    "exactgrasp",
    "exactgrasp.backends.registry",
    "exactgrasp.errors",
    "exactgrasp.lazy",
}


def room(module: str) -> str:
    return module.split(".")[1] if "." in module else ""


def package_of(module: str) -> str:
    """The package a module belongs to (a package's own `__init__` belongs to itself)."""
    path = MODULES[module]
    return module if path.name == "__init__.py" else module.rpartition(".")[0]


def in_type_checking(node: ast.AST, parents: dict) -> bool:
    while node in parents:
        node = parents[node]
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            return True
    return False


def imports(module: str) -> list[tuple[str, list[str], bool, int]]:
    """(imported module, names, only for type checking, line) for every exactgrasp import."""
    tree = ast.parse(MODULES[module].read_text())
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "exactgrasp":
                    found.append((alias.name, [], in_type_checking(node, parents), node.lineno))
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.split(".")[0] != "exactgrasp":
                continue
            names = [alias.name for alias in node.names]
            target = node.module
            for name in names:
                # `from exactgrasp.x import y` where y is a submodule imports that submodule.
                if f"{target}.{name}" in MODULES:
                    found.append(
                        (f"{target}.{name}", [], in_type_checking(node, parents), node.lineno)
                    )
                else:
                    found.append((target, [name], in_type_checking(node, parents), node.lineno))
        elif (
            isinstance(node, ast.Call)
            and ast.unparse(node.func) in ("__import__", "importlib.import_module")
            and module not in DYNAMIC_IMPORTERS
        ):
            pytest.fail(f"{module}:{node.lineno} imports dynamically: {ast.unparse(node)}")
    return found


def edges(*, runtime_only: bool) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for module in MODULES:
        for target, _, type_only, _ in imports(module):
            if runtime_only and type_only:
                continue
            graph[module].add(target)
    return graph


def test_every_room_has_a_layer():
    rooms = {room(m) for m in MODULES if "." in m}
    assert rooms == set(LAYERS), "add the new room to LAYERS and to docs/architecture.md"


@pytest.mark.parametrize("module", sorted(m for m in MODULES if "." in m))
def test_imports_flow_downward(module):
    here = room(module)
    for target, _, _, line in imports(module):
        there = room(target)
        if target == "exactgrasp":
            pytest.fail(f"{module}:{line} imports the package root; import the submodule")
        if there == here:
            continue
        assert LAYERS[there] < LAYERS[here], (
            f"{module}:{line} imports {target}: room {here!r} (layer {LAYERS[here]}) may not "
            f"import room {there!r} (layer {LAYERS[there]})"
        )


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_private_name_crosses_a_package(module):
    mine = package_of(module)
    for target, names, _, line in imports(module):
        if target not in MODULES or package_of(target) == mine:
            continue
        private = [n for n in names if n.startswith("_") and n != "__version__"]
        private_module = any(p.startswith("_") for p in target.split(".")[1:])
        assert not private and not private_module, (
            f"{module}:{line} imports {target} {private}: a private name of another package"
        )


def test_no_import_circle():
    graph = edges(runtime_only=True)
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in graph:
                continue
            if state.get(nxt) == 1:
                # A package imports its own submodules to re-export them; that is not a circle
                # unless a submodule imports the package back.
                cycle = [*stack[stack.index(nxt) :], nxt]
                pytest.fail("import circle: " + " -> ".join(cycle))
            if nxt not in state:
                visit(nxt)
        stack.pop()
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node)


@pytest.mark.parametrize("module", sorted(MODULES))
def test_module_has_a_docstring_and_a_size_limit(module):
    text = MODULES[module].read_text()
    tree = ast.parse(text)
    docstring = ast.get_docstring(tree)
    if MODULES[module].name != "__main__.py":
        assert docstring, f"{module} has no module docstring"
    n_lines = len(text.splitlines())
    if n_lines > MAX_LINES:
        assert docstring and LONG_REASON in docstring, (
            f"{module} has {n_lines} lines (> {MAX_LINES}) and no '{LONG_REASON} ...' line"
        )


def test_every_exception_is_exported():
    from exactgrasp import errors

    classes = {
        name
        for name, value in vars(errors).items()
        if isinstance(value, type)
        and issubclass(value, Exception)
        and value.__module__ == errors.__name__
    }
    assert len(classes) >= 14
    missing = sorted(classes - set(exactgrasp.__all__))
    assert not missing, f"exceptions not exported from exactgrasp: {missing}"
    for name in classes:
        assert getattr(exactgrasp, name) is getattr(errors, name)


def test_exceptions_live_in_errors():
    for module, path in MODULES.items():
        if module == "exactgrasp.errors":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef):
                bases = {ast.unparse(b) for b in node.bases}
                assert not any(b.endswith(("Error", "Exception")) for b in bases), (
                    f"{module} defines exception {node.name}; it belongs in exactgrasp/errors.py"
                )


def test_architecture_doc_names_every_room_and_only_real_modules():
    doc = (ROOT / "docs" / "architecture.md").read_text()
    for name in LAYERS:
        assert f"`{name}" in doc, f"docs/architecture.md does not describe room {name!r}"
    for path in re.findall(r"`(exactgrasp/[\w/]+\.pyx?)`", doc):
        assert (ROOT / path).exists(), f"docs/architecture.md names {path}, which does not exist"
    # The compiled kernels' sources are modules too, named by their path.
    for pyx in sorted(PACKAGE.rglob("*.pyx")):
        path = pyx.relative_to(ROOT).as_posix()
        assert f"`{path}`" in doc, f"docs/architecture.md does not name {path}"
    for dotted in re.findall(r"`(exactgrasp(?:\.\w+)+)`", doc):
        parts = dotted.split(".")
        assert any(".".join(parts[:k]) in MODULES for k in range(len(parts), 1, -1)), (
            f"docs/architecture.md names {dotted}, which is not a module"
        )


WORDS = re.compile(
    r"\b(issue|brief|ticket|another engineer)s?\b|(?<!scope=\")\bsessions?\b", re.IGNORECASE
)


@pytest.mark.parametrize(
    "path",
    [
        *sorted(
            str(p.relative_to(ROOT))
            for pattern in (
                "exactgrasp/**/*.py",
                "exactgrasp/**/*.pyx",
                "tests/*.py",
                "tests/*/*.py",
                "docs/**/*.md",
                "benchmarks/*.py",
            )
            for p in ROOT.glob(pattern)
            if p.name != "test_architecture.py"
        ),
        "README.md",
        "Makefile",
        "meson.build",
        "pyproject.toml",
    ],
)
def test_project_speaks_of_itself(path):
    text = (ROOT / path).read_text()
    hits = [
        f"{path}:{text[: m.start()].count(chr(10)) + 1}: {m.group(0)}"
        for m in WORDS.finditer(text)
    ]
    assert not hits, "words about how the project is run, not what it is: " + "; ".join(hits)


# -- errors are data ------------------------------------------------------------------------

#: The one adapter that reads a third-party library's message: MuJoCo says which mesh file it
#: could not open only in its text.
MESSAGE_ADAPTERS = {"exactgrasp.hands.loading"}


def _caught_text(node: ast.AST, caught: set[str]) -> bool:
    """``str(exc)`` or ``exc.args`` of an exception bound by an enclosing ``except``."""
    if isinstance(node, ast.Call) and ast.unparse(node.func) == "str" and len(node.args) == 1:
        return isinstance(node.args[0], ast.Name) and node.args[0].id in caught
    return (
        isinstance(node, ast.Attribute)
        and node.attr == "args"
        and isinstance(node.value, ast.Name)
        and node.value.id in caught
    )


def message_readers(tree: ast.AST) -> list[str]:
    """Places that read a caught exception's text rather than pass it on whole: a method called
    on it (``str(exc).replace``), an index into it, a comparison, or a call that takes it (other
    than printing, warning or logging it)."""
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    found = []
    for handler in (n for n in ast.walk(tree) if isinstance(n, ast.ExceptHandler)):
        if not handler.name:
            continue
        for node in ast.walk(handler):
            if not _caught_text(node, {handler.name}):
                continue
            parent = parents[node]
            whole = isinstance(parent, ast.FormattedValue | ast.Return | ast.keyword | ast.Dict)
            if isinstance(parent, ast.Call) and node in parent.args:
                whole = ast.unparse(parent.func).split(".")[-1] in {"print", "warn", "log"}
            if isinstance(parent, ast.BoolOp):  # str(exc) or repr(exc): still whole
                whole = isinstance(parents[parent], ast.keyword | ast.Dict | ast.Return)
            if not whole:
                found.append(f"line {node.lineno}: {ast.unparse(parent)[:80]}")
    return found


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_exception_text_is_parsed(module):
    """Errors carry their fields (`exactgrasp.errors.Fix`); front ends spell those, never an
    exception's text. Only the adapter of a library that says something in its text alone may
    read it."""
    found = message_readers(ast.parse(MODULES[module].read_text()))
    if module in MESSAGE_ADAPTERS:
        assert found, f"{module} no longer reads a message: take it off MESSAGE_ADAPTERS"
    else:
        assert not found, f"{module} reads an exception's text: {found}"


def test_the_message_rule_catches_rewriting():
    bad = [
        "try:\n    f()\nexcept E as exc:\n    raise E(str(exc).replace('a', 'b'))",
        "try:\n    f()\nexcept E as exc:\n    m = re.sub('a', 'b', str(exc))",
        "try:\n    f()\nexcept E as exc:\n    if str(exc).startswith('x'):\n        pass",
        "try:\n    f()\nexcept KeyError as exc:\n    k = exc.args[0]",
        "try:\n    f()\nexcept E as exc:\n    m = translate(str(exc), TABLE)",
    ]
    good = [
        "try:\n    f()\nexcept E as exc:\n    raise E(f'bad JSON ({exc})') from exc",
        "try:\n    f()\nexcept E as exc:\n    r.update(message=str(exc) or repr(exc))",
        "try:\n    f()\nexcept E as exc:\n    return {'reason': str(exc)}",
        "try:\n    f()\nexcept E as exc:\n    raise exc.prefixed('A: ') from exc",
    ]
    assert all(message_readers(ast.parse(code)) for code in bad)
    assert not any(message_readers(ast.parse(code)) for code in good)


# -- results are returned -------------------------------------------------------------------


def state_writes(tree: ast.AST) -> list[str]:
    """``self.x = ...`` in a method other than ``__init__``, outside a ``with`` block: state a
    call leaves behind. A value built once and shared (a cache) is built under a lock."""
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    found = []
    for cls in (n for n in ast.walk(tree) if isinstance(n, ast.ClassDef)):
        for method in cls.body:
            if not isinstance(method, ast.FunctionDef) or method.name == "__init__":
                continue
            for node in ast.walk(method):
                targets = (
                    node.targets
                    if isinstance(node, ast.Assign)
                    else [node.target]
                    if isinstance(node, ast.AugAssign | ast.AnnAssign)
                    else []
                )
                for target in targets:
                    if not (
                        isinstance(target, ast.Attribute)
                        and isinstance(target.value, ast.Name)
                        and target.value.id == "self"
                    ):
                        continue
                    up = parents[node]
                    while up is not method and not isinstance(up, ast.With):
                        up = parents[up]
                    if up is method:
                        found.append(f"{cls.name}.{method.name}: {ast.unparse(target)}")
    return found


@pytest.mark.parametrize("module", sorted(m for m in MODULES if room(m) == "backends"))
def test_no_backend_keeps_results_as_attributes(module):
    """A backend or intersector returns what a call computed (`ExactIntersector.intersect`
    returns an `Intersection`); it keeps nothing of the last call, which would describe
    another call after the next one and race between threads."""
    found = state_writes(ast.parse(MODULES[module].read_text()))
    assert not found, f"{module} keeps results of a call on the object: {found}"


def test_the_state_rule_catches_last_call_results():
    code = "class A:\n    def __init__(self):\n        self.a = 1\n    def f(self):\n        {}"
    assert state_writes(ast.parse(code.format("self.stats = {}")))
    assert state_writes(ast.parse(code.format("self.n += 1")))
    assert not state_writes(ast.parse(code.format("with self.lock:\n            self.c = 2")))
    assert not state_writes(ast.parse(code.format("x = self.a")))


# -- declared parameters ------------------------------------------------------------------


def invalid_values(param) -> list:
    """Values no constraint of ``param`` admits, generated from its constraints (as
    scikit-learn's ``check_param_validation`` does): just past each bound, the wrong kind of
    number, NaN, a bool, text, None and an object no option lists."""
    from exactgrasp.backends.params import Interval

    candidates = [object(), "not-an-option", float("nan"), float("inf"), True, None, [1], 0.5]
    for constraint in param.allowed:
        if isinstance(constraint, Interval):
            step = 1 if constraint.kind.__name__ == "Integral" else 1e-9
            for bound, past in ((constraint.lo, -step), (constraint.hi, step)):
                if bound is not None:
                    candidates += [bound + past, bound, float(bound) + 0.5 * past]
    return [v for v in candidates if param.admits(v) is NotImplemented]


def backend_classes() -> dict:
    from exactgrasp.backends import registry

    return {name: registry.backend_class(name) for name in registry.available_backends()}


@pytest.mark.parametrize("name", sorted(backend_classes()))
def test_declared_constraints_match_the_constructor(name):
    import inspect

    cls = backend_classes()[name]
    signature = inspect.signature(cls.__init__).parameters
    kinds = {p.kind for p in signature.values()}
    assert inspect.Parameter.VAR_KEYWORD not in kinds, f"{name} hides options in **kwargs"
    assert list(signature)[1:] == list(cls.parameter_constraints), (
        f"{name}: the constructor takes {list(signature)[1:]}, the constraints declare "
        f"{list(cls.parameter_constraints)}"
    )
    for key, param in cls.parameter_constraints.items():
        default = signature[key].default
        assert param.admits(default) is not NotImplemented, f"{name}.{key}: default refused"


@pytest.mark.parametrize("name", sorted(backend_classes()))
def test_invalid_values_generated_from_the_constraints_are_refused(name):
    from exactgrasp.errors import BackendError

    cls = backend_classes()[name]
    tried = 0
    for key, param in cls.parameter_constraints.items():
        for value in invalid_values(param):
            with pytest.raises(BackendError, match=rf"{key} must be"):
                cls(**{key: value})
            tried += 1
    assert tried >= 5 * len(cls.parameter_constraints)


#: A docstring sentence listing a module's imports ("Imports `x` and numpy.", "May import: ...").
IMPORT_LIST = re.compile(r"(^|\s)(May import:|Imports:?\s+(`|numpy|numba|only|the\b))")


@pytest.mark.parametrize("module", sorted(MODULES))
def test_docstrings_do_not_list_imports_by_hand(module):
    """What a module may import is the layers' rule, checked above from the source; a list
    written by hand in a docstring goes stale unchecked."""
    docstring = ast.get_docstring(ast.parse(MODULES[module].read_text())) or ""
    match = IMPORT_LIST.search(docstring)
    assert not match, f"{module}'s docstring lists its imports: {match.group(0).strip()} ..."


# -- one spelling, one check ----------------------------------------------------------------


def functions(module: str) -> list[ast.FunctionDef | ast.AsyncFunctionDef]:
    tree = ast.parse(MODULES[module].read_text())
    return [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)]


def parameter_names(function: ast.FunctionDef | ast.AsyncFunctionDef) -> list[str]:
    args = function.args
    return [a.arg for a in (*args.posonlyargs, *args.args, *args.kwonlyargs)]


#: Backend parameter names that also mean something else: a bootstrap's seed, an object's
#: surface samples, a figure's grid.
SHARED_NAMES = {"seed", "surface_samples", "grid"}


def backend_option_names() -> set[str]:
    """Every constructor parameter of the built-in backends, but `SHARED_NAMES`."""
    from exactgrasp.backends.exact.options import PARAMETERS
    from exactgrasp.backends.voxel.backend import VoxelBackend

    return (set(PARAMETERS) | set(VoxelBackend.parameter_constraints)) - SHARED_NAMES


@pytest.mark.parametrize("module", sorted(MODULES))
def test_a_backend_is_configured_only_by_its_instance(module):
    """``backend=`` is a registered name or a configured instance everywhere: no function
    takes ``backend_params``, and outside the backends no function takes a backend's own
    option (``broadphase=``, ``n_jobs=``, ``object_resolution=``, ...)."""
    options = backend_option_names()
    found = []
    for function in functions(module):
        names = parameter_names(function)
        kwarg = function.args.kwarg.arg if function.args.kwarg else None
        if "backend_params" in (*names, kwarg):
            found.append(f"{function.name}: backend_params")
        if room(module) == "backends":
            continue
        if set(names) & options:
            found.append(f"{function.name}: {sorted(set(names) & options)}")
    assert not found, f"{module}: {found}"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_flag_changes_a_return_type(module):
    """One return type per function: a richer result is another function
    (`close_fingers_result` beside `close_fingers`), not a ``full_output=`` or ``return_*=``
    flag."""
    flags = [
        f"{function.name}({name}=...)"
        for function in functions(module)
        for name in parameter_names(function)
        if name == "full_output" or name.startswith("return_")
    ]
    assert not flags, f"{module}: {flags}"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_repair_has_one_default(module):
    """Every ``repair`` option defaults to `exactgrasp.geometry.intake.REPAIR` (or None: "as
    the file says"), never to a literal of its own."""
    found = []
    for function in functions(module):
        args = function.args
        positional = [*args.posonlyargs, *args.args]
        with_default = positional[len(positional) - len(args.defaults) :]
        pairs = list(zip(with_default, args.defaults, strict=True))
        pairs += [
            (a, d) for a, d in zip(args.kwonlyargs, args.kw_defaults, strict=True) if d is not None
        ]
        for arg, default in pairs:
            if (
                arg.arg == "repair"
                and isinstance(default, ast.Constant)
                and default.value is not None
            ):
                found.append(f"{function.name}(repair={default.value!r})")
    assert not found, f"{module}: {found}"


#: The public entries that check poses (`exactgrasp.backends.base.check_poses`); what they call
#: takes checked poses and does not check them again.
POSE_CHECKERS = {
    "exactgrasp.backends",
    "exactgrasp.backends.base",
    "exactgrasp.backends.exact.backend",
    "exactgrasp.backends.exact.gradients",  # the boolean reference of the moments only
    "exactgrasp.backends.exact.reference",
    "exactgrasp.backends.voxel.backend",
    "exactgrasp.backends.voxel.kernel",  # `estimate_*`; the `*_of_checked` functions trust
    "exactgrasp.overlap",
    "exactgrasp.vertex_gradients",
    "exactgrasp.cli.overlap",
}


def test_poses_are_checked_at_the_public_entries_only():
    checking = {
        module
        for module, path in MODULES.items()
        if any(
            isinstance(node, ast.Name) and node.id == "check_poses"
            for node in ast.walk(ast.parse(path.read_text()))
        )
    }
    assert checking <= POSE_CHECKERS, sorted(checking - POSE_CHECKERS)
    assert "exactgrasp.backends.exact.intersector" not in checking
