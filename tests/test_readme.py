"""The README's commands exist as written.

Every ``nvrq``/``annotate``/``analyze`` line of the README's bash blocks is parsed by the
real argument parser (an unknown option or subcommand fails here); benchmark scripts and
paths they name must exist. The demo workflow itself runs end to end in ``.ci/run`` and
its steps are pinned below against the README's walkthrough.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "README.md").read_text()


def bash_commands() -> list[str]:
    cmds = []
    for block in re.findall(r"```bash\n(.*?)```", README, flags=re.S):
        for line in block.strip().splitlines():
            cmds.extend(part.strip() for part in line.split("&&"))
    return [c for c in cmds if c]


def parser_for(program: str):
    if program == "nvrq":
        from nvrq.cli import build_parser
    elif program == "annotate":
        from annotate.cli import build_parser
    else:
        from analysis.cli import build_parser
    return build_parser()


CLI = [c for c in bash_commands() if shlex.split(c)[0] in ("nvrq", "annotate", "analyze")]


def test_readme_has_the_three_main_commands():
    cmds = bash_commands()
    assert cmds[:3] == ['pip install torch==2.13.0', 'pip install -e ".[test]"', "nvrq demo out/demo"]
    assert "python -m pytest" in cmds
    ci = (REPO / ".ci" / "run").read_text()
    assert 'pip install torch==2.13.0 && pip install -e ".[test]"' in ci and "python -m pytest" in ci


@pytest.mark.parametrize("command", CLI)
def test_readme_cli_line_parses(command):
    argv = shlex.split(command)
    args = parser_for(argv[0]).parse_args(argv[1:])
    assert callable(getattr(args, "func", None)) or argv[0] == "analyze"


@pytest.mark.parametrize("command", [c for c in bash_commands() if c.startswith("python benchmarks/")])
def test_readme_benchmarks_exist(command):
    assert (REPO / shlex.split(command)[1]).is_file()


def test_walkthrough_is_what_the_demo_runs(tmp_path):
    """The demo's steps are the README walkthrough's commands, in order."""
    from argparse import Namespace

    from nvrq.commands.demo import demo_steps

    args = Namespace(seed=0, seconds=6.0, size="960x540", offsets="-3,-2,-1,0,1,2,3",
                     encoder="efficientnet-lite0", raters=5, methods=None)
    steps = demo_steps(Path("out"), args)
    readme_cmds = [shlex.split(c) for c in CLI]

    def parsed(argv):  # the options a command line means, with defaults filled in
        ns = vars(parser_for(argv[0]).parse_args(argv[1:]))
        return {k: v for k, v in ns.items() if k != "func"}

    shown = [parsed(c) for c in readme_cmds]
    for program, argv in steps:
        assert parsed([program, *argv]) in shown, f"README does not show `{program} {' '.join(argv)}`"


def test_readme_figures_exist():
    for img in re.findall(r"\]\((docs/[^)]+\.png)\)", README):
        assert (REPO / img).is_file(), img


def test_compare_reconstructions_is_what_the_methods_demo_runs():
    """``nvrq demo OUT --methods ...`` runs the README's "Compare reconstructions" commands."""
    from argparse import Namespace

    from nvrq.commands.demo import demo_steps

    assert "nvrq demo out/methods --methods sharp:0.5,blurry:1.5" in CLI
    args = Namespace(seed=0, seconds=6.0, size="960x540", offsets="-3,-2,-1,0,1,2,3",
                     encoder="efficientnet-lite0", raters=5, methods="sharp:0.5,blurry:1.5")
    section = README[README.index("## Compare reconstructions"):]
    section = section[:section.index("\n## ")]
    shown = [shlex.split(c) for c in CLI if c in section]

    def parsed(argv):
        ns = vars(parser_for(argv[0]).parse_args(argv[1:]))
        return {k: v for k, v in ns.items() if k != "func"}

    shown = [parsed(c) for c in shown]
    for program, argv in demo_steps(Path("out/methods"), args):
        assert parsed([program, *argv]) in shown, f"README does not show `{program} {' '.join(argv)}`"
