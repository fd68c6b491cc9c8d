"""Count the public functions and classes that carry numpydoc sections (issue 34, item 7).

Layer: tests (documentation audit, reads source with ``ast``, imports nothing).

The public API is every function and class named in a module's ``__all__`` and defined in
that same module, across the packages ``nvrq``, ``data_schema``, ``annotate`` and
``analysis`` (a name re-exported by a package ``__init__`` is counted once, where it is
defined).

Rule for "where they apply":

- a function needs a ``Parameters`` section if it takes any parameter (positional,
  keyword-only, ``*args`` or ``**kwargs``);
- a function needs a ``Returns`` section if it returns a value: its return annotation is
  present and is not ``None``, or (without an annotation) its body has a ``return <value>``
  statement; a generator (a ``yield`` in its own body) needs a ``Yields`` section instead;
- a class needs a ``Parameters`` section if its ``__init__`` takes parameters besides
  ``self``; a dataclass or ``NamedTuple`` needs an ``Attributes`` or ``Parameters`` section
  when it declares fields;
- command modules' ``register(sub)`` and ``run(args)`` are functions like any other.

An item counts as documented when it has a docstring and every section the rule asks for
(a numpydoc section is its title on its own line, underlined by dashes). The share of
documented items must be at least 90 %.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("nvrq", "data_schema", "annotate", "analysis")
THRESHOLD = 0.90


@dataclass(frozen=True)
class Item:
    """One public function or class and what its docstring lacks.

    Attributes
    ----------
    where : str
        ``path:line name`` of the definition, relative to the repository root.
    missing : tuple of str
        Section titles the rule asks for that the docstring lacks (``"docstring"`` when
        there is none at all); empty when the item is documented.
    """

    where: str
    missing: tuple[str, ...]


def _sections(doc: str) -> set[str]:
    """Titles of the numpydoc sections in ``doc`` (a title line underlined by dashes)."""
    found = re.findall(r"^[ \t]*([A-Z][A-Za-z ]+?)[ \t]*\n[ \t]*-{3,}[ \t]*$", doc, re.M)
    return set(found)


def _all_names(tree: ast.Module) -> set[str]:
    """String constants assigned (or added) to ``__all__`` at module level."""
    names: set[str] = set()
    for node in tree.body:
        targets: list[ast.expr] = []
        if isinstance(node, ast.Assign):
            targets = node.targets
        elif isinstance(node, (ast.AugAssign, ast.AnnAssign)):
            targets = [node.target]
        if not any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
            continue
        if node.value is None:
            continue
        for elt in ast.walk(node.value):
            if isinstance(elt, ast.Constant) and isinstance(elt.value, str):
                names.add(elt.value)
    return names


def _own_nodes(func: ast.AST):
    """Nodes in ``func``'s body, not descending into nested functions, lambdas or classes."""
    stack = list(ast.iter_child_nodes(func))
    while stack:
        node = stack.pop()
        yield node
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)):
            continue
        stack.extend(ast.iter_child_nodes(node))


def _takes_parameters(args: ast.arguments, *, method: bool = False) -> bool:
    """Whether a signature has a parameter (besides a method's leading ``self``/``cls``)."""
    positional = [a.arg for a in args.posonlyargs + args.args]
    if method and positional and positional[0] in ("self", "cls"):
        positional = positional[1:]
    return bool(positional or args.kwonlyargs or args.vararg or args.kwarg)


def _is_none(node: ast.expr | None) -> bool:
    return isinstance(node, ast.Constant) and node.value is None or (
        isinstance(node, ast.Name) and node.id == "None"
    )


