"""``alpaca-zwo --survey``: as an owner runs it, in a subprocess, on the built-in emulator of a chosen preset."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from alpaca_zwo.zwo.survey import SURVEY_COMMANDS

RUN = "import sys\nfrom alpaca_zwo.cli import server_main\nsys.exit(server_main(sys.argv[1:]))\n"


def _run(tmp_path: Path, *arguments: str) -> subprocess.CompletedProcess[str]:
    config = tmp_path / "config.toml"
    config.write_text("[server]\nmdns = false\n")
    return subprocess.run([sys.executable, "-c", RUN, "--config", str(config), *arguments], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120, check=False)


def test_survey_writes_its_report_where_told_and_names_the_preset(tmp_path: Path) -> None:
    out = tmp_path / "report.txt"
    done = _run(tmp_path, "--survey", "--emulator-preset", "am5n-1.6.3", "--survey-out", str(out))
    assert done.returncode == 0, done.stderr
    assert f"survey report written to {out}" in done.stdout
    assert "gmza_south_azimuth = True" in done.stdout and "model = 'AM5N'" in done.stdout
    text = out.read_text(encoding="utf-8")
    assert "connection: the built-in emulator, preset am5n-1.6.3" in text
    assert f"exchanges ({len(SURVEY_COMMANDS)} of {len(SURVEY_COMMANDS)})" in text


def test_survey_default_file_is_timestamped_in_the_current_directory(tmp_path: Path) -> None:
    done = _run(tmp_path, "--survey")
    assert done.returncode == 0, done.stderr
    files = list(tmp_path.glob("alpaca-zwo-survey-*Z.txt"))
    assert len(files) == 1 and f"written to {files[0]}" in done.stdout


def test_survey_says_why_when_the_mount_cannot_be_reached(tmp_path: Path) -> None:
    done = _run(tmp_path, "--survey", "--device", "socket://127.0.0.1:9", "--survey-out", str(tmp_path / "r.txt"))
    assert done.returncode == 1 and "survey failed" in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "r.txt").exists()


def test_an_unknown_preset_is_refused_with_the_list(tmp_path: Path) -> None:
    done = _run(tmp_path, "--survey", "--emulator-preset", "am9-9.9")
    assert done.returncode == 2 and "am5-1.9.2" in done.stderr
