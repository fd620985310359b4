"""Bakes the shipped phantom, presses its highest point deeper and deeper with
the multi-beam model and with the linear FEM, and plots force against depth.

    PYTHONPATH=build/python python3 docs/examples/force_depth.py   # from the repository root

Writes force_depth.png in the current folder (matplotlib, no display needed).
"""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import organsim

organsim.bake("data_samples/phantom_ct.nii.gz", "phantom.organ", seed=(-65, 5, 0), surface_vertices=800,
              tet_size=12, stations=8, section_samples=32)
model = organsim.load("phantom.organ")
top = model.surface_vertices[np.argmax(model.surface_vertices[:, 2])]  # the highest point, pressed straight down
depths = np.linspace(0.0, 0.010, 11)  # m

beam = organsim.MultiBeam(model, max_tools=1)
beam.attach(0, top)
beam_force = [beam.force(0, [0.0, 0.0, -d])[2] for d in depths]

fem_force = []
for d in depths:  # a static FEM press: one step of the linear model holds its equilibrium
    fem = organsim.Simulation(model, "linear", tools=1, fixed_radius=0.03)
    fem.attach(0, top)
    fem.step(1 / 60, [[0.0, 0.0, -d]])
    fem_force.append(fem.force(0, [0.0, 0.0, -d])[2])

plt.plot(1e3 * depths, beam_force, "o-", label="multi-beam")
plt.plot(1e3 * depths, fem_force, "s-", label="linear FEM")
plt.xlabel("press depth (mm)")
plt.ylabel("force on the tool, up (N)")
plt.title("The shipped phantom's highest point, pressed down")
plt.legend()
plt.savefig("force_depth.png", dpi=100)
print(f"force at {1e3 * depths[-1]:.0f} mm: multi-beam {beam_force[-1]:.3f} N, linear FEM {fem_force[-1]:.3f} N")
