"""The package's layout rules, checked on its source (issue 25, "One home for each idea").

- Nothing outside ``sklearn_ifog/export/`` and ``sklearn_ifog/cli/`` imports
  ``sklearn_ifog.export``, at module level or inside a function (the online path and the
  estimators need no code generator): checked on every module of the package.
- No module above ``MAX_MODULE_LINES`` code lines and no function above
  ``MAX_FUNCTION_LINES``: a *code line* is a non-blank line that holds code, outside
  comments and docstrings (the lines of other strings, such as the C templates, count).
  Checked on every module of the package.
- No access to a ``_private`` attribute or method of another module's object, and no import
  of a ``_private`` name from another module unless that module is itself private (a
  module whose name starts with ``_`` says it serves several): checked on every module of
  the package. The allowed exceptions are in ``ALLOWED_PRIVATE`` (each with its reason).
- The version has one home, ``sklearn_ifog/_version.py``: no module but the package root
  reads ``__version__`` from the package root (issue 43).
- The policy has one home, ``sklearn_ifog/policy.py``: no other module compares a policy
  name (``"blend"``, ``"clip"``) with anything, directly or as a member of a tuple, list or
  set of policy names, nor matches one in a ``case`` (issue 43, point 2: the modules ask
  the policy object instead). ``POLICY_COMPARERS`` lists the modules allowed to, at most
  two.
- The house has at most ``MAX_FLOORS`` floors (issue 43, point 8): see :func:`floors`.
- The report, the conformal band, streaming and the exports ask the calibration protocol
  (``outside_calibration``, ``calibration_distance``, ``fallback_share``,
  ``fallback_predict``, ``calibrated_parts``), not the class of the package's estimators:
  no ``isinstance`` / ``issubclass`` against ``PROTOCOL_CLASSES`` in ``PROTOCOL_USERS``
  (issue 43, point 5).

Each checker is also run on a small source with a violation (``test_*_catches_*``), so a
checker that stopped seeing anything would fail here rather than pass silently.
"""

import ast
import io
import re
import tokenize
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "sklearn_ifog"
# Issue 43, point 8 (600 and 120 before).
MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 100

# Private attribute names that are another library's public API: a NamedTuple's own methods
# (underscored so as not to clash with field names), and scikit-learn's parameter validation
# that its estimators call on themselves (``BaseEstimator._validate_params``).
ALLOWED_PRIVATE = {"_asdict", "_fields", "_make", "_replace", "_validate_params"}

# Where importing the code generator is allowed.
EXPORT_USERS = ("export", "cli")

# The policy names a module may not compare, and the modules that may (issue 43, point 2:
# "policy names are compared in at most two modules"; policy.py's ``policy_for`` resolves
# the pipeline's ``uncalibrated`` to its object).
POLICY_NAMES = ("blend", "clip")
POLICY_COMPARERS = ("policy.py",)
# Issue 43, point 8: the floors of the package's module-level import graph (see floors()).
MAX_FLOORS = 9
# Issue 43, point 5: the estimators of the calibration protocol, and the modules that ask the
# protocol rather than branch on these classes.
PROTOCOL_CLASSES = ("CompensationPipeline", "UnitwiseRegressor", "ConformalRegressor")
PROTOCOL_USERS = (
    "report",
    "conformal.py",
    "_compiled.py",
    "_description.py",
    "streaming",
    "export",
)


def _modules(paths=None):
    """The package's modules (``paths``: relative files or folders; None: all of them)."""
    roots = [PACKAGE] if paths is None else [PACKAGE / path for path in paths]
    found = []
    for root in roots:
        found += [root] if root.is_file() else sorted(root.rglob("*.py"))
    return found


def _name(path):
    return path.relative_to(PACKAGE).as_posix()


def _docstring_lines(tree):
    lines = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if (
                body
                and isinstance(body[0], ast.Expr)
                and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)
            ):
                lines.update(range(body[0].lineno, body[0].end_lineno + 1))
    return lines


def code_lines(source):
    """The numbers of the code lines of ``source`` (see the module docstring), and its AST."""
    tree = ast.parse(source)
    skipped = _docstring_lines(tree)
    text = source.splitlines()
    ignored = {
        tokenize.COMMENT,
        tokenize.NL,
        tokenize.NEWLINE,
        tokenize.INDENT,
        tokenize.DEDENT,
        tokenize.ENDMARKER,
    }
    lines = set()
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type in ignored:
            continue
        for number in range(token.start[0], token.end[0] + 1):
            if number not in skipped and text[number - 1].strip():
                lines.add(number)
    return lines, tree


