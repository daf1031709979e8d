"""The installed product: a wheel that carries the setup page, console scripts that run from a venv."""

from __future__ import annotations

import re
import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import requests

ROOT = Path(__file__).resolve().parent.parent


def test_wheel_installs_into_a_fresh_venv_and_serves_the_setup_page(tmp_path: Path) -> None:
    dist = tmp_path / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(dist),
                    str(ROOT)], check=True, timeout=300)
    wheel = next(dist.glob("alpaca_zwo-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    for asset in ("index.html", "app.js", "style.css", "guide.css"):
        assert f"alpaca_zwo/static/{asset}" in names
    # The user guide (docs/guide/, its notes and screenshots) ships too: /docs must work with no checkout.
    for page in ("guide/index.md", "guide/first-night.md", "guide/configuration.md", "meridian.md",
                 "screenshots/handset-progress-phone.png"):
        assert f"alpaca_zwo/docs/{page}" in names, page

    # A fresh environment; dependencies come from this interpreter's site-packages (no network), put
    # behind the venv's own by a .pth line. (system_site_packages would give the *base* Python's, which
    # on a fresh machine has none of them.) A plain path line does not run that directory's own .pth
    # files, so this checkout's editable install is not seen: alpaca_zwo can only come from the wheel.
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    python = env_dir / "bin" / "python"
    own_site = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                              capture_output=True, text=True, check=True, timeout=60).stdout.strip()
    ours = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
    (Path(own_site) / "test-dependencies.pth").write_text("".join(f"{path}\n" for path in sorted(ours)))
    subprocess.run([str(python), "-m", "pip", "install", "--no-deps", "-q", str(wheel)], check=True, timeout=300)
    for script in ("alpaca-zwo", "alpaca-zwo-emulator"):
        version = subprocess.run([str(env_dir / "bin" / script), "--help"], capture_output=True, text=True,
                                 timeout=60, cwd=tmp_path)
        assert version.returncode == 0 and "usage" in version.stdout.lower()

    # Run the installed server from a directory without the source tree: the page must come from the wheel.
    server = subprocess.Popen(
        [str(env_dir / "bin" / "alpaca-zwo"), "--host", "127.0.0.1", "--port", "0", "--discovery-port", "0",
         "--config", str(tmp_path / "config.toml")],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        port = None
        assert server.stdout is not None
        for line in server.stdout:
            match = re.search(r"http://127\.0\.0\.1:(\d+)/setup", line)
            if match:
                port = int(match.group(1))
                break
        assert port is not None, "the installed server never printed its setup URL"
        page = requests.get(f"http://127.0.0.1:{port}/setup", timeout=10)
        assert page.status_code == 200 and "<html" in page.text.lower()
        script = requests.get(f"http://127.0.0.1:{port}/setup/static/app.js", timeout=10)
        assert script.status_code == 200 and "javascript" in script.headers["Content-Type"]
        guide = requests.get(f"http://127.0.0.1:{port}/docs/first-night", timeout=10)
        assert guide.status_code == 200 and 'id="3-open-the-page-on-your-phone"' in guide.text
        shot = requests.get(f"http://127.0.0.1:{port}/docs/screenshots/handset-progress-phone.png", timeout=10)
        assert shot.status_code == 200 and shot.content.startswith(b"\x89PNG")
        location = subprocess.run([str(python), "-c", "import alpaca_zwo, sys; print(alpaca_zwo.__file__)"],
                                  capture_output=True, text=True, timeout=60, cwd=tmp_path).stdout
        assert str(env_dir) in location, "the venv imported the source tree instead of the installed wheel"
    finally:
        server.terminate()
        server.wait(timeout=30)
    assert server.returncode == 0
