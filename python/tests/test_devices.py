"""Device choice by index and UUID (Python, VKENGINE_DEVICE, the CLI), and which device a
worker process is pinned to (vkengine.gpus)."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import vkengine
from conftest import run_cli
from vkengine import gpus

KW = dict(size=(16, 16), renderer="eam", n=16)


def test_devices_lists_index_name_and_uuid():
    devs = vkengine.devices()
    assert devs and [d["index"] for d in devs] == list(range(len(devs)))
    for d in devs:
        assert d["name"] and len(d["uuid"]) == 36 and d["uuid"].count("-") == 4, d


def test_device_by_index_and_by_uuid_render_on_that_device():
    first = vkengine.devices()[0]
    by_index = vkengine.Renderer(device="#0", **KW)
    by_uuid = vkengine.Renderer(device=f"uuid:{first['uuid'].upper()}", **KW)
    for r in (by_index, by_uuid):
        assert r.device.startswith(f"#0 {first['name']}") and r.device.endswith(f"uuid:{first['uuid']}"), r.device
        dev = r.report()["device"]
        assert dev["index"] == 0 and dev["uuid"] == first["uuid"], dev
    np.testing.assert_array_equal(by_index.render(frames=1), by_uuid.render(frames=1))


@pytest.mark.parametrize("choice, says", [
    ("#{n}", "no Vulkan device #{n}"),
    ("uuid:00000000-0000-0000-0000-0000000000ff", "no Vulkan device has uuid"),
    ("uuid:123", "32 hex digits"),
    ("#one", "device index"),
    ("no-such-gpu", "no Vulkan device matches `no-such-gpu`"),
])
def test_a_choice_naming_no_device_is_one_error_listing_them(choice, says):
    devs = vkengine.devices()
    n = len(devs)
    choice, says = choice.format(n=n), says.format(n=n)
    with pytest.raises(ValueError) as e:
        vkengine.Renderer(device=choice, **KW)
    msg = str(e.value)
    assert says in msg and "\n" not in msg, msg
    for d in devs:
        assert f"#{d['index']} {d['name']}" in msg and d["uuid"] in msg, msg


def test_vkengine_device_environment_variable_takes_the_same_forms(monkeypatch):
    uuid = vkengine.devices()[0]["uuid"]
    monkeypatch.setenv("VKENGINE_DEVICE", f"uuid:{uuid}")
    assert vkengine.Renderer(**KW).device.startswith("#0 ")
    monkeypatch.setenv("VKENGINE_DEVICE", f"#{len(vkengine.devices())}")
    with pytest.raises(ValueError, match="no Vulkan device #"):
        vkengine.Renderer(**KW)
    # The keyword wins over the environment.
    assert vkengine.Renderer(device="#0", **KW).device.startswith("#0 ")


def test_cli_device_choice_and_report(volume_bin, tmp_path):
    uuid = vkengine.devices()[0]["uuid"]
    for choice in ("#0", f"uuid:{uuid}", f"uuid:GPU-{uuid}"):
        rep = tmp_path / "r.json"
        run_cli(volume_bin, "--size", "16x16", "--set", "n=16", "--renderer", "eam", "--device", choice,
                "--out", str(tmp_path / "o.png"), "--report", str(rep))
        dev = json.loads(rep.read_text())["device"]
        assert dev["index"] == 0 and dev["uuid"] == uuid, (choice, dev)
    n = len(vkengine.devices())
    bad = run_cli(volume_bin, "--size", "16x16", "--device", f"#{n}", check=False)
    assert bad.returncode == 2, bad.stderr
    lines = [ln for ln in bad.stderr.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1 and f"no Vulkan device #{n}" in lines[0] and f"uuid:{uuid}" in lines[0], bad.stderr
    env_bad = subprocess.run([str(volume_bin), "--headless", "--size", "16x16"], capture_output=True, text=True,
                             env={**os.environ, "VKENGINE_DEVICE": "uuid:" + "0" * 32, "DISPLAY": ""})
    assert env_bad.returncode == 2 and "no Vulkan device has uuid" in env_bad.stderr, env_bad.stderr


def test_cuda_visible_devices_become_vulkan_choices(monkeypatch):
    monkeypatch.setattr(gpus, "_nvidia_uuid", lambda i: None)  # no nvidia-smi: Vulkan's index
    assert gpus.from_cuda_visible_devices("GPU-8f2a1c3e-0000-1111-2222-333344445555,GPU-ab") == \
        "uuid:8f2a1c3e-0000-1111-2222-333344445555"
    assert gpus.from_cuda_visible_devices("3,1") == "#3"
    assert gpus.from_cuda_visible_devices("") is None and gpus.from_cuda_visible_devices("-1") is None
    monkeypatch.setattr(gpus, "_nvidia_uuid", lambda i: {2: "GPU-aaaa0000-0000-0000-0000-000000000002"}.get(i))
    assert gpus.from_cuda_visible_devices("2") == "uuid:aaaa0000-0000-0000-0000-000000000002"
    with pytest.raises(ValueError, match="MIG"):
        gpus.from_cuda_visible_devices("MIG-4a2b")
    with pytest.raises(ValueError, match="expected GPU indices"):
        gpus.from_cuda_visible_devices("gpu0")
    assert gpus.choose_device(env={"CUDA_VISIBLE_DEVICES": "GPU-8f2a1c3e-0000-1111-2222-333344445555"},
                              available=[]) == "uuid:8f2a1c3e-0000-1111-2222-333344445555"


def test_workers_of_a_node_take_distinct_slots_round_robin(tmp_path):
    folder = str(tmp_path / "slots")
    two = [{"index": 0, "name": "GPU A", "unsupported": None}, {"index": 1, "name": "GPU A", "unsupported": None},
           {"index": 2, "name": "old", "unsupported": "missing Vulkan 1.3"}]
    code = ("import sys, time; from vkengine import gpus; "
            f"print(gpus.choose_device(env={{}}, slot_folder={folder!r}, available={two!r}), flush=True); "
            "time.sleep(30)")
    procs = [subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True) for _ in range(3)]
    try:
        chosen = sorted(p.stdout.readline().strip() for p in procs)
        # Three live workers over two usable devices: both used, the unusable one never.
        assert chosen == ["#0", "#0", "#1"], chosen
        assert sorted(os.listdir(folder)) == ["slot-0", "slot-1", "slot-2"]
    finally:
        for p in procs:
            p.kill()
            p.wait()
    # Their slots are free again (dead holders): a new worker takes slot 0, an explicit list
    # is indexed by the slot.
    assert gpus.choose_device(["uuid:x", "uuid:y"], env={}, slot_folder=folder) == "uuid:x"
    assert gpus.choose_device(env={"CUDA_VISIBLE_DEVICES": ""}, slot_folder=folder, available=two) == "#0"
    # Workers sharing one CUDA_VISIBLE_DEVICES (a SLURM job with several GPUs): by slot.
    cuda = {"CUDA_VISIBLE_DEVICES": "GPU-aaaa0000-0000-0000-0000-000000000007,GPU-b"}
    assert gpus.choose_device(["cuda"], env=cuda, slot_folder=folder) == "uuid:aaaa0000-0000-0000-0000-000000000007"
    with pytest.raises(ValueError, match="names no GPU"):
        gpus.choose_device(["cuda"], env={"CUDA_VISIBLE_DEVICES": ""}, slot_folder=folder)
    with pytest.raises(RuntimeError, match="old: missing Vulkan 1.3"):
        gpus.choose_device(env={}, slot_folder=folder, available=two[2:])
