"""The commands of the README and of every guide exist as written, and follow each other.

The documents are read in the order a newcomer reads them: README.md, then the guides in the
order of the README's guides map (docs/guides/), then docs/PYTHON.md. Every
``nvrq``/``annotate``/``analyze`` line of their bash blocks is parsed by the real argument
parser (an unknown option or subcommand fails here); every input under ``out/`` is made by an
earlier line of that sequence, as on a fresh clone; benchmark scripts they name must exist.
The blocks that run in seconds run here (the fleet, the drivestudio example); the two demos run
end to end in ``.ci/run`` and tests/test_doc_numbers.py, and their steps are pinned below
against the walkthrough and "Compare reconstructions".
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "README.md").read_text()


def guide_paths() -> list[Path]:
    """The guides, in the order of the README's guides map, then docs/PYTHON.md."""
    linked = re.findall(r"\]\((docs/guides/[\w-]+\.md)\)", README)
    return [REPO / p for p in dict.fromkeys(linked)] + [REPO / "docs" / "PYTHON.md"]


#: every document with commands, in reading order, as one text
DOCS = "\n".join([README, *(p.read_text(encoding="utf-8") for p in guide_paths())])


def guide(name: str) -> str:
    return (REPO / "docs" / "guides" / name).read_text(encoding="utf-8")


def test_every_guide_is_in_the_readme_map():
    on_disk = {p.name for p in (REPO / "docs" / "guides").glob("*.md")}
    assert on_disk == {p.name for p in guide_paths()[:-1]}


def test_readme_is_short():
    assert len(README.splitlines()) <= 200


def bash_commands(text: str = DOCS) -> list[str]:
    cmds = []
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
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
    cmds = bash_commands(README)
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
    """The demo's steps are the walkthrough's commands."""
    from argparse import Namespace

    from nvrq.commands.demo import demo_steps

    args = Namespace(seed=0, seconds=6.0, size="960x540", offsets="-3,-2,-1,0,1,2,3",
                     encoder="efficientnet-lite0", raters=5, methods=None)
    steps = demo_steps(Path("out"), args)
    readme_cmds = [shlex.split(c) for c in bash_commands(guide("walkthrough.md"))]

    def parsed(argv):  # the options a command line means, with defaults filled in
        ns = vars(parser_for(argv[0]).parse_args(argv[1:]))
        return {k: v for k, v in ns.items() if k != "func"}

    shown = [parsed(c) for c in readme_cmds]
    for program, argv in steps:
        assert parsed([program, *argv]) in shown, f"the walkthrough does not show `{program} {' '.join(argv)}`"


def test_compare_reconstructions_is_what_the_methods_demo_runs():
    """``nvrq demo OUT --methods ...`` runs the commands of the guide "Compare reconstructions"."""
    from argparse import Namespace

    from nvrq.commands.demo import demo_steps

    assert "nvrq demo out/methods --methods sharp:0.5,blurry:1.5" in CLI
    args = Namespace(seed=0, seconds=6.0, size="960x540", offsets="-3,-2,-1,0,1,2,3",
                     encoder="efficientnet-lite0", raters=5, methods="sharp:0.5,blurry:1.5")
    shown = [shlex.split(c) for c in bash_commands(guide("compare-reconstructions.md"))]

    def parsed(argv):
        ns = vars(parser_for(argv[0]).parse_args(argv[1:]))
        return {k: v for k, v in ns.items() if k != "func"}

    shown = [parsed(c) for c in shown]
    for program, argv in demo_steps(Path("out/methods"), args):
        assert parsed([program, *argv]) in shown, f"the guide does not show `{program} {' '.join(argv)}`"


# --- the README and the guides run in order ---------------------------------------------------

#: Inputs under out/ that the README leaves to the user, with why: your renderer's output.
USER_MADE = {"out/renders-3dgs": "the gsplat sketch (needs a trained model)",
             "out/renders-omnire": "another renderer's output"}


def _step(command: str) -> tuple[list[str], list[str]]:
    """``(inputs, outputs)`` under ``out/`` of one README line."""
    argv = shlex.split(command)
    if argv[0] not in ("nvrq", "annotate", "analyze"):
        redirect = argv[argv.index(">") + 1:] if ">" in argv else []
        outs = redirect or ([argv[-1]] if argv[:3] == ["python", "-m", "nvrq.examples.kitti_drivestudio"] else [])
        return [], [o for o in outs if o.startswith("out/")]
    ns = vars(parser_for(argv[0]).parse_args(argv[1:]))
    values = [x for v in ns.values() for x in (v if isinstance(v, list) else [v])
              if isinstance(x, str) and x.startswith("out/")]
    outs = [ns[k] for k in ("out", "study") if isinstance(ns.get(k), str) and ns[k].startswith("out/")]
    if ns.get("command") in ("score", "proxy") and outs and outs[0].endswith(".csv"):
        outs.append(outs[0][:-4] + ".timing.csv")  # written beside --out (FORMATS §4)
    return [v for v in values if v not in outs], outs


