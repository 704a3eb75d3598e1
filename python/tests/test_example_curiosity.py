"""examples/python/curiosity.py on real footage: its surprise is rost run's surprise.csv."""

import os
import subprocess
import sys

import numpy as np
import pytest

import rost
from conftest import SOURCE_DIR, footage_or_skip

FRAMES = 30


def test_curiosity_example_plots_the_surprise_rost_run_computes(tmp_path):
    pytest.importorskip("cv2", reason="python3-opencv (scripts/install-deps.sh)")
    pytest.importorskip("matplotlib", reason="python3-matplotlib (scripts/install-deps.sh)")
    video = footage_or_skip()
    png, csv = tmp_path / "surprise.png", tmp_path / "surprise.csv"
    r = subprocess.run([sys.executable, str(SOURCE_DIR / "examples/python/curiosity.py"), str(video),
                        "--frames", str(FRAMES), "--out", str(png), "--csv", str(csv)],
                       check=True, capture_output=True, text=True)
    assert f"{FRAMES} frames" in r.stdout
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10000
    mine = rost.io.read_surprise(csv)
    assert len(mine) == FRAMES and (mine["surprise"] > 1).all()
    tool = os.environ.get("ROST_TOOL")
    if not tool or not os.path.exists(tool):
        pytest.skip("the rost tool was not built: compared with nothing")
    out = tmp_path / "run"
    subprocess.run([tool, "run", str(video), "--max-frames", str(FRAMES), "--out", str(out)], check=True,
                   capture_output=True)
    theirs = rost.io.read_surprise(out / "surprise.csv")
    assert (theirs["frame"] == mine["frame"]).all()
    np.testing.assert_allclose(mine["surprise"], theirs["surprise"], rtol=1e-6)
