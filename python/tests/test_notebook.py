"""How a renderer behaves in a notebook: Ctrl-C, progress, close() and `with`, inline PNG, and
two threads sharing one renderer."""

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import vkengine

KW = dict(size=(24, 24), renderer="mcs", n=16)


def test_close_frees_the_device_memory_at_once():
    keeper = vkengine.Renderer(size=(8, 8), renderer="eam", n=8)
    before = keeper.report()["device"]["process_reserved_bytes"]
    big = vkengine.Renderer(vkengine.Volume(np.ones((96, 96, 96), np.float32)), size=(128, 128), renderer="mcs")
    big.render(frames=1)
    during = keeper.report()["device"]["process_reserved_bytes"]
    assert during > before + 96**3 * 2, (before, during)  # the volume alone is 1.7 MiB as float16
    big.close()
    assert keeper.report()["device"]["process_reserved_bytes"] == before
    assert big.closed and not keeper.closed
    big.close()  # twice is harmless


def test_with_block_closes_and_later_calls_raise():
    with vkengine.Renderer(**KW) as r:
        assert r.render(frames=1).shape == (24, 24, 4)
    assert r.closed
    for call in (lambda: r.render(), lambda: r.image(), lambda: r.report(), lambda: r.orbit(yaw=1), lambda: r.device):
        with pytest.raises(ValueError, match="closed"):
            call()
    assert "closed" in repr(r)


def test_repr_png_is_the_tone_mapped_image(tmp_path):
    r = vkengine.Renderer(**KW)
    r.render(frames=2)
    png = r._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    (tmp_path / "x.png").write_bytes(png)
    back = vkengine.read_image(str(tmp_path / "x.png"))
    np.testing.assert_array_equal(np.round(back * 255).astype(np.uint8), r.image_srgb())


def test_progress_is_called_after_every_frame():
    r = vkengine.Renderer(**KW)
    seen = []
    r.render(frames=3, progress=lambda done, total: seen.append((done, total)))
    assert seen == [(1, 3), (2, 3), (3, 3)]
    seen.clear()
    r.accumulate(2, 5, progress=lambda done, total: seen.append((done, total)))
    assert seen == [(1, 3), (2, 3), (3, 3)]
    # A callback calling its own renderer would wait for itself: a clear error instead, after
    # the first frame (accumulate left the progressive mean at frame 0).
    with pytest.raises(RuntimeError, match="progress callback"):
        r.render(frames=2, progress=lambda d, t: r.image())
    assert r.frames == 1
    # An exception in the callback stops the render after that frame and arrives as itself.
    with pytest.raises(ZeroDivisionError):
        r.render(frames=5, progress=lambda d, t: 1 / 0)
    assert r.frames == 2
    assert r.render(frames=1).shape == (24, 24, 4)


def test_two_threads_share_one_renderer():
    r = vkengine.Renderer(**KW)
    errors, images = [], []

    def work():
        try:
            for _ in range(3):
                images.append(r.render(frames=1))
        except Exception as e:  # noqa: BLE001 - any failure fails the test below
            errors.append(e)

    threads = [threading.Thread(target=work) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and len(images) == 6 and r.frames == 6


CHILD = textwrap.dedent("""
    import signal, sys, time, vkengine
    # Python leaves SIGINT ignored when it starts with it ignored, as every command a
    # non-interactive shell runs in the background does (tools/test.sh under `cmd &`): Ctrl-C's
    # handler, as an interactive session has it.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    # Frames of ~100 ms here: two frames' time stays well above the OS's scheduling noise.
    r = vkengine.Renderer(size=(192, 192), renderer="mcm", n=48)
    r.render(frames=1)
    t0 = time.monotonic()
    r.render(frames=4)
    print("ready", (time.monotonic() - t0) / 4, flush=True)
    try:
        # No progress callback: Python code run between frames would see the signal by itself.
        r.render(frames=10000)
    except KeyboardInterrupt:
        print("interrupted", time.monotonic(), r.frames, flush=True)
        sys.exit(0)
    print("finished", flush=True)
""")


def test_ctrl_c_stops_a_long_render_within_two_frames():
    p = subprocess.Popen([sys.executable, "-c", CHILD], stdout=subprocess.PIPE, text=True,
                         env={**os.environ, "VKENGINE_VALIDATION": "0"})
    try:
        ready = p.stdout.readline().split()
        assert ready and ready[0] == "ready", ready
        frame_s = float(ready[1])
        time.sleep(frame_s * 1.5)  # somewhere inside a frame
        sent = time.monotonic()
        p.send_signal(signal.SIGINT)
        out = p.communicate(timeout=max(30, 50 * frame_s))[0].split()
    finally:
        p.kill()
    assert out and out[0] == "interrupted", out
    stopped, frames = float(out[1]), int(out[2])
    assert stopped - sent <= 2 * frame_s, (stopped - sent, frame_s)
    assert 5 <= frames < 10000