def size_violations(source, label):
    """``label: N code lines`` for a module over the limit, and the same for its functions."""
    lines, tree = code_lines(source)
    found = []
    if len(lines) > MAX_MODULE_LINES:
        found.append(f"{label}: {len(lines)} code lines (limit {MAX_MODULE_LINES})")
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            count = sum(node.lineno <= line <= node.end_lineno for line in lines)
            if count > MAX_FUNCTION_LINES:
                found.append(
                    f"{label}:{node.lineno} {node.name}: {count} code lines "
                    f"(limit {MAX_FUNCTION_LINES})"
                )
    return found


def export_imports(source, label):
    """Every import of ``sklearn_ifog.export`` in ``source`` (a module of the package named
    ``label``), at any depth: ``import``, ``from ... import``, relative imports resolved
    from ``label``, and ``importlib.import_module("...")`` with a constant name."""
    tree = ast.parse(source)
    package = ["sklearn_ifog", *label.removesuffix(".py").split("/")][:-1]
    if label.endswith("__init__.py"):
        package = ["sklearn_ifog", *label.split("/")[:-1]]
    found = []
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package[: len(package) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            names = [base] + [f"{base}.{alias.name}" for alias in node.names]
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, (ast.Attribute, ast.Name))
            and getattr(node.func, "attr", getattr(node.func, "id", None)) == "import_module"
            and node.args
            and isinstance(node.args[0], ast.Constant)
        ):
            names = [str(node.args[0].value)]
        if any(name.split(".")[:2] == ["sklearn_ifog", "export"] for name in names):
            found.append(f"{label}:{node.lineno} imports {names[0]}")
    return found


def _defined_private_names(tree):
    """Private names this module defines: functions, classes, methods, attributes it sets."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
    return {name for name in names if name.startswith("_")}


def private_accesses(source, label):
    """``(name, "label:line .name")`` for each ``obj._name`` whose ``_name`` this module does
    not define (a private attribute or method of another module's object), and for each
    ``from <module> import _name`` of a module of the package that is not itself private."""
    tree = ast.parse(source)
    own = _defined_private_names(tree)
    package = ["sklearn_ifog", *label.removesuffix(".py").split("/")][:-1]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package[: len(package) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            parts = base.split(".")
            if parts[0] != "sklearn_ifog" or parts[-1].startswith("_"):
                continue
            folder = PACKAGE.joinpath(*parts[1:])
            for alias in node.names:
                # a private module of the package (``from sklearn_ifog import _table``)
                is_module = (folder / f"{alias.name}.py").is_file() or (
                    folder / alias.name
                ).is_dir()
                if (
                    alias.name.startswith("_")
                    and not alias.name.startswith("__")
                    and not is_module
                ):
                    found.append((alias.name, f"{label}:{node.lineno} imports {alias.name}"))
            continue
        if not isinstance(node, ast.Attribute):
            continue
        name = node.attr
        if not name.startswith("_") or name.startswith("__") or name in own:
            continue
        if name in ALLOWED_PRIVATE:
            continue
        found.append((name, f"{label}:{node.lineno} .{name}"))
    return found


def root_version_reads(source, label):
    """Every read of ``__version__`` from the package root in ``source``:
    ``from sklearn_ifog import __version__`` and ``sklearn_ifog.__version__``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.module == "sklearn_ifog" and not node.level:
            if any(alias.name == "__version__" for alias in node.names):
                found.append(f"{label}:{node.lineno} imports __version__")
        elif (
            isinstance(node, ast.Attribute)
            and node.attr == "__version__"
            and isinstance(node.value, ast.Name)
            and node.value.id == "sklearn_ifog"
        ):
            found.append(f"{label}:{node.lineno} reads sklearn_ifog.__version__")
    return found


def _policy_names_in(node):
    """The policy names ``node`` is, or holds as a tuple, list or set of policy names only
    (``key in {"name", "clip"}`` is about keys, not the policy)."""
    if isinstance(node, ast.Constant):
        return [node.value] if node.value in POLICY_NAMES else []
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)) and node.elts:
        names = [element.value for element in node.elts if isinstance(element, ast.Constant)]
        if len(names) == len(node.elts) and all(name in (*POLICY_NAMES, "none") for name in names):
            return [name for name in names if name in POLICY_NAMES]
    return []


