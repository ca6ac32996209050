"""Render a numpy volume. Notebook-ready: each `# %%` block is a cell (Jupytext, VS Code), or
run it whole:

    python examples/render_numpy.py            # writes out/numpy-mcm.png and out/numpy-mcm.exr
"""

# %%
import numpy as np

import vkengine

# %% A volume is any 3D integer or float array indexed [z, y, x]; spacing and origin are physical.
z, y, x = np.mgrid[-1:1:96j, -1:1:96j, -1:1:96j]
density = np.exp(-5 * (x * x + 2 * y * y + z * z)) + 0.3 * np.exp(-40 * ((x - 0.4) ** 2 + y * y + z * z))
vol = vkengine.Volume((density * 1000).astype(np.uint16), spacing=(1.0, 1.0, 1.0))

# %% Every `--set` key of the `volume` CLI is a keyword; a typo raises ValueError with its message.
r = vkengine.Renderer(vol, size=(384, 384), renderer="mcm", tf="cloud", density=2.0, validation=False)
hdr = r.render(frames=16)  # float32 (384, 384, 4), linear radiance
print(r.report()["frame_ms"], "ms per frame on", r.device)

# %% In a notebook: `import matplotlib.pyplot as plt; plt.imshow(r.image_srgb())`.
vkengine.write_image("out/numpy-mcm.exr", hdr)
r.save("out/numpy-mcm.png")

# %% Progressive refinement, then another view: the camera orbits the volume's centre.
for _ in range(16):
    r.step()
r.orbit(yaw=2.0, pitch=0.2)
r.render(frames=8)
r.save("out/numpy-mcm-side.png")
