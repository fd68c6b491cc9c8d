"""Code-shape rules of issue 34 item 6, checked over every non-test module.

Layer: tests (repository hygiene). The rules come from ../shared/DESIGN.md "Habits" 15 and the
helper standards: no public function takes more than 8 parameters (``self``/``cls`` excluded;
``*args``/``**kwargs`` count as one each), and no function body is longer than 60 lines, the
docstring excluded. The scan reads the source with :mod:`ast`, so it measures exactly what a reader
sees, independently of imports or runtime decoration.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("nvrq", "data_schema", "annotate", "analysis", "benchmarks")
MAX_PARAMS = 8
MAX_BODY_LINES = 60


def _source_files() -> list[Path]:
    files = []
    for package in PACKAGES:
        files.extend(p for p in sorted((ROOT / package).rglob("*.py")) if "tests" not in p.parts)
    return files


def _functions(tree: ast.AST):
    """Yield ``(qualified name, node, public)`` for every function, nested ones included."""

    def walk(node, prefix, public):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = f"{prefix}{child.name}"
                is_public = public and not child.name.startswith("_")
                yield name, child, is_public
                yield from walk(child, name + ".<locals>.", False)
            elif isinstance(child, ast.ClassDef):
                yield from walk(child, f"{prefix}{child.name}.",
                                public and not child.name.startswith("_"))
            else:
                yield from walk(child, prefix, public)

    yield from walk(tree, "", True)


def _param_count(fn: ast.FunctionDef) -> int:
    args = fn.args
    names = [a.arg for a in args.posonlyargs + args.args + args.kwonlyargs]
    count = len(names) + (args.vararg is not None) + (args.kwarg is not None)
    if names and names[0] in ("self", "cls"):
        count -= 1
    return count


def _body_lines(fn: ast.FunctionDef) -> int:
    body = fn.body
    if (body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
            and isinstance(body[0].value.value, str)):
        body = body[1:]
    if not body:
        return 0
    return body[-1].end_lineno - body[0].lineno + 1


def _scan():
    too_many, too_long = [], []
    for path in _source_files():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        rel = path.relative_to(ROOT).as_posix()
        for name, fn, public in _functions(tree):
            if public and _param_count(fn) > MAX_PARAMS:
                too_many.append(f"{rel}:{fn.lineno} {name} ({_param_count(fn)} parameters)")
            if _body_lines(fn) > MAX_BODY_LINES:
                too_long.append(f"{rel}:{fn.lineno} {name} ({_body_lines(fn)} lines)")
    return too_many, too_long


def test_scanner_counts_a_hand_written_example():
    # Hand-worked: 9 named parameters after self, plus *args and **kwargs -> 11; the body is the
    # three statements after the docstring, spanning 4 lines (the dict literal takes two).
    src = ('class K:\n'
           '    def f(self, a, b, c, d, e, f, g, h, i, *args, **kw):\n'
           '        """doc\n        more"""\n'
           '        x = 1\n'
           '        y = {1: 2,\n'
           '             3: 4}\n'
           '        return x\n')
    [(name, fn, public)] = list(_functions(ast.parse(src)))
    assert (name, public) == ("K.f", True)
    assert _param_count(fn) == 11
    assert _body_lines(fn) == 4


def test_no_public_function_takes_more_than_eight_parameters():
    too_many, _ = _scan()
    assert not too_many, "public functions over 8 parameters:\n" + "\n".join(too_many)


def test_no_function_body_is_longer_than_sixty_lines():
    _, too_long = _scan()
    assert not too_long, "function bodies over 60 lines:\n" + "\n".join(too_long)