def policy_comparisons(source, label):
    """``label:line`` for every comparison with a policy name in ``source``, and every
    ``case`` that matches one."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            names = [
                name for part in (node.left, *node.comparators) for name in _policy_names_in(part)
            ]
        elif isinstance(node, ast.MatchValue):
            names = _policy_names_in(node.value)
        else:
            continue
        if names:
            found.append(f"{label}:{node.lineno} compares {', '.join(map(repr, names))}")
    return found


def class_branches(source, label):
    """``label:line`` for every ``isinstance``/``issubclass`` against a protocol class."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if not (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in ("isinstance", "issubclass")
            and len(node.args) == 2
        ):
            continue
        second = node.args[1]
        kinds = second.elts if isinstance(second, ast.Tuple) else [second]
        names = [
            kind.id if isinstance(kind, ast.Name) else getattr(kind, "attr", None)
            for kind in kinds
        ]
        hits = [name for name in names if name in PROTOCOL_CLASSES]
        if hits:
            found.append(f"{label}:{node.lineno} branches on {', '.join(hits)}")
    return found


def _module_name(label):
    """``"rbf/_basis.py"`` -> ``"sklearn_ifog.rbf._basis"``, ``"rbf/__init__.py"`` ->
    ``"sklearn_ifog.rbf"``, ``"__init__.py"`` -> ``"sklearn_ifog"``."""
    parts = ["sklearn_ifog", *label.removesuffix(".py").split("/")]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_type_checking(test):
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _module_level_imports(nodes):
    """The import statements that run when the module is imported: at any depth of the
    module's body (``try``, ``if``, a class body), not inside a function or a lambda, nor
    under ``if TYPE_CHECKING:`` (its ``else`` runs)."""
    for node in nodes:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            continue
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            yield from _module_level_imports(node.orelse)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        else:
            yield from _module_level_imports(ast.iter_child_nodes(node))


