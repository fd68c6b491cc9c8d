"""The stage order of imports (data_schema <- nvrq <- annotate <- analysis; commands on top)
and the command-line entry points' import cost (no deep-learning runtime, plotting, web app
or SciPy for ``--help``)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: each package may import only the stages at or below it (its index in this tuple)
STAGES = ("data_schema", "nvrq", "annotate", "analysis")


def _imported_packages(path: Path) -> set[str]:
    """First components of every absolute import in ``path`` (module top or in functions)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.add(node.module.split(".")[0])
        elif isinstance(node, ast.Import):
            out.update(a.name.split(".")[0] for a in node.names)
    return out


@pytest.mark.parametrize("package", STAGES)
def test_no_module_imports_a_later_stage(package):
    later = set(STAGES[STAGES.index(package) + 1:])
    bad = {
        str(p.relative_to(ROOT)): sorted(_imported_packages(p) & later)
        for p in sorted((ROOT / package).rglob("*.py"))
    }
    assert {k: v for k, v in bad.items() if v} == {}


#: what no ``--help`` may import: deep-learning runtimes, plotting, the web app, the analyses,
#: and the table and image libraries (pandas alone costs about 0.5 s of CPU)
HELP_FREE = ("torch", "transformers", "ray", "openvino", "onnxruntime", "matplotlib", "streamlit",
             "playwright", "ultralytics", "scipy", "sklearn", "pandas", "pyarrow", "cv2")