def _function_needs(func: ast.FunctionDef | ast.AsyncFunctionDef) -> list[tuple[str, ...]]:
    """Sections a function needs; each entry lists the titles that satisfy it."""
    needs: list[tuple[str, ...]] = []
    if _takes_parameters(func.args):
        needs.append(("Parameters",))
    body = list(_own_nodes(func))
    if any(isinstance(n, (ast.Yield, ast.YieldFrom)) for n in body):
        needs.append(("Yields",))
        return needs
    if func.returns is not None:
        returns_value = not _is_none(func.returns)
    else:
        returns_value = any(
            isinstance(n, ast.Return) and n.value is not None and not _is_none(n.value)
            for n in body
        )
    if returns_value:
        needs.append(("Returns",))
    return needs


def _decorator_name(node: ast.expr) -> str:
    if isinstance(node, ast.Call):
        node = node.func
    if isinstance(node, ast.Attribute):
        return node.attr
    return node.id if isinstance(node, ast.Name) else ""


def _class_needs(cls: ast.ClassDef) -> list[tuple[str, ...]]:
    """Sections a class needs; each entry lists the titles that satisfy it."""
    is_record = any(_decorator_name(d) == "dataclass" for d in cls.decorator_list) or any(
        _decorator_name(b) == "NamedTuple" for b in cls.bases
    )
    if is_record:
        fields = [
            n for n in cls.body
            if isinstance(n, ast.AnnAssign) and "ClassVar" not in ast.unparse(n.annotation)
        ]
        if fields:
            return [("Attributes", "Parameters")]
    for node in cls.body:
        if isinstance(node, ast.FunctionDef) and node.name == "__init__":
            if _takes_parameters(node.args, method=True):
                return [("Parameters",)]
    return []


def _audit(path: Path) -> list[Item]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    public = _all_names(tree)
    items = []
    for node in tree.body:
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            continue
        if node.name not in public:
            continue
        doc = ast.get_docstring(node)
        if isinstance(node, ast.ClassDef):
            needs = _class_needs(node)
        else:
            needs = _function_needs(node)
        if doc is None:
            missing = ("docstring",)
        else:
            have = _sections(doc)
            missing = tuple("/".join(n) for n in needs if not have.intersection(n))
        where = f"{path.relative_to(ROOT)}:{node.lineno} {node.name}"
        items.append(Item(where, missing))
    return items


def audit() -> list[Item]:
    """Every public function and class of the four packages, with what each lacks.

    Returns
    -------
    list of Item
        One entry per function or class named in its own module's ``__all__``, in path
        order.
    """
    items: list[Item] = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            items.extend(_audit(path))
    return items


def test_rule_on_hand_written_examples():
    # Hand-worked cases of the rule in the module docstring: what each definition needs.
    src = '''
def f(x) -> int:
    """Doc.

    Parameters
    ----------
    x : int
        A value.
    """
def g():
    yield 1
def h():
    return None
@dataclass
class R:
    a: int
class P:
    def __init__(self, n): ...
'''
    tree = ast.parse(src)
    f, g, h, r, p = tree.body
    assert _function_needs(f) == [("Parameters",), ("Returns",)]
    assert _sections(ast.get_docstring(f)) == {"Parameters"}
    assert _function_needs(g) == [("Yields",)]
    assert _function_needs(ast.parse("def d(cls): return cls").body[0]) == [
        ("Parameters",), ("Returns",)]  # a module-level function's ``cls`` is a parameter
    assert _function_needs(h) == []
    assert _class_needs(r) == [("Attributes", "Parameters")]
    assert _class_needs(p) == [("Parameters",)]


def test_public_api_has_numpydoc_sections():
    items = audit()
    assert len(items) > 300, "the audit found too few public items: is __all__ parsed?"
    undocumented = [i for i in items if i.missing]
    share = 1 - len(undocumented) / len(items)
    report = "\n".join(f"{i.where}: missing {', '.join(i.missing)}" for i in undocumented)
    assert share >= THRESHOLD, (
        f"{len(items) - len(undocumented)} of {len(items)} public functions and classes "
        f"({share:.1%}) have the numpydoc sections they need; {THRESHOLD:.0%} required.\n"
        f"{report}"
    )