def package_imports(source, label, modules):
    """The package modules (dotted names, among ``modules``) that the module ``label``
    imports at module level. ``from a.b import c`` imports the module ``a.b.c`` when there
    is one, else the module ``a.b`` (``c`` is a name in it); a package's ``__init__`` is the
    module of its dotted name. The ancestors' ``__init__`` that Python runs on the way to
    ``a.b.c`` are not counted (see :func:`floors`)."""
    package = _module_name(label).split(".")
    if not label.endswith("__init__.py"):
        package = package[:-1]
    found = set()
    for node in _module_level_imports(ast.parse(source).body):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        else:
            base = node.module or ""
            if node.level:
                parent = package[: len(package) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            targets = [
                f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                for alias in node.names
            ]
        for target in targets:
            while target and target not in modules:  # ``import a.b.c as d``: the module
                target = target.rpartition(".")[0]
            if target and target != _module_name(label):
                found.add(target)
    return found


def floors(sources):
    """The floor of every module of a package, and the longest chain under each.

    ``sources`` maps a module's label (``"rbf/_basis.py"``) to its source. A module that
    imports no other module of the package at module level is on floor 1; any other is one
    floor above the highest module it imports at module level (:func:`package_imports`:
    imports inside a function, or under ``if TYPE_CHECKING:``, do not count). A package's
    ``__init__`` is a module like the others: importing ``sklearn_ifog.rbf`` stands on it.

    Importing ``sklearn_ifog.rbf._basis`` also runs ``rbf/__init__.py``, and this measure
    does not count that: a floor is what a module's own code stands on, and the code that
    uses ``rbf._basis.tail_features`` uses none of the estimator ``rbf/__init__`` re-exports.
    Counting the ancestors' ``__init__`` would put every user of a subpackage's low-level
    helper above the subpackage's top, so a helper under ``rbf/`` (where DESIGN.md puts it)
    could never sit low, whatever the code's layering. A module that imports the package
    root itself (``from sklearn_ifog import x``) does stand on the root, which imports the
    public modules: that is an arrow back up, and it shows as a cycle.

    Returns
    -------
    floor : dict
        Dotted module name -> its floor.
    chain : dict
        Dotted module name -> the longest chain of imports under it, itself first.

    Raises
    ------
    ValueError
        On an import cycle, naming it.
    """
    names = {_module_name(label): label for label in sources}
    imports = {
        name: sorted(package_imports(sources[label], label, names))
        for name, label in names.items()
    }
    floor, chain = {}, {}

    def visit(name, path):
        if name in path:
            cycle = [*path[path.index(name) :], name]
            raise ValueError("import cycle: " + " -> ".join(cycle))
        if name not in floor:
            below = [(visit(other, (*path, name)), other) for other in imports[name]]
            top = max(below, default=(0, None))
            floor[name] = top[0] + 1
            chain[name] = [name, *(chain[top[1]] if top[1] else [])]
        return floor[name]

    for name in sorted(names):
        visit(name, ())
    return floor, chain


def _package_floors():
    return floors({_name(path): path.read_text() for path in _modules()})


def _tallest(floor, chain):
    """The height and every longest chain, one per line."""
    height = max(floor.values())
    tops = sorted(name for name, value in floor.items() if value == height)
    return height, "\n".join(" -> ".join(chain[name]) for name in tops)


# -- the rules on the package -----------------------------------------------------------------


def test_nothing_outside_export_and_cli_imports_export():
    found = []
    for path in _modules():
        label = _name(path)
        if label.split("/")[0] in EXPORT_USERS:
            continue
        found += export_imports(path.read_text(), label)
    assert not found, "\n".join(found)


def test_the_version_is_read_from_its_module():
    found = []
    for path in _modules():
        if _name(path) != "__init__.py":
            found += root_version_reads(path.read_text(), _name(path))
    assert not found, "\n".join(found)


@pytest.mark.parametrize("path", _modules(), ids=_name)
def test_modules_and_functions_are_short(path):
    found = size_violations(path.read_text(), _name(path))
    print("\n".join(found))
    assert not found, "\n".join(found)


def test_the_house_has_at_most_9_floors():
    height, tallest = _tallest(*_package_floors())
    print(f"{height} floors; the longest chains:\n{tallest}")
    assert height <= MAX_FLOORS, f"{height} floors (limit {MAX_FLOORS}):\n{tallest}"


def test_no_private_names_of_other_modules():
    found = []
    for path in _modules():
        found += [where for _, where in private_accesses(path.read_text(), _name(path))]
    assert not found, "\n".join(found)


def test_policy_names_are_compared_in_the_policy_module_only():
    assert len(POLICY_COMPARERS) <= 2
    found = []
    for path in _modules():
        if _name(path) not in POLICY_COMPARERS:
            found += policy_comparisons(path.read_text(), _name(path))
    assert not found, "\n".join(found)


def test_the_protocol_users_do_not_branch_on_the_estimators_class():
    found = []
    for path in _modules(PROTOCOL_USERS):
        found += class_branches(path.read_text(), _name(path))
    assert not found, "\n".join(found)


# -- the checkers see a violation -------------------------------------------------------------


def test_the_import_check_catches_every_form():
    source = (
        "import numpy\n"
        "from sklearn_ifog import export\n"
        "import sklearn_ifog.export._c\n"
        "def f():\n"
        "    from sklearn_ifog.export._json import to_json\n"
        "    from ..export import to_c\n"
        "    return importlib.import_module('sklearn_ifog.export')\n"
    )
    found = export_imports(source, "streaming/_compensator.py")
    assert [line.split(":")[1].split()[0] for line in found] == ["2", "3", "5", "6", "7"]
    assert export_imports("from sklearn_ifog import exports_table\n", "x.py") == []


def test_the_version_check_catches_both_forms():
    source = (
        "import sklearn_ifog\n"
        "from sklearn_ifog import __version__\n"
        "def f():\n"
        "    return sklearn_ifog.__version__\n"
    )
    found = root_version_reads(source, "persistence.py")
    assert [line.split(":")[1].split()[0] for line in found] == ["2", "4"]
    assert root_version_reads("from sklearn_ifog._version import __version__\n", "x.py") == []


def test_the_size_check_counts_code_lines_only():
    padding = '    """A docstring\n\n    of four lines."""\n    # a comment\n\n'

    def function(n_statements):
        return "def f():\n" + padding + "".join(f"    x{k} = {k}\n" for k in range(n_statements))

    # The def line and the statements count; the docstring, the comment and blanks do not.
    at_limit, over = function(MAX_FUNCTION_LINES - 1), function(MAX_FUNCTION_LINES)
    assert code_lines(at_limit)[0] == {1, *range(7, 7 + MAX_FUNCTION_LINES - 1)}
    assert size_violations(at_limit, "m.py") == []
    limit = f"(limit {MAX_FUNCTION_LINES})"
    assert size_violations(over, "m.py") == [
        f"m.py:1 f: {MAX_FUNCTION_LINES + 1} code lines {limit}"
    ]
    # The lines of a string that is not a docstring count (not its blank ones).
    template = "T = '''\n" + "#define X 1\n\n" * MAX_MODULE_LINES + "'''\n"
    expected = f"t.py: {MAX_MODULE_LINES + 2} code lines (limit {MAX_MODULE_LINES})"
    assert size_violations(template, "t.py") == [expected]


def test_the_private_check_catches_another_modules_name():
    source = (
        "from sklearn_ifog.metrics import _hidden, per_run_metrics\n"
        "from sklearn_ifog._table import as_table, _scalar\n"
        "from ._per_run import _shared\n"
        "from .report import _number\n"
        "class A:\n"
        "    def _own(self):\n"
        "        return self._cache\n"
        "    def f(self, other):\n"
        "        self._cache = 1\n"
        "        record = other._replace(x=1)\n"
        "        return other._prior, self._own(), other.__class__, record\n"
    )
    # Another module's private attribute; private names imported from public modules (an
    # absolute and a relative import); not those of a private module, not a NamedTuple's.
    found = sorted(name for name, _ in private_accesses(source, "cli/m.py"))
    assert found == ["_hidden", "_number", "_prior"]
    # A private module imported as a module is not a private name.
    assert private_accesses("from sklearn_ifog import _table\n", "m.py") == []


def test_the_policy_check_catches_every_form():
    source = (
        "def f(model, policy, key, domain):\n"
        "    if model.uncalibrated == 'blend':\n"
        "        return 1\n"
        "    if 'clip' != policy:\n"
        "        return 2\n"
        "    if policy in ('blend', 'none'):\n"
        "        return 3\n"
        "    if domain['uncalibrated'] not in {'clip'}:\n"
        "        return 4\n"
        "    match policy:\n"
        "        case 'blend':\n"
        "            return 5\n"
        "    if key in {'name', 'clip', 'op'} or domain['clip'] is None:\n"
        "        return 6\n"  # a step's "clip" key, not the policy
        "    return policy == 'none' or {'blend': 1}[policy]\n"
    )
    found = policy_comparisons(source, "report/_words.py")
    assert [line.split(":")[1].split()[0] for line in found] == ["2", "4", "6", "8", "11"]
    assert found[0] == "report/_words.py:2 compares 'blend'"


def test_the_class_check_catches_every_form():
    source = (
        "import sklearn_ifog.pipeline as p\n"
        "def f(model):\n"
        "    if isinstance(model, CompensationPipeline):\n"
        "        return 1\n"
        "    if isinstance(model, (Pipeline, p.UnitwiseRegressor)):\n"
        "        return 2\n"
        "    if issubclass(type(model), ConformalRegressor):\n"
        "        return 3\n"
        "    return isinstance(model, Pipeline)\n"  # scikit-learn's own class: allowed
    )
    found = class_branches(source, "report/_status.py")
    assert [line.split(":")[1].split()[0] for line in found] == ["3", "5", "7"]
    assert found[1] == "report/_status.py:5 branches on UnitwiseRegressor"


def test_the_floor_count_catches_every_form():
    sources = {
        "__init__.py": "from sklearn_ifog.top import run\n",
        "_low.py": "import numpy\nfrom typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
        "    from sklearn_ifog import top\n",
        "sub/__init__.py": "from .mid import Mid\n",
        "sub/mid.py": "try:\n    from .._low import x\nexcept ImportError:\n    x = None\n",
        "sub/_leaf.py": "X = 1\n",
        "top.py": "import sklearn_ifog.sub._leaf as leaf\nfrom sklearn_ifog.sub import Mid\n"
        "class A:\n    from sklearn_ifog import _low\n"
        "def f():\n    from sklearn_ifog import top\n",
    }
    floor, chain = floors(sources)
    # _low: numpy and the TYPE_CHECKING import do not count; mid: the import inside ``try``
    # (relative, two levels) counts; top: ``sub`` (its __init__, which imports mid) counts,
    # ``sub._leaf`` counts without ``sub``'s __init__, the class body's import counts and the
    # function's does not.
    assert floor == {
        "sklearn_ifog": 5,
        "sklearn_ifog._low": 1,
        "sklearn_ifog.sub": 3,
        "sklearn_ifog.sub.mid": 2,
        "sklearn_ifog.sub._leaf": 1,
        "sklearn_ifog.top": 4,
    }
    assert chain["sklearn_ifog.top"] == [
        "sklearn_ifog.top",
        "sklearn_ifog.sub",
        "sklearn_ifog.sub.mid",
        "sklearn_ifog._low",
    ]
    assert _tallest(floor, chain) == (
        5,
        "sklearn_ifog -> sklearn_ifog.top -> sklearn_ifog.sub -> sklearn_ifog.sub.mid -> "
        "sklearn_ifog._low",
    )
    # An arrow back up: a module that imports the package root stands on every floor.
    cycle = "import cycle: sklearn_ifog -> sklearn_ifog.top -> sklearn_ifog"
    with pytest.raises(ValueError, match=f"^{re.escape(cycle)}$"):
        floors({**sources, "top.py": "from sklearn_ifog import _low, run\n"})
