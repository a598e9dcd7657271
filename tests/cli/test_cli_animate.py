"""``freefloat simulate SCENARIO --animate PATH`` (issue 11 item 4): a GIF of the run, never over an existing file."""

from __future__ import annotations

from pathlib import Path

from PIL import Image
from typer.testing import CliRunner

from freefloat.cli import app

runner = CliRunner()
EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "scenarios" / "papadopoulos1992_joint_pd.toml"


def short_scenario(tmp_path: Path) -> Path:
    text = EXAMPLE.read_text().replace("duration = 10.0", "duration = 1.0")
    assert "duration = 1.0" in text
    path = tmp_path / "pd.toml"
    path.write_text(text)
    return path


def test_simulate_animate_writes_a_gif(tmp_path: Path) -> None:
    gif = tmp_path / "anim" / "pd.gif"
    result = runner.invoke(app, ["simulate", str(short_scenario(tmp_path)), "--out", str(tmp_path / "out"), "--animate", str(gif)])
    assert result.exit_code == 0, result.output
    assert str(gif) in result.stdout.splitlines()
    with Image.open(gif) as image:
        assert image.n_frames == 51  # 1 s at the scenario's 0.02 s output period: 51 samples, one frame each


def test_simulate_animate_refuses_an_existing_file_before_running(tmp_path: Path) -> None:
    gif = tmp_path / "keep.gif"
    gif.write_bytes(b"not ours")
    out = tmp_path / "out"
    result = runner.invoke(app, ["simulate", str(short_scenario(tmp_path)), "--out", str(out), "--animate", str(gif)])
    assert result.exit_code == 1
    assert result.stderr.startswith("error: --animate") and "never overwrites" in result.stderr
    assert gif.read_bytes() == b"not ours"
    assert not any(out.glob("*.npz"))  # refused before the run
    bad = runner.invoke(app, ["simulate", str(short_scenario(tmp_path)), "--out", str(out), "--animate", str(tmp_path / "a.avi")])
    assert bad.exit_code == 1 and ".gif (Pillow) or .mp4 (ffmpeg)" in bad.stderr