@pytest.mark.parametrize("cli", ["nvrq.cli", "annotate.cli", "analysis.cli"])
def test_help_imports_no_heavy_package(cli):
    # `PROG --help` and `PROG COMMAND --help` of every subcommand (issue 29 item 10: --help answers
    # in under 1 s, benchmarks/bench_cli_help.py times it): torch, matplotlib, streamlit, SciPy,
    # scikit-learn, pandas and OpenCV are imported by the commands that run them, never for help
    code = (
        "import contextlib, io, sys\n"
        f"import {cli} as cli\n"
        "def commands(parser, path=()):\n"  # every (sub)command, nested ones too
        "    yield path\n"
        "    for a in parser._actions:\n"
        "        for name, sub in (a.choices.items() if isinstance(a.choices, dict) else ()):\n"
        "            if hasattr(sub, '_actions'):\n"
        "                yield from commands(sub, (*path, name))\n"
        "names = list(commands(cli.build_parser()))[1:]\n"
        "for argv in [['--help'], *[[*n, '--help'] for n in names]]:\n"
        "    with contextlib.redirect_stdout(io.StringIO()) as out:\n"
        "        assert cli.main(argv) == 0, argv\n"
        "    assert 'usage:' in out.getvalue(), argv\n"
        f"print(len(names), sorted(h for h in {HELP_FREE!r} if h in sys.modules))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    n, heavy = proc.stdout.strip().split(" ", 1)
    assert heavy == "[]"
    assert int(n) >= {"nvrq.cli": 10, "annotate.cli": 6, "analysis.cli": 0}[cli]


# --- the module import graph ---------------------------------------------------------------------
#
# Edges are every import statement of a module, at its top *and* inside functions: a deferred
# import (kept for start-up cost) is still a dependency, and the one cycle the tree had
# (nvrq.metrics <-> nvrq.pyiqa_bridge, issue 26) ran through a function-level import. An import
# ``from a.b import c`` points at ``a.b.c`` when that is a module, else at ``a.b``; a package's
# ``__init__`` is a module of its own (its re-exports are its edges) and is not added as an edge
# of every import of one of its submodules, which would make each re-exporting package a cycle.

def _module_names() -> dict[str, Path]:
    out = {}
    for package in STAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            out[_module_name(path)] = path
    return out


def _module_graph() -> dict[str, set[str]]:
    """Module name -> the project modules it imports (see the comment above)."""
    modules = _module_names()

    def target(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        edges = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package.split(".")[:len(package.split(".")) - node.level + 1]
                    base = ".".join([*up, base] if base else up)
                names = [f"{base}.{a.name}" for a in node.names]
            else:
                continue
            edges.update(t for t in map(target, names) if t is not None and t != name)
        graph[name] = edges
    return graph


def _strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of ``graph`` (iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, edges = work[-1]
            w = next(edges, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                out.append(sorted(comp))
    return out


def test_strongly_connected_components_of_a_known_graph():
    # a -> b -> c -> a is one component; d -> a alone; e alone (a hand-drawn graph)
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert sorted(_strongly_connected(graph)) == [["a", "b", "c"], ["d"], ["e"]]


def test_module_graph_counts_function_level_and_relative_imports():
    graph = _module_graph()
    assert "nvrq.metrics.formulas" in graph["nvrq.encoders.drift"]  # imported inside a function
    assert "nvrq.metrics.pixel" in graph["nvrq.metrics.registry"]  # from nvrq.metrics import pixel


def test_no_import_cycle_anywhere():
    cycles = [c for c in _strongly_connected(_module_graph()) if len(c) > 1]
    assert cycles == []


def _reachable(graph: dict[str, set[str]], start: str) -> set[str]:
    seen, todo = set(), [start]
    while todo:
        for w in graph[todo.pop()] - seen:
            seen.add(w)
            todo.append(w)
    return seen


#: within nvrq: each package may not reach the modules above it (metric facts <- scoring <- api,
#: engines <- commands); ``nvrq.metrics.info`` is a leaf of the metrics package. The metrics and
#: the scoring plan name encoders (the leaf ``nvrq.encoder_specs``) but never reach the encoders
#: that load them, nor the tau calibration
NVRQ_LAYERS = {
    "nvrq.metrics": ("nvrq.scoring", "nvrq.api", "nvrq.engines", "nvrq.commands", "nvrq.cli", "nvrq.encoders",
                     "nvrq.calibrate"),
    "nvrq.scoring": ("nvrq.api", "nvrq.engines", "nvrq.commands", "nvrq.cli", "nvrq.encoders", "nvrq.calibrate"),
    "nvrq.api": ("nvrq.scoring.driver", "nvrq.engines", "nvrq.commands", "nvrq.cli"),
}


@pytest.mark.parametrize("package", sorted(NVRQ_LAYERS))
def test_nvrq_packages_reach_no_layer_above(package):
    graph = _module_graph()
    bad = {}
    for name in graph:
        if name == package or name.startswith(package + "."):
            above = sorted(m for m in _reachable(graph, name) if m.startswith(NVRQ_LAYERS[package]))
            if above:
                bad[name] = above
    assert bad == {}


def test_metric_info_is_a_leaf_and_the_api_imports_no_driver():
    graph = _module_graph()
    assert not {m for m in graph["nvrq.metrics.info"] if m.startswith("nvrq")}
    # the Python front door calls the core and the resolver, never the table driver (no tqdm,
    # no decode threads); at run time too. Since issue 34 the resolver is reached through the
    # one scoring plan (nvrq.scoring.plan.resolve_plan, which calls nvrq.metrics.resolve)
    assert {"nvrq.scoring.core", "nvrq.scoring.plan"} <= graph["nvrq.api"]
    assert "nvrq.metrics.resolve" in graph["nvrq.scoring.plan"]
    code = ("import sys, numpy as np, nvrq\n"
            "gt = np.zeros((8, 8, 3), np.uint8)\n"
            "nvrq.score_crops([gt], [gt + 1], metrics=['psnr', 'niqe'])\n"
            "print(sorted(m for m in ('tqdm', 'torch', 'nvrq.scoring.driver', 'nvrq.scoring.batches')"
            " if m in sys.modules))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "[]"


#: The command layer, on top of every stage: the three entry points (and ``python -m nvrq``) and
#: their subcommand modules (``nvrq.commands.args`` holds the argument conventions all three share).
COMMAND_LAYER = ("nvrq.cli", "nvrq.__main__", "nvrq.commands", "annotate.cli", "annotate.commands",
                 "analysis.cli")


def _in_command_layer(module: str) -> bool:
    return any(module == c or module.startswith(c + ".") for c in COMMAND_LAYER)


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imported_modules(path: Path, text: str | None = None) -> set[str]:
    """Every module the file ``path`` (its ``text``, default: read) imports by name, relative
    imports resolved: ``from a.b import c`` gives ``a.b`` and ``a.b.c`` (``c`` may be a module)."""
    package = _module_name(path).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8") if text is None else text)):
        if isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = ".".join([*base, *([node.module] if node.module else [])])
            out.add(module)
            out.update(f"{module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def test_only_the_command_layer_imports_the_command_layer():
    # the library of every stage is callable without its CLI: no module outside the command
    # layer imports an entry point or a subcommand module (the CLIs import the library)
    bad = {}
    for package in STAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if _in_command_layer(_module_name(path)):
                continue
            hits = sorted(m for m in _imported_modules(path) if _in_command_layer(m))
            if hits:
                bad[str(path.relative_to(ROOT))] = hits
    assert bad == {}


def test_the_command_layer_rule_sees_every_kind_of_import():
    # the rule's import reader on a hand-written module with each kind of import
    lib = ROOT / "nvrq" / "engines" / "example.py"  # as if it were in nvrq.engines (not written)
    text = ("import nvrq.commands.args\nfrom nvrq import cli\nfrom ..commands import score\n"
            "from annotate.commands.serve import base_url\nimport numpy\n")
    modules = {m for m in _imported_modules(lib, text) if _in_command_layer(m)}
    assert modules == {"nvrq.commands.args", "nvrq.cli", "nvrq.commands", "nvrq.commands.score",
                       "annotate.commands.serve", "annotate.commands.serve.base_url"}
    assert not _in_command_layer("nvrq.client") and _in_command_layer("analysis.cli")



def test_tests_mirror_the_packages():
    # issue 26: tests live in the folder of the package they test (tests/conftest.py says which);
    # only the project-wide checks stay at the top of tests/
    loose = sorted(p.name for p in (ROOT / "tests").glob("test_*.py"))
    assert loose == ["test_benchmarks.py", "test_doc_links.py", "test_doc_numbers.py", "test_import_layers.py",
                     "test_lint_imports.py", "test_numpydoc.py", "test_readme.py", "test_signatures.py",
                     "test_user_text.py", "test_vulture.py"]


#: the old homes of nvrq's tests (before they moved under tests/nvrq/): none may hold a test again
OLD_NVRQ_TEST_FOLDERS = ("api", "commands", "engines", "geometry", "metrics", "pairs", "proxies", "scoring",
                         "sets", "sources", "synth")


def _modules(package: Path) -> set[str]:
    """The names a test file in the mirror of ``package`` may start with: its modules, its
    subpackages and its own name."""
    names = {p.stem for p in package.glob("*.py") if p.stem != "__init__"}
    names |= {p.name for p in package.iterdir() if (p / "__init__.py").is_file()}
    return names | {package.name}


def test_nvrq_tests_mirror_nvrq_packages():
    # tests/nvrq/<folder>/test_<module>[_<aspect>].py tests nvrq/<folder>/<module>(.py or package)
    tests = ROOT / "tests" / "nvrq"
    files = sorted(tests.rglob("test_*.py"))
    assert files, "no test under tests/nvrq"
    bad = []
    for path in files:
        package = ROOT / "nvrq" / path.parent.relative_to(tests)
        if not (package / "__init__.py").is_file():
            bad.append(f"{path.relative_to(ROOT)}: nvrq has no package {package.relative_to(ROOT)}")
            continue
        name = path.stem.removeprefix("test_")
        if not any(name == m or name.startswith(m + "_") for m in _modules(package)):
            bad.append(f"{path.relative_to(ROOT)}: names no module of {package.relative_to(ROOT)}")
    assert bad == []


@pytest.mark.parametrize("package", ["annotate", "data_schema"])
def test_package_tests_mirror_package_folders(package):
    tests = ROOT / "tests" / package
    bad = [str(p.relative_to(ROOT)) for p in sorted(tests.rglob("test_*.py"))
           if not (ROOT / package / p.parent.relative_to(tests) / "__init__.py").is_file()]
    assert bad == []


def test_no_test_left_in_the_old_nvrq_test_folders():
    left = [str(p.relative_to(ROOT)) for folder in OLD_NVRQ_TEST_FOLDERS
            for p in sorted((ROOT / "tests" / folder).rglob("*")) if p.is_file() and "__pycache__" not in p.parts]
    assert left == []
