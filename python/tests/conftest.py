"""Shared fixtures: the CLI binary the Python renders are compared with, small render sizes."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def demo_bin(name) -> pathlib.Path:
    """A demo program of this checkout built in the module's own profile (release SPIR-V is
    optimized, so only the same profile gives the same image bit for bit): the `cargo test`
    build for a `maturin develop` module, a release build for a `pip install ./python` wheel;
    built here when missing."""
    import vkengine

    profile = vkengine._native.BUILD_PROFILE
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    exe = target / profile / name
    if not exe.exists():
        release = ["--release"] if profile == "release" else []
        subprocess.run(["cargo", "build", "--locked", *release, "--bin", name], cwd=ROOT, check=True)
    return exe


@pytest.fixture(scope="session")
def volume_bin() -> pathlib.Path:
    """The `volume` CLI."""
    return demo_bin("volume")


@pytest.fixture(scope="session")
def cornell_bin() -> pathlib.Path:
    """The `cornell` mesh demo."""
    return demo_bin("cornell")


def run_cli(exe, *args, check=True):
    """Runs the CLI headless; returns the completed process (stderr as text)."""
    return subprocess.run([str(exe), "--headless", *args], capture_output=True, text=True, check=check,
                          env={**os.environ, "DISPLAY": "", "WAYLAND_DISPLAY": ""})