def test_every_readme_input_under_out_is_made_by_an_earlier_step():
    # e.g. "Scale out" once used out/fleet, out/clip-attributes.csv and out/fleet-clip-drop with
    # no step making them
    made, missing = set(USER_MADE), []
    for command in bash_commands():
        inputs, outputs = _step(command)
        for path in inputs:
            # made: the path itself, a folder holding it, or a folder of outputs (a fleet)
            if not any(path == m or path.startswith(m + "/") or m.startswith(path + "/") for m in made):
                missing.append((path, command))
        made.update(outputs)
    assert missing == []


def test_a_report_the_readme_writes_again_keeps_its_inputs():
    # `analyze --stability ... --out out/report` after `analyze ... --out out/report` once dropped
    # the speed chart and the torch column
    by_out: dict[str, set] = {}
    for command in CLI:
        if not command.startswith("analyze "):
            continue
        inputs, outputs = _step(command)
        before = by_out.setdefault(outputs[0], set(inputs))
        assert before <= set(inputs), (command, before - set(inputs))
        by_out[outputs[0]] = set(inputs)


def test_readme_names_the_home_folder_variables():
    # where the guides say what the commands write under the home folder
    text = guide("files-and-layout.md")
    section = text[text.index("Under your home folder"):]
    section = section[:section.index("\n\n")]
    assert "$NVRQ_CACHE" in section and "$NVRQ_CONFIG" in section
    assert "~/.cache/nvrq" in section and "~/.config/nvrq/tau.json" in section


def test_python_md_states_the_pairs_min_side_default():
    # docs/PYTHON.md once said >= 16 px; the default is data_schema.defaults.MIN_SIDE_PX
    from data_schema.defaults import MIN_SIDE_PX

    text = (REPO / "docs" / "PYTHON.md").read_text(encoding="utf-8")
    assert re.findall(r"shorter side >= (\d+) px", text) == [str(MIN_SIDE_PX)]


def _block_after(marker: str) -> list[str]:
    """The commands of the first bash block after ``marker`` in the README or a guide."""
    rest = DOCS[DOCS.index(marker):]
    block = re.search(r"```bash\n(.*?)```", rest, flags=re.S).group(1)
    return [line.strip() for line in block.strip().splitlines() if line.strip()]


def _run_line(command: str, shared: Path) -> int:
    """Run one documented line in-process (``../shared`` read from ``shared``)."""
    import subprocess

    argv = shlex.split(command.replace("../shared", str(shared)))
    if argv[0] == "nvrq":
        from nvrq.cli import main
        return main(argv[1:])
    if argv[0] == "analyze":
        from analysis.cli import main
        return main(argv[1:])
    if argv[:3] == ["python", "-m", "nvrq.examples.kitti_drivestudio"]:
        from nvrq.examples.kitti_drivestudio import main
        return main(argv[3:])
    return subprocess.run(command, shell=True, check=False).returncode  # printf > FILE


def test_example_drivestudio_block_runs(shared_dir, tmp_path, monkeypatch, capsys):
    # import -> render plan -> renders back -> leaderboard, no trained model
    if not (shared_dir / "realdata" / "kitti").is_dir():
        pytest.skip("no KITTI frames in ../shared/realdata")
    monkeypatch.chdir(tmp_path)
    for command in _block_after("**Try it without a trained model.**"):
        assert _run_line(command, shared_dir) == 0, command
    out = capsys.readouterr()
    assert "methods by psnr" in out.err + out.out
    board = pytest.importorskip("pandas").read_csv(tmp_path / "out/example-leaderboard/methods.csv")
    psnr = board[(board.metric == "psnr") & (board.breakdown == "on-path") & (board.group == "all")]
    psnr = psnr.set_index("method")["mean"]
    assert psnr["sharp"] > psnr["blurry"]  # a GT blurred by sigma 1 px is closer to it than one by 4 px
    assert list((tmp_path / "out/example").rglob("*.png"))  # made here, never in the repository


def test_scale_out_fleet_block_runs(tmp_path, monkeypatch):
    # the block that makes the fleet, its attributes table and its pairs dataset
    monkeypatch.chdir(tmp_path)
    block = _block_after("A fleet to try it on")
    for command in block:
        assert _run_line(command, tmp_path) == 0, command
    import pandas as pd

    pairs = pd.read_parquet(tmp_path / "out/fleet-pairs")
    assert set(pairs.clip_id) == {"synth-000001", "synth-000002"}
    assert set(pairs.weather) == {"rain", "clear"}


def test_the_readme_links_the_report_screenshots_small_pngs():
    """The report at a desktop and a phone size (docs/make_figures.py writes them)."""
    for name in ("report-1280x800.png", "report-390x844.png"):
        assert f"(docs/img/{name})" in README, name
        data = (REPO / "docs" / "img" / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) < 300_000, (name, len(data))
