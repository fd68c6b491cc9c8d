"""A decompression bomb (a 30000 x 30000 PNG of a few hundred kilobytes, whose decode would take
2.7 GB) is refused from its header: ``nvrq import renders`` below 300 MB of peak memory,
``nvrq score`` below 1 GB, each with one line and exit status 2. Peak memory is each child
process's own high-water mark ``VmHWM`` (Linux ``/proc/self/status``)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from malformed_world import snapshot

# VmHWM, not ru_maxrss: the latter keeps the forked parent's peak across exec
_RUN = ("import json, re, sys\n"
        "from nvrq.cli import main\n"
        "rc = main(sys.argv[1:])\n"
        "hwm = re.search(r'VmHWM:\\s+(\\d+) kB', open('/proc/self/status').read()).group(1)\n"
        "print(json.dumps({'rc': rc, 'peak_mb': int(hwm) / 1024}))\n")


def _bomb(path: Path, side: int = 30000) -> None:
    import struct
    import zlib

    def chunk(tag, body):
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body))

    comp = zlib.compressobj(9)
    row = b"\0" * (side + 1)
    idat = b"".join(comp.compress(row) for _ in range(64)) + comp.flush()  # the first rows only
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", side, side, 8, 0, 0, 0, 0))
                     + chunk(b"IDAT", idat) + chunk(b"IEND", b""))


def _peak(argv) -> tuple[int, float, str]:
    proc = subprocess.run([sys.executable, "-c", _RUN, *argv], capture_output=True, text=True)
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    return res["rc"], res["peak_mb"], proc.stderr


@pytest.mark.parametrize("command", ["import renders", "score"])
def test_a_bomb_is_refused_from_its_header_with_little_memory(world, tmp_path, command):
    import shutil

    if command == "score":
        scene = tmp_path / "scene"
        shutil.copytree(world / "toy" / "scene", scene)
        pairs = tmp_path / "pairs.csv"
        shutil.copy(world / "toy" / "pairs.csv", pairs)
        _bomb(scene / pd.read_csv(pairs)["render_path"].iloc[0])
        argv, limit = ["score", str(pairs), "--scene", str(scene), "--metrics", "psnr", "--out",
                       str(tmp_path / "m.csv"), "--quiet"], 1024
    else:
        from nvrq.cli import main

        assert main(["synth", str(tmp_path / "scene"), "--seconds", "1", "--fps", "1", "--size", "96x54",
                     "--offsets", "1", "--quiet"]) == 0
        _bomb(tmp_path / "r" / "00000.png")
        argv, limit = ["import", "renders", str(tmp_path / "scene"), str(tmp_path / "r"), "--layout", "order",
                       "--replace"], 300
    before = snapshot(tmp_path)
    rc, peak_mb, err = _peak(argv)
    print(f"{command}: peak {peak_mb:.0f} MB")
    assert rc == 2 and err.count("\n") == 1 and "30000x30000" in err, err
    assert peak_mb < limit
    assert snapshot(tmp_path) == before
